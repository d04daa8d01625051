"""General-purpose I/O, analog I/O, auxiliary outputs and the limit settings [S §4.2, §4.4-4.6,
Table 6-2; spec oms.md §4.2-4.3 "Limits, home, I/O", §5.7].

The 16 I/O lines: bit n = IOn in BX (exactly 4 hex digits) and in the word at 0x09C; the factory
setting is IO0-7 inputs, IO8-15 outputs (spec §8.18); an open input reads high.
"""

from __future__ import annotations

import pytest
from vdevmaps.oms import Shm

from tests.devices.oms.conftest import Maxk, maxk_card

HZ = 1024


def gpio(maxk: Maxk) -> tuple[str, int]:
    """(BX, the word at 0x09C) after one update cycle."""
    maxk.step(1)
    return maxk.query("BX;"), maxk.shm.read32(Shm.GPIO_STATUS)


# -- digital I/O [S §4.4] -----------------------------------------------------------------------
def test_factory_setting_is_eight_inputs_and_eight_outputs(maxk: Maxk) -> None:
    """IO0-7 inputs (open: high), IO8-15 outputs (low)."""
    assert gpio(maxk) == ("00ff", 0x00FF)


def test_bh_bl_drive_output_bits(maxk: Maxk) -> None:
    maxk.send("BH8; BH15;")
    assert gpio(maxk) == ("81ff", 0x81FF)
    assert maxk.control("get_outputs")["gpio"] == 0x81FF
    maxk.send("BL8;")
    assert gpio(maxk) == ("80ff", 0x80FF)


@pytest.mark.parametrize("text", ["BH3", "BL0", "BH16", "BH-1", "BH"])
def test_bh_bl_refuse_an_input_bit_or_no_bit(maxk: Maxk, text: str) -> None:
    maxk.send(f"{text};")
    assert maxk.command_error()
    assert gpio(maxk) == ("00ff", 0x00FF)


def test_bd_sets_every_direction_one_is_output(maxk: Maxk) -> None:
    """`BD%04x` [E-traj]: here IO0-3 outputs, the rest inputs."""
    maxk.send("BD000F; BH2;")
    assert not maxk.command_error()
    assert gpio(maxk) == ("fff4", 0xFFF4)  # outputs 0, 1, 3 low, 2 high; inputs open (high)
    maxk.send("BH8;")
    assert maxk.command_error()


@pytest.mark.parametrize("text", ["BD10000", "BD", "BD12,34"])
def test_bd_takes_one_16_bit_mask(maxk: Maxk, text: str) -> None:
    maxk.send(f"{text};")
    assert maxk.command_error()
    maxk.send("BH8;")
    assert not maxk.command_error()  # the directions did not change


def test_io_sets_one_bit_direction(maxk: Maxk) -> None:
    """`IO bit,dir`, 1 = output [E-traj]."""
    maxk.send("IO3,1; BH3;")
    assert not maxk.command_error()
    assert gpio(maxk) == ("00ff", 0x00FF)
    maxk.send("BL3;")
    assert gpio(maxk) == ("00f7", 0x00F7)
    maxk.send("IO3,0;")
    assert gpio(maxk) == ("00ff", 0x00FF)
    maxk.send("IO16,1; IO3,2; IO3;")
    assert maxk.command_error()


def test_bw_writes_every_output_bit(maxk: Maxk) -> None:
    """BW writes the outputs at once; the bits of inputs keep reading the inputs."""
    maxk.send("BWA5A5;")
    assert gpio(maxk) == ("a5ff", 0xA5FF)
    maxk.send("BW0;")
    assert gpio(maxk) == ("00ff", 0x00FF)


def test_inputs_read_what_drives_them_outputs_what_the_card_drives(maxk: Maxk) -> None:
    """The backdoor drives the lines from outside: an input shows it, an output does not."""
    maxk.control("set_input", bit=2, level=0)
    maxk.control("set_input", bit=9, level=1)
    assert gpio(maxk) == ("00fb", 0x00FB)
    maxk.send("BD0000;")  # IO9 becomes an input: now it reads the line
    assert gpio(maxk) == ("fffb", 0xFFFB)


def test_bx_is_always_four_hex_digits(maxk: Maxk) -> None:
    """[E-traj] reads BX as exactly 4 hex digits."""
    for bit in range(8):
        maxk.control("set_input", bit=bit, level=0)
    reply = maxk.query("BX;")
    assert reply == "0000" and len(reply) == 4


