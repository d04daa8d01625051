"""General I/O [M Ch3 §TTL Outputs, §Uncommitted Digital Inputs, §Analog Inputs]: SB CB OB OP and
@OUT/_OP for OUT1-OUT8, TI and @IN for IN1-IN8 (driven by `set_input`), @AN for the 12-bit analog
inputs (driven by `set_analog`) and the record's analog field, the TZ summary and the TB status
byte (spec §4.4: bit 6 data record active, bit 0 echo on)."""

from __future__ import annotations

import ctypes
import struct

import pytest
import vdevclient
from vdevclient import galil
from vdevmaps.galil import AXIS_SIZE, FIRST_AXIS
from vdevmaps.galil import REV4DMCDataRecordAxisOffsets as _A

from tests.devices.galil.conftest import Dmc, host_command

NUMBER_OUT_OF_RANGE = 6
ADC_STEP = 20 / 4096  # 12 bits over +-10 V: "a voltage resolution of approximately .005 V"
ANALOG_FULL_SCALE = 32767  # the record's analog inputs are +-32767 for +-10 V (README)
AXIS_BLOCK, ANALOG = FIRST_AXIS, int(_A.DRREV4AxisOffAnalogInput)  # axis k: analog input k+1 (spec §2.5)
TB_DATA_RECORD, TB_ECHO = 1 << 6, 1 << 0


def analog_field(record: bytes, axis: int) -> int:
    (value,) = struct.unpack_from("<h", record, AXIS_BLOCK + AXIS_SIZE * axis + ANALOG)
    return int(value)


def quantised(volts: float) -> float:
    return round(volts / ADC_STEP) * ADC_STEP


# -- outputs --------------------------------------------------------------------------------------
def test_sb_and_cb_set_and_clear_one_output(dmc: Dmc) -> None:
    """SB n / CB n on OUT1-OUT8; @OUT[n] reads the bit, _OP and OP ? the port."""
    assert dmc.value("OP ?") == 0
    dmc.cmd("SB 1;SB 8")
    assert dmc.value("MG @OUT[1]") == dmc.value("MG @OUT[8]") == 1
    assert dmc.value("MG @OUT[2]") == 0
    assert dmc.cmd("OP ?") == "129"  # 3.0 with leading zeros: 2^0 + 2^7
    assert dmc.value("MG _OP") == 129
    dmc.cmd("CB 1")
    assert dmc.value("MG @OUT[1]") == 0
    assert dmc.value("OP ?") == 128


def test_ob_sets_a_bit_to_an_expressions_truth(dmc: Dmc) -> None:
    """OB n,expr: output n = 1 when expr is not 0 (spec §4.5 I/O)."""
    dmc.cmd("OB 2,1")
    dmc.cmd("OB 3,5>2")
    assert dmc.value("OP ?") == 0b110
    dmc.cmd("OB 2,0")
    dmc.cmd("OB 4,-7")
    assert dmc.value("OP ?") == 0b1100


def test_op_writes_the_whole_port(dmc: Dmc) -> None:
    dmc.cmd("OP 165")
    assert [dmc.value(f"MG @OUT[{n}]") for n in range(1, 9)] == [(165 >> (n - 1)) & 1 for n in range(1, 9)]
    assert dmc.cmd("OP ?") == "165"


@pytest.mark.parametrize("line", ["SB 0", "SB 9", "CB 9", "OB 0,1", "OP 256", "OP -1"])
def test_outputs_outside_out1_to_out8_are_tc_6(dmc: Dmc, line: str) -> None:
    """The outputs are OUT1-OUT8 (bit 0 rejected, spec open question 26); the port is a byte."""
    dmc.cmd("OP 85")
    assert dmc.refused(line) == NUMBER_OUT_OF_RANGE
    assert dmc.value("OP ?") == 85


def test_outputs_show_in_the_record(dmc: Dmc) -> None:
    """General output 0 (byte 12) is OUT1-OUT8 [M Ch4 memory map]."""
    dmc.cmd("OP 90")
    dmc.step(0.02)
    assert dmc.record()[12] == 90


# -- digital inputs -------------------------------------------------------------------------------
def test_open_inputs_read_1(dmc: Dmc) -> None:
    assert dmc.cmd("TI 0") == "255"
    assert dmc.cmd("TI") == "255"
    assert all(dmc.value(f"MG @IN[{n}]") == 1 for n in range(1, 9))


def test_ti_and_in_follow_the_input_levels(dmc: Dmc) -> None:
    """TI 0 is IN1-IN8 as a byte, @IN[n] one input (spec §4.4)."""
    for n in (3, 8):
        dmc.control("set_input", input=n, level=0)
    expected = 0xFF & ~(1 << 2) & ~(1 << 7)
    assert dmc.value("TI 0") == expected
    assert dmc.value("MG _TI0") == expected
    assert [dmc.value(f"MG @IN[{n}]") for n in range(1, 9)] == [0 if n in (3, 8) else 1 for n in range(1, 9)]
    dmc.control("set_input", input=3, level=1)
    assert dmc.value("MG @IN[3]") == 1
    assert dmc.value("TI 0") == expected | 1 << 2


