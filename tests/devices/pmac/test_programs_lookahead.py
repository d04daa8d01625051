"""Isx13 segmentation and the special lookahead buffer, without sockets: DEFINE/DELETE LOOKAHEAD,
Isx20, Ixx16 and Ixx17 enforced per Isx13 segment by slowing the trajectory, stopping in time
at the end of the buffer [Turbo SRM DEFINE LOOKAHEAD, Isx13, Isx20, Ixx16, Ixx17; Turbo UM
"Special Lookahead"; README "Motion programs"].

The limits act per segment (a segment's mean velocity, the change of mean velocity from one
segment to the next): the trajectory's velocity and acceleration are measured here over
windows of one segment (Isx13 = 10 ms)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_programs import cs_words, download, running

DT = 442_710e-9
WINDOW = int(round(0.010 / DT))   # one Isx13 segment of servo cycles
LOOKAHEAD_BIT = 1 << 23           # `??` word 2 [digest §2.6]
#: X 0 -> 10 units (10000 counts) at F100 (100 counts/ms) with TA10: 110 ms as programmed
MOVE = ("LINEAR ABS TA10 TS0 F100", "X10")


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->1000X &1#2->1000Y #1J/#2J/")
    c.ask("I116=1000 I216=1000 I117=100 I217=100")
    return c


def run(card: Card) -> tuple[float, np.ndarray]:
    """Run PROG 1 to its end: (seconds, motor 1's commanded counts every servo cycle)."""
    card.ask("&1B1R")
    xs = [0.0]
    for _ in range(20000):
        card.tick()
        xs.append(float(card.fw.reports.commanded()[0]))
        if not running(card):
            break
    return (len(xs) - 1) * DT, np.array(xs)


def window_velocity(xs: np.ndarray) -> np.ndarray:
    """Mean velocity over one segment's time, counts/ms."""
    return (xs[WINDOW:] - xs[:-WINDOW]) / (WINDOW * DT * 1000)


def window_acceleration(xs: np.ndarray) -> np.ndarray:
    """Change of the segment-mean velocity over one segment's time, counts/ms²."""
    v = window_velocity(xs)
    return (v[WINDOW:] - v[:-WINDOW]) / (WINDOW * DT * 1000)


def test_define_and_delete_lookahead(card: Card) -> None:
    assert card.raw("&1DEFINE LOOKAHEAD 0,10") == b"\x07ERR003\r"
    assert card.raw("&1DEFINE LOOKAHEAD 70000,10") == b"\x07ERR003\r"
    assert card.raw("&1DEFINE LOOKAHEAD 100,10") == b"\x06"
    assert card.fw.motion.runner(1).lookahead_buffer == (100, 10)
    assert card.raw("&2DEFINE LOOKAHEAD 50") == b"\x06"
    download(card, 1, *MOVE)
    card.ask("&1B1R")
    assert card.raw("&1DELETE LOOKAHEAD") == b"\x07ERR001\r"
    assert card.raw("&2DELETE LOOKAHEAD") == b"\x06"
    assert card.fw.motion.runner(2).lookahead_buffer is None
    card.raw("$$$***")
    assert card.fw.motion.runner(1).lookahead_buffer is None


def test_lookahead_buffers_keep_the_buffer_order(card: Card) -> None:
    """The order COMP, BLCOMP, TCOMP, TBUF, ROTARY, LOOKAHEAD, GATHER [Turbo SRM; A L3139;
    README "Compensation tables"]: a lookahead buffer refuses DEFINE COMP and DEFINE ROT, a
    gather buffer refuses DEFINE LOOKAHEAD, all with ERR007; a rotary buffer comes before."""
    card.ask("&2 DEFINE ROT 100")
    assert card.raw("&1DEFINE LOOKAHEAD 100,10") == b"\x06"
    assert card.raw("#1 DEFINE COMP 4,1000") == b"\x07ERR007\r"
    assert card.raw("&1 DEFINE ROT 100") == b"\x07ERR007\r"
    card.ask("DEFINE GATHER 100")
    assert card.raw("&3DEFINE LOOKAHEAD 100,10") == b"\x07ERR007\r"
    card.ask("DELETE GATHER")
    assert card.raw("&3DEFINE LOOKAHEAD 100,10") == b"\x06"


def test_segmentation_alone_keeps_the_programmed_time_and_end(card: Card) -> None:
    """Isx13 = 10 without a lookahead buffer: segments only; Ixx16/Ixx17 are the lookahead's
    (not applied) [SRM Ixx16, Ixx17]: 110 ms as programmed, ending on the point."""
    download(card, 1, *MOVE)
    card.ask("I5113=10 I5120=50 I117=0.5 I116=20")
    t, xs = run(card)
    assert t == pytest.approx(0.110, abs=2 * DT)
    assert xs[-1] == 10000.0


def test_lookahead_keeps_every_segment_within_ixx17(card: Card) -> None:
    """Ixx17 = 0.5 counts/ms²: the ramp to speed would be 10 counts/ms² as programmed; the
    lookahead stretches it so no segment-to-segment change exceeds Ixx17, and decelerates in
    time to stop on the end point: a triangle, peak sqrt(0.5 × 10000) = 70.7 counts/ms at
    the middle, 283 ms in all (the segment grid adds a little)."""
    download(card, 1, *MOVE)
    card.ask("&1DEFINE LOOKAHEAD 200,20")
    card.ask("I5113=10 I5120=50 I117=0.5")
    t, xs = run(card)
    assert xs[-1] == 10000.0
    assert 0.282 <= t < 0.283 * 1.12
    assert np.max(np.abs(window_acceleration(xs))) <= 0.5 * 1.05
    assert 65 < np.max(window_velocity(xs)) <= 71.0


def test_lookahead_keeps_every_segment_within_ixx16(card: Card) -> None:
    """Ixx16 = 20 counts/ms (Ixx17 = 2): the move cruises at 20 counts/ms, not 100. The
    segments are the programmed path's 10 ms points, stretched: the first (500 counts of the
    programmed 10 ms ramp) takes 50 ms from rest to 20 counts/ms, as does the last; 9000
    counts at 20 counts/ms between: 550 ms."""
    download(card, 1, *MOVE)
    card.ask("&1DEFINE LOOKAHEAD 200,20")
    card.ask("I5113=10 I5120=50 I116=20 I117=2")
    t, xs = run(card)
    assert xs[-1] == 10000.0
    assert t == pytest.approx(0.550, abs=3 * DT)
    assert np.max(window_velocity(xs)) <= 20 * 1.03
    assert np.max(np.abs(window_acceleration(xs))) <= 2 * 1.05


def test_a_short_lookahead_slows_the_move_to_stop_within_the_buffer(card: Card) -> None:
    """Isx20 = 2: the motion must be able to stop within the two segments buffered (2 × 1000
    counts of path): the speed stays within sqrt(2 × 0.5 × 2000) = 44.7 counts/ms, not the
    70.7 that 50 segments allow; the limits hold."""
    download(card, 1, *MOVE)
    card.ask("&1DEFINE LOOKAHEAD 200,20")
    card.ask("I5113=10 I5120=2 I117=0.5")
    t, xs = run(card)
    assert xs[-1] == 10000.0
    assert 40 < np.max(window_velocity(xs)) <= 44.73
    assert t > 0.3
    assert np.max(np.abs(window_acceleration(xs))) <= 0.5 * 1.05


def test_corner_speed_is_limited_by_ixx17_and_the_path_is_kept(card: Card) -> None:
    """X then Y at F100 with a 10 ms blend: as programmed motor 1 stops and motor 2 starts
    within 10 ms at the corner (10 counts/ms²). With Ixx17 = 0.5 the lookahead slows the
    corner so that no motor's velocity changes by more than Ixx17 over a segment's time; where
    the path turns, the spline through the points is not of constant acceleration inside a
    segment, so the measured peak may pass Ixx17 there, within twice it (README). The run ends
    on (10, 10), the straight parts ramp at Ixx17 exactly."""
    download(card, 1, "LINEAR ABS TA10 TS0 F100", "X10", "Y10")
    card.ask("&1DEFINE LOOKAHEAD 200,20")
    card.ask("I5113=10 I5120=50 I117=0.5 I217=0.5")
    card.ask("&1B1R")
    xs, ys = [0.0], [0.0]
    bits = 0
    for _ in range(20000):
        card.tick()
        cmd = card.fw.reports.commanded()
        xs.append(float(cmd[0]))
        ys.append(float(cmd[1]))
        bits |= cs_words(card)[1] if len(xs) == 50 else 0
        if not running(card):
            break
    assert bits & LOOKAHEAD_BIT
    assert (xs[-1], ys[-1]) == (10000.0, 10000.0)
    for trace in (np.array(xs), np.array(ys)):
        acc = np.abs(window_acceleration(trace))
        assert np.max(acc) <= 0.5 * 2
        assert np.count_nonzero(acc > 0.5 * 1.05) < 0.1 * len(acc)
    assert not cs_words(card)[1] & LOOKAHEAD_BIT


def test_a_blended_sequence_runs_through_the_lookahead_without_stopping(card: Card) -> None:
    """Ten X1 moves (INC) at F20 blended: the buffer is refilled move after move as it runs.
    Ixx17 = 0.05 counts/ms²: 400 ms ramps up to 20 counts/ms and down to the end, 2000 counts
    at speed between: 900 ms, ending on X = 10; Isx20 = 20 segments of 200 counts hold just
    the 4000 counts the stop from 20 counts/ms needs."""
    download(card, 1, "LINEAR INC TA50 TS0 F20", *["X1"] * 10)
    card.ask("&1DEFINE LOOKAHEAD 200,20")
    card.ask("I5113=10 I5120=20 I117=0.05")
    t, xs = run(card)
    assert xs[-1] == 10000.0
    assert t == pytest.approx(0.900, abs=3 * DT)
    v = window_velocity(xs)
    assert np.max(v) == pytest.approx(20.0, abs=0.01)
    assert np.count_nonzero(v > 19.99) * DT > 0.05    # at speed in the middle
    assert np.max(np.abs(window_acceleration(xs))) <= 0.05 * 1.02


def test_the_lookahead_turns_a_right_angle_corner_without_stopping(card: Card) -> None:
    """X then Y at F100 with a 10 ms blend, Ixx17 = 0.5: inside the corner's segment motor 1
    stops and motor 2 starts, so both ends of that segment run at the speed that makes each
    motor's change Ixx17 × the segment's time: the corner is entered and left at sqrt(0.5 ×
    1000) = 22.4 counts/ms (1000 counts: the segment's programmed 10 ms at 100 counts/ms), one
    motor slowing as the other speeds up, so the path speed dips to 22.4/√2 = 15.8 in the middle
    but does not stop there, and no motor passes Ixx17 [UM "Special Lookahead"]."""
    download(card, 1, "LINEAR ABS TA10 TS0 F100", "X10", "Y10")
    card.ask("&1DEFINE LOOKAHEAD 200,20")
    card.ask("I5113=10 I5120=50 I117=0.5 I217=0.5")
    card.ask("&1B1R")
    rows = [card.fw.reports.commanded()[:2].copy()]
    for _ in range(20000):
        card.tick()
        rows.append(card.fw.reports.commanded()[:2].copy())
        if not running(card):
            break
    xy = np.array(rows)
    assert np.array_equal(xy[-1], [10000.0, 10000.0])
    speed = np.linalg.norm(np.diff(xy, axis=0), axis=1) / (DT * 1000)
    corner = (xy[1:, 0] > 9000) & (xy[1:, 1] < 1000)   # the last/first 1000 counts of X/Y
    assert np.min(speed[corner]) == pytest.approx(np.sqrt(500 / 2), abs=0.05)
    for trace in xy.T:
        assert np.max(np.abs(window_acceleration(trace))) <= 0.5 * 1.001
