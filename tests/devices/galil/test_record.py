"""Manual chapter 4 "Communication with Controller - Secondary FIFO channel": DR -n, the polling
mode read procedure on N+5/N+7, and the record's memory map ("DMA / Secondary FIFO Memory Map"),
through the A16 window and through DMCRefreshDataRecord / DMCGetDataRecord. The record is read
little-endian (spec §8 question 1, the card's default `record_endian`)."""

from __future__ import annotations

import ctypes
import struct

import pytest
import vdevclient
from vdevclient import galil
from vdevmaps.galil import AXIS_SIZE, FIRST_AXIS, AxisStatus
from vdevmaps.galil import REV4DMCDataRecordAxisOffsets as _A
from vdevmaps.galil import REV4DMCDataRecordGeneralOffsets as _G

from tests.devices.galil.conftest import (
    FIFO2_BUSY,
    FIFO2_DATA,
    FIFO2_FREEZE,
    FIFO2_NOT_EMPTY,
    FIFO2_STATUS,
    Dmc,
    card_config,
    host_command,
)
from vdevd.testing import DaemonThread

RECORD_SIZE = FIRST_AXIS + 4 * AXIS_SIZE  # the memory map ends at 150-151 (w,d axis analog input)
GENERAL_INPUT_0 = int(_G.DRREV4GenOffGeneralInput0)
GENERAL_OUTPUT_0 = int(_G.DRREV4GenOffGeneralOutput0)
ERROR_CODE = int(_G.DRREV4GenOffErrorCode)
AXIS_BLOCKS = tuple(FIRST_AXIS + AXIS_SIZE * k for k in range(4))  # x,a ... w,d axis status
# within an axis block
STATUS, STOPCODE = int(_A.DRREV4AxisOffAxisStatus), int(_A.DRREV4AxisOffAxisStopCode)
REFERENCE, MOTOR = int(_A.DRREV4AxisOffAxisReferencePosition), int(_A.DRREV4AxisOffAxisMotorPosition)
ERROR, VELOCITY = int(_A.DRREV4AxisOffAxisPositionError), int(_A.DRREV4AxisOffAxisVelocity)
TORQUE = int(_A.DRREV4AxisOffAxisTorque)
MOVE_IN_PROGRESS, MOTOR_OFF = int(AxisStatus.MOVING), int(AxisStatus.MOTOR_OFF)
TORQUE_FULL_SCALE = 32767  # "Maximum positive torque is 32767" at the DAC's +10 V
VELOCITY_SCALE = 64  # "64 times larger than the value returned when using the command TV"


def axis_item(record: bytes, axis: int, offset: int, fmt: str) -> int:
    (value,) = struct.unpack_from("<" + fmt, record, AXIS_BLOCKS[axis] + offset)
    return int(value)


def sample_number(record: bytes) -> int:
    return int(struct.unpack_from("<H", record, 0)[0])


def polling_read(a16: vdevclient.Region, size: int = RECORD_SIZE) -> bytes:
    """[M Ch4 §Polling Mode Read Procedure] steps 1-6."""
    assert a16.wait_value(FIFO2_STATUS, FIFO2_NOT_EMPTY, mask=FIFO2_NOT_EMPTY, size=1,
                          timeout_s=1.0) is not None  # 1. bit 2 of N+7 until 1
    a16.write8(FIFO2_DATA, 0x00)  # 2. freeze
    assert a16.wait_value(FIFO2_STATUS, 0, mask=FIFO2_BUSY, size=1, timeout_s=1.0) is not None  # 3.
    record = bytes(a16.read8(FIFO2_DATA) for _ in range(size))  # 4., 5.
    a16.write8(FIFO2_DATA, 0x00)  # 6. resume
    return record


# -- the secondary FIFO ---------------------------------------------------------------------------
def test_qz_gives_the_record_layout(dmc: Dmc) -> None:
    """4 axes, 24 general bytes (00-23), 16 coordinated (24-39), 28 per axis (40-67 ...)."""
    assert dmc.cmd("QZ") == "4,24,16,28"
    assert RECORD_SIZE == 24 + 16 + 4 * 28


