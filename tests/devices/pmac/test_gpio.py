"""JIO, JTHW and JANA general-purpose I/O (vdevd/devices/pmac/gpio.py) [A L487-675]."""

from __future__ import annotations

import pytest

from vdevd.devices.pmac.gpio import GeneralIO
from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.memory import Memory
from vdevd.devices.pmac.mvars import MVars, parse_definition

SUGGESTED = {  # [A L504-539, L581-609]
    0: "Y:$078400,0", 1: "Y:$078400,1", 3: "Y:$078400,3", 23: "Y:$078400,23",
    24: "Y:$078401,0", 30: "Y:$078401,6",
    32: "X:$078400,0,8", 33: "Y:$070800,0", 38: "X:$078401,0,8", 39: "Y:$070800,3",
    40: "Y:$078402,8", 48: "Y:$078402,8,8,U", 50: "Y:$078402,0", 58: "Y:$078402,0,8,U",
    60: "X:$078402,0,8", 61: "Y:$070800,4", 62: "X:$078402,8,8", 63: "Y:$070800,5",
}


class Card:
    def __init__(self) -> None:
        self.memory = Memory()
        self.ivars = IVars(8)
        self.io = GeneralIO(self.memory, self.ivars)
        self.m = MVars(self.memory)
        for n, text in SUGGESTED.items():
            self.m.define(n, parse_definition(text)[0])


@pytest.fixture
def card() -> Card:
    return Card()


def test_power_up_jio_all_inputs_non_inverting_pulled_high(card: Card) -> None:
    mem = card.memory
    assert (mem.read("X", 0x078400), mem.read("X", 0x078401)) == (0, 0)          # M32..M38 = 0 [A L543]
    assert (mem.read("X", 0x078404), mem.read("X", 0x078405)) == (0, 0)          # non-inverting [A L556]
    assert (mem.read("Y", 0x078404), mem.read("Y", 0x078405)) == (0, 0)          # general purpose [A L560]
    assert (mem.read("Y", 0x078400), mem.read("Y", 0x078401)) == (0xFFFFFF, 0xFF)
    assert card.io.outputs() == 0xFFFFFFFF   # undriven lines pull to +5 V [A L495]
    assert card.io.driven() == 0


def test_power_up_jthw_dat_inputs_sel_outputs_low(card: Card) -> None:
    assert (card.m.read(60), card.m.read(62)) == (0, 255)                      # [A L593]
    assert (card.m.read(61), card.m.read(63)) == (0, 1)
    assert card.m.read(48) == 0
    assert card.m.read(58) == 255
    assert card.io.thw_outputs() & 0xFF00 == 0
    card.m.write(40, 1)
    assert card.io.thw_outputs() >> 8 & 1 == 1


def test_input_reads_the_line_level_and_follows_inversion(card: Card) -> None:
    card.io.set_input(3, False)
    assert card.m.read(3) == 0
    card.memory.write("X", 0x078404, 1 << 3)   # inverting: 0 = +5 V [A L547]
    assert card.m.read(3) == 1
    card.io.set_input(30, False)
    assert card.m.read(30) == 0


def test_output_byte_needs_asic_and_buffer_direction(card: Card) -> None:
    card.m.write(32, 255)                      # ASIC direction, I/O00-07 [A L519]
    card.m.write(0, 0)
    assert card.io.outputs() & 1 == 1          # buffer still input: the pull-up wins
    card.m.write(33, 1)                        # buffer direction must match [A L532]
    assert card.io.driven() == 0xFF
    assert card.io.outputs() & 0b11 == 0b00    # latches are 0
    card.m.write(1, 1)
    assert card.io.outputs() & 0b11 == 0b10
    assert card.m.read(1) == 1                 # an output reads back its latch
    card.memory.write("X", 0x078404, 0b10)     # inverting output: 1 = 0 V
    assert card.io.outputs() & 0b10 == 0


def test_top_byte_lives_in_the_second_word(card: Card) -> None:
    card.m.write(38, 255)
    card.m.write(39, 1)
    card.m.write(24, 1)
    assert card.io.outputs() >> 24 & 0xFF == 0x01
    assert card.memory.read("X", 0x078401) == 0xFF


@pytest.mark.parametrize(
    ("channel", "volts", "select", "expect"),
    [
        (3, 2.5, 3, 2048),              # unipolar ANAI03: 0-5 V [A L655]
        (3, 2.5, 3 + 8, 2047),          # bipolar: -2.5..+2.5 V, saturates
        (3, -1.25, 3 + 8, 0xC00),       # two's complement -1024
        (10, 5.0, 2 << 12, 4095 << 12),  # high 12 bits select ANAI08+2
        (10, -2.5, 10 << 12, 0x800 << 12),
    ],
)
def test_jana_pair_select_and_read(card: Card, channel: int, volts: float, select: int, expect: int) -> None:
    card.io.set_analog(channel, volts)
    card.memory.write("Y", 0x078800, select)
    mask = 0xFFF000 if select >> 12 else 0xFFF
    assert card.memory.read("Y", 0x078800) & mask == expect


def _code(anai: int, bipolar: bool) -> tuple[int, int]:
    """($00m00n, which half): the selection-code formulas [A L665-671]."""
    if anai >= 8:
        return (anai if bipolar else anai - 8) << 12, 1
    return (anai + 8 if bipolar else anai), 0


def test_demultiplexing_ring_stores_bits_12_to_23_even_low_odd_high(card: Card) -> None:
    for ch, v in ((3, 1.25), (10, 2.5), (5, -1.0), (15, 0.5)):
        card.io.set_analog(ch, v)
    v = card.ivars.values
    v[5060] = 2
    v[5061] = 0                                 # 0 still means $078800 [A L3249]
    v[5062] = 0x078800
    v[5081] = _code(10, False)[0] | _code(3, False)[0]   # $002003
    v[5082] = _code(15, True)[0] | _code(5, True)[0]     # $00F00D
    assert (v[5081], v[5082]) == (0x002003, 0x00F00D)
    card.io.tick()
    assert card.memory.read("Y", 0x3400) == 0          # I5080 = 0 disables [A L3257]
    v[5080] = 1
    card.io.tick()
    mem = card.memory
    assert mem.read("Y", 0x3400) == 1024 << 12         # ANAI03, the low converter: even address
    assert mem.read("Y", 0x3401) == 2048 << 12         # ANAI10, the high converter: odd address
    assert mem.read("Y", 0x3402) == (-819 & 0xFFF) << 12
    assert mem.read("Y", 0x3403) == 410 << 12


def test_demultiplexing_converts_one_pair_per_phase_cycle(card: Card) -> None:
    v = card.ivars.values
    v[5060], v[5080] = 16, 1
    for k in range(16):
        v[5081 + k] = k % 8
        card.io.set_analog(k % 8, 1.0 + k % 8 * 0.5)
    card.io.tick()                             # I7002 = 3: four phase cycles per servo cycle
    filled = [card.memory.read("Y", 0x3400 + 2 * k) != 0 for k in range(16)]
    assert filled == [True] * 4 + [False] * 12
    card.io.tick(), card.io.tick(), card.io.tick()
    assert all(card.memory.read("Y", 0x3400 + 2 * k) for k in range(16))
