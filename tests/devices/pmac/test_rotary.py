"""Rotary buffers without sockets: DEFINE ROT / DELETE ROT order, OPEN ROT entry per addressed
C.S., on-line commands while open, room (ERR006), PR and the I16/I17 full flag [Turbo SRM "DEFINE
ROT", "OPEN ROT", "PR", I16, I17; Turbo UM "Rotary Motion Program Buffers"; A L3187]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.online import PortState


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    return c


def err(card: Card, line: str) -> bytes:
    return card.raw(line)


def test_define_from_high_to_low_and_delete_from_low_to_high(card: Card) -> None:
    """UM: "define the rotary buffers from high-numbered to low-numbered"; the addendum deletes
    &1 before &2 [A L3187]."""
    card.ask("&3 DEFINE ROT 200")
    card.ask("&2 DEFINE ROT 1000")
    assert err(card, "&4 DEFINE ROT 20") == b"\x07ERR007\r"
    assert err(card, "&2 DEFINE ROT 20") == b"\x07ERR007\r"   # already there
    card.ask("&1 DEFINE ROT 20")
    assert err(card, "&2 DELETE ROT") == b"\x07ERR007\r"
    card.ask("&1 DELETE ROTARY")
    card.ask("&2 DELETE ROT")
    card.ask("&3 DEL ROT")
    assert not card.fw.rotary.defined


def test_a_gather_buffer_blocks_define_rot_and_a_rotary_buffer_blocks_define_comp(card: Card) -> None:
    card.ask("DEFINE GATHER 100")
    assert err(card, "&1 DEFINE ROT 100") == b"\x07ERR007\r"
    card.ask("DELETE GATHER")
    card.ask("&1 DEFINE ROT 100")
    assert err(card, "#1 DEFINE COMP 4,1000") == b"\x07ERR007\r"   # comp tables come first [A L3139]
    card.ask("DEFINE GATHER 100")   # gathering is defined after the rotary buffers


def test_lines_go_to_the_buffer_of_the_addressed_cs(card: Card) -> None:
    """The SRM's OPEN ROT example: `&1 X10 Y10 F5`, `&2 X30 Y30 F10`."""
    card.ask("&2 DEFINE ROT 100")
    card.ask("&1 DEFINE ROT 100")
    card.ask("OPEN ROT")
    card.ask("&1 X10 Y10 F5")
    card.ask("&2 X30 Y30 F10")
    card.ask("&1 X20 &2 X40")
    card.ask("CLOSE")
    assert card.ask("&1 PR") == "2" and card.ask("&2 PR") == "2"
    assert card.fw.rotary.take(1) == "X10 Y10 F5"
    assert card.fw.rotary.take(2) == "X30 Y30 F10"
    assert card.fw.rotary.take(1) == "X20" and card.fw.rotary.take(2) == "X40"
    assert card.fw.rotary.take(1) is None


def test_b0_is_a_b_axis_move_while_open_and_run_control_acts_on_line(card: Card) -> None:
    """SRM: B0 cannot be given while the rotary buffers are open (it is a B-axis move); `&1R`
    in the SRM example runs on-line."""
    card.ask("&1 DEFINE ROT 100")
    card.ask("OPEN ROT")
    card.ask("B0")
    assert card.ask("PR") == "1"
    assert card.ask("&1 PR") == "1"
    card.ask("CLOSE")
    assert card.fw.rotary.take(1) == "B0"


def test_no_room_is_err006_and_stores_nothing(card: Card) -> None:
    """Each value takes a word [UM]: a 5-word buffer holds X1 Y2 Z3 and A4 B5, not a sixth."""
    card.ask("&1 DEFINE ROT 5")
    card.ask("OPEN ROT")
    card.ask("X1 Y2 Z3")
    card.ask("A4 B5")
    assert card.raw("C6") == b"\x07ERR006\r"
    assert card.ask("PR") == "2"
    card.fw.rotary.take(1)      # executed lines free their words
    card.ask("C6")
    assert card.ask("PR") == "2"


def test_full_flag_sets_at_i17_and_clears_within_i16(card: Card) -> None:
    """SRM I17: "greater than or equal to I17 lines ahead ... Rotary Buffer Full becomes 1",
    back to 0 when execution catches up to within I16 lines."""
    card.ask("I16=2 I17=4")
    card.ask("&1 DEFINE ROT 100")
    card.ask("OPEN ROT")
    for k in range(3):
        card.ask(f"X{k}")
    assert not card.fw.rotary.full(1)
    card.ask("X3")
    assert card.fw.rotary.full(1)
    card.fw.rotary.take(1)
    assert card.fw.rotary.full(1)          # 3 ahead: not yet within I16
    card.fw.rotary.take(1)
    assert not card.fw.rotary.full(1)      # 2 ahead


def test_open_rot_without_buffers_and_buffers_of_other_ports(card: Card) -> None:
    assert card.raw("OPEN ROT") == b"\x07ERR003\r"
    card.ask("&1 DEFINE ROT 10")
    other = PortState()
    card.fw.execute(other, "OPEN ROT")
    assert card.raw("OPEN ROT") == b"\x07ERR007\r"
    assert card.raw("OPEN PLC 1") == b"\x07ERR007\r"
    card.fw.execute(other, "CLOSE")
    card.ask("OPEN ROT")
    assert card.raw("&2 X1") == b"\x07ERR003\r"   # C.S. 2 has no rotary buffer


def test_clear_empties_the_addressed_buffer(card: Card) -> None:
    card.ask("&1 DEFINE ROT 10")
    card.ask("OPEN ROT X1")
    card.ask("X2")
    card.ask("CLEAR")
    assert card.ask("PR") == "0"


def test_reset_removes_rotary_buffers(card: Card) -> None:
    """UM: rotary buffers "are not retained through a power-down or board reset"."""
    card.ask("&1 DEFINE ROT 10")
    card.ask("SAVE")
    card.raw("$$$")
    card.raw("I3=2")
    assert not card.fw.rotary.defined
    card.ask("&1 DEFINE ROT 10")


def test_motor_commands_act_on_line_while_the_rotary_buffer_is_open(card: Card) -> None:
    """On-line-only commands (`#1P`) are not buffered [UM "Talking to Turbo PMAC"]."""
    card.ask("&1 DEFINE ROT 10")
    card.ask("OPEN ROT")
    assert card.ask("#1P") == "0"
    card.ask("X1 &1 #2P")
    assert card.ask("PR") == "1"
