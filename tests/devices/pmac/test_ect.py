"""Encoder conversion table (vdevd/devices/pmac/ect.py) [A L2445-3116]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.fakes import FakeEncoders
from vdevd.devices.pmac.ect import ConversionTable, setup_address, sext
from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.memory import WORD, Memory
from vdevd.devices.pmac.servo_ic import ChannelFlag, ServoIC


class Card:
    def __init__(self) -> None:
        self.memory = Memory()
        self.ivars = IVars(8)
        self.enc = FakeEncoders()
        self.ic = ServoIC(self.memory, self.ivars, self.enc)
        self.ect = ConversionTable(self.memory, self.ivars, self.ic)

    def set(self, **ivars: int) -> None:
        for name, value in ivars.items():
            self.ivars.values[int(name[1:])] = value

    def tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.ic.tick()
            self.ect.tick()

    def x(self, addr: int) -> int:
        return self.memory.read("X", addr)


@pytest.fixture
def card() -> Card:
    return Card()


def test_default_table_is_eight_one_over_t_entries_computed_when_read(card: Card) -> None:
    assert [card.memory.read("Y", 0x3501 + k) for k in range(9)] == [
        0x078000, 0x078008, 0x078010, 0x078018, 0x078100, 0x078108, 0x078110, 0x078118, 0]
    assert [e.method for e in card.ect.entries()] == [0] * 8
    assert not card.ect._stateful            # the tick only checks the setup lines
    card.enc.counts[:] = [10.5, -2, 0, 0, 0, 0, 0, 7.96875]
    card.tick()
    assert card.x(0x3501) == 336             # 10.5 counts in 1/32 count
    assert card.x(0x3502) == -64 & WORD
    assert card.x(0x3508) == 255


def test_at_i_constant_gives_the_table_address() -> None:
    assert setup_address(8000) == 0x3501     # I103=@I8000 [A L2549]
    assert setup_address(8009) == 0x350A     # I5193=@I8009 [A L2844]
    assert setup_address(8191) == 0x35C0
    assert setup_address(103) is None


def test_y_words_are_the_setup_i_variables(card: Card) -> None:
    card.memory.write("Y", 0x3509, 0x403504)
    assert card.ivars[8008] == 0x403504


def test_first_zero_line_ends_the_table(card: Card) -> None:
    card.set(I8002=0, I8003=0x078018)
    card.tick()
    assert [e.first for e in card.ect.entries()] == [0, 1]
    card.enc.counts[3] = 5
    card.tick()
    assert card.x(0x3504) == 0               # beyond the end: not processed


def _sums(card: Card) -> None:
    card.set(I8008=0xE00100, I8009=0xE20100)  # [A L2971-2973]
    for k in range(10, 19):
        card.ivars.values[8000 + k] = 0xC78000
    card.set(I8019=0xC78010, I8020=0xE50013)  # [A L2975]


def test_sum_difference_and_negation_entries(card: Card) -> None:
    _sums(card)
    card.enc.counts[:3] = [100, 30, 7]
    card.tick()
    assert card.x(0x3509) == 130 * 32        # $E00100: I8000 + I8001
    assert card.x(0x350A) == 70 * 32         # $E20100: I8000 - I8001
    assert card.x(0x3515) == -7 * 32 & WORD  # $E50013: -I8019


def test_integrating_sum_accumulates_each_cycle(card: Card) -> None:
    card.set(I8008=0xEC0000)                 # integrate, no second source, I8000
    card.enc.counts[0] = 2
    card.tick(3)
    assert card.x(0x3509) == 3 * 64


def test_time_base_example_differentiates_encoder_4(card: Card) -> None:
    card.set(I8003=0x078018, I8008=0x403504, I8009=512)   # TBSF = 131072/256 [A L2841-2843]
    card.tick()
    for p in (113, 226, 339):
        card.enc.counts[3] = p
        card.tick()
        assert card.x(0x350A) == 2 * 512 * 113 * 32
        assert card.x(0x3509) == p * 32      # line 1 keeps the source for the next cycle


def test_exponential_filter_time_constant_seven_cycles(card: Card) -> None:
    k = 8_388_608 // (7 + 1)                 # K = 2**23/(Tf+1) = 1,048,576 [A L2947]
    assert k == 1_048_576
    card.set(I8008=0xD03504, I8009=k, I8010=0x7FFFFF)
    card.tick()
    card.enc.counts[3] = 1000
    out = []
    for _ in range(8):
        card.tick()
        out.append(sext(card.x(0x350B)))     # result in X of the third line [A L2951]
    expect = [32000 * (1 - (7 / 8) ** (n + 1)) for n in range(8)]
    assert out == pytest.approx(expect, abs=8)


def test_exponential_filter_step_is_limited_to_max_change(card: Card) -> None:
    card.set(I8008=0xD03504, I8009=1_048_576, I8010=64 * 32)   # 64 counts per cycle [A L2949]
    card.tick()
    card.enc.counts[3] = 1000
    card.tick(3)
    assert card.x(0x350B) == 3 * 2048


@pytest.mark.parametrize(
    ("first", "width_offset", "expect"),
    [
        (0x278A00, 0x014000, (0xBCDEF << 5) & WORD),              # 20 bits from bit 0 [A L2741]
        (0x678A00, 0x018018, (0x654321 << 5) & WORD),             # all 24 bits of X [A L2743]
        (0x278A00, 0x01800C, (0x456ABC << 5) & WORD),             # bits 12-35, next Y word
        (0x678A00, 0x01800C, (0x321ABC << 5) & WORD),             # bits 12-35, X word
        (0x2F8A00, 0x018000, 0xABCDEF),                           # unshifted
    ],
)
def test_parallel_width_and_offset_words(card: Card, first: int, width_offset: int, expect: int) -> None:
    card.memory.write("Y", 0x078A00, 0xABCDEF)
    card.memory.write("Y", 0x078A01, 0x123456)
    card.memory.write("X", 0x078A00, 0x654321)
    card.set(I8000=first, I8001=width_offset, I8002=0)
    card.tick()
    assert card.x(0x3502) == expect


def test_narrow_parallel_data_rolls_over_into_the_result(card: Card) -> None:
    card.memory.write("Y", 0x078A00, 0xF0)
    card.set(I8000=0x2F8A00, I8001=0x008000, I8002=0)   # 8 bits, unshifted
    card.tick()
    assert card.x(0x3502) == 0xF0
    card.memory.write("Y", 0x078A00, 0x10)
    card.tick()
    assert card.x(0x3502) == 0x110


MLDT_EXAMPLE = {  # [A L342-356]
    "I8000": 0x378000, "I8001": 0x013000, "I8002": 32,
    "I8003": 0x378008, "I8004": 0x013000, "I8005": 32,
    "I8006": 0x378010, "I8007": 0x013000, "I8008": 32,
    "I8009": 0x378018, "I8010": 0x013000, "I8011": 32,
}


def test_mldt_direct_example_results_in_the_third_lines(card: Card) -> None:
    for c, mm in enumerate((100.0, 200.0, 300.0, 400.0)):
        card.ivars.values[7010 + 10 * c] = 12
        card.ivars.values[7016 + 10 * c] = 3
        card.memory.write("Y", 0x078004 + 8 * c, 11 << 8)
        card.ic.set_mldt_base(c, mm)
    card.tick(3)                             # excitation running before the entries start
    card.set(**MLDT_EXAMPLE)
    card.tick()
    assert [e.last for e in card.ect.entries()] == [2, 5, 8, 11]
    timers = [round(mm * 0.35 * 117.96) for mm in (100, 200, 300, 400)]
    assert [card.x(a) for a in (0x3503, 0x3506, 0x3509, 0x350C)] == [t << 5 for t in timers]
    card.enc.counts[0] = 100                 # a jump of 100 LSB passes at 32 LSB per cycle
    card.tick(4)
    assert card.x(0x3503) == (timers[0] + 100) << 5


def test_adc_entries_signed_unsigned_and_integrated_with_bias(card: Card) -> None:
    card.memory.write("Y", 0x078205, 0xFFFE00)          # -2 in the high 16 bits (signed)
    card.set(I8000=0x178205, I8001=0x1F8205, I8002=0x5F8206, I8003=1280)
    card.memory.write("Y", 0x078206, 7 << 8)
    card.tick(2)
    assert card.x(0x3501) == -64 & WORD
    assert card.x(0x3502) == 0xFFFE << 5 & WORD
    assert card.x(0x3504) == 2 * ((7 - 5) * 256) >> 3    # bias of +5 LSB = 1280 [A L2716]


def test_parallel_extension_takes_the_fraction_from_the_flags(card: Card) -> None:
    card.set(I8000=0x8F8000)
    card.enc.counts[0] = 3
    card.ic.set_flag(0, ChannelFlag.USER, True)
    card.ic.set_flag(0, ChannelFlag.T, True)
    card.tick()
    assert card.x(0x3501) == 3 * 32 + 0b10001


def test_no_extension_and_hardware_one_over_t(card: Card) -> None:
    card.set(I8000=0xC78000, I8001=0xCF8008)
    card.enc.counts[:2] = [5.5, 5.5]
    card.tick()
    assert (card.x(0x3501), card.x(0x3502)) == (160, 160)  # I7029=0: no hardware fraction
    card.ivars.values[7029] = 1
    assert card.x(0x3502) == 176
    card.set(I8000=0x078008)                 # software 1/T cannot work with I7mn9=1 [A L2437]
    card.tick()
    assert card.x(0x3501) == 160


def test_triggered_time_base_example(card: Card) -> None:
    card.set(I8008=0xAF8018, I8009=64, I7042=1)   # TBSF = 16384/256, rising index [A L2911-2913]
    card.set(I8008=0x9F8018)                      # freeze [A L2919]
    card.memory.read("X", 0x07801B)               # dummy read re-arms the capture [A L2863]
    card.enc.counts[3] = 50
    card.tick()
    assert card.x(0x350A) == 0
    card.set(I8008=0xBF8018)                      # arm [A L2925]
    card.enc.counts[3] = 60
    card.tick()
    assert card.x(0x350A) == 0
    card.ic.set_flag(3, ChannelFlag.CHC, True)
    card.enc.counts[3] = 70
    card.tick()
    assert card.ivars[8008] == 0xAF8018           # the firmware starts it running
    card.ic.set_flag(3, ChannelFlag.CHC, False)
    card.enc.counts[3] = 80
    card.tick()
    assert card.x(0x350A) == 2 * 64 * 10 * 256
    assert card.x(0x3509) == 80 * 256             # line 1: 1/256-count position [A L2857]


def test_high_resolution_interpolator_combines_counter_and_arctangent(card: Card) -> None:
    card.set(I8000=0xFF8000, I8001=0x078205, I8002=0)
    card.memory.write("Y", 0x078205, 1_000_000)   # sine
    card.memory.write("Y", 0x078206, 1_000_000)   # cosine: 45 degrees = 512/4096 line
    card.enc.counts[0] = 8                        # two lines of 4 counts
    card.tick()
    assert card.x(0x3503) == 2 * 4096 + 512


def test_byte_wide_parallel_entry(card: Card) -> None:
    card.memory.write("Y", 0x078C00, 0x0000AB)
    card.memory.write("Y", 0x078C01, 0x0000CD)
    card.set(I8000=0xF78C00, I8001=0x210000)      # 16 bits, low byte, LSB bit 0 [A L3097-3112]
    card.tick()
    assert card.x(0x3502) == 0xCDAB << 5


def test_tick_with_default_table_is_cheap(card: Card) -> None:
    import time

    t = time.perf_counter()
    for _ in range(2000):
        card.ect.tick()
    assert (time.perf_counter() - t) / 2000 < 200e-6
