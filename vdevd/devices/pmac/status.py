"""The motor status words of a Turbo PMAC (`#n?`): bit names and their vectorised assembly.

Word 1 is X:$0000B0 and word 2 Y:$0000C0 for motor 1 (+$80 per motor); `#n?` prints word 1 then
word 2 as 12 hex digits [spec pmac.md §2.6, SRM p.281-284]. Bit names follow the SRM's headings.
Bits 0 and 1 of word 1 follow the V1.940 layout of the digest (maximum rapid speed, alternate
command-output mode); newer SRMs list bit 1 as "integrator in velocity loop".
"""

from __future__ import annotations

import enum
from collections.abc import Iterable

import numpy as np


class MotorStatus1(enum.IntFlag):
    """Motor status word 1 (X:$0000B0) [SRM p.281-282, digest §2.6]."""

    MAX_RAPID_SPEED = 1 << 0  # RAPID moves at Ixx16 (Ixx90 = 1)
    ALT_COMMAND_OUTPUT_MODE = 1 << 1  # Ixx96 bit 0
    SOFTWARE_POSITION_CAPTURE = 1 << 2  # Ixx97 bit 0
    ERROR_TRIGGER = 1 << 3  # Ixx97 bit 1
    FOLLOWING_ENABLED = 1 << 4  # Ixx06 bit 0
    FOLLOWING_OFFSET_MODE = 1 << 5  # Ixx06 bit 1
    PHASED_MOTOR = 1 << 6  # Ixx01 bit 0
    ALT_SOURCE_DESTINATION = 1 << 7
    USER_SERVO_ENABLED = 1 << 8
    USER_PHASE_ENABLED = 1 << 9
    HOME_SEARCH_IN_PROGRESS = 1 << 10
    BLOCK_REQUEST = 1 << 11
    ABORT_DECELERATION = 1 << 12  # decelerating after an abort or a position limit
    DESIRED_VELOCITY_ZERO = 1 << 13  # closed loop and holding position
    DATA_BLOCK_ERROR = 1 << 14
    DWELL_IN_PROGRESS = 1 << 15
    INTEGRATION_MODE = 1 << 16  # Ixx34 = 1
    MOVE_TIMER_ACTIVE = 1 << 17  # jog-to-position, post-trigger part of a home search
    OPEN_LOOP = 1 << 18
    AMP_ENABLED = 1 << 19
    EXTENDED_SERVO_ALGORITHM = 1 << 20
    POS_END_LIMIT = 1 << 21  # +limit input, or actual position beyond Ixx13
    NEG_END_LIMIT = 1 << 22  # -limit input, or actual position beyond Ixx14
    MOTOR_ACTIVATED = 1 << 23  # Ixx00 = 1


class MotorStatus2(enum.IntFlag):
    """Motor status word 2 (Y:$0000C0) [SRM p.283-284, digest §2.6]; bits 16-19 hold the axis
    definition code and 20-23 the coordinate system number - 1 (`CS_SHIFT`, `AXIS_SHIFT`)."""

    IN_POSITION = 1 << 0
    WARNING_FOLLOWING_ERROR = 1 << 1
    FATAL_FOLLOWING_ERROR = 1 << 2
    AMP_FAULT_ERROR = 1 << 3
    BACKLASH_DIRECTION = 1 << 4
    I2T_AMP_FAULT = 1 << 5
    INTEGRATED_FATAL_FOLLOWING_ERROR = 1 << 6
    TRIGGER_MOVE = 1 << 7
    PHASING_REFERENCE_ERROR = 1 << 8
    PHASING_SEARCH_ACTIVE = 1 << 9
    HOME_COMPLETE = 1 << 10
    STOPPED_ON_POSITION_LIMIT = 1 << 11
    STOPPED_ON_DESIRED_POSITION_LIMIT = 1 << 12
    FOREGROUND_IN_POSITION = 1 << 13  # I13 = 1 [A L3254]
    ASSIGNED_TO_CS = 1 << 15


AXIS_SHIFT = 16  # word 2 bits 16-19: axis definition code
CS_SHIFT = 20  # word 2 bits 20-23: coordinate system number - 1


