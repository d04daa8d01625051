"""Axis state of the motion core (DESIGN.md "Axes and the motion core").

Structure of arrays, one row per axis, in the card's native units: counts, counts/s,
counts/s^2. A card owns one `Axes` through its `MotionCore`.
"""

from __future__ import annotations

import enum

import numpy as np


class AxisFlag(enum.IntFlag):
    """Per-axis status bits in `Axes.flags`.

    MOVING         set while a profile (move, jog, stop) runs; cleared when it ends.
    IN_POSITION    set when no profile runs and |ferr| <= the in-position band.
    SERVO_ON       the loop is closed (servo_on/servo_off).
    FE_TRIP        |ferr| exceeded fe_limit; latched until the next servo_on.
    HARD_LIMIT_*   the limit switch input is active (follows the input).
    SOFT_LIMIT_*   the commanded position reached a soft limit; cleared by the next motion
                   command.
    AMP_FAULT, ENCODER_LOSS   follow their inputs.
    STOPPED_BY_LIMIT  a hard or soft limit stopped the last profile; cleared by the next
                   motion command.
    ABORTED        the last profile was aborted (abort, fault); cleared by the next motion
                   command.
    DONE           the last profile finished (normally or stopped); cleared by the next
                   motion command.
    """

    MOVING = 1 << 0
    IN_POSITION = 1 << 1
    SERVO_ON = 1 << 2
    FE_TRIP = 1 << 3
    HARD_LIMIT_POS = 1 << 4
    HARD_LIMIT_NEG = 1 << 5
    SOFT_LIMIT_POS = 1 << 6
    SOFT_LIMIT_NEG = 1 << 7
    AMP_FAULT = 1 << 8
    ENCODER_LOSS = 1 << 9
    STOPPED_BY_LIMIT = 1 << 10
    ABORTED = 1 << 11
    DONE = 1 << 12


#: bits that a motion command clears
MOTION_STICKY = (
    AxisFlag.DONE | AxisFlag.ABORTED | AxisFlag.STOPPED_BY_LIMIT
    | AxisFlag.SOFT_LIMIT_POS | AxisFlag.SOFT_LIMIT_NEG
)


class PlantKind(enum.IntEnum):
    """What the axis drives: an ideal follower, a servo motor with amplifier, a stepper."""

    IDEAL = 0
    SERVO = 1
    STEPPER = 2


class Axes:
    """The state of n axes; float64 arrays unless noted."""

    FIELDS = ("cmd_pos", "cmd_vel", "cmd_acc", "pos", "vel", "ferr", "out")

    def __init__(self, n: int, cmd_vel: np.ndarray | None = None,
                 cmd_acc: np.ndarray | None = None) -> None:
        self.n = n
        self.cmd_pos = np.zeros(n)
        #: may be views owned by the controller (Pid.terms), so the profile writes in place
        self.cmd_vel = np.zeros(n) if cmd_vel is None else cmd_vel
        self.cmd_acc = np.zeros(n) if cmd_acc is None else cmd_acc
        self.pos = np.zeros(n)
        self.vel = np.zeros(n)
        self.encoder = np.zeros(n, dtype=np.int64)
        self.ferr = np.zeros(n)
        self.out = np.zeros(n)
        self.flags = np.zeros(n, dtype=np.int64)

    def snapshot(self) -> dict[str, list[float] | list[int]]:
        snap: dict[str, list[float] | list[int]] = {f: getattr(self, f).tolist() for f in self.FIELDS}
        snap["encoder"] = self.encoder.tolist()
        snap["flags"] = self.flags.tolist()
        return snap
