"""Stopping a PVT program on a moving point, without sockets: Q and `/` end in a controlled
deceleration (no velocity step), H slews the time base, A decelerates at Ixx15 [Turbo SRM Q, `/`,
H, A, PVT, Ixx15; UM "Writing and Executing Motion Programs": Abort; pvt.py `PvtPlanner.stop`,
stop_commands.py; README "Motion programs", Assumptions].

The program: PVT100, one unit (1000 counts) a segment at 10 units/s (10 counts/ms) from X1 to
X10, the last point at rest. Segment k runs from (k−1)·0.1 s to k·0.1 s; the calculation is one
segment ahead (README "Calculation and look-ahead"), so at 0.35 s segment 4 executes and segment 5
is calculated."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
V = 10_000.0            # counts/s on the constant-velocity points
SEG = 0.1               # the PVT segment time, s
PROGRAM = ["OPEN PROG 7 CLEAR", "ABS PVT100", *[f"X{k}:10" for k in range(1, 10)], "X10:0",
           "CLOSE"]


def setup(ixx15: float | None = None) -> Card:
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->1000X", "#1J/", *PROGRAM]:
        c.ask(line)
    if ixx15 is not None:
        c.ask(f"I115={ixx15}")
    return c


def ticks(seconds: float) -> int:
    return round(seconds / DT)


def running(c: Card) -> bool:
    return bool(int(c.ask("&1??")[:6], 16) & 1)


def trace(c: Card, seconds: float) -> np.ndarray:
    """Motor 1's commanded position (counts) at each servo cycle for `seconds`."""
    out = []
    for _ in range(ticks(seconds)):
        c.tick()
        out.append(float(c.fw.motors.core.axes.cmd_pos[0] - c.fw.motors.origin[0]))
    return np.array(out)


def max_dv(positions: np.ndarray) -> float:
    """The largest change of velocity from one servo cycle to the next, counts/s per cycle."""
    v = np.diff(positions) / DT
    return float(np.abs(np.diff(v)).max())


def run_to(c: Card, seconds: float) -> np.ndarray:
    c.ask("&1B7R")
    return trace(c, seconds)


def test_q_in_pvt_decelerates_over_the_segment_time_past_the_last_point_calculated() -> None:
    """Q at 0.35 s: segments 4 and 5 (calculated) run to X5 at 10 units/s, then the axes slow at
    a constant rate to rest in the PVT time (0.1 s; Ixx15 = 0.25 counts/ms² would allow 40 ms),
    v·T/2 = 500 counts past X5; no cycle changes the velocity by more than V/T·dt."""
    c = setup()
    before = run_to(c, 0.35)
    c.ask("&1Q")
    after = trace(c, 0.5)
    assert not running(c)
    assert c.ask("#1P") == "5500"
    assert after[-1] == pytest.approx(5500.0, abs=1e-6)
    whole = np.concatenate([before[-3:], after])
    assert max_dv(whole) <= V / SEG * DT * 1.05 + 1.0   # the stop's own deceleration, ±rounding
    stopping = after[ticks(0.16):ticks(0.24)]           # 0.51-0.59 s: inside the deceleration
    assert 5000 < stopping[0] < stopping[-1] < 5500


def test_q_in_pvt_decelerates_no_faster_than_ixx15() -> None:
    """Ixx15 = 0.05 counts/ms²: from 10 counts/ms the stop takes 200 ms (longer than the 100 ms
    segment), V·0.2/2 = 1000 counts past X5."""
    c = setup(ixx15=0.05)
    run_to(c, 0.35)
    c.ask("&1Q")
    after = trace(c, 0.6)
    assert c.ask("#1P") == "6000" and not running(c)
    assert max_dv(after) <= 0.05e6 * DT * 1.05 + 1.0


def test_slash_in_pvt_stops_after_the_executing_segment_and_r_ends_on_the_program_end() -> None:
    """`/` at 0.35 s: segment 5 is given back; segment 4 ends on X4 at 10 units/s and the axes
    decelerate to 4500 counts; R calculates segment 5 again from there and the program ends on
    X10."""
    c = setup()
    run_to(c, 0.35)
    c.ask("&1/")
    after = trace(c, 0.4)
    assert c.ask("#1P") == "4500" and not running(c)
    assert max_dv(after) <= V / SEG * DT * 1.05 + 1.0
    c.ask("&1R")
    resumed = trace(c, 1.5)
    assert c.ask("#1P") == "10000" and not running(c)
    assert resumed[0] >= 4500                            # it starts from where it stopped


def test_feed_hold_in_pvt_slews_the_velocity_down_without_a_step() -> None:
    """H at 0.35 s: the time base slews to 0 at Isx95/I10 per cycle (1644/3713707), so the
    velocity falls by at most V·Isx95/I10 a cycle (plus the segment's own acceleration, 0
    here); the axes stand on the path until R, and the program ends on X10."""
    c = setup()
    before = run_to(c, 0.35)
    c.ask("&1H")
    held = trace(c, 1.5)
    assert running(c)
    assert held[-1] == held[-200]                        # standing
    assert max_dv(np.concatenate([before[-3:], held])) <= V * 1644 / 3713707 * 1.05 + 1.0
    c.ask("&1R")
    trace(c, 2.5)
    assert c.ask("#1P") == "10000" and not running(c)


def test_abort_in_pvt_decelerates_each_motor_at_ixx15() -> None:
    """A at 0.35 s: the motors leave the path and stop at Ixx15 (0.25 counts/ms²): from 10
    counts/ms in 40 ms, V·0.04/2 = 200 counts past where A came [UM "Abort"]."""
    c = setup()
    before = run_to(c, 0.35)
    at = before[-1]
    c.ask("&1A")
    after = trace(c, 0.2)
    assert not running(c)
    assert max_dv(np.concatenate([before[-3:], after])) <= 0.25e6 * DT * 1.05 + 1.0
    assert after[-1] == pytest.approx(at + 200, abs=10)
