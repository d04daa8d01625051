"""Axis state of the motion core (DESIGN.md "Axes and the motion core").

Structure of arrays, one row per axis, in the card's native units: counts, counts/s,
counts/s^2. A card owns one `Axes` through its `MotionCore`.
"""

from __future__ import annotations

import enum

import numpy as np


class AxisFlag(enum.IntFlag):
    """Per-axis status bits in `Axes.flags`; "motion command" = move, jog, home (the commands
    that start a profile). Bits marked (event) are also returned by `MotionCore.tick` when they
    happen.

    MOVING            set when a profile (move, jog, stop, abort with dec) is planned; cleared
                      when it ends (or at once by abort without dec, servo off, set_position).
    IN_POSITION       no profile running and |ferr| <= limits.in_position; refreshed at the end
                      of every `run` and by `update_in_position` (a status, not per tick).
    SERVO_ON          set by servo_on (refused while AMP_FAULT), cleared by servo_off/amp fault.
    FE_TRIP           (event) |ferr| > fe_limit; latched until the next servo_on.
    HARD_LIMIT_POS/NEG  (event on the rising edge if it stops an axis) follow the switch inputs.
    SOFT_LIMIT_POS/NEG  (event) a soft limit stopped or refused a motion; cleared by the next
                      motion command.
    AMP_FAULT         (event on the rising edge) follows the input; its rising edge aborts and
                      turns the servo off.
    ENCODER_LOSS      follows the input; the encoder is frozen while set.
    STOPPED_BY_LIMIT  (event) a hard or soft limit stopped or refused the last motion; cleared
                      by the next motion command.
    ABORTED           (event with DONE) abort or a fault ended the profile; cleared by the next
                      motion command.
    DONE              (event) latched when a move/jog/home/stop/abort profile finishes (also at once
                      for a zero-length or refused command); cleared by the next motion command.
    HOME_SWITCH       follows the home switch input; its rising edge ends a home search.
    HOMED             a home search found the switch and made that place position 0; cleared
                      when the next home search starts.
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
    HOME_SWITCH = 1 << 13
    HOMED = 1 << 14


def wrap_int32(values: np.ndarray) -> np.ndarray:
    """Counts as a card's signed 32-bit counters and register fields hold them: rounded to
    whole counts, wrapping beyond 2^31 (a non-finite value reads 0)."""
    v = np.rint(np.asarray(values, dtype=np.float64))
    v = np.where(np.isfinite(v), v, 0.0)
    return (v.astype(np.int64) + 2**31) % 2**32 - 2**31


#: bits that a motion command clears
MOTION_STICKY = (
    AxisFlag.DONE | AxisFlag.ABORTED | AxisFlag.STOPPED_BY_LIMIT
    | AxisFlag.SOFT_LIMIT_POS | AxisFlag.SOFT_LIMIT_NEG
)


class ProfileMode(enum.IntEnum):
    """What an axis's profile generator runs (`ProfileGenerator.mode`); IDLE once it ended."""

    IDLE = 0
    TRAPEZOID = 1
    SCURVE = 2
    JOG = 3
    STOPPING = 4
    ABORTING = 5
    HOMING = 6


class PlantKind(enum.IntEnum):
    """What the axis drives: an ideal follower, a servo motor with amplifier, a stepper."""

    IDEAL = 0
    SERVO = 1
    STEPPER = 2


class Axes:
    """The state of n axes: float64 rows of one block (`state`), plus int64 encoder and flags.

    The named arrays are views of those rows: write into them (`ax.pos[i] = ...`, `[:] =`),
    never rebind them. The rows are laid out so that the tick needs few numpy calls:
    (cmd_pos, cmd_vel, cmd_acc) are adjacent (one matrix step advances all three), so are
    (pos, vel) (one copy makes ideal axes follow), and rows CMD_VEL..FERR are the terms of the
    PID's dot product (`pid_terms`, used by `Pid`): cmd_vel, cmd_acc, a row of ones (the offset),
    the integrator, the previous error and the error (ferr). `fb` is the loop's feedback: the
    encoder in position counts (encoder / scale), as floats.
    """

    CMD_POS, CMD_VEL, CMD_ACC, ONE, INTEG, E_PREV, FERR, POS, VEL, OUT, FB = range(11)
    FIELDS = ("cmd_pos", "cmd_vel", "cmd_acc", "pos", "vel", "ferr", "out")

    def __init__(self, n: int) -> None:
        self.n = n
        self.state = np.zeros((11, n))
        s = self.state
        s[self.ONE] = 1.0
        self.cmd_pos, self.cmd_vel, self.cmd_acc = s[self.CMD_POS], s[self.CMD_VEL], s[self.CMD_ACC]
        self.pos, self.vel, self.ferr, self.out = s[self.POS], s[self.VEL], s[self.FERR], s[self.OUT]
        #: the feedback of the loop in position counts: the encoder as floats (/ its scale)
        self.fb = s[self.FB]
        self.cmd_pv = s[self.CMD_POS:self.CMD_VEL + 1]  # (cmd_pos, cmd_vel)
        self.cmd_pva = s[self.CMD_POS:self.CMD_ACC + 1]  # (cmd_pos, cmd_vel, cmd_acc)
        self.pv = s[self.POS:self.VEL + 1]  # (pos, vel)
        self.pid_terms = s[self.CMD_VEL:self.FERR + 1]
        self.encoder = np.zeros(n, dtype=np.int64)
        self.flags = np.zeros(n, dtype=np.int64)

    def snapshot(self) -> dict[str, list[float] | list[int]]:
        """Plain lists of every field, for debugging and statistics."""
        snap: dict[str, list[float] | list[int]] = {f: getattr(self, f).tolist() for f in self.FIELDS}
        snap["encoder"] = self.encoder.tolist()
        snap["flags"] = self.flags.tolist()
        return snap
