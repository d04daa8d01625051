"""The motion-program fields of the DPRAM background buffer's C.S. records and the program's motor
status bit [PComm32 dprbkg.h `backcTURBO` ffdrate, fdptr (`bkfdptrTURBO` fdhld, fdslew), cpos,
pr, timrem, tats, pe; digest §2.6 motor word 1 bit 15 "dwell in progress"; README "Reporting
buffers", "Motion programs"]."""

from __future__ import annotations

import struct
from collections.abc import Iterator

import pytest
from vdevmaps.pmac import (
    BG_CS,
    BG_CS_COUNT,
    BG_READY,
    CS_AXES,
    CS_FDPTR,
    CS_FEED,
    CS_PE,
    CS_PR,
    CS_TATS,
    CS_TIMREM,
    FDPTR_HOLD,
    FDPTR_SLEW,
)

from tests.devices.pmac.conftest import Pmac
from tests.devices.pmac.test_acceptance import pmac_pcomm
from tests.devices.pmac.test_dpram_buffers import next_sample, pc, words
from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.numbers import from_pmac_float_words

PROG = ("LINEAR ABS TA100 TS0 F2", "X4", "DWELL500", "Y1")


@pytest.fixture
def card() -> Iterator[Pmac]:
    """A daemon card (plant `ideal`), C.S. 1 with motors 1 and 2 as X and Y at 1000 counts per
    unit, PROG 3 loaded, the background buffer reporting C.S. 1 every servo cycle."""
    with pmac_pcomm() as host:
        pc("&1#1->1000X &1#2->1000Y #1J/ #2J/ I116=1000 I216=1000 I117=100 I217=100")
        pc("OPEN PROG 3 CLEAR")
        for line in PROG:
            pc(line)
        pc("CLOSE")
        host.card.region("dpram").write16(BG_CS_COUNT, 1)
        pc("I50=1 I49=1")
        yield host


def cs_record(card: Pmac) -> tuple[int, ...]:
    """The next background sample's C.S. 1 record, 32 words."""
    dpram = card.card.region("dpram")
    next_sample(card, dpram, BG_READY)
    return struct.unpack("<32i", dpram.read(BG_CS, 128))


def float48(rec: tuple[int, ...], at: int) -> float:
    """A 48-bit PMAC float at word `at`: the low (Y) word first."""
    return from_pmac_float_words(rec[at + 1] & 0xFFFFFF, rec[at] & 0xFFFFFF)


def axis(rec: tuple[int, ...], letter: str) -> float:
    return float48(rec, CS_AXES + 2 * "ABCUVWXYZ".index(letter))


def test_feed_rate_and_axis_positions_follow_the_program(card: Pmac) -> None:
    """F2 (units per Isx90 = 1000 ms) in the feed-rate words; X and Y as the motors' commanded
    positions give them back, as L:$002041-$002049 do (X4 at F2 from rest: 2.1 s; X = 4
    exactly at the end)."""
    idle = cs_record(card)
    assert axis(idle, "X") == 0.0 and idle[CS_TIMREM] == 0 and idle[CS_PE] == 0
    pc("&1B3R")
    card.step_ms(600)
    rec = cs_record(card)
    assert float48(rec, CS_FEED) == 2.0
    x = float(pc("RL:$002047")[0])   # the X axis position register [README "Memory"]
    assert axis(rec, "X") == pytest.approx(x, abs=1e-9) and 0.9 < x < 1.2
    assert float(pc("#1P")[0]) == pytest.approx(1000 * x, abs=1.0)
    assert axis(rec, "Y") == 0.0 and axis(rec, "A") == 0.0
    card.step_ms(3000)   # Y1 ends at 2.6 + 0.6 s
    rec = cs_record(card)
    assert axis(rec, "X") == 4.0 and axis(rec, "Y") == 1.0


def test_move_time_left_executing_line_and_lines_remaining(card: Pmac) -> None:
    """timrem is MOVETIME's time (ms), pe the executing line's offset (PE), pr the rotary lines
    remaining (PR: 0 for a fixed program)."""
    pc("&1B3R")
    card.step_ms(600)
    rec = cs_record(card)
    movetime = float(pc("&1MOVETIME")[0])
    assert abs(rec[CS_TIMREM] - movetime) <= 1 and 1400 < movetime < 1600
    assert rec[CS_PE] == 1 and pc("&1PE") == ["P3:1"]
    assert rec[CS_PR] == 0
    card.step_ms(1600)   # in the DWELL (2.1 s to 2.6 s)
    rec = cs_record(card)
    assert rec[CS_PE] == 2


def test_ta_time_left_counts_down_the_acceleration_only(card: Pmac) -> None:
    """X4 from rest accelerates for TA = 100 ms: 50 ms in, 50 ms of TA are left; cruising, none."""
    pc("&1B3R")
    card.step_ms(50)
    assert abs(cs_record(card)[CS_TATS] - 50) <= 1
    card.step_ms(500)
    assert cs_record(card)[CS_TATS] == 0


def test_time_base_pointer_holds_isx93_and_the_hold_and_slew_bits(card: Pmac) -> None:
    """bits 0-18: Isx93 ($002000 for C.S. 1), bit 21 while the time base slews (H slews it to
    0 at Isx95 = 1644 I10 units a cycle: about 1 s), bit 22 from H until R [bkfdptrTURBO]."""
    rec = cs_record(card)
    assert rec[CS_FDPTR] == 0x002000
    pc("&1B3R")
    card.step_ms(300)
    pc("&1H")
    rec = cs_record(card)
    assert rec[CS_FDPTR] == 0x002000 | FDPTR_SLEW | FDPTR_HOLD
    card.step_ms(1200)
    assert cs_record(card)[CS_FDPTR] == 0x002000 | FDPTR_HOLD
    pc("&1R")
    assert cs_record(card)[CS_FDPTR] == 0x002000 | FDPTR_SLEW
    pc("&1%50")
    card.step_ms(1200)
    assert cs_record(card)[CS_FDPTR] == 0x002000
    assert words(pc("&1??")[0])[0] & 1


# -- motor status word 1 bit 15 (sans-I/O) -----------------------------------------------------------------
def test_motor_word_1_bit_15_is_set_while_its_program_dwells() -> None:
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->1000X &1#2->1000Y #1J/#2J/#3J/ I116=1000 I216=1000 I117=100 I217=100")
    c.ask("OPEN PROG 3 CLEAR")
    for line in PROG:
        c.ask(line)
    c.ask("CLOSE")

    def dwelling(motor: int) -> bool:
        return bool(int(c.ask(f"#{motor}?")[:6], 16) & 1 << 15)

    c.ask("&1B3R")
    c.tick(int(1.0 / 442.71e-6))
    assert not dwelling(1)
    c.tick(int(1.3 / 442.71e-6))   # 2.3 s: in the DWELL (2.1-2.6 s)
    assert dwelling(1) and dwelling(2) and not dwelling(3)
    c.tick(int(0.4 / 442.71e-6))   # 2.7 s: Y1 moves
    assert not dwelling(1) and not dwelling(2)
