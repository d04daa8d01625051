"""Servo IC channel registers and position compare (vdevd/devices/pmac/servo_ic.py) [A L677-894]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.fakes import FakeEncoders
from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.memory import Memory
from vdevd.devices.pmac.mvars import MVars, parse_definition
from vdevd.devices.pmac.servo_ic import ChannelFlag, ServoIC

#: the suggested M-variables of Servo IC 0 channel 1 [A L155, L790-800, L863, L871-872]
SUGGESTED = {
    101: "X:$078001,0,24,S", 103: "X:$078003,0,24,S", 107: "Y:$078004,8,16,S",
    108: "Y:$078007,0,24,S", 109: "X:$078007,0,24,S", 110: "X:$078006,0,24,S",
    111: "X:$078005,11", 112: "X:$078005,12", 113: "X:$078000,9", 114: "X:$078005,18,1",
    188: "Y:$078000,0,12,U", 189: "Y:$078001,0,12,U",
}


class Card:
    def __init__(self) -> None:
        self.memory = Memory()
        self.ivars = IVars(8)
        self.enc = FakeEncoders()
        self.ic = ServoIC(self.memory, self.ivars, self.enc)
        self.m = MVars(self.memory)
        for n, text in SUGGESTED.items():
            self.m.define(n, parse_definition(text)[0])

    def go(self, positions: list[float], channel: int = 0) -> list[tuple[float, int]]:
        """Tick once at each position of encoder `channel`; the EQU status (M113) after each."""
        seen = []
        for p in positions:
            self.enc.counts[channel] = p
            self.ic.tick()
            seen.append((p, int(self.m.read(113))))
        return seen


@pytest.fixture
def card() -> Card:
    return Card()


def _path(start: int, stop: int, step: int) -> list[float]:
    pts = list(range(start, stop, step if stop > start else -step)) + [stop]
    return [float(p) for p in pts]


@pytest.mark.parametrize("step", [1, 3, 7, 11])
def test_single_pulse_recipe_output_is_on_between_1000_and_1010(card: Card, step: int) -> None:
    card.go([100.0])
    for n, v in ((108, 1000), (109, 1010), (110, 0), (112, 0), (111, 1)):   # [A L822-826]
        card.m.write(n, v)
    assert card.m.read(111) == 0            # write enable clears itself [A L784]
    for p, equ in card.go(_path(100, 1100, step)):
        assert equ == (1001 <= p <= 1010), p   # toggles leaving 1000 and leaving 1010 [A L766]


def test_single_pulse_moving_back_toggles_leaving_each_register_downward(card: Card) -> None:
    for n, v in ((108, 1000), (109, 1010), (110, 0), (112, 0), (111, 1)):
        card.m.write(n, v)
    card.go([1100.0])
    for p, equ in card.go(_path(1100, 0, 1)):
        assert equ == (1000 <= p <= 1009), p   # 1010 -> 1009 on, 1000 -> 999 off


@pytest.mark.parametrize("step", [1, 3, 37, 2500])
def test_multiple_pulse_recipe_with_auto_increment_2000(card: Card, step: int) -> None:
    card.go([100.0])
    card.m.write(110, 2000)                  # [A L845-849]
    card.m.write(108, 1000)
    card.m.write(109, 1010 - card.m.read(110))
    card.m.write(112, 0)
    card.m.write(111, 1)
    for p, equ in card.go(_path(100, 7100, step)):
        assert equ == (p >= 1001 and (p - 1001) % 2000 < 10), p
    assert (card.m.read(108), card.m.read(109)) == (9000, 7010)


def test_multiple_pulses_moving_negative_step_the_other_register_down(card: Card) -> None:
    card.go([4990.0])
    for n, v in ((110, 2000), (108, 3010), (109, 3000 + 2000), (112, 0), (111, 1)):
        card.m.write(n, v)
    for p, equ in card.go(_path(4990, 0, 5)):
        assert equ == (3000 <= p <= 3009 or 1000 <= p <= 1009), p


def test_extended_count_edge_at_743_25_is_integer_742_fraction_1024(card: Card) -> None:
    card.m.write(114, 1)                     # extended-count mode, bit 18 = I7mn9 [A L859-863]
    assert card.ivars[7019] == 1
    p108 = 743.25
    card.m.write(108, int(p108) - 1)         # [A L887-888]
    card.m.write(188, (p108 - (card.m.read(108) + 1)) * 4096)
    assert (card.m.read(108), card.m.read(188)) == (742, 1024)   # [A L880]
    card.m.write(109, 2000)
    card.m.write(112, 0)
    card.m.write(111, 1)
    seen = card.go([700 + k / 8 for k in range(400)])
    assert min(p for p, equ in seen if equ) == 743.25


def test_extended_count_edge_moving_negative_is_one_count_below_the_integer(card: Card) -> None:
    card.m.write(114, 1)
    card.go([800.0])
    card.m.write(108, 744)                   # n-1 moving negative, plus 1024/4096 [A L880]
    card.m.write(188, 1024)
    card.m.write(109, -2000)
    card.m.write(111, 1)
    seen = card.go([800 - k / 8 for k in range(600)])
    assert max(p for p, equ in seen if equ) == 743.25


def test_writing_past_the_24_bit_range_wraps(card: Card) -> None:
    card.m.write(108, 9_388_608)             # [A L942]
    assert card.m.read(108) == -7_388_608


def test_compare_follows_the_counter_through_its_24_bit_rollover(card: Card) -> None:
    card.m.write(108, 8_388_605)
    card.m.write(109, 8_388_612)             # stored as -8,388,604
    card.m.write(111, 1)
    path = [float(p) for p in range(8_388_600, 8_388_620)]
    wrapped = [(p + 2**23) % 2**24 - 2**23 for p in path]
    for p, (_, equ) in zip(path, card.go(wrapped), strict=True):
        assert equ == (8_388_606 <= p <= 8_388_612), p


def test_direct_write_forces_the_output_only_when_enabled(card: Card) -> None:
    card.m.write(112, 1)
    assert card.m.read(113) == 0             # the value alone does nothing [A L780]
    card.m.write(111, 1)
    assert (card.m.read(113), card.m.read(111), card.m.read(112)) == (1, 0, 1)
    card.m.write(112, 0)
    card.m.write(111, 1)
    assert card.m.read(113) == 0


def test_power_up_compare_is_idle_and_never_toggles(card: Card) -> None:
    assert not card.ic._armed.any()
    assert all(equ == 0 for _, equ in card.go(_path(0, 300, 7)))


def test_channel_select_compares_channel_2_on_channel_1_encoder(card: Card) -> None:
    card.ivars.values[7021] = 1              # I7021: Servo IC 0 channel 2 uses encoder 1 [A L774-776]
    card.memory.write("Y", 0x07800F, 10)     # channel 2 compare A
    card.memory.write("X", 0x07800F, 20)     # channel 2 compare B
    for p, equ in card.go(_path(0, 30, 1)):   # M113 is channel 1's status bit
        assert equ == (11 <= p <= 20), p     # channel 1's output ORs channel 2's logic


def test_counter_register_reads_the_encoder_and_ignores_writes(card: Card) -> None:
    card.go([-5.0])
    assert card.m.read(101) == -5
    card.memory.write("X", 0x078001, 1234)
    assert card.memory.read("X", 0x078001) == 0xFFFFFB


def test_dac_and_pfm_registers_hold_what_was_written(card: Card) -> None:
    card.memory.write("Y", 0x07800A, 0xFFFF00)   # channel 2 DAC A
    card.m.write(107, 11)                         # PFM command, 16-bit form [A L155]
    assert card.ic.dac()[1] == -256
    assert card.ic.pfm()[0] == 11 * 256
    assert card.memory.read("Y", 0x078004) == 11 * 256


def test_capture_on_home_flag_latches_the_counter_and_rearms_on_read(card: Card) -> None:
    card.ivars.values[7012] = 2              # I7012: capture on flag high; I7013=0: home flag
    card.go([0.0])
    card.m.read(103)                         # arm
    card.go([100.0, 200.0])
    assert card.memory.read("X", 0x078000) >> ChannelFlag.CAPTURE & 1 == 0
    card.ic.set_flag(0, ChannelFlag.HMFL, True)
    card.go([250.0, 300.0])
    status = card.memory.read("X", 0x078000)
    assert status >> ChannelFlag.CAPTURE & 1 and status >> ChannelFlag.HMFL & 1
    assert card.m.read(103) == 250
    assert card.memory.read("X", 0x078000) >> ChannelFlag.CAPTURE & 1 == 0


def test_mldt_timer_latches_the_echo_time_of_the_distance(card: Card) -> None:
    card.ivars.values[7010] = 12             # MLDT decode [A L199-203]
    card.ivars.values[7016] = 3              # PFM on C [A L193-195]
    card.m.write(107, 11)                    # ~1.65 kHz with PFMCLK 9.83 MHz [A L169-171]
    card.ic.set_mldt_base(0, 500.0)
    card.go([0.0, 0.0, 0.0])
    assert card.memory.read("Y", 0x078000) == round(500 * 0.35 * 117.96)   # 20643 LSB
    card.go([100.0, 100.0, 100.0])
    assert card.memory.read("Y", 0x078000) == 20643 + 100   # one count is one timer LSB


def test_mldt_timer_holds_without_pfm_pulses_or_when_the_echo_outlasts_the_period(card: Card) -> None:
    card.ivars.values[7010] = 12
    card.ivars.values[7016] = 3
    card.ic.set_mldt_base(0, 500.0)
    card.go([0.0, 0.0, 0.0])
    assert card.memory.read("Y", 0x078000) == 0      # Mxx07 = 0: no excitation
    card.m.write(107, 11)
    card.ic.set_mldt_base(0, 2000.0)                 # 700 us echo > 606 us period
    card.go([0.0, 0.0, 0.0])
    assert card.memory.read("Y", 0x078000) == 0


def test_one_over_t_timers_follow_the_velocity(card: Card) -> None:
    card.go([0.0, 10.25])
    between, since = card.memory.read("Y", 0x078000), card.memory.read("Y", 0x078001)
    assert since / between == pytest.approx(0.25, abs=1e-3)
