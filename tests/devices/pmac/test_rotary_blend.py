"""A rotary buffer fed while it runs blends its moves as a stored program would, without sockets
[Turbo SRM "OPEN ROT", I16, I17, Isx13, Isx20; Turbo UM "Rotary Motion Program Buffers",
"Calculating Ahead", "Special Lookahead"; README "Rotary buffers"].

The card calculates ahead; the rotary buffer is dry only if its next line is not there when the
card needs it: when the motion would have to begin the blend out of the last move (its TA/2
before the corner; with Isx13 > 0 up to two segments earlier: the segment interpolated and the
point after it; with the lookahead, Isx20 segments more, the lookahead buffer filling from the
rotary buffer). A line
sent before that blends through the corner; after it the last move decelerates to a stop on
its end in its TA and the late line starts from rest.

The moves: X10 at F20 (0.5 s) from rest with TA50, then Y10. The blend out of X10 begins at
0.5 s (centred on the corner at 0.525 s) and ends at 0.55 s; blended, the sequence ends at
1.05 s; stopped at the corner, the Y move runs 0.55-1.10 s."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9


def feed(isx13: int, send: dict[float, str], lookahead: int = 0, seconds: float = 1.3,
         accel: float = 1.0) -> np.ndarray:
    """Run C.S. 1's rotary buffer holding `INC LINEAR TA50 TS0 F20` and X10, each further line
    sent at its time (s) while it runs; the commanded counts of motors 1 and 2 each cycle."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X #2->1000Y", "#1J/ #2J/", f"I5113={isx13}",
                 f"I117={accel} I217={accel}", "&1 DEFINE ROT 200"]:
        c.ask(line)
    if lookahead:
        c.ask(f"&1 DEFINE LOOKAHEAD 500,10 I5120={lookahead}")
    for line in ["&1 B0", "OPEN ROT", "INC LINEAR TA50 TS0 F20", "X10", "&1 R"]:
        c.ask(line)
    waiting = sorted(send.items())
    rows = [c.fw.reports.commanded()[:2].copy()]
    for k in range(round(seconds / DT)):
        while waiting and waiting[0][0] <= k * DT:
            c.ask(waiting.pop(0)[1])
        c.tick()
        rows.append(c.fw.reports.commanded()[:2].copy())
    return np.array(rows)


