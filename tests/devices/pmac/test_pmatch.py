"""PMATCH in a motion program: the axis positions computed again from the motors' commanded
positions, through the forward kinematic program with Isx50 = 1 [Turbo SRM PMATCH; Turbo UM
"Kinematic Calculations"]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
#: one motor, X = counts / Q91 (forward) and counts = X · Q91 (inverse)
FORWARD = ["Q7=P1/Q91"]
INVERSE = ["P1=Q7*Q91"]


def kinematic_card() -> Card:
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
    return c


def run(c: Card, body: list[str]) -> None:
    c.ask("OPEN PROG 7 CLEAR")
    for line in ["LINEAR ABS TA50 TS0 F20", *body]:
        c.ask(line)
    c.ask("CLOSE")
    c.ask("&1B7R")
    c.tick(round(3.0 / DT))
    assert not int(c.ask("&1??")[:6], 16) & 1


@pytest.mark.parametrize(("pmatch", "end"), [(True, "12000"), (False, "22000")])
def test_pmatch_takes_the_axis_position_from_the_forward_program(pmatch: bool, end: str) -> None:
    """X10 puts motor 1 at 10000 counts (DWELL0: the calculation waits for it, so Q91 changes
    after the move); Q91 = 2000 then makes the forward program read X = 5:
    with PMATCH the incremental X1 goes to X6 (12000 counts), without it from the axis position
    the program had (X10) to X11 (22000 counts)."""
    c = kinematic_card()
    run(c, ["X10", "DWELL0", "Q91=2000", *(["PMATCH"] if pmatch else []), "INC X1"])
    assert c.ask("#1P") == end


def test_pmatch_in_a_plain_cs_reads_the_motor_positions_back() -> None:
    """Without kinematics the axis positions come from the axis definitions (least squares over
    them, as at R): PMATCH after X20 reads X = 20 back from 20000 counts and INC X1 ends at
    21000 counts."""
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->1000X #1J/")
    run(c, ["X20", "PMATCH", "INC X1"])
    assert c.ask("#1P") == "21000"


def test_pmatch_is_stored_and_listed() -> None:
    c = Card()
    c.raw("I3=2")
    c.ask("OPEN PROG 8 CLEAR")
    c.ask("PMATCH")
    c.ask("CLOSE")
    assert "PMATCH" in c.ask("LIST PROG 8")


def test_online_pmatch_runs_the_forward_program() -> None:
    """SRM OPEN FORWARD: the forward program runs "any time an R (run), S (step), or PMATCH
    command is given": `&1 PMATCH` leaves X = counts / Q91 in Q7 (P1 the commanded counts)."""
    c = kinematic_card()
    c.ask("#1J=3000")
    c.tick(round(2.0 / DT))
    c.ask("&1 Q7=0")
    c.ask("&1 PMATCH")
    assert c.ask("&1 Q7") == "3" and c.ask("P1") == "3000"


def test_online_pmatch_while_the_program_runs_is_err001() -> None:
    c = kinematic_card()
    c.ask("OPEN PROG 7 CLEAR")
    c.ask("LINEAR ABS TA50 TS0 F1 X10")
    c.ask("CLOSE")
    c.ask("&1B7R")
    c.tick(10)
    assert c.raw("&1 PMATCH") == b"\x07ERR001\r"
