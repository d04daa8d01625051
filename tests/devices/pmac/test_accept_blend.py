"""Acceptance: a LINEAR move blended into a CIRCLE move at a corner in segmentation mode (Isx13 > 0),
with and without the special lookahead buffer. Blended moves change velocity over the TA blend
at each corner [Turbo SRM "TA{data}"; Turbo UM "Linear Blended Moves", "Circular Interpolation":
CIRCLE moves blend as LINEAR moves do]: the commanded velocity never jumps between servo cycles,
whatever the angle between the moves."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
F = 10.0            # units/s, 1000 counts/unit: 10 counts/ms
TA = 0.2            # s
#: up +Y to (0, 10), then the clockwise arc about (-10, 10) to (-10, 20): the arc starts towards
#: -Y, a reversal at the corner
PATH = ["LINEAR ABS TA200 TS0 F10", "X0 Y10", "CIRCLE1 X-10 Y20 I-10 J0"]


def run(lookahead: bool) -> np.ndarray:
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->1000X", "&1#2->1000Y", "#1J/", "#2J/", "I5113=10",
                 "I116=1000", "I216=1000", "I117=100", "I217=100",
                 "OPEN PROG 3 CLEAR", *PATH, "CLOSE"]:
        c.ask(line)
    if lookahead:
        c.ask("&1DEFINE LOOKAHEAD 500,10")
        c.ask("I5120=50")
    c.ask("&1B3R")
    xs = [c.fw.reports.commanded()[:2].copy()]
    for _ in range(round(8.0 / DT)):
        c.tick()
        xs.append(c.fw.reports.commanded()[:2].copy())
        if not int(c.ask("&1??")[:6], 16) & 1:
            break
    else:
        raise AssertionError("the program did not end")
    assert c.ask("#1P") == "-10000" and c.ask("#2P") == "20000"
    return np.array(xs)


@pytest.mark.parametrize("lookahead", [False, True])
def test_line_into_reversing_arc_turns_over_the_blend(lookahead: bool) -> None:
    """The corner reverses Y at 10 counts/ms: over TA that is 0.1 counts/ms² (the arc adds
    v²/r = 0.01); a jump in one servo cycle would be 20 counts/ms in 0.44 ms, ~45 counts/ms².
    The speed never exceeds F (the velocity vectors blend, the corner is cut)."""
    xs = run(lookahead)
    v = np.diff(xs, axis=0) / (DT * 1000)              # counts/ms
    a = np.diff(v, axis=0) / (DT * 1000)               # counts/ms²
    assert np.abs(a).max() < 0.3
    assert np.hypot(v[:, 0], v[:, 1]).max() < F * 1.001
    # the reversal takes the blend: from +F/2 to -F/2 is half of TA
    y = v[:, 1]
    down = int(np.flatnonzero(y < -5)[0])
    assert down - np.flatnonzero(y[:down] > 5)[-1] > 0.45 * TA / DT


@pytest.mark.parametrize("stop", ["&1Q", "&1/"])
def test_quit_while_the_linear_move_is_handed_to_the_circle_planner(stop: str) -> None:
    """Q (and `/`, as Q here) during the first of X10, Y10, CIRCLE1: the program stops at the
    end of the move calculated, (10, 10) [SRM Q]. That move keeps F (10 counts/ms) and ends in a
    TA deceleration: the sequence lasts TA + 20 units / F = 2.1 s; it was one cubic from the
    corner to the end, peaking at 13.3 counts/ms."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->1000X", "&1#2->1000Y", "#1J/", "#2J/", "I5113=10",
                 "OPEN PROG 3 CLEAR", "LINEAR ABS TA100 TS0 F10", "X10 Y0", "X10 Y10",
                 "CIRCLE1 X0 Y0 R10", "CLOSE", "&1B3R"]:
        c.ask(line)
    xs = [c.fw.reports.commanded()[:2].copy()]
    for k in range(round(3.0 / DT)):
        if k == round(0.5 / DT):
            c.ask(stop)
        c.tick()
        xs.append(c.fw.reports.commanded()[:2].copy())
    x = np.array(xs)
    v = np.diff(x, axis=0) / (DT * 1000)
    assert np.abs(v).max() < F * 1.001
    assert np.abs(np.diff(v, axis=0) / (DT * 1000)).max() < 0.3
    assert c.ask("#1P") == "10000" and c.ask("#2P") == "10000"
    at_rest = np.flatnonzero(np.abs(v).max(axis=1) > 1e-6)[-1] * DT
    assert at_rest == pytest.approx(0.1 + 20 / F, abs=0.005)
