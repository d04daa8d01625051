"""The Galil DMC-13X8 register map: the A16 window, interrupts and the data record (manual ch. 4).

One source for the daemon (`vdevd.devices.galil`), the client (`vdevclient.galil`, `gclib`) and
the tests: register offsets from the base N, the bits of the status registers, the CONTROL write
sequences, the EI condition bits and interrupt status codes, and the layout of the secondary-FIFO
data record (revision 4, `QZ` -> axes,24,16,28) with the names of Galil's dmcdrc.h. Plain
constants and enums; nothing here imports the daemon or the client.
"""

from __future__ import annotations

import enum

# -- the A16 window [M Ch4 §Communication Registers] -----------------------------------------------
WINDOW_SIZE = 16  # A4..A15 select the base N (JP10); the card decodes N+0 .. N+15
FIFO_SIZE = 512  # the command and response FIFOs [M Ch4 Introduction]
DEFAULT_ALMOST_FULL = 16  # the almost-full level m at power-on [M Ch4 §Changing Almost Full Flags]
INTERRUPT_QUEUE_DEPTH = 8  # "an interrupt buffer that is eight levels deep" [M Ch4 §Interrupts]
EMPTY_READ = 0xFF  # "Reading data from the READ register when the register is empty ... FF hex"


class A16Reg(enum.IntEnum):
    """Register offsets from N; D08(O) decodes odd byte lanes only [M Ch4 §Communication Registers]."""

    DATA = 1  # READ (card->host FIFO) / WRITE (host->card command FIFO)
    CONTROL = 3
    SECONDARY_DATA = 5  # the polling FIFO's data record [M Ch4 §Overview of Secondary FIFO Procedure]
    SECONDARY_STATUS = 7


class ControlStatus(enum.IntFlag):
    """Bits of the CONTROL register read [M Ch4 §Simplified Communication Procedure]; others read 0."""

    WRITE_ALMOST_FULL = 1 << 4  # free space in the command FIFO is below the almost-full level
    READ_EMPTY = 1 << 5  # 0 = data to be read
    CLEARED = 1 << 7  # "Bit 7 will be 1" after the clear sequence [M Ch4 §Clearing FIFO Buffer]


class SecondaryStatus(enum.IntFlag):
    """Bits of N+7 [M Ch4 §Overview of Secondary FIFO Procedure]; bits 3-7 unused."""

    BUSY = 1 << 0
    FREEZE = 1 << 1
    NOT_EMPTY = 1 << 2


class ControlWrite(enum.IntEnum):
    """Bytes of the CONTROL write sequences [M Ch4 §Changing Almost Full Flags, §Clearing FIFO Buffer,
    §Setting up Interrupts, §Servicing Interrupts]."""

    CLEAR_01 = 0x01
    CLEAR_80 = 0x80
    IRQ_ENABLE_2 = 0x02
    IRQ_ENABLE_4 = 0x04
    ALMOST_FULL = 0x05  # followed by m - 16
    IRQ_STATUS = 0x06  # the next CONTROL read returns the interrupt status byte


#: 01 80 01 80 to N+3 clears both FIFOs [M Ch4 §Clearing FIFO Buffer]
CLEAR_SEQUENCE = (ControlWrite.CLEAR_01, ControlWrite.CLEAR_80, ControlWrite.CLEAR_01,
                  ControlWrite.CLEAR_80)
#: 02 04 to N+3 enables the interrupt output [M Ch4 §Setting up Interrupts]
IRQ_ENABLE_SEQUENCE = (ControlWrite.IRQ_ENABLE_2, ControlWrite.IRQ_ENABLE_4)
#: 06 to N+3, then read N+3: the interrupt status [M Ch4 §Servicing Interrupts]
IRQ_STATUS_SELECT = ControlWrite.IRQ_STATUS


# -- interrupts [M Ch4 §Configuring Interrupts, §Servicing Interrupts] ------------------------------
class InterruptCondition(enum.IntFlag):
    """Bits of EI's condition mask m [M Ch4 §Configuring Interrupts]; bits 0-3: X..W complete."""

    X_COMPLETE = 1 << 0
    Y_COMPLETE = 1 << 1
    Z_COMPLETE = 1 << 2
    W_COMPLETE = 1 << 3
    ALL_COMPLETE = 1 << 8
    EXCESS_ERROR = 1 << 9  # re-enable after each occurrence
    LIMIT_SWITCH = 1 << 10
    WATCHDOG = 1 << 11
    PROGRAM_STOPPED = 1 << 13
    COMMAND_DONE = 1 << 14
    INPUTS = 1 << 15  # re-enable after each occurrence


