"""Isx13 segmentation keeps the TA/TS blend of LINEAR moves, without sockets [Turbo SRM Isx13
("segmentation mode": the path computed every Isx13 ms, fine interpolation between), TA, TS;
Turbo UM "Linear Blended Moves"; README "Segmentation and the special lookahead"].

The segments are the programmed trajectory's points every Isx13 ms joined by cubics: the
trajectory keeps its time, its end and, blending through a corner with S-curve, the acceleration
of the unsegmented blend (peak Δv/(TA − TS) per motor) within what a cubic per segment follows
of a piecewise-linear acceleration (1.1× here). A step of acceleration (TS = 0) inside a segment
is followed by the cubic of the segment's end states, whose acceleration passes the step by a
third at most. Ixx17 is high: without segmentation it would stretch the blends [SRM Ixx17]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9


def trace(isx13: int, ta: int, ts: int, f: int, *moves: str) -> np.ndarray:
    """The commanded counts of motors 1 and 2 (X, Y at 1000 counts/unit) every servo cycle of
    PROG 1 run to its end."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X #2->1000Y", "#1J/ #2J/", f"I5113={isx13} I117=1000 I217=1000",
                 "OPEN PROG 1 CLEAR", f"ABS LINEAR TA{ta} TS{ts} F{f}", *moves, "CLOSE",
                 "&1 B1 R"]:
        c.ask(line)
    rows = [c.fw.reports.commanded()[:2].copy()]
    runner = c.fw.motion.runner(1)
    for _ in range(round(5.0 / DT)):
        c.tick()
        rows.append(c.fw.reports.commanded()[:2].copy())
        if not runner.running:
            break
    assert not runner.running
    return np.array(rows)


def peak_accel(rows: np.ndarray) -> np.ndarray:
    """Each motor's peak |acceleration|, counts/ms²."""
    return np.max(np.abs(np.diff(rows, 2, axis=0)), axis=0) / (DT * 1000) ** 2


CORNERS = [(100, 50, 17, ("X10", "Y10")),          # right angle, S-curve blends (TS = TA/2)
           (100, 50, 17, ("X10 Y3", "X4 Y9")),     # obtuse turn
           (73, 30, 23, ("X10", "X3 Y7"))]         # acute turn, TS < TA/2, off the ms grid


@pytest.mark.parametrize("isx13", [5, 10, 20])
@pytest.mark.parametrize(("ta", "ts", "f", "moves"), CORNERS)
def test_segmented_corner_keeps_the_s_curve_blend_acceleration(
        isx13: int, ta: int, ts: int, f: int, moves: tuple[str, ...]) -> None:
    """Segmented, the peak |acceleration| of each motor through the blends is within 1.1× the
    unsegmented run's; same time (servo cycles), same end."""
    plain = trace(0, ta, ts, f, *moves)
    seg = trace(isx13, ta, ts, f, *moves)
    assert len(seg) == len(plain)
    assert np.array_equal(seg[-1], plain[-1])
    assert np.all(peak_accel(seg) <= 1.1 * peak_accel(plain))


def test_segmented_corner_without_s_curve_passes_the_step_by_a_third_at_most() -> None:
    """TS = 0: the blend's acceleration steps (Δv/TA); the segment holding a step follows it with a
    cubic of its end states: at most 4/3 of the step (a step at 2/3 of the segment)."""
    plain = trace(0, 100, 0, 17, "X10", "Y10")
    seg = trace(20, 100, 0, 17, "X10", "Y10")
    assert len(seg) == len(plain) and np.array_equal(seg[-1], plain[-1])
    assert np.all(peak_accel(seg) <= 4 / 3 * peak_accel(plain))