def test_a_two_axis_dmc_1328_record_has_two_axis_blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """"the DMC-1328 uses X and Y": QZ 2,24,16,28 and a record of 40 + 2 * 28 bytes, whose y,b
    block (68-95) follows the moves of Y."""
    with DaemonThread(card_config(axes=2)) as daemon, \
            vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as rack:
        monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
        handle = ctypes.c_long()
        assert galil.DMCOpen(1, 0, ctypes.byref(handle)) == galil.DMCNOERROR
        dmc = Dmc(handle, rack)
        try:
            assert dmc.cmd("QZ") == "2,24,16,28"
            dmc.cmd("DR-1;PR 0,-2222;BG Y;AM Y")
            dmc.step(0.01)
            record = dmc.record()
            assert len(record) == 40 + 2 * 28
            assert axis_item(record, 1, REFERENCE, "i") == -2222
        finally:
            galil.DMCClose(handle)


def test_not_active_by_default(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """"The secondary communication is NOT ACTIVE by default and must be enabled with the DR
    command"."""
    rack.sim.step(seconds=0.05)
    assert not a16.read8(FIFO2_STATUS) & FIFO2_NOT_EMPTY


def test_polling_read_gets_a_record_every_2_to_the_n_samples(a16: vdevclient.Region) -> None:
    """DR-n: "This rate is 2^n samples between updates"; DR-2: the sample numbers of two records in
    a row differ by 4."""
    assert host_command(a16, b"DR-2\r") == b":"
    first = polling_read(a16)
    assert len(first) == RECORD_SIZE
    assert not a16.read8(FIFO2_STATUS) & FIFO2_NOT_EMPTY  # read to its end
    second = polling_read(a16)
    assert sample_number(second) - sample_number(first) == 4


def test_a_frozen_record_is_not_updated_while_it_is_read(rack: vdevclient.Rack,
                                                         a16: vdevclient.Region) -> None:
    """"this procedure does not allow the FIFO to be updated while being read": after 00 to N+5
    the freeze bit reads 1 and the record stays the one of that moment."""
    host_command(a16, b"DR-1\r")
    a16.wait_value(FIFO2_STATUS, FIFO2_NOT_EMPTY, mask=FIFO2_NOT_EMPTY, size=1, timeout_s=1.0)
    a16.write8(FIFO2_DATA, 0x00)
    assert a16.read8(FIFO2_STATUS) & FIFO2_FREEZE
    rack.sim.step(seconds=0.02)  # ten updates would have come
    frozen = bytes(a16.read8(FIFO2_DATA) for _ in range(RECORD_SIZE))
    a16.write8(FIFO2_DATA, 0x00)
    assert not a16.read8(FIFO2_STATUS) & FIFO2_FREEZE
    fresh = polling_read(a16)
    assert sample_number(fresh) - sample_number(frozen) >= 20


def test_an_unread_record_is_replaced_by_new_data(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """"If the data is not read, the FIFO is updated with new data"."""
    host_command(a16, b"DR-2\r")
    rack.sim.step(seconds=0.1)
    record = polling_read(a16)
    now = float(host_command(a16, b"MG TIME\r")[:-3])  # samples since reset
    assert 0 <= now - sample_number(record) <= 4 + 1


def test_dr0_turns_the_polling_fifo_off(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """"DR 0 turns off the Polling FIFO mode"."""
    host_command(a16, b"DR-1\r")
    polling_read(a16)
    host_command(a16, b"DR 0\r")
    while a16.read8(FIFO2_STATUS) & FIFO2_NOT_EMPTY:
        a16.read8(FIFO2_DATA)
    rack.sim.step(seconds=0.05)
    assert not a16.read8(FIFO2_STATUS) & FIFO2_NOT_EMPTY


# -- the memory map, through the DMC library ------------------------------------------------------
def test_positions_errors_and_stop_codes_equal_the_reports_after_a_move(dmc: Dmc) -> None:
    """After DR-2 and a move on each axis, each axis block holds reference position (RP), motor
    position (TP), position error (TE) and stop code (SC)."""
    dmc.cmd("DR-2")
    dmc.cmd("PR 1234,-567,89,-10;BG;AM")
    dmc.step(0.3)
    record = dmc.record()
    rp, tp, te, sc = (dmc.values(q) for q in ("RP", "TP", "TE", "SC"))
    for axis in range(4):
        assert axis_item(record, axis, REFERENCE, "i") == rp[axis] == [1234, -567, 89, -10][axis]
        assert axis_item(record, axis, MOTOR, "i") == tp[axis]
        assert axis_item(record, axis, ERROR, "i") == te[axis]
        assert axis_item(record, axis, STOPCODE, "B") == sc[axis]


def test_dmc_get_data_record_by_the_manuals_offsets(dmc: Dmc) -> None:
    """DMCGetDataRecord(general offset of the axis block, offset in the block): the library's
    REV4 offsets are the manual's map (x,a block at 40, y,b at 68; reference position +4)."""
    assert galil.DRREV4GenOffAxis1 == AXIS_BLOCKS[0] and galil.DRREV4GenOffAxis2 == AXIS_BLOCKS[1]
    assert galil.DRREV4AxisOffAxisReferencePosition == REFERENCE
    assert galil.DRREV4AxisOffAxisMotorPosition == MOTOR
    dmc.cmd("DR-2")
    dmc.cmd("PR 0,4321;BG Y;AM Y")
    dmc.step(0.3)
    dmc.record()
    kind, value = ctypes.c_ushort(0), ctypes.c_long()
    rc = galil.DMCGetDataRecord(dmc.handle, AXIS_BLOCKS[1], REFERENCE, ctypes.byref(kind),
                                ctypes.byref(value))
    assert rc == galil.DMCNOERROR
    assert (value.value, kind.value) == (4321, galil.DRTypeLONG)
    kind.value = 0
    rc = galil.DMCGetDataRecordByItemId(dmc.handle, galil.DRIdAxisMotorPosition, galil.DRIdAxis2,
                                        ctypes.byref(kind), ctypes.byref(value))
    assert rc == galil.DMCNOERROR
    assert value.value == dmc.value("TP Y")


def test_velocity_is_64_times_tv(dmc: Dmc) -> None:
    """"The velocity information that is returned in the data record is 64 times larger than the
    value returned when using the command TV"."""
    dmc.cmd("DR-1")
    dmc.cmd("JG 12000,-3000;BG XY")
    dmc.step(2.0)
    record = dmc.record()
    tv = dmc.values("TV XY")
    for axis in (0, 1):
        # TV is read one sample after the record: its 0.25 s average moves by a few counts/s
        assert axis_item(record, axis, VELOCITY, "i") / VELOCITY_SCALE == pytest.approx(tv[axis], rel=0.005)


def test_torque_is_plus_minus_32767_for_plus_minus_10_volts(dmc: Dmc) -> None:
    """"The Torque information is represented as a number in the range of +/-32767": a motor
    stalled against friction at TL 0.2 drives 0.2 V (TT), 0.2/10 of full scale."""
    dmc.control("set_friction", axis="X", volts=0.5)
    dmc.cmd("DR-1;TL 0.2;JG 1000;BG X")
    dmc.step(0.2)
    record = dmc.record()
    volts = dmc.value("TT X")
    assert volts == pytest.approx(0.2, abs=1e-3)
    assert axis_item(record, 0, TORQUE, "h") == pytest.approx(volts / 10 * TORQUE_FULL_SCALE, abs=1)


def test_axis_status_move_in_progress_and_motor_off(dmc: Dmc) -> None:
    """Axis status bit 15 "Move in Progress", bit 0 "Motor Off" [M Ch4 §Explanation of Status
    Information]."""
    dmc.cmd("DR-1")
    dmc.cmd("JG 5000;BG X")
    dmc.step(0.05)
    assert axis_item(dmc.record(), 0, STATUS, "H") & MOVE_IN_PROGRESS
    dmc.cmd("ST X;AM X;MO Y")
    dmc.step(0.01)
    record = dmc.record()
    assert not axis_item(record, 0, STATUS, "H") & (MOVE_IN_PROGRESS | MOTOR_OFF)
    assert axis_item(record, 1, STATUS, "H") & MOTOR_OFF


def test_error_code_inputs_and_outputs(dmc: Dmc) -> None:
    """General bytes: 22 error code (the TC code), 2 general input 0 (IN1-IN8), 12 general output
    0 (OUT1-OUT8)."""
    dmc.cmd("DR-1")
    dmc.refused("KP 2000")
    dmc.cmd("SB 1;SB 3")
    dmc.control("set_input", input=2, level=0)
    dmc.step(0.01)
    record = dmc.record()
    assert record[ERROR_CODE] == 6
    assert record[GENERAL_OUTPUT_0] == 0b101
    assert record[GENERAL_INPUT_0] == 0xFF & ~0b10  # IN2 low, the others open (1)
    assert dmc.value("MG @IN[2]") == 0 and dmc.value("MG @IN[1]") == 1
