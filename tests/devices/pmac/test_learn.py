"""LEARN: with a PROG or rotary buffer open on the port, a line of the addressed C.S.'s present
commanded axis positions goes into it; only the opening port may LEARN (V1.936 [A L3234]);
without a buffer open, ERR005 [README "Motion programs", learn.py]."""

from __future__ import annotations

from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_programs import card, trace, xy
from vdevd.devices.pmac.online import PortState

__all__ = ["card"]


def _jog_to(card: Card, x: int, y: int) -> None:
    card.ask(f"I122=50 I222=50 #1J={x} #2J={y}")
    card.tick(4000)
    assert xy(card) == (float(x), float(y))


def test_learn_appends_the_axis_positions_to_the_open_prog(card: Card) -> None:
    _jog_to(card, 2500, -1250)
    assert card.ask("OPEN PROG 3 CLEAR") == ""
    assert card.raw("RAPID") == b"\x06"
    assert card.raw("LEARN") == b"\x06"
    assert card.raw("learn (Y)") == b"\x06"
    assert card.ask("LIST") == "RAPID\rX2.5 Y-1.25\rY-1.25"
    card.ask("CLOSE")


def test_a_learned_program_goes_back_to_the_learned_point(card: Card) -> None:
    _jog_to(card, 3000, 1000)
    card.ask("OPEN PROG 4 CLEAR")
    card.ask("RAPID ABS")
    card.ask("LEARN")
    card.ask("CLOSE")
    _jog_to(card, 0, 0)
    card.ask("I122=20 I222=20 &1B4R")
    trace(card, 5.0)
    assert xy(card) == (3000.0, 1000.0)


def test_learn_into_the_rotary_buffer_of_the_addressed_cs(card: Card) -> None:
    _jog_to(card, 1500, 0)
    card.ask("&1 DEFINE ROT 100")
    card.ask("OPEN ROT")
    assert card.raw("LEARN") == b"\x06"
    card.ask("CLOSE")
    assert card.ask("&1PR") == "1"


def test_learn_without_a_buffer_or_from_another_port_is_err005(card: Card) -> None:
    assert card.raw("LEARN") == b"\x07ERR005\r"
    card.ask("OPEN PROG 5 CLEAR")
    assert card.fw.interpreter.execute(PortState(), "LEARN").error == 5
    assert card.ask("LIST") == ""
    card.ask("CLOSE")


def test_learn_with_a_bad_axis_list_is_err003(card: Card) -> None:
    card.ask("OPEN PROG 6 CLEAR")
    assert card.raw("LEARN(X,Q)") == b"\x07ERR003\r"
    assert card.ask("LIST") == ""
    card.ask("CLOSE")
