"""Where Q and `/` stop in each move mode, without sockets [Turbo SRM Q, `/`; UM "How PMAC
Executes a Motion Program", "When No Calculation Ahead"; README "Calculation and look-ahead",
"`/` and `\\`"].

Q stops "at the end of the moves already calculated": as deep as the mode calculates ahead of
the executing move (LINEAR and CIRCLE two moves with Isx13 = 0, one with Isx13 > 0; PVT one;
SPLINE1 two, SPLINE2 three, as their next segment needs; RAPID none, the calculation waits for
the motors). `/` stops at the end of the executing move (SPLINE: where the executing segment
lets the sequence end, one move sooner than Q).

The program: eight 10-unit moves along X (#1->1000X), 1 s each (TM1000 / PVT1000 / SPLINE
TM1000 at 10 units/s; RAPID at Ixx22 = 10 counts/ms, Ixx19 = 0.1 counts/ms²), TA100 TS0. At
2.5 s move 3 executes (LINEAR/CIRCLE corners at 1.05, 2.05, 3.05 s; PVT segments end at whole
seconds; RAPID moves last 1.1 s) and SPLINE's move 2 (its added start segment takes the first
second). The velocity never changes faster than the program's own accelerations allow."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
#: units/s²: 1.5 × the steepest acceleration the programs ask (a 100 ms TA blend of 10 units/s)
A_MAX = 150.0
HEADS = {"LINEAR": "LINEAR TA100 TS0 TM1000", "CIRCLE1": "CIRCLE1 TA100 TS0 TM1000",
         "PVT": "PVT1000", "SPLINE1": "SPLINE1 TM1000", "SPLINE2": "SPLINE2 TM1000",
         "RAPID": "RAPID"}


def setup(mode: str, isx13: int) -> Card:
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->1000X", "#2->1000Y", "#1J/", "#2J/", f"I5113={isx13}",
                 "I122=10", "I222=10", "I119=0.1", "I120=0", "I121=0", "I219=0.1", "I220=0",
                 "I221=0"]:
        c.ask(line)
    moves = [f"X{10 * k}:10" if mode == "PVT" else
             f"X{10 * k} Y0 R5" if mode.startswith("CIRCLE") else f"X{10 * k}"
             for k in range(1, 9)]
    for line in ["OPEN PROG 5 CLEAR", "ABS " + HEADS[mode], *moves, "CLOSE"]:
        c.ask(line)
    return c


def running(c: Card) -> bool:
    return bool(int(c.ask("&1??")[:6], 16) & 1)


def stop_at(mode: str, isx13: int, command: str) -> tuple[Card, float, float]:
    """Run, give `command` at 2.5 s, run 12 s more: (card, stop X in units, the largest change
    of X velocity from one servo cycle to the next, units/s per cycle)."""
    c = setup(mode, isx13)
    c.ask("&1B5R")
    c.tick(round(2.5 / DT))
    c.ask("&1" + command)
    xs = []
    for _ in range(round(12.0 / DT)):
        c.tick()
        xs.append(float(c.fw.motors.core.axes.cmd_pos[0] - c.fw.motors.origin[0]) / 1000)
    dv = float(np.abs(np.diff(np.diff(xs))).max()) / DT
    assert not running(c)
    return c, float(c.ask("#1P")) / 1000, dv


@pytest.mark.parametrize(("mode", "isx13", "q_end", "slash_end"), [
    ("LINEAR", 0, 50.0, 30.0),     # two calculated ahead; `/` gives both back
    ("LINEAR", 10, 40.0, 30.0),    # one calculated ahead (segmentation)
    ("CIRCLE1", 0, 50.0, 30.0),    # runs as LINEAR without segmentation
    ("CIRCLE1", 10, 40.0, 30.0),   # segmented as LINEAR
    ("PVT", 0, 45.0, 35.0),        # one ahead, then v·T/2 = 10·1/2 of deceleration
    ("PVT", 10, 45.0, 35.0),       # Isx13 does not act on PVT
    ("SPLINE1", 0, 40.0, 30.0),    # move 2 executes, points 3 and 4 calculated; `/`: its
    ("SPLINE2", 10, 50.0, 40.0),   # segment bends toward point 3 (SPLINE2: and point 4's time)
    ("RAPID", 0, 30.0, 30.0),      # no calculation during a RAPID move
])
def test_q_stops_at_the_end_of_the_moves_calculated_and_slash_at_the_executing_ones(
        mode: str, isx13: int, q_end: float, slash_end: float) -> None:
    for command, end in (("Q", q_end), ("/", slash_end)):
        c, at, dv = stop_at(mode, isx13, command)
        assert at == pytest.approx(end, abs=1e-3), command
        assert dv <= A_MAX * DT, command                  # no velocity step at the stop
        c.ask("&1R")                                     # R goes on to the program's end
        c.tick(round(14.0 / DT))
        assert not running(c) and c.ask("#1P") == "80000", command
