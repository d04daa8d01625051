"""The DPRAM background variable read and write buffers without sockets (I55): the header at
0x1044-0x104E, address specifications from $060450 + start, the data after them, 32-bit
sign-extended words [Turbo UM p.407-410; EPICS tpmac drvPmac.c drvPmacVarSetup/drvPmacVarRead;
PComm32 dprbkg.h; dpram_vars.py]."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.pmac import (
    DPRAM_SIZE,
    OPEN_USE,
    VB_CONTROL,
    VB_SIZE,
    VB_START,
    VB_TIMER,
    VBW_SIZE,
    VBW_START,
)

from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.dpram_vars import VariableBuffers
from vdevd.devices.pmac.numbers import from_pmac_float_words, pmac_float_words

#: EPICS drvPmacVarSetup's table: start offset $F0 (host 0x1500), types Y 0x00, L 0x10, X 0x20
START = 0xF0
TABLE = OPEN_USE + 4 * START
HIGH = 0x010000  # a Y word above 16 bits: address bit 16 goes in the type word's bit 0


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    return c


def u16(mem: bytearray, at: int) -> int:
    return int(struct.unpack_from("<H", mem, at)[0])


def setup_read(mem: bytearray, specs: list[tuple[int, int]], control: int = 0) -> None:
    """As drvPmacVarSetup: size 0, start, the specifications, size, control."""
    struct.pack_into("<H", mem, VB_SIZE, 0)
    struct.pack_into("<H", mem, VB_START, START)
    for i, (addr, kind) in enumerate(specs):
        struct.pack_into("<HH", mem, TABLE + 4 * i, addr & 0xFFFF, kind | addr >> 16)
    struct.pack_into("<H", mem, VB_SIZE, len(specs))
    struct.pack_into("<H", mem, VB_CONTROL, control)


def test_single_user_read_buffer_copies_the_registers_then_sets_data_ready(card: Card) -> None:
    """P1 (L:$6001, two words Y then X), the servo counter X:$000000 and Y:$010000 (negative):
    the data follow the three specifications; bit 0 of 0x1044 says ready, X:$060411 the servo
    count; nothing more until the host clears bit 0 [drvPmacVarRead]."""
    mem = bytearray(DPRAM_SIZE)
    vb = VariableBuffers(mem, card.fw.memory)
    card.ask("P1=-2.75")
    card.fw.memory.write("Y", HIGH, 0xFFFFFB)  # -5 as a 24-bit word
    setup_read(mem, [(0x6001, 0x10), (0x0000, 0x20), (HIGH, 0x00)])
    card.tick(3)
    assert vb.due()
    vb.service(0x12345)
    data = TABLE + 12
    low, high, counter, neg = struct.unpack_from("<iiii", mem, data)
    assert from_pmac_float_words(high & 0xFFFFFF, low & 0xFFFFFF) == -2.75
    assert counter == card.fw.memory.read("X", 0) == 3
    assert neg == -5
    assert u16(mem, VB_CONTROL) & 1 and u16(mem, VB_TIMER) == 0x2345
    assert not vb.due()
    card.ask("P1=4")
    vb.service(0x12346)  # not requested: the data stay
    assert struct.unpack_from("<i", mem, data)[0] == low
    struct.pack_into("<H", mem, VB_CONTROL, 0)
    assert vb.due()
    vb.service(0x12347)
    lo, hi = struct.unpack_from("<ii", mem, data)
    assert from_pmac_float_words(hi & 0xFFFFFF, lo & 0xFFFFFF) == 4.0


def test_multi_user_read_buffer_updates_the_entries_whose_ready_bit_is_clear(card: Card) -> None:
    """Bit 8 of 0x1044: each entry's type word bit 15 is its data-ready bit [UM p.409]."""
    mem = bytearray(DPRAM_SIZE)
    vb = VariableBuffers(mem, card.fw.memory)
    card.ask("P1=1 P2=2")
    setup_read(mem, [(0x6001, 0x10), (0x6002, 0x10)], control=0x100)
    vb.service(1)
    assert all(u16(mem, TABLE + 4 * i + 2) & 0x8000 for i in range(2))
    assert not vb.due() and not u16(mem, VB_CONTROL) & 1
    card.ask("P1=10 P2=20")
    struct.pack_into("<H", mem, TABLE + 6, 0x10)  # the host took entry 1 (P2) only
    assert vb.due()
    vb.service(2)
    words = struct.unpack_from("<iiii", mem, TABLE + 8)
    assert from_pmac_float_words(words[1] & 0xFFFFFF, words[0] & 0xFFFFFF) == 1.0
    assert from_pmac_float_words(words[3] & 0xFFFFFF, words[2] & 0xFFFFFF) == 20.0


def test_read_buffer_off_or_out_of_bounds_does_nothing(card: Card) -> None:
    """Size 0 disables [UM p.409]; more than 128 entries, or a table past the DPRAM's end, is
    not served (bounded)."""
    mem = bytearray(DPRAM_SIZE)
    vb = VariableBuffers(mem, card.fw.memory)
    setup_read(mem, [])
    assert not vb.due()
    struct.pack_into("<H", mem, VB_SIZE, 129)
    assert not vb.due()
    struct.pack_into("<HH", mem, VB_SIZE, 2, (DPRAM_SIZE - OPEN_USE) // 4 - 1)
    assert not vb.due()


def test_write_buffer_copies_the_entries_until_address_0_then_clears_its_size(card: Card) -> None:
    """0x104E the start, six 16-bit words an entry (address, type, VBGWFormat data1, data2),
    0x104C the number: the card copies them and writes 0 there; address 0 ends the list
    [UM p.410]."""
    mem = bytearray(DPRAM_SIZE)
    vb = VariableBuffers(mem, card.fw.memory)
    x, y = pmac_float_words(3.25)
    at = OPEN_USE + 4 * 0x40
    entries = [(0x6002, 0x10, y, x), (HIGH & 0xFFFF, 0x00 | HIGH >> 16, -7, 0),
               (0x0123, 0x20, 0x7FFFFF, 0), (0, 0x00, 0, 0), (0x6003, 0x10, y, x)]
    for i, (a, t, d1, d2) in enumerate(entries):
        struct.pack_into("<HHii", mem, at + 12 * i, a, t, d1, d2)
    struct.pack_into("<HH", mem, VBW_SIZE, 5, 0x40)
    assert u16(mem, VBW_START) == 0x40 and vb.due()
    vb.service(1)
    assert card.ask("P2 P3") == "3.25\r0"
    assert card.fw.memory.read("Y", HIGH) == 0xFFFFF9
    assert card.fw.memory.read("X", 0x123) == 0x7FFFFF
    assert u16(mem, VBW_SIZE) == 0 and not vb.due()