class InterruptStatus(enum.IntEnum):
    """Interrupt status codes read after writing 6 to N+3 [M Ch4 §Servicing Interrupts]."""

    NONE = 0x00  # the queue is empty
    LIMIT_SWITCH = 0xC0
    EXCESS_ERROR = 0xC8
    AXIS_COMPLETE = 0xD0  # + axis (X D0 ... W D3)
    ALL_COMPLETE = 0xD8
    WATCHDOG = 0xD9
    COMMAND_DONE = 0xDA
    PROGRAM_STOPPED = 0xDB
    INPUT = 0xE0  # + input 1..8
    USER = 0xF0  # + n (UI n)


# -- the data record, revision 4 [M Ch4 §DMA / Secondary FIFO Memory Map; DMCLIB dmcdrc.h] ---------
GENERAL_SIZE = 24
COORDINATED_SIZE = 16
AXIS_SIZE = 28
FIRST_AXIS = GENERAL_SIZE + COORDINATED_SIZE
MAX_AXES = 8  # the layout's axis blocks; the DMC-13X8 fills 1 to 4


class REV4DMCDataRecordGeneralOffsets(enum.IntEnum):
    """Revision 4: general items and where each axis block starts (dmcdrc.h names)."""

    DRREV4GenOffSampleNumber = 0
    DRREV4GenOffGeneralInput0 = 2
    DRREV4GenOffGeneralInput1 = 3
    DRREV4GenOffGeneralInput2 = 4
    DRREV4GenOffGeneralInput3 = 5
    DRREV4GenOffGeneralInput4 = 6
    DRREV4GenOffGeneralInput5 = 7
    DRREV4GenOffGeneralInput6 = 8
    DRREV4GenOffGeneralInput7 = 9
    DRREV4GenOffGeneralInput8 = 10
    DRREV4GenOffGeneralInput9 = 11
    DRREV4GenOffGeneralOutput0 = 12
    DRREV4GenOffGeneralOutput1 = 13
    DRREV4GenOffGeneralOutput2 = 14
    DRREV4GenOffGeneralOutput3 = 15
    DRREV4GenOffGeneralOutput4 = 16
    DRREV4GenOffGeneralOutput5 = 17
    DRREV4GenOffGeneralOutput6 = 18
    DRREV4GenOffGeneralOutput7 = 19
    DRREV4GenOffGeneralOutput8 = 20
    DRREV4GenOffGeneralOutput9 = 21
    DRREV4GenOffErrorCode = 22
    DRREV4GenOffGeneralStatus = 23
    DRREV4GenOffSegmentCountS = 24
    DRREV4GenOffCoordinatedMoveStatusS = 26
    DRREV4GenOffCoordinatedMoveDistanceS = 28
    DRREV4GenOffSegmentCountT = 32
    DRREV4GenOffCoordinatedMoveStatusT = 34
    DRREV4GenOffCoordinatedMoveDistanceT = 36
    DRREV4GenOffAxis1 = 40
    DRREV4GenOffAxis2 = 68
    DRREV4GenOffAxis3 = 96
    DRREV4GenOffAxis4 = 124
    DRREV4GenOffAxis5 = 152
    DRREV4GenOffAxis6 = 180
    DRREV4GenOffAxis7 = 208
    DRREV4GenOffAxis8 = 236
    DRREV4GenOffEnd = 264


class REV4DMCDataRecordAxisOffsets(enum.IntEnum):
    """Revision 4: items within an axis block (dmcdrc.h names)."""

    DRREV4AxisOffNoAxis = 0
    DRREV4AxisOffAxisStatus = 0
    DRREV4AxisOffAxisSwitches = 2
    DRREV4AxisOffAxisStopCode = 3
    DRREV4AxisOffAxisReferencePosition = 4
    DRREV4AxisOffAxisMotorPosition = 8
    DRREV4AxisOffAxisPositionError = 12
    DRREV4AxisOffAxisAuxillaryPosition = 16
    DRREV4AxisOffAxisVelocity = 20
    DRREV4AxisOffAxisTorque = 24
    DRREV4AxisOffAnalogInput = 26
    DRREV4AxisOffEnd = 28


