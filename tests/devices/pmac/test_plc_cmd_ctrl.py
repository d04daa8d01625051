"""`CMD^{c}`: a control character issued from a PLC or a motion program as if from the host,
with no reply [Turbo SRM p.424 COMMAND: "CMD^D would disable all PLC programs", "CMD^K would
kill (disable) all motors", "CMD^A would stop all programs and moves"; README "PLCs"]."""

from __future__ import annotations

from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_plc import card, download, p
from tests.devices.pmac.test_programs import download as download_prog

__all__ = ["card"]


def test_cmd_ctrl_d_from_a_plc_disables_every_plc(card: Card) -> None:
    download(card, 2, "P2=P2+1")
    download(card, 3, "IF (P2 > 5)", "CMD^D", "ENDIF")
    card.ask("ENABLE PLC 2,3")
    card.tick(400)
    assert not card.fw.plc.running
    stopped = p(card, 2)
    card.tick(400)
    assert p(card, 2) == stopped and 5 < stopped < 10


def test_cmd_ctrl_k_from_a_plc_kills_every_motor(card: Card) -> None:
    card.ask("#1J/ #2J/")
    assert card.fw.motors.core.servo_on_mask[:2].all()
    download(card, 1, "CMD ^ K", "DISABLE PLC 1")
    card.ask("ENABLE PLC 1")
    card.tick(40)
    assert not card.fw.motors.core.servo_on_mask[:2].any()


def test_cmd_ctrl_a_from_a_motion_program_stops_it(card: Card) -> None:
    card.ask("&1#1->1000X #1J/ I116=1000 I117=100")
    download_prog(card, 1, "LINEAR ABS TA50 TS0 F1", "X10", "CMD^A", "X20")
    card.ask("&1B1R")
    card.tick(400)
    assert not card.fw.motion.any_running()
    card.tick(4000)
    assert float(card.fw.reports.commanded()[0]) < 10000.0


def test_cmd_ctrl_needs_a_letter(card: Card) -> None:
    card.ask("OPEN PLC 1 CLEAR")
    assert card.raw("CMD^1") == b"\x07ERR003\r"
    card.ask("CLOSE")