def test_sw_holds_the_queue_until_the_input_is_high(maxk: Maxk) -> None:
    """SW# "wait until GP input bit # is high before running later commands of that axis"
    [E-traj; spec §4.3]; queued, so the move behind it waits."""
    maxk.control("set_input", bit=4, level=0)
    maxk.send("AX SW4; MR1000; GO;")
    maxk.step(HZ // 2)
    assert maxk.word(Shm.MOTOR_POSITION) == 0
    assert maxk.query("RQC;") != "2559"  # the wait and the move are in the queue
    maxk.control("set_input", bit=4, level=1)
    maxk.step(HZ // 2)
    assert maxk.word(Shm.MOTOR_POSITION) == 1000


def test_sw_on_other_axes_does_not_block_x(maxk: Maxk) -> None:
    maxk.control("set_input", bit=5, level=0)
    maxk.send("AY SW5; MR500; GO; AX MR700; GO;")
    maxk.step(HZ // 2)
    assert (maxk.word(Shm.MOTOR_POSITION), maxk.word(Shm.MOTOR_POSITION + 4)) == (700, 0)


# -- analog inputs [S §4.5.1, Table 6-2; spec §5.7] --------------------------------------------------
def test_ai_reads_volts_with_three_decimals(maxk: Maxk) -> None:
    maxk.control("set_analog", channel=1, volts=2.5)
    maxk.control("set_analog", channel=0, volts=-7.25)
    assert maxk.query("AI1;") == "2.500"
    assert maxk.query("AI0;") == "-7.250"


def test_ai_is_a_16_bit_reading(maxk: Maxk) -> None:
    """±10 V over ±32767 counts: 1.23456 V reads as round(1.23456/10·32767) = 4045 counts."""
    maxk.control("set_analog", channel=0, volts=1.23456)
    assert maxk.query("AI0;") == f"{4045 * 10 / 32767:.3f}"
    maxk.control("set_analog", channel=0, volts=12.0)
    assert maxk.query("AI0;") == "10.000"


@pytest.mark.parametrize(("axes", "channels"), [(1, 2), (5, 2), (6, 4), (10, 4)])
def test_two_analog_inputs_up_to_five_axes_four_above(axes: int, channels: int) -> None:
    """[S Table 6-2]: MAXk-1000..5000 have 2 analog inputs, 6000..A000 have 4."""
    with maxk_card(axes=axes, axis_types=["stepper"] * axes) as maxk:
        for ch in range(channels):
            assert maxk.query(f"AI{ch};") == "0.000"
        maxk.send(f"AI{channels};")
        assert maxk.command_error()


# -- analog outputs [S §4.5.2] -------------------------------------------------------------------------
def test_ao_drives_the_dac_of_an_axis_that_is_not_a_servo() -> None:
    """"For every available axis that is not being used as a servo motor, there is a general
    purpose analog output available" [S §4.5.2]; it is the axis's DAC word."""
    with maxk_card(axis_types=["servo", "stepper", "stepper_encoder", "stepper"]) as maxk:
        maxk.send("AY AO2.5; AZ AO-10;")
        assert not maxk.command_error()
        maxk.step(1)
        assert maxk.word(Shm.DAC + 4) == round(2.5 / 10 * 32767)
        assert maxk.word(Shm.DAC + 8) == -32767
        assert maxk.control("get_outputs")["dac_volts"][1] == pytest.approx(2.5, abs=0.001)
        maxk.send("AX AO1;")  # X is a servo: its DAC belongs to the loop
        assert maxk.command_error()
        maxk.send("AY AO10.5;")
        assert maxk.command_error()
        maxk.send("AA AO,1,,3;")
        maxk.step(1)
        assert [maxk.word(Shm.DAC + 4 * a) for a in (1, 3)] == [3277, 9830]


# -- auxiliary outputs [S §4.6, §2.14; spec §4.3 AN/AF] -----------------------------------------------
def test_an_af_switch_the_auxiliary_output_of_the_axis(maxk: Maxk) -> None:
    assert maxk.control("get_outputs")["aux"] == [False] * 4
    maxk.send("AY AN; AT AN;")
    assert maxk.control("get_outputs")["aux"] == [False, True, False, True]
    maxk.send("AY AF;")
    assert maxk.control("get_outputs")["aux"] == [False, False, False, True]
    maxk.send("AA AF;")
    assert maxk.control("get_outputs")["aux"] == [False] * 4


# -- limit settings and their queries [S §4.2; spec §4.2] ---------------------------------------------
def test_lt_sets_the_limit_level_and_lt_query_reports_it(maxk: Maxk) -> None:
    """LTH/LTL; LT? -> =h/=l [A-base]; factory active low [S §2.14]."""
    assert maxk.query("AX LT?;") == "=l"
    assert maxk.query("LTH; LT?;") == "=h"
    assert maxk.query("LTL; LT?;") == "=l"
    assert maxk.query("AA LTH,,H; LT?;") == "=h,=l,=h,=l"


def test_lm_sets_the_limit_mode_and_lm_query_reports_it(maxk: Maxk) -> None:
    """LMH hard, LMS soft, LMF off; LM? -> =h/=s/=f (spec §4.2); factory hard [S §2.14]."""
    assert maxk.query("AX LM?;") == "=h"
    assert maxk.query("LMS; LM?;") == "=s"
    assert maxk.query("LMF; LM?;") == "=f"
    assert maxk.query("LMH; LM?;") == "=h"
    maxk.send("LMQ;")
    assert maxk.command_error()
