"""Acceptance: a kinematic coordinate system (Isx50 = 1, `#n->I` motors) in segmentation mode
(Isx13 > 0), with and without a lookahead buffer. The card computes the path every Isx13 ms, runs
the inverse kinematic program on it and fine-interpolates the motors [Turbo UM "Kinematic
Calculations"; SRM Isx13]: at constant axis speed the motors run at constant speed, no ripple at
the segment rate."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9


@pytest.mark.parametrize("lookahead", [False, True])
def test_segmented_kinematic_move_runs_at_constant_motor_speed(lookahead: bool) -> None:
    """X 0 -> 10 at F10 (TA100): the inverse program makes motor 1 2000 counts per unit, so
    20 counts/ms while the move cruises; it ends on 20000 counts at TA + 1 s."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->I", "&1#2->I", "#1J/", "#2J/", "I5113=10", "I5150=1",
                 "&1OPEN FORWARD CLEAR", "Q7=P1/2000", "Q8=P2/1000", "CLOSE",
                 "&1OPEN INVERSE CLEAR", "P1=Q7*2000", "P2=Q8*1000", "CLOSE",
                 "OPEN PROG 3 CLEAR", "LINEAR ABS TA100 TS0 F10", "X10 Y0", "CLOSE"]:
        c.ask(line)
    if lookahead:
        c.ask("&1DEFINE LOOKAHEAD 500,10")
        c.ask("I5120=50")
    c.ask("&1B3R")
    xs = [float(c.fw.reports.commanded()[0])]
    for _ in range(round(1.2 / DT)):
        c.tick()
        xs.append(float(c.fw.reports.commanded()[0]))
    v = np.diff(xs) / (DT * 1000)                       # counts/ms each servo cycle
    cruise = v[round(0.15 / DT):round(0.95 / DT)]
    assert cruise == pytest.approx(np.full(len(cruise), 20.0), rel=1e-3)
    assert xs[-1] == pytest.approx(20000, abs=1e-6)
    assert not int(c.ask("&1??")[:6], 16) & 1
