"""Program reports and ABR without sockets: `PC` (the line calculated next), `PE` (the line
executing), `PR` (rotary lines remaining), `ABR` (abort and run) [Turbo SRM PC, PE, PR; A L3261;
UM "How PMAC Executes a Motion Program"; README "Motion programs"]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_programs import (
    RUNNING,
    cs_words,
    download,
    running,
    seconds,
    trace,
    xy,
)


@pytest.fixture
def card() -> Card:
    """As test_programs.py's: motors 1 and 2 as X and Y at 1000 counts per unit, ideal plant."""
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->1000X &1#2->1000Y #1J/#2J/")
    c.ask("I116=1000 I216=1000 I117=100 I217=100")
    return c


#: line 1 X1 (1.1 s from rest at F1 with TA100), line 2 a 300 ms DWELL, lines 3-4 moves
PROG = ("LINEAR INC TA100 TS0 F1", "X1", "DWELL300", "X1", "X1")


def test_pc_and_pe_after_b_point_to_the_program_top(card: Card) -> None:
    download(card, 4, *PROG)
    card.ask("&1B4")
    assert card.ask("&1PC") == "P4:0"
    assert card.ask("&1PE") == "P4:0"


def test_pc_is_the_line_calculated_next_and_pe_the_move_executing(card: Card) -> None:
    """At R the calculation goes through the first move and the DWELL (a move for the
    look-ahead), where it stops until the dwell is over [UM "When No Calculation Ahead"]: PC
    is line 3 while line 1 executes (PE P4:1); in the dwell PE is line 2; once the dwell is
    over, line 3 executes and the calculation is past line 4 (the end)."""
    download(card, 4, *PROG)
    card.ask("&1B4R")
    seconds(card, 0.5)
    assert card.ask("&1PE") == "P4:1"
    assert card.ask("&1PC") == "P4:3"
    seconds(card, 0.75)   # the move ends at 1.1 s: in the dwell
    assert cs_words(card)[1] & (1 << 12)
    assert card.ask("&1PE") == "P4:2"
    assert card.ask("&1PC") == "P4:3"
    seconds(card, 0.3)    # the dwell ended at 1.4 s: line 3's move runs
    assert card.ask("&1PE") == "P4:3"
    assert card.ask("&1PC") == "P4:5"
    trace(card, 5.0)
    assert not running(card)
    assert card.ask("&1PE") == "P4:4"


def test_pc_follows_a_call_into_the_called_program(card: Card) -> None:
    """CALL: the counter reports the called program and its line."""
    download(card, 5, "LINEAR INC TA100 TS0 F1", "CALL6", "X1")
    download(card, 6, "P1=1", "DWELL1000", "RETURN")
    card.ask("&1B5R")
    seconds(card, 0.2)
    assert card.ask("&1PE") == "P6:1"
    assert card.ask("&1PC") == "P6:2"


def test_pr_is_0_for_a_fixed_program(card: Card) -> None:
    """PR counts the C.S.'s rotary-buffer lines waiting (rotary.py); running a fixed PROG with
    no rotary buffer it is 0 [SRM PR]."""
    download(card, 4, *PROG)
    card.ask("&1B4R")
    seconds(card, 0.2)
    assert card.ask("&1PR") == "0"
    assert running(card)


def test_abr_aborts_and_runs_the_new_program_from_where_the_motors_stopped(card: Card) -> None:
    """ABR7 while PROG 4 moves X: the motors stop at Ixx15 (1 count/ms at 0.25 counts/ms²: 4 ms),
    then PROG 7 runs its move to X = 5 from there [A L3261]."""
    download(card, 4, *PROG)
    download(card, 7, "LINEAR ABS TA100 TS0 F5", "X5")
    card.ask("&1B4R")
    seconds(card, 0.6)
    x_before = xy(card)[0]
    card.ask("&1ABR7")
    assert running(card)
    seconds(card, 0.004)
    assert xy(card)[0] - x_before < 2.5 + 0.5   # stopping, not going on at 1 count/ms
    seconds(card, 0.05)
    assert card.ask("&1PE") == "P7:1"
    trace(card, 3.0)
    assert not running(card)
    assert xy(card)[0] == 5000.0
    assert not cs_words(card)[1] & (1 << 22)


def test_abr_alone_restarts_the_program_pointed_to_from_its_top(card: Card) -> None:
    download(card, 8, "LINEAR INC TA100 TS0 F10", "X1")
    card.ask("&1B8R")
    trace(card, 1.0)
    assert xy(card)[0] == 1000.0
    card.ask("&1ABR")
    assert cs_words(card)[0] & RUNNING
    trace(card, 1.0)
    assert xy(card)[0] == 2000.0


def test_abr_to_a_missing_program_is_err015(card: Card) -> None:
    assert card.raw("&1ABR99") == b"\x07ERR015\r"
    assert not running(card)
    assert xy(card) == (0.0, 0.0)