_G, _A = REV4DMCDataRecordGeneralOffsets, REV4DMCDataRecordAxisOffsets

#: (name, offset, struct format without byte order) of the general and coordinated items
GENERAL_ITEMS: tuple[tuple[str, int, str], ...] = (
    ("sample_number", _G.DRREV4GenOffSampleNumber, "H"),
    *((f"input_bank_{i}", _G.DRREV4GenOffGeneralInput0 + i, "B") for i in range(10)),
    *((f"output_bank_{i}", _G.DRREV4GenOffGeneralOutput0 + i, "B") for i in range(10)),
    ("error_code", _G.DRREV4GenOffErrorCode, "B"),
    ("general_status", _G.DRREV4GenOffGeneralStatus, "B"),
    ("s_plane_segment_count", _G.DRREV4GenOffSegmentCountS, "H"),
    ("s_plane_move_status", _G.DRREV4GenOffCoordinatedMoveStatusS, "H"),
    ("s_distance", _G.DRREV4GenOffCoordinatedMoveDistanceS, "i"),
    ("t_plane_segment_count", _G.DRREV4GenOffSegmentCountT, "H"),
    ("t_plane_move_status", _G.DRREV4GenOffCoordinatedMoveStatusT, "H"),
    ("t_distance", _G.DRREV4GenOffCoordinatedMoveDistanceT, "i"),
)
#: (name, offset in the axis block, struct format without byte order) of each axis's items
AXIS_ITEMS: tuple[tuple[str, int, str], ...] = (
    ("status", _A.DRREV4AxisOffAxisStatus, "H"),
    ("switches", _A.DRREV4AxisOffAxisSwitches, "B"),
    ("stop_code", _A.DRREV4AxisOffAxisStopCode, "B"),
    ("reference_position", _A.DRREV4AxisOffAxisReferencePosition, "i"),
    ("motor_position", _A.DRREV4AxisOffAxisMotorPosition, "i"),
    ("position_error", _A.DRREV4AxisOffAxisPositionError, "i"),
    ("aux_position", _A.DRREV4AxisOffAxisAuxillaryPosition, "i"),
    ("velocity", _A.DRREV4AxisOffAxisVelocity, "i"),  # 64 times TV
    ("torque", _A.DRREV4AxisOffAxisTorque, "h"),  # +-32767 at +-10 V
    ("analog_in", _A.DRREV4AxisOffAnalogInput, "h"),  # analog input n rides in axis n's block
)


class GeneralStatus(enum.IntFlag):
    """Bits of the general status byte [M Ch4 §General Status Information]."""

    ECHO_ON = 1 << 0
    TRACE_ON = 1 << 1
    WAITING_FOR_IN = 1 << 2
    PROGRAM_RUNNING = 1 << 7


class AxisStatus(enum.IntFlag):
    """The axis status word of the data record [M Ch4 §Axis Status Information]."""

    MOTOR_OFF = 1 << 0
    OFF_ON_ERROR = 1 << 1
    LATCH_ARMED = 1 << 2
    FINAL_DECEL = 1 << 3
    STOPPING = 1 << 4
    SLEWING = 1 << 5
    CONTOUR = 1 << 6
    NEGATIVE = 1 << 7
    COORDINATED = 1 << 8
    HM_PHASE2_OR_FI = 1 << 9
    HM_PHASE1 = 1 << 10
    HOMING = 1 << 11
    FIND_EDGE = 1 << 12
    PA_ONLY = 1 << 13
    PA_OR_PR = 1 << 14
    MOVING = 1 << 15


class AxisSwitch(enum.IntFlag):
    """The axis switch byte of the data record [M Ch4 §Axis Switch Information]."""

    SM_JUMPER = 1 << 0
    HOME = 1 << 1
    REVERSE_LIMIT = 1 << 2
    FORWARD_LIMIT = 1 << 3
    LATCH_INPUT = 1 << 6
    LATCH_OCCURRED = 1 << 7