def pack(n: int, bits: Iterable[tuple[int, np.ndarray | bool]]) -> np.ndarray:
    """One int64 status word per motor from (bit, per-motor condition) pairs."""
    word = np.zeros(n, dtype=np.int64)
    for bit, on in bits:
        word |= np.asarray(on, dtype=np.int64) * int(bit)
    return word


def cs_fields(cs: np.ndarray, axis_code: np.ndarray) -> np.ndarray:
    """Word 2 bits 15-23 from each motor's coordinate system (1-16, 0 = none) and axis
    definition code (0-15)."""
    assigned = cs > 0
    fields = (((cs - 1) & 0xF) << CS_SHIFT) | ((axis_code & 0xF) << AXIS_SHIFT)
    return np.where(assigned, fields | int(MotorStatus2.ASSIGNED_TO_CS), 0).astype(np.int64)


def word1(n: int, *, iv: dict[int, np.ndarray], closed: np.ndarray, amp_enabled: np.ndarray,
          moving: np.ndarray, searching: np.ndarray, abort_decel: np.ndarray, timed: np.ndarray,
          limits: np.ndarray) -> np.ndarray:
    """Word 1 of n activated motors [SRM p.281-282]: `iv` maps yy to Ixx yy per motor (01, 06,
    34, 90, 96, 97); `limits` holds bits 21/22 (frozen by the caller while killed); the others
    are the motors' states. Desired velocity zero = closed loop and no profile running."""
    i96, i97, i06 = (iv[yy].astype(np.int64) for yy in (96, 97, 6))
    return pack(n, (
        (MotorStatus1.MAX_RAPID_SPEED, iv[90] == 1),
        (MotorStatus1.ALT_COMMAND_OUTPUT_MODE, (i96 & 1) != 0),
        (MotorStatus1.SOFTWARE_POSITION_CAPTURE, (i97 & 1) != 0),
        (MotorStatus1.ERROR_TRIGGER, (i97 & 2) != 0),
        (MotorStatus1.FOLLOWING_ENABLED, (i06 & 1) != 0),
        (MotorStatus1.FOLLOWING_OFFSET_MODE, (i06 & 2) != 0),
        (MotorStatus1.PHASED_MOTOR, (iv[1].astype(np.int64) & 1) != 0),
        (MotorStatus1.HOME_SEARCH_IN_PROGRESS, searching),
        (MotorStatus1.ABORT_DECELERATION, abort_decel & moving),
        (MotorStatus1.DESIRED_VELOCITY_ZERO, closed & ~moving),
        (MotorStatus1.INTEGRATION_MODE, iv[34] == 1),
        (MotorStatus1.MOVE_TIMER_ACTIVE, timed & moving),
        (MotorStatus1.OPEN_LOOP, ~closed),
        (MotorStatus1.AMP_ENABLED, amp_enabled),
        (MotorStatus1.MOTOR_ACTIVATED, True),
    )) | limits


def word2(n: int, *, in_position: np.ndarray, warning: np.ndarray, fatal: np.ndarray,
          amp_fault: np.ndarray, home_complete: np.ndarray, stopped_on_limit: np.ndarray,
          foreground: bool, cs: np.ndarray, axis_code: np.ndarray,
          trigger_move: np.ndarray | bool = False) -> np.ndarray:
    """Word 2 of n motors [SRM p.283-284]; `foreground` is I13 = 1 (bit 13 mirrors the
    in-position bit then)."""
    return pack(n, (
        (MotorStatus2.IN_POSITION, in_position),
        (MotorStatus2.WARNING_FOLLOWING_ERROR, warning),
        (MotorStatus2.FATAL_FOLLOWING_ERROR, fatal),
        (MotorStatus2.AMP_FAULT_ERROR, amp_fault),
        (MotorStatus2.TRIGGER_MOVE, trigger_move),
        (MotorStatus2.HOME_COMPLETE, home_complete),
        (MotorStatus2.STOPPED_ON_POSITION_LIMIT, stopped_on_limit),
        (MotorStatus2.FOREGROUND_IN_POSITION, in_position & foreground),
    )) | cs_fields(cs, axis_code)
