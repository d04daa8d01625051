"""Coordinate systems without sockets: axis definitions, addressing, C.S. status words, the
Isx11/Isx12 timers, the position bias [spec pmac.md §2.5, §2.6, §2.8; A L922-934, L3284]."""

from __future__ import annotations

import pytest

from vdevd.devices.pmac.firmware import Firmware
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.reply import frame

PERIOD_NS = 442_710
ASSIGNED = 1 << 15  # motor status word 2 bit 15 [§2.6]


class Card:
    """A firmware and one port with I3=2 framing."""

    def __init__(self) -> None:
        self.fw = Firmware(8, PERIOD_NS, "ideal")
        self.fw.restore({})
        self.port = PortState()
        self.raw("I3=2")

    def raw(self, line: str) -> bytes:
        iv = self.fw.ivars.values
        return frame(self.fw.execute(self.port, line), int(iv[3]), int(iv[6]))

    def ask(self, line: str) -> list[str]:
        out = self.raw(line)
        assert out.endswith(b"\x06"), out
        text = out[:-1].decode()
        return text.rstrip("\r").split("\r") if text else []

    def word2(self, motor: int) -> int:
        return int(self.ask(f"#{motor}?")[0][6:], 16)

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.fw.tick(self.fw.now_ns + PERIOD_NS)


@pytest.fixture
def card() -> Card:
    return Card()


def err(code: int) -> bytes:
    return b"\x07" + f"ERR{code:03d}".encode() + b"\r"


# -- axis definitions [§2.8; A L922] -------------------------------------------------------------
def test_definitions_with_several_axes_and_offset_are_reported_back(card: Card) -> None:
    assert card.ask("&1#1->1000X+500Y+10 #2->41.3X #3->-2.5Z-7") == []
    assert card.ask("&1#1-> #2-> #3->") == ["1000X+500Y+10", "41.3X", "-2.5Z-7"]
    assert card.ask("&1 #4->I #4->") == ["I"]   # inverse kinematics: EPICS checks for "I"
    assert card.ask("&1#5->") == ["0"]          # no definition


def test_a_definition_is_local_to_its_coordinate_system(card: Card) -> None:
    card.ask("&2#1->100U")
    assert card.ask("&1#1-> &2#1->") == ["0", "100U"]


def test_status_word_2_carries_the_cs_number_and_assignment_bit(card: Card) -> None:
    """Word 2 bit 15 = assigned, bits 20-23 = C.S. − 1 (EPICS: cs = (w2 >> 20) + 1) [§2.6]."""
    assert card.word2(3) & 0xFF8000 == 0
    card.ask("&12#3->1000X")
    w2 = card.word2(3)
    assert w2 & ASSIGNED and (w2 >> 20) + 1 == 12
    assert (w2 >> 16) & 0xF != 0                  # an axis definition code
    card.ask("&12#3->")
    assert card.ask("&12 #3->") == ["1000X"]


def test_a_motor_in_another_cs_is_refused_and_nothing_changes(card: Card) -> None:
    card.ask("&1#1->1000X")
    before = card.word2(1)
    assert card.raw("&2#1->1000Y") == err(3)
    assert card.ask("&1#1-> &2#1->") == ["1000X", "0"]
    assert card.word2(1) == before
    assert card.ask("&1#1->2000Y #1->") == ["2000Y"]  # redefining in its own C.S. replaces


@pytest.mark.parametrize("line", ["&1#1->1000Q", "&1#1->X+2X", "&1#1->+", "&17", "&0"])
def test_bad_definitions_and_addresses_answer_err003(card: Card, line: str) -> None:
    assert card.raw(line) == err(3)
    assert card.ask("&1#1-> VER") == ["0", "1.940"]


def test_undefine_clears_only_the_addressed_cs_and_undefine_all_every_one(card: Card) -> None:
    """UNDEFINE clears only the addressed C.S. since V1.938 [A L3284]."""
    card.ask("&1#1->X #2->Y &2#3->X")
    card.ask("&1 UNDEFINE")
    assert card.ask("&1#1-> #2-> &2#3->") == ["0", "0", "1X"]
    assert not card.word2(1) & ASSIGNED and card.word2(3) & ASSIGNED
    card.ask("&1#1->X")
    card.ask("UNDEFINE ALL")
    assert card.ask("&1#1-> &2#3->") == ["0", "0"]
    assert not card.word2(3) & ASSIGNED


def test_zero_definition_clears_one_motor(card: Card) -> None:
    card.ask("&1#1->X #2->Y #1->0")
    assert card.ask("#1-> #2->") == ["0", "1Y"]


def test_definitions_survive_save_and_reset_but_not_reinitialise(card: Card) -> None:
    card.ask("&3#2->250V+4")
    card.ask("SAVE")
    card.ask("UNDEFINE ALL")
    card.ask("$$$")
    card.port = PortState()
    assert card.ask("&3#2->") == ["250V+4"]
    card.raw("$$$***")
    card.raw("I3=2")  # factory framing again
    assert card.ask("&3#2->") == ["0"]


# -- addressing: &n, #n, K in C.S. context [§2.4, §2.5] -------------------------------------------------
def test_ampersand_alone_reports_the_addressed_cs(card: Card) -> None:
    assert card.ask("& &7 &") == ["1", "7"]


def test_k_after_ampersand_kills_the_cs_motors_after_hash_the_motor(card: Card) -> None:
    card.ask("#1J/ #2J/ #3J/")
    card.ask("&1#1->X #2->Y")
    card.ask("&1K")
    closed = [not int(card.ask(f"#{m}?")[0][:6], 16) & (1 << 18) for m in (1, 2, 3)]
    assert closed == [False, False, True]            # word 1 bit 18 open loop
    card.ask("#1J/ #2J/")
    card.ask("&1#2K")                                # the last address was #2: motor 2 only
    closed = [not int(card.ask(f"#{m}?")[0][:6], 16) & (1 << 18) for m in (1, 2)]
    assert closed == [True, False]


