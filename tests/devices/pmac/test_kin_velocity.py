"""PVT moves of a kinematic coordinate system: the inverse program runs with Q10 = 1 and the
axis velocities in Q11-Q19, and gives the motor velocities in P101-P132; each motor follows
the cubic through its positions and velocities at the segment ends [Turbo UM "Kinematic
Calculations", "Velocity Calculation Flag"; kin_velocity.py]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card
from vdevd.devices.pmac.kin_velocity import motor_cubic

DT = PERIOD_NS / 1e9
#: one motor, counts = Q91 · X² (so the motor path is not the axis path scaled)
FORWARD = ["Q7=SQRT(P1/Q91)"]
INVERSE = ["P1=Q91*Q7*Q7", "IF (Q10=1)", "P101=2*Q91*Q7*Q17", "P60=P60+1", "ENDIF",
           "IF (Q10=0)", "P61=P61+1", "ENDIF"]


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.ask("&1 #1->I")
    c.ask("&1 Q91=1000")
    c.ask("I5150=1")
    for kind, lines in (("FORWARD", FORWARD), ("INVERSE", INVERSE)):
        c.ask(f"&1 OPEN {kind} CLEAR")
        for line in lines:
            c.ask(line)
        c.ask("CLOSE")
    c.ask("#1J/")
    c.ask("#1J=1000")           # X = 1
    c.tick(round(2.0 / DT))
    assert c.ask("#1P") == "1000"
    return c


def program(c: Card, lines: list[str]) -> None:
    c.ask("OPEN PROG 9 CLEAR")
    for line in lines:
        c.ask(line)
    c.ask("CLOSE")
    c.ask("P60=0 P61=0")


def test_pvt_motor_follows_the_cubic_through_the_segment_ends(card: Card) -> None:
    """X from 1 to 2 at rest at both ends in 500 ms: the motor goes from 1000 to 4000 counts at
    rest at both ends, so at mid-segment it is half way (2500), where the inverse of the axis
    mid point (X = 1.5) would be 2250; the inverse ran with Q10 = 1 (P60 counts those runs)."""
    program(card, ["ABS PVT500", "X2:0"])
    card.ask("&1B9R")
    card.tick(round(0.25 / DT))
    assert float(card.ask("#1P")) == pytest.approx(2500, abs=30)
    card.tick(round(0.5 / DT))
    assert card.ask("#1P") == "4000"
    assert float(card.ask("P60")) >= 2


def test_linear_moves_keep_q10_at_0(card: Card) -> None:
    """UM: "In every move mode other than PVT mode, Turbo PMAC sets the variable Q10 ... to 0":
    a LINEAR move runs the inverse each servo cycle with Q10 = 0 and never with 1."""
    program(card, ["ABS LINEAR TA100 TS0 F2", "X2"])
    card.ask("&1B9R")
    card.tick(round(2.0 / DT))
    assert card.ask("#1P") == "4000"
    assert card.ask("P60") == "0" and float(card.ask("P61")) > 10


def test_motor_cubic_meets_both_ends() -> None:
    start = (np.array([0.0, 10.0]), np.array([1.0, -2.0]))
    end = (np.array([5.0, 4.0]), np.array([3.0, 0.0]))
    c = motor_cubic(start, end, 2.0)
    t = 2.0
    assert c[0] + t * (c[1] + t * (c[2] + t * c[3])) == pytest.approx(end[0])
    assert c[1] + t * (2 * c[2] + 3 * t * c[3]) == pytest.approx(end[1])
    assert (c[0], c[1]) == (pytest.approx(start[0]), pytest.approx(start[1]))
