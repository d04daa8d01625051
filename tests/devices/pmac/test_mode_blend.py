"""LINEAR and CIRCLE moves blended into one sequence in segmentation mode: no stop at a change of
move mode, TA/TS at the boundaries [Turbo SRM LINEAR, CIRCLE1/2, Isx13; mode_blend.py]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
#: a line to (10, 0), the counter-clockwise quarter circle about (10, 10) to (20, 10), a line to
#: (20, 20): tangent at both joins, 10 + 5π + 10 units at F10
PATH = ["LINEAR ABS TA200 TS0 F10", "X10 Y0", "CIRCLE2 X20 Y10 I0 J10", "LINEAR X20 Y20"]
LENGTH = 20 + 5 * np.pi


def card(isx13: int) -> Card:
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->1000X", "&1#2->1000Y", "#1J/", "#2J/", f"I5113={isx13}",
                 "OPEN PROG 3 CLEAR", *PATH, "CLOSE"]:
        c.ask(line)
    return c


def position(c: Card) -> np.ndarray:
    return np.array([float(c.ask("#1P")), float(c.ask("#2P"))]) / 1000


def running(c: Card) -> bool:
    return bool(int(c.ask("&1??")[:6], 16) & 1)


def test_line_arc_line_runs_without_a_stop() -> None:
    """One acceleration (TA/2 before the path's start time) and one deceleration: the sequence
    ends at TA + length/F, where a stop at each change of mode would add a TA each; the speed
    at both joins is F."""
    c = card(10)
    c.ask("&1B3R")
    speeds = []
    for join in (1.1, 0.2 + (10 + 5 * np.pi) / 10):   # the joins' times on the path
        c.tick(round(join / DT) - c.fw.servo_cycles + 1)
        a = position(c)
        c.tick(10)
        speeds.append(float(np.linalg.norm(position(c) - a)) / (10 * DT))
    assert speeds == [pytest.approx(10, rel=0.03)] * 2
    end = 0.2 + LENGTH / 10
    c.tick(round((end - 0.01) / DT) - c.fw.servo_cycles)
    assert running(c)
    c.tick(round(0.02 / DT))
    assert not running(c)
    assert c.ask("#1P") == "20000" and c.ask("#2P") == "20000"


def test_without_segmentation_each_change_still_stops() -> None:
    """Isx13 = 0: CIRCLE moves are straight moves of their own planner (the chord, 10·√2) and
    the change of mode ends the sequence (README): three sequences of TA + length/F each, 4.01 s,
    still running when the blended arc path (longer) would be done."""
    c = card(0)
    c.ask("&1B3R")
    c.tick(round((0.2 + LENGTH / 10 + 0.05) / DT))
    assert running(c)
    c.tick(round(3.0 / DT))
    assert c.ask("#1P") == "20000" and c.ask("#2P") == "20000" and not running(c)