def test_abort_acts_on_the_motors_of_the_addressed_cs_only(card: Card) -> None:
    card.ask("#1J/ #2J/")
    card.ask("&1#1->X &2#2->X")
    card.ask("#1J+ #2J+")
    card.tick(200)
    card.ask("&1A")
    card.tick(2000)
    v1, v2 = (float(card.ask(f"#{m}V")[0]) for m in (1, 2))
    assert v1 == 0 and v2 > 0


# -- C.S. status words [§2.6] ---------------------------------------------------------------------
def test_cs_status_word_2_in_position_is_the_and_of_its_motors(card: Card) -> None:
    card.ask("#1J/ #2J/")
    card.tick(50)
    card.ask("&1#1->X #2->Y")
    w = card.ask("&1??")[0]
    assert len(w) == 18
    assert int(w[6:12], 16) & (1 << 17)           # both in position
    assert int(w[:6], 16) & 1 == 0                # no program running
    card.ask("#2K")
    card.tick(5)
    assert not int(card.ask("&1??")[0][6:12], 16) & (1 << 17)
    assert int(card.ask("&5??")[0][6:12], 16) & (1 << 17)  # a C.S. without motors


def test_control_c_reports_sixteen_cs_status_words(card: Card) -> None:
    card.ask("#1J/")
    card.tick(50)
    card.ask("&1#1->X")
    words = card.fw.control(card.port, 0x03).split(" ")
    assert len(words) == 16 and words[0] == card.ask("&1??")[0]


# -- Isx I-variables [§2.2, §2.8] ----------------------------------------------------------------
def test_isx11_isx12_count_down_one_per_servo_cycle(card: Card) -> None:
    card.ask("I5111=1000 I5212=-5")
    card.tick(250)
    assert card.ask("I5111 I5212 I5311") == ["750", "-255", "-250"]
    card.fw.skip(50)                               # cycles at rest count the same
    assert card.ask("I5111") == ["700"]


def test_timers_are_the_cs_block_words_x_y_002015(card: Card) -> None:
    """X:$002015 = Isx11, Y:$002015 = Isx12, C.S. stride $100 [§2.8]."""
    card.ask("M1->X:$002015,0,24,S M2->Y:$002115,0,24,S")
    card.ask("I5111=100 I5212=40")
    card.tick(10)
    assert card.ask("M1 M2") == ["90", "30"]
    card.ask("M1=500 M2=-3")                       # writing the register sets the timer
    card.tick(1)
    assert card.ask("I5111 I5212") == ["499", "-4"]


def test_isx_defaults_and_range(card: Card) -> None:
    assert card.ask("I5194 I5195 I5113 I5390") == ["1644", "1644", "0", "1000"]
    assert card.raw("I5111=8388608") == err(3)
    assert card.ask("I5111") == ["0"]


# -- feed rate, Q-variables per C.S. [§2.5, §2.8] ---------------------------------------------------
def test_feedrate_override_and_q_variables_are_per_cs(card: Card) -> None:
    card.ask("&1%50")
    card.ask("&2Q1=7")
    card.ask("&1Q1=5")
    assert card.ask("&1% &2% &1Q1 &2Q1") == ["50", "100", "5", "7"]
    assert card.ask("RX:$002000") == [f"${round(3_713_707 * 0.5):06X}"]


# -- axis position, position bias, axis registers [A L922-934] -------------------------------------------
def test_axis_set_changes_the_position_bias_not_the_motor(card: Card) -> None:
    card.ask("#1J/")
    card.ask("&1#1->100X+20 M164->D:$0000CC M191->L:$0000CF M194->L:$0000D2")
    assert card.ask("M164 M191 M194") == [str(20 * 96 * 32), "100", "20"]
    card.ask("#1J=1020")
    card.tick(20000)
    assert card.ask("#1P RL:$002047") == ["1020", "10"]     # X = (1020 − 20)/100
    card.ask("&1X=2.5")
    assert card.ask("#1P RL:$002047") == ["1020", "2.5"]
    assert card.ask("M164") == [str((1020 - 250) * 96 * 32)]
    card.ask("UNDEFINE")
    assert card.ask("RD:$0000CC RL:$0000CF") == ["0", "0"]  # no definition: no bias, no scale


def test_bias_returns_to_the_definition_offset_at_reset(card: Card) -> None:
    card.ask("&1#1->100X+20 X=7 SAVE $$$")
    card.port = PortState()
    assert card.ask("RD:$0000CC") == [str(20 * 96 * 32)]


# -- commands that need programs: the card's error, the card keeps serving ------------------------------
@pytest.mark.parametrize("line", ["&1R", "&1S", "&1B1R", "&1B1S"])
def test_program_commands_answer_err015_with_axes_defined(card: Card, line: str) -> None:
    """R/S with no program to run: ERR015 "not pointing to valid program buffer" [§2.4]."""
    card.ask("&1#1->X")
    assert card.raw(line) == err(15)
    assert card.ask("&1#1->") == ["1X"]


def test_homing_sets_the_bias_back_to_the_definition_offset(card: Card) -> None:
    """Mxx64 "is set equal to the axis definition offset ... on power-up/reset and homing"
    [A L932]."""
    card.ask("#1J/ &1#1->10X+3 X=50")
    assert card.ask("RD:$0000CC") == [str(-500 * 96 * 32)]   # 0 = 10·50 + bias
    card.ask("#1HMZ")
    assert card.ask("RD:$0000CC") == [str(3 * 96 * 32)]
