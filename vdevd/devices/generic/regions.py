"""Bus map of the generic servo card: one 4 KiB register BAR, little-endian, 32-bit (README.md).

Global registers at 0x000, then one 64-byte block per axis at AXIS_BASE + AXIS_STRIDE * axis.
"""

from __future__ import annotations

import enum

import numpy as np

BAR_SIZE = 0x1000
CARD_ID = 0x56444556  # "VDEV"
FIRMWARE_VERSION = 0x00010000

# global registers
ID = 0x000  # RO
VERSION = 0x004  # RO
AXES = 0x008  # RO: number of axes
PERIOD_NS = 0x00C  # RO: servo period
TICK_LO = 0x010  # RO: servo ticks since start, low word
TICK_HI = 0x014  # RO: high word
IRQ_STATUS = 0x020  # W1C: bit n = axis n done, bit 16+n = axis n stopped by a fault or limit
IRQ_ENABLE = 0x024  # RW: same bits; the line is asserted while STATUS & ENABLE != 0
INPUTS = 0x028  # RO: general inputs (backdoor `set_inputs`)
OUTPUTS = 0x02C  # RW: general outputs
CARD_STATUS = 0x030  # RO: CardStatus bits

AXIS_BASE = 0x100
AXIS_STRIDE = 0x40
MAX_AXES = 16


class CardStatus(enum.IntFlag):
    """Bits of CARD_STATUS."""

    ABORT_INPUT = 1 << 0  # the abort input is active (backdoor `set_abort`)


class AxisReg(enum.IntEnum):
    """Offsets inside an axis block."""

    COMMAND = 0x00  # W: a Command code; executes on write; reads back the last command
    TARGET = 0x04  # RW i32: position (MOVE_ABS), distance (MOVE_REL), velocity (JOG), direction (HOME)
    VMAX = 0x08  # RW u32 counts/s
    ACC = 0x0C  # RW u32 counts/s^2
    DEC = 0x10  # RW u32 counts/s^2
    JERK = 0x14  # RW u32 counts/s^3 (0 = trapezoid)
    STATUS = 0x18  # RO: vdevd.rt AxisFlag bits
    POSITION = 0x1C  # RO i32: encoder counts
    COMMANDED = 0x20  # RO i32: commanded position
    FERR = 0x24  # RO i32: following error
    VELOCITY = 0x28  # RO i32: actual velocity, counts/s
    OUTPUT = 0x2C  # RO i32: controller output (DAC counts)
    ERROR = 0x30  # RO: CommandError of the last command


class Command(enum.IntEnum):
    NONE = 0
    MOVE_ABS = 1
    MOVE_REL = 2
    JOG = 3
    STOP = 4
    ABORT = 5
    SERVO_ON = 6
    SERVO_OFF = 7
    SET_POSITION = 8
    HOME = 9


class CommandError(enum.IntEnum):
    OK = 0
    UNKNOWN_COMMAND = 1
    BAD_PARAMETER = 2  # zero or out-of-range speed, acceleration
    SERVO_OFF = 3  # motion commanded while the servo is off
    FAULT = 4  # motion commanded with an amplifier fault or encoder loss
    ABORT_INPUT = 5  # motion commanded while the card's abort input is active


#: the read-only status fields of an axis block, refreshed every tick in one vectorised store
STATUS_DTYPE = np.dtype(
    [
        ("status", "<u4"),
        ("position", "<i4"),
        ("commanded", "<i4"),
        ("ferr", "<i4"),
        ("velocity", "<i4"),
        ("output", "<i4"),
    ]
)
AXIS_DTYPE = np.dtype(
    {
        "names": ["command", "target", "vmax", "acc", "dec", "jerk", "live", "error"],
        "formats": ["<u4", "<i4", "<u4", "<u4", "<u4", "<u4", STATUS_DTYPE, "<u4"],
        "offsets": [0x00, 0x04, 0x08, 0x0C, 0x10, 0x14, 0x18, 0x30],
        "itemsize": AXIS_STRIDE,
    }
)
