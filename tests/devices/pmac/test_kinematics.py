"""Kinematic program buffers without sockets: OPEN FORWARD / OPEN INVERSE per C.S., LIST, CLEAR,
the statements they take, and running them on P and Q variables [Turbo SRM "OPEN FORWARD",
"OPEN INVERSE"; Turbo UM "Kinematic Calculations"]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.planerr import RUN_TIME_ERROR, PlanError

#: the UM's two-link (shoulder-elbow) robot, L1 = 400, L2 = 300 mm, 1000 counts per degree
FORWARD = ["Q7=Q91*COS(P1/Q93)+Q92*COS((P1+P2)/Q93)",
           "Q8=Q91*SIN(P1/Q93)+Q92*SIN((P1+P2)/Q93)"]
INVERSE = ["Q20=(Q7*Q7+Q8*Q8-Q91*Q91-Q92*Q92)/(2*Q91*Q92)",
           "Q21=ACOS(Q20)",
           "Q0=Q7",
           "Q22=ATAN2(Q8)",
           "Q0=Q91+Q92*COS(Q21)",
           "Q24=ATAN2(Q92*SIN(Q21))",
           "P1=(Q22-Q24)*Q93",
           "P2=Q21*Q93"]


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.ask("&1 #1->I #2->I")
    c.ask("&1 Q91=400 Q92=300 Q93=1000")
    return c


def download(card: Card, kind: str, lines: list[str]) -> None:
    card.ask(f"&1 OPEN {kind} CLEAR")
    for line in lines:
        card.ask(line)
    card.ask("CLOSE")


def test_buffers_store_list_and_clear_per_cs(card: Card) -> None:
    download(card, "FORWARD", FORWARD)
    download(card, "INVERSE", INVERSE[:2])
    assert card.ask("&1 LIST FORWARD") == "\r".join(FORWARD)
    assert card.ask("&1 LIST INVERSE") == "\r".join(INVERSE[:2])
    assert card.ask("&2 LIST FORWARD") == ""
    card.ask("&1 OPEN INV CLEAR CLOSE")
    assert card.ask("&1 LIST INVERSE") == ""
    assert card.fw.kinematics.has(1, "FORWARD") and not card.fw.kinematics.has(1, "INVERSE")


def test_cmd_and_address_are_refused_and_structure_is_checked_at_close(card: Card) -> None:
    """UM: any PLC math or logic statement except ADDRESS, DISPLAY, CMD and SEND."""
    card.ask("&1 OPEN FORWARD CLEAR")
    assert card.raw('CMD"#1J+"') == b"\x07ERR003\r"
    assert card.raw("ADDRESS &2") == b"\x07ERR003\r"
    card.ask("IF (P1 > 0)")
    assert card.raw("CLOSE") == b"\x07ERR009\r"
    assert not card.fw.kinematics.has(1, "FORWARD")


def test_another_port_cannot_open_a_buffer_meanwhile(card: Card) -> None:
    from vdevd.devices.pmac.online import PortState
    card.ask("&1 OPEN FORWARD")
    other = PortState()
    assert card.fw.execute(other, "OPEN PLC 1").error == 7
    assert card.fw.execute(other, "&2 OPEN INVERSE").error == 7
    card.ask("CLOSE")


def test_forward_takes_motor_positions_in_p_and_gives_axes_in_q(card: Card) -> None:
    download(card, "FORWARD", FORWARD)
    commanded = np.zeros(8)
    commanded[0], commanded[1] = 30_000.0, 60_000.0   # 30° and 60°
    axes = card.fw.kinematics.forward(1, commanded)
    assert card.fw.p[1] == 30_000 and card.fw.p[2] == 60_000
    x = 400 * np.cos(np.radians(30)) + 300 * np.cos(np.radians(90))
    y = 400 * np.sin(np.radians(30)) + 300 * np.sin(np.radians(90))
    assert axes[6] == pytest.approx(x, abs=1e-6) and axes[7] == pytest.approx(y, abs=1e-6)


def test_inverse_takes_axes_in_q_and_gives_inverse_motors_in_p(card: Card) -> None:
    download(card, "FORWARD", FORWARD)
    download(card, "INVERSE", INVERSE)
    kin = card.fw.kinematics
    assert kin.inverse_motors(1) == [1, 2]
    axes = np.zeros(9)
    axes[6], axes[7] = 500.0, 200.0
    motors = kin.inverse(1, axes)
    commanded = np.zeros(8)
    commanded[:2] = motors
    back = kin.forward(1, commanded)
    assert back[6] == pytest.approx(500, abs=1e-6) and back[7] == pytest.approx(200, abs=1e-6)
    assert card.fw.q[0, 10] == 0   # Q10 = 0: no velocities


def test_a_program_that_does_not_end_is_a_run_time_error(card: Card) -> None:
    download(card, "FORWARD", ["WHILE (1 = 1)", "Q1=Q1+1", "ENDWHILE"])
    with pytest.raises(PlanError) as exc:
        card.fw.kinematics.forward(1, np.zeros(8))
    assert exc.value.bit == RUN_TIME_ERROR


def test_save_keeps_the_kinematic_buffers(card: Card) -> None:
    download(card, "INVERSE", INVERSE)
    card.ask("SAVE")
    card.raw("$$$")
    card.raw("I3=2")
    assert card.ask("&1 LIST INVERSE") == "\r".join(INVERSE)
    assert card.fw.kinematics.has(1, "INVERSE")


def test_open_of_another_buffer_closes_the_kinematic_one(card: Card) -> None:
    card.ask("&1 OPEN FORWARD CLEAR")
    card.ask("Q7=1")
    card.ask("OPEN PLC 3")
    card.ask("P1=1")
    card.ask("CLOSE")
    assert card.ask("&1 LIST FORWARD") == "Q7=1" and card.ask("LIST PLC 3") == "P1=1"
    assert card.fw.kinematics.has(1, "FORWARD")


def test_a_forward_program_that_does_not_end_refuses_r(card: Card) -> None:
    """Isx50 = 1: R runs the forward program first; one that never ends answers an error and
    nothing runs (ASSUMPTION: ERR003)."""
    download(card, "FORWARD", ["WHILE (1 = 1)", "Q1=Q1+1", "ENDWHILE"])
    card.ask("&1 I5150=1 #1J/ #2J/")
    card.ask("OPEN PROG 1 CLEAR X1 CLOSE")
    assert card.raw("&1 B1 R") == b"\x07ERR003\r"
    assert not card.fw.motion.runner(1).running
