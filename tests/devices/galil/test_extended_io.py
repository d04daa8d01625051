"""The extended I/O points 17-80 in banks of 8 configured by CO [M Ch1 §General I/O, Ch3
§Uncommitted Digital Inputs; spec §1; the DMC-1700/1800 appendix form of CO, OP, TI]."""

from __future__ import annotations

import numpy as np

from tests.devices.galil.program_rig import Rig as FlashRig
from tests.devices.galil.test_firmware import Rig
from vdevd.devices.galil.record import record_dtype


def test_power_on_every_bank_is_inputs_reading_open() -> None:
    rig = Rig()
    assert rig.send(b"CO ?;MG @IN[17],@IN[80],@OUT[17];TI 2;TI 9\r") == (
        b"000\r\n: 0000000001.0000 0000000001.0000 0000000000.0000\r\n:255\r\n:255\r\n:")


def test_co_makes_banks_outputs_that_sb_cb_ob_and_op_drive() -> None:
    """CO 3: blocks 2 and 3 (17-32) outputs [appendix: "if blocks 2 and 3 are to be outputs,
    then n is 3"]."""
    rig = Rig()
    assert rig.send(b"CO 3;SB 17;SB 32;OB 20,1;MG _CO,@OUT[17],@OUT[18],@OUT[20],@OUT[32]\r") == (
        b":::: 0000000003.0000 0000000001.0000 0000000000.0000 0000000001.0000"
        b" 0000000001.0000\r\n:")
    assert rig.send(b"TI 2;TI 3;CB 17;TI 2;MG @IN[20]\r") == (
        b"009\r\n:128\r\n::008\r\n: 0000000001.0000\r\n:")
    # OP m,a: a is 16 bits of points 17-32
    assert rig.send(b"OP 5,$0102;OP ?;TI 2;TI 3\r") == b":005\r\n:002\r\n:001\r\n:"


def test_op_words_for_input_banks_are_ignored() -> None:
    rig = Rig()
    assert rig.send(b"CO 4;OP ,,$FFFF;TI 4;TI 5\r") == b"::255\r\n:255\r\n:"  # bank 4 out, 5 in
    assert rig.send(b"OP ,,0;TI 4;MG @OUT[41]\r") == b":000\r\n: 0000000000.0000\r\n:"


def test_writing_a_point_of_an_input_bank_is_tc6_and_changes_nothing() -> None:
    rig = Rig()
    rig.send(b"CO 1\r")
    for bad in (b"SB 25", b"CB 80", b"OB 33,1", b"SB 81", b"SB 9", b"CO 256", b"CO -1"):
        assert rig.send(bad + b"\r") == b"?", bad
        assert rig.send(b"TC\r") == b"006\r\n:"
    assert rig.send(b"CO ?;TI 3;SB 24;TI 2\r") == b"001\r\n:255\r\n::128\r\n:"


def test_driven_inputs_read_in_input_banks_ti_and_the_data_record() -> None:
    rig = Rig()
    rig.fw.set_input(17, 0)
    rig.fw.set_input(80, 0)
    assert rig.send(b"MG @IN[17],@IN[18],@IN[80];TI 2;TI 9;MG _TI9\r") == (
        b" 0000000000.0000 0000000001.0000 0000000000.0000\r\n:254\r\n:127\r\n:"
        b" 0000000127.0000\r\n:")
    rig.send(b"CO 128;SB 73\r")  # bank 9 outputs: reads its latches, not the driven level
    rec = np.frombuffer(rig.fw.data_record(), dtype=record_dtype(4), count=1)[0]
    assert rec["input_bank_2"] == 254 and rec["input_bank_9"] == 1
    assert rec["output_bank_9"] == 1 and rec["output_bank_2"] == 0


def test_rs_returns_to_co_0_keeping_the_driven_levels() -> None:
    rig = Rig()
    rig.fw.set_input(20, 0)
    assert rig.send(b"CO 1;SB 17;RS;CO ?;MG @OUT[17],@IN[20]\r") == (
        b":::000\r\n: 0000000000.0000 0000000000.0000\r\n:")



def test_bn_burns_co_the_outputs_and_the_formats_for_the_next_power_up() -> None:
    """"The configuration of the extended I/O and the state of the outputs can be stored in the
    EEPROM with the BN command" [DMC-1700/1800 appendix]; PF and VF with them."""
    rig = FlashRig()
    assert rig.send(b"CO 2;SB 26;OP 9;PF-4;VF 2.1;BN\r") == b"::::::"
    after = FlashRig(flash=rig.flash)
    assert after.send(b"CO ?;TI 3;OP ?;PF ?;VF ?\r") == b"002\r\n:002\r\n:009\r\n:-04\r\n:02\r\n:"