def stored(isx13: int, lookahead: int = 0, seconds: float = 1.3,
           accel: float = 1.0) -> np.ndarray:
    """The same moves as PROG 1 (as `feed`): the trace a stored program gives."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X #2->1000Y", "#1J/ #2J/", f"I5113={isx13}",
                 f"I117={accel} I217={accel}"]:
        c.ask(line)
    if lookahead:
        c.ask(f"&1 DEFINE LOOKAHEAD 500,10 I5120={lookahead}")
    for line in ["OPEN PROG 1 CLEAR", "INC LINEAR TA50 TS0 F20", "X10", "Y10", "CLOSE",
                 "&1 B1 R"]:
        c.ask(line)
    rows = [c.fw.reports.commanded()[:2].copy()]
    for _ in range(round(seconds / DT)):
        c.tick()
        rows.append(c.fw.reports.commanded()[:2].copy())
    return np.array(rows)


def speed(rows: np.ndarray) -> np.ndarray:
    """Path speed, counts/ms, each cycle."""
    return np.linalg.norm(np.diff(rows, axis=0), axis=1) / (DT * 1000)


def corner_speed(rows: np.ndarray) -> float:
    """The lowest path speed between X9 and Y1 (the corner's blend)."""
    v = speed(rows)
    inside = (rows[1:, 0] > 9000) & (rows[1:, 1] < 1000)
    return float(np.min(v[inside]))


def end_time(rows: np.ndarray) -> float:
    return float(np.argmax(np.all(rows == [10000.0, 10000.0], axis=1)) * DT)


@pytest.mark.parametrize("isx13", [0, 10])
def test_a_line_sent_while_the_move_runs_blends_through_the_corner(isx13: int) -> None:
    """Y10 sent at 0.45 s, 0.05 s before the blend out of X10 begins (the card took X10 at R,
    so the buffer was empty when X10 started): the TA blend turns the corner, the path speed
    dipping to 20/√2 = 14.1 counts/ms in its middle, and the sequence ends at 1.05 s: the
    trajectory of the same moves stored in a PROG."""
    rows = feed(isx13, {0.45: "Y10"})
    assert np.allclose(rows, stored(isx13), rtol=0, atol=1e-6)
    assert corner_speed(rows) == pytest.approx(20 / np.sqrt(2), abs=0.05)
    assert end_time(rows) == pytest.approx(1.05, abs=2 * DT)


@pytest.mark.parametrize("isx13", [0, 10])
def test_a_line_sent_too_late_finds_the_move_stopping_on_its_end(isx13: int) -> None:
    """Y10 sent at 0.52 s, after the blend would have begun: X10 decelerates to a stop on X10 in
    its TA (0.50-0.55 s), Y10 starts from rest there and ends at 1.10 s."""
    rows = feed(isx13, {0.52: "Y10"})
    stop = round(0.55 / DT)
    assert rows[stop - 2, 0] == pytest.approx(10000, abs=0.5) and rows[stop - 2, 1] == 0.0
    assert corner_speed(rows) < 0.05
    assert end_time(rows) == pytest.approx(1.10, abs=2 * DT)


@pytest.mark.parametrize("isx13", [0, 10])
def test_lines_fed_just_in_time_keep_the_speed(isx13: int) -> None:
    """INC X1 moves at F20 (50 ms each) fed one at a time, each 30 ms before the blend into it
    must begin (two segments of 10 ms ahead with Isx13 = 10): X keeps 20 counts/ms from the end
    of the first ramp (TA20) to the last, no stop at any corner (Ixx17 high: with Isx13 = 0 it
    would stretch the ramps)."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X", "#1J/", f"I5113={isx13} I117=1000", "&1 DEFINE ROT 200", "&1 B0",
                 "OPEN ROT", "INC LINEAR TA20 TS0 F20", "X1", "&1 R"]:
        c.ask(line)
    xs = [float(c.fw.reports.commanded()[0])]
    sends = [0.05 * k - 0.03 for k in range(1, 8)]   # blend into move k begins at 0.05·k
    for k in range(round(0.6 / DT)):
        while sends and sends[0] <= k * DT:
            c.ask("X1")
            sends.pop(0)
        c.tick()
        xs.append(float(c.fw.reports.commanded()[0]))
    v = np.diff(np.array(xs)) / (DT * 1000)
    cruise = v[round(0.021 / DT):round(0.399 / DT)]
    assert np.all(np.abs(cruise - 20.0) < 1e-6)
    assert xs[-1] == 8000.0


def test_a_blend_ixx17_stretches_keeps_its_room_while_the_line_is_awaited() -> None:
    """Isx13 = 0, Ixx17 = 0.2 counts/ms²: the corner's 20 counts/ms change needs a 100 ms blend,
    not TA50 [SRM Ixx17], beginning at 0.475 s. Waiting for Y10, X10 runs on only as far as
    the motion needs (10 ms at a time), so Y10 sent at 0.44 s still gets the stretched blend:
    the stored program's trajectory."""
    rows = feed(0, {0.44: "Y10"}, accel=0.2, seconds=2.0)
    assert np.allclose(rows, stored(0, accel=0.2, seconds=2.0), rtol=0, atol=1e-6)
    assert corner_speed(rows) > 5.0


def test_the_lookahead_fills_from_the_rotary_buffer() -> None:
    """Isx13 = 10 with a lookahead of Isx20 = 10 segments: the lookahead calculates 0.1 s of path
    ahead, so Y10 must come 0.1 s before the blend: at 0.35 s it blends (and the lookahead bit
    is set), at 0.45 s (in time without the lookahead) X10 stops on its end first."""
    blended = feed(10, {0.35: "Y10"}, lookahead=10)
    assert corner_speed(blended) == pytest.approx(20 / np.sqrt(2), abs=0.05)
    assert end_time(blended) == pytest.approx(1.05, abs=2 * DT)
    stopped = feed(10, {0.45: "Y10"}, lookahead=10)
    assert corner_speed(stopped) < 0.05
    assert end_time(stopped) == pytest.approx(1.10, abs=2 * DT)


def test_the_lookahead_slows_a_rotary_corner_within_ixx17() -> None:
    """Ixx17 = 0.2 counts/ms² and Y10 in time: the lookahead runs the trajectory of the same
    stored program, the corner slowed but not stopped, every motor's segment-to-segment change
    within Ixx17 (but where the path turns inside a segment: 1.1×, README), ending on (10, 10)."""
    rows = feed(10, {0.1: "Y10"}, lookahead=10, accel=0.2, seconds=2.0)
    assert np.allclose(rows, stored(10, lookahead=10, accel=0.2, seconds=2.0), rtol=0, atol=1e-6)
    assert np.array_equal(rows[-1], [10000.0, 10000.0])
    assert corner_speed(rows) > 5.0
    w = round(0.010 / DT)
    for trace in rows.T:
        vel = (trace[w:] - trace[:-w]) / (w * DT * 1000)
        acc = (vel[w:] - vel[:-w]) / (w * DT * 1000)
        assert np.max(np.abs(acc)) <= 0.2 * 1.1


def run_lines(lines: list[str], send: dict[float, str], seconds: float) -> np.ndarray:
    """Isx13 = 10: `lines` into C.S. 1's rotary buffer (B0 R) with `send` (time: line) sent as it
    runs, or, `send` empty, as PROG 1 (B1 R); motors 1 and 2 each cycle."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X #2->1000Y", "#1J/ #2J/", "I5113=10", "&1 DEFINE ROT 200"]:
        c.ask(line)
    start = ["&1 B0", "OPEN ROT", *lines, "&1 R"] if send else \
        ["OPEN PROG 1 CLEAR", *lines, "CLOSE", "&1 B1 R"]
    for line in start:
        c.ask(line)
    waiting = sorted(send.items())
    rows = [c.fw.reports.commanded()[:2].copy()]
    for k in range(round(seconds / DT)):
        while waiting and waiting[0][0] <= k * DT:
            c.ask(waiting.pop(0)[1])
        c.tick()
        rows.append(c.fw.reports.commanded()[:2].copy())
    return np.array(rows)


ARCS = ["ABS CIRCLE1 TA50 TS0 F20", "X10 Y10 I10 J0"]   # then X20 Y0 I0 J-10, on the same circle


def test_a_circle_sequence_fed_in_time_blends_as_stored() -> None:
    """CIRCLE moves (Isx13 > 0) blend as LINEAR ones [UM "Circular Interpolation"]: the second
    arc sent at 0.6 s, while the first (0.785 s of path from 0.025 s) runs, gives the stored
    program's trajectory, at F without a slow-down (the arcs are tangent); sent at 0.78 s,
    after its blend would have begun, the first arc stops on its end first."""
    second = "X20 Y0 I0 J-10"
    stored_arcs = run_lines([*ARCS, second], {}, 2.5)
    fed = run_lines(ARCS, {0.6: second}, 2.5)
    assert np.allclose(fed, stored_arcs, rtol=0, atol=1e-6)
    v = speed(fed)[round(0.1 / DT):round(1.5 / DT)]
    assert np.min(v) > 19.99
    late = run_lines(ARCS, {0.78: second}, 2.5)
    assert np.min(speed(late)[round(0.1 / DT):round(1.5 / DT)]) < 0.1
    assert np.array_equal(late[-1], [20000.0, 0.0])


def test_linear_into_circle_and_back_fed_in_time_runs_as_stored() -> None:
    """LINEAR X10, then CIRCLE1 and LINEAR again sent while the move before runs (mode_blend.py:
    the sequence goes on in the CIRCLE planner): the stored program's trajectory."""
    lines = ["ABS LINEAR TA50 TS0 F20", "X10"]
    more = {0.3: "CIRCLE1 X20 Y10 I0 J10", 0.8: "LINEAR Y20"}
    fed = run_lines(lines, more, 5.0)
    stored_seq = run_lines([*lines, *more.values()], {}, 5.0)
    assert np.allclose(fed, stored_seq, rtol=0, atol=1e-6)
    assert np.array_equal(fed[-1], [20000.0, 20000.0])
