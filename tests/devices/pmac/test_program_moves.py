"""PVT, SPLINE and CIRCLE moves, rotary buffers and kinematics run through the firmware's motion
program runner (no sockets, ideal plant: the motors follow their command) [Turbo SRM "PVT",
"SPLINE1", "CIRCLE1", "NORMAL", "OPEN ROT", "PR", I17, Isx13, Isx50; Turbo UM "Kinematic
Calculations"]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_kinematics import FORWARD, INVERSE
from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.online import PortState

PERIOD = 3_713_707 / 8_388_608 / 1000   # servo period, seconds (I10)


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.ask("&1 #1->1000X #2->1000Y")
    c.ask("#1J/ #2J/")
    return c


def download(card: Card, n: int, *lines: str) -> None:
    card.ask(f"OPEN PROG {n} CLEAR")
    for line in lines:
        card.ask(line)
    card.ask("CLOSE")


def run(card: Card, start: str = "&1 B1 R", limit: float = 30.0) -> np.ndarray:
    """Start the program and tick until it ends; the commanded positions of motors 1 and 2
    every servo cycle (counts), row 0 before the first cycle."""
    card.ask(start)
    rows = [card.fw.reports.commanded()[:2].copy()]
    runner = card.fw.motion.runner(1)
    for _ in range(int(limit / PERIOD)):
        card.tick()
        rows.append(card.fw.reports.commanded()[:2].copy())
        if not runner.running:
            break
    assert not runner.running, "the program did not end"
    return np.array(rows)


# -- PVT ----------------------------------------------------------------------------------------
def test_pvt_scan_from_p_variables_passes_every_point_at_its_time(card: Card) -> None:
    """A PVT scan whose points and velocities come from P-variables: at k·T the axis is at
    point k (Hermite segments pass through the programmed points) [SRM PVT]."""
    n, t_ms = 20, 40
    pts = 2.0 * np.sin(np.linspace(0.3, 3.0, n))
    vel = np.gradient(pts, t_ms / 1000) / 1000 * 1000   # units per Isx90 (1000 ms) = units/s
    vel[-1] = 0
    for k in range(n):
        card.ask(f"P{100 + k}={pts[k]:.6f} P{200 + k}={vel[k]:.6f}")
    card.ask(f"P1=0 P2={n}")
    download(card, 1, f"PVT{t_ms}", "ABS", "WHILE (P1 < P2)", "X(P(100+P1)):(P(200+P1))",
             "P1=P1+1", "ENDWHILE")
    x = run(card)[:, 0] / 1000
    # sample k·T (the servo grid is not a multiple of T: compare within a cycle's travel)
    for k in range(n):
        tick = (k + 1) * t_ms / 1000 / PERIOD
        lo, hi = int(np.floor(tick)), int(np.ceil(tick))
        assert min(x[lo], x[hi]) - 1e-6 <= pts[k] <= max(x[lo], x[hi]) + 1e-6 or \
            pts[k] == pytest.approx(x[lo], abs=1e-3)
    assert x[-1] == pytest.approx(pts[-1], abs=1e-6)
    assert len(x) - 1 == pytest.approx(n * t_ms / 1000 / PERIOD, abs=3)


def test_pvt_gathered_around_with_cmd_gat(card: Card) -> None:
    """CMD"GAT" / CMD"END GAT" in the program gather the commanded motion (gather.py)."""
    card.ask("I5001=$800088 I5050=1 I5049=10")   # D:$000088 motor 1 commanded position
    card.ask("DEFINE GATHER 4000")
    download(card, 1, "PVT100", 'CMD"GAT"', "X1:10", "X2:0", "DWELL0", 'CMD"END GAT"')
    run(card)
    card.tick(5)
    lines = card.ask("LIST GATHER").split("\r")
    assert 15 <= len(lines) <= 60
    last = int(lines[-1].split()[0], 16)
    if last >= 1 << 47:
        last -= 1 << 48
    assert last / (96 * 32) == pytest.approx(2000, abs=1)   # Ixx08 = 96: 1/3072 count units


def test_pvt_then_linear_stops_between_modes(card: Card) -> None:
    download(card, 1, "PVT100", "X1:10", "X2:0", "LINEAR TA50 TS0 F10", "X0")
    x = run(card)[:, 0]
    assert x[-1] == pytest.approx(0, abs=1e-6) and x.max() == pytest.approx(2000, abs=0.01)


# -- SPLINE -------------------------------------------------------------------------------------
def test_spline1_adds_the_zero_distance_segments(card: Card) -> None:
    """n moves in SPLINE1 take n + 2 segment times and end on the last point [UM]."""
    download(card, 1, "SPLINE1 TA100", "X1", "X2", "X3")
    x = run(card)[:, 0]
    assert x[-1] == pytest.approx(3000, abs=1e-6)
    assert (len(x) - 1) * PERIOD == pytest.approx(0.5, abs=3 * PERIOD)


# -- CIRCLE -------------------------------------------------------------------------------------
def test_circle_move_keeps_its_radius_and_ends_on_the_end_point(card: Card) -> None:
    """CIRCLE1 with the centre vector: clockwise half circle of radius 5 from (0,0) to (10,0)
    around (5,0) passes (5,5) [SRM CIRCLE1, NORMAL K-1 default]."""
    card.ask("&1 I5113=10")   # Isx13 = 10 ms: segmentation mode, required for circles
    download(card, 1, "CIRCLE1 TA100 TS0 F10", "X10 Y0 I5 J0")
    xy = run(card) / 1000
    r = np.hypot(xy[:, 0] - 5, xy[:, 1])
    assert r == pytest.approx(np.full(len(r), 5.0), abs=2e-4)
    assert xy[:, 1].max() == pytest.approx(5.0, abs=1e-3)
    assert xy[-1] == pytest.approx([10.0, 0.0], abs=1e-9)
    assert (len(xy) - 1) * PERIOD == pytest.approx(np.pi * 5 / 10 + 0.1, abs=2 * PERIOD)


def test_circle_radius_form_and_normal_and_inc_r(card: Card) -> None:
    """R-10 (long arc) CIRCLE2 in the XY plane given as NORMAL K-1, then ABS(R) centres."""
    card.ask("&1 I5113=10")
    download(card, 1, "NORMAL K-1 CIRCLE2 TA50 F20 INC", "X10 Y10 R-10", "ABS ABS(R)",
             "X0 Y0 I10 J0")
    xy = run(card) / 1000
    assert xy[-1] == pytest.approx([0.0, 0.0], abs=1e-9)
    # the long CCW arc from (0,0) to (10,10) with radius 10 turns about (0,10)... or (10,0);
    # CCW and long: about (10,0), through (10,-10)
    assert xy[:, 1].min() == pytest.approx(-10.0, abs=1e-3)


def test_circle_radius_error_stops_the_program_with_its_status_bit(card: Card) -> None:
    """Isx96 example: X7.072 Y7.072 R5 with Isx96 = 0.001: the program stops at the start of
    the move and sets the circle-radius-error bit (word 2 bit 21) [SRM Isx96]."""
    card.ask("&1 I5113=10 I5196=0.001")
    download(card, 1, "CIRCLE1 TA50 F10 INC", "X7.072 Y7.072 R5")
    xy = run(card)
    assert np.all(xy == 0)
    status = card.fw.cs_status(1)
    assert status[1] & (1 << 21)


def test_circle_with_isx13_zero_runs_as_a_linear_move(card: Card) -> None:
    download(card, 1, "CIRCLE1 TA100 TS0 F10", "X10 Y0 I5 J0")
    xy = run(card)
    assert np.all(np.abs(xy[:, 1]) < 1e-6) and xy[-1, 0] == pytest.approx(10_000)


# -- rotary buffers -----------------------------------------------------------------------------
def test_rotary_buffer_fed_while_it_runs(card: Card) -> None:
    """B0 runs the rotary buffer; lines sent while it runs are executed; PR counts the lines
    waiting; the full bit follows I17/I16 [SRM OPEN ROT, PR, I17]."""
    card.ask("I16=1 I17=3")
    card.ask("&1 DEFINE ROT 100")
    card.ask("&1 B0")
    card.ask("OPEN ROT")
    card.ask("INC LINEAR TA20 TS0 F20")
    card.ask("X1")
    card.ask("&1 R")
    runner = card.fw.motion.runner(1)
    assert runner.running
    card.tick()
    assert card.ask("&1 PR") == "0"   # both lines taken by the calculation
    for _ in range(3):
        card.ask("X1")
    assert card.ask("&1 PR") == "3"
    assert card.fw.rotary.full(1) and card.fw.cs_status(1)[1] & (1 << 16)
    for _ in range(int(0.5 / PERIOD)):
        card.tick()
    assert int(card.ask("&1 PR")) < 3 and not card.fw.rotary.full(1)
    for _ in range(int(2.0 / PERIOD)):
        card.tick()
    assert card.fw.reports.commanded()[0] == pytest.approx(4000, abs=1e-6)
    assert runner.running          # waiting for more lines
    card.ask("X-4")
    for _ in range(int(1.0 / PERIOD)):
        card.tick()
    assert card.fw.reports.commanded()[0] == pytest.approx(0, abs=1e-6)
    card.ask("CLOSE")
    card.ask("&1 A")
    assert card.raw("&1 DELETE ROT") == b"\x06"


def test_rotary_errors(card: Card) -> None:
    assert card.raw("&1 B0 R") == b"\x07ERR015\r"     # no rotary buffer
    card.ask("&1 DEFINE ROT 20")
    card.ask("OPEN ROT")
    assert card.raw("X1 FOO") == b"\x07ERR003\r"      # not a program statement
    card.ask("CLOSE")
    card.ask("&1 B0 R")
    assert card.raw("&1 DELETE ROT") == b"\x07ERR001\r"


# -- kinematics -----------------------------------------------------------------------------------
def test_two_motor_kinematic_cs_moves_the_tip_on_a_straight_line() -> None:
    """The UM's shoulder-elbow robot: Isx50 = 1, #1->I #2->I; the forward program gives the
    start (motors at 30° and 60°), the move runs in tip coordinates and the inverse program gives
    the motors every segment [UM "Kinematic Calculations"]."""
    c = Card()
    c.raw("I3=2")
    c.ask("&1 #1->I #2->I")
    c.ask("&1 Q91=400 Q92=300 Q93=1000 I5150=1 I5113=10")
    c.ask("&1 OPEN FORWARD CLEAR")
    for line in FORWARD:
        c.ask(line)
    c.ask("CLOSE &1 OPEN INVERSE CLEAR")
    for line in INVERSE:
        c.ask(line)
    c.ask("CLOSE")
    c.ask("#1J/ #2J/")
    c.ask("#1J=30000 #2J=60000")
    for _ in range(int(3 / PERIOD)):
        c.tick()
    start = (400 * np.cos(np.radians(30)), 400 * np.sin(np.radians(30)) + 300)
    download(c, 1, "LINEAR ABS TA100 TS0 F100", "X500 Y200")
    m = run(c, limit=10)
    a, b = np.radians(m[:, 0] / 1000), np.radians(m[:, 1] / 1000)
    x = 400 * np.cos(a) + 300 * np.cos(a + b)
    y = 400 * np.sin(a) + 300 * np.sin(a + b)
    assert (x[0], y[0]) == pytest.approx(start, abs=1e-3)
    assert (x[-1], y[-1]) == pytest.approx((500, 200), abs=1e-3)
    # on the line from the start to (500, 200)
    d = np.array([500 - start[0], 200 - start[1]])
    normal = np.array([-d[1], d[0]]) / np.hypot(*d)
    off = (x - start[0]) * normal[0] + (y - start[1]) * normal[1]
    assert np.abs(off).max() < 0.01
    assert c.fw.q[0, 7] == pytest.approx(500, abs=1e-6)   # Q7: X of the last inverse call


def test_open_forward_while_running_and_run_while_open() -> None:
    c = Card()
    c.raw("I3=2")
    c.ask("&1 #1->1000X")
    c.ask("#1J/")
    download(c, 1, "DWELL 1000")
    c.ask("&1 B1 R")
    assert c.raw("&1 OPEN FORWARD") == b"\x07ERR001\r"
    c.ask("&1 A")
    c.ask("&1 OPEN FORWARD")
    other = PortState()
    assert c.fw.execute(other, "&1 B1 R").error == 15
    c.ask("CLOSE")