# -- analog inputs --------------------------------------------------------------------------------
def test_an3_reads_2_5_volts_and_the_z_axis_record_carries_it(dmc: Dmc) -> None:
    """@AN[3] in volts; the record's analog field of axis Z (offset 40 + 28*2 + 26) is analog
    input 3, +-32767 for +-10 V."""
    dmc.control("set_analog", input=3, volts=2.5)
    assert dmc.value("MG @AN[3]") == quantised(2.5)
    assert dmc.value("MG @AN[2]") == 0
    dmc.step(0.02)
    record = dmc.record()
    assert analog_field(record, 2) == pytest.approx(quantised(2.5) / 10 * ANALOG_FULL_SCALE, abs=1)
    assert analog_field(record, 1) == 0


@pytest.mark.parametrize("volts", [1.234, -3.3, 0.004, -0.0012])
def test_analog_inputs_are_12_bit(dmc: Dmc, volts: float) -> None:
    """"decoded by a 12-bit A/D decoder": readings are multiples of 20/4096 V, the nearest one
    (MG prints 4 decimals)."""
    dmc.control("set_analog", input=5, volts=volts)
    assert dmc.value("MG @AN[5]") == pytest.approx(quantised(volts), abs=0.00005)
    assert abs(dmc.value("MG @AN[5]") - volts) <= ADC_STEP / 2 + 0.00005


def test_analog_inputs_stop_at_minus_10_volts(dmc: Dmc) -> None:
    """"configured for the range between -10V and 10V"."""
    dmc.control("set_analog", input=1, volts=-12)
    assert dmc.value("MG @AN[1]") == -10


def test_a_12_bit_converter_has_4096_levels(dmc: Dmc) -> None:
    """12 bits over +-10 V are codes -2048..2047 of 20/4096 V: -10 V is the bottom code and the top
    one is 9.9951 V, so +10 V (and above) reads 9.9951."""
    dmc.control("set_analog", input=1, volts=-10)
    dmc.control("set_analog", input=2, volts=10)
    low, high = dmc.value("MG @AN[1]"), dmc.value("MG @AN[2]")
    assert round((high - low) / ADC_STEP) + 1 == 4096


# -- TZ and TB ------------------------------------------------------------------------------------
def test_tz_reports_the_input_and_output_blocks_and_the_analog_inputs(dmc: Dmc,
                                                                      a16: vdevclient.Region) -> None:
    """TZ (README "reports"): one line per block, the value in decimal and in binary, the analog
    inputs; read with the chapter 4 read procedure."""
    dmc.cmd("OP 165")
    dmc.control("set_input", input=3, level=0)
    dmc.control("set_analog", input=3, volts=2.5)
    reply = host_command(a16, b"TZ\r").decode()
    assert reply.endswith("\r\n:")
    lines = reply[:-3].split("\r\n")
    assert len(lines) == 3
    assert lines[0].endswith(f"input- value {0xFB} ({0xFB:08b})")
    assert lines[1].endswith(f"output- value 165 ({165:08b})")
    analog = [float(v) for v in lines[2].rsplit(" ", 1)[1].split(",")]
    assert analog == [0, 0, quantised(2.5), 0, 0, 0, 0, 0]


def test_tz_through_dmc_command_is_whole(dmc: Dmc) -> None:
    """A data reply is "data, CR LF, ':'" [M Ch4 §Controller Response to DATA]; DMCCommand reads to
    the ':' and nothing of TZ's reply may be left over."""
    reply = dmc.cmd("TZ")
    assert len(reply.split("\r\n")) == 3
    assert len(reply.rsplit(" ", 1)[1].split(",")) == 8
    left = ctypes.create_string_buffer(256)
    rc = galil.DMCGetUnsolicitedResponse(dmc.handle, left, ctypes.sizeof(left))
    assert (rc, left.value) == (galil.DMCNOERROR, b"")


def test_tb_bit_6_says_the_data_record_is_active(dmc: Dmc) -> None:
    assert dmc.value("TB") == 0
    dmc.cmd("DR-4")
    assert dmc.cmd("TB") == "064"
    assert dmc.value("MG _TB") == TB_DATA_RECORD
    dmc.cmd("DR 0")
    assert dmc.value("TB") == 0


def test_tb_bit_0_says_echo_is_on(dmc: Dmc, a16: vdevclient.Region) -> None:
    """EO 1 echoes the characters the card receives before its reply [M Ch4]: TB answers its own
    echo "TB" CR, then 001."""
    assert host_command(a16, b"EO 1\r") == b":"
    reply = host_command(a16, b"TB\r")
    assert reply == b"TB\r" + b"001\r\n:"
    assert int(reply[3:6]) & TB_ECHO
    assert host_command(a16, b"EO 0\r") == b"EO 0\r:"  # echoed: it arrived while echo was on
    assert not int(host_command(a16, b"TB\r")[:3]) & TB_ECHO
