"""Motion cycles that are the motion core's tick alone, run as a loop of core ticks
(docs/card-pattern.md "Moving ticks in runs", decision 0008; card.py `AdlinkCard.run`).

A cycle (`Kernel.cycle`) does nothing beside the core's tick while: every axis is idle or in a
PTP, velocity move or stop on the core's phase table (no home, jog or unit, no MDN delay or
MDM_CONDI wait), no unit has work (`motion_only`), no segment end or pre/post-distance event
falls due, no protection can trip (EMG, ALM, a hard or soft limit on a moving axis, a
position-error level), the DI word and the system factors have no edge to take, and no enabled
interrupt factor follows a condition that changes mid-move (VM, ACC, DEC, INP). The run stops
right after a tick whose core events report a profile end, and that cycle's kernel work then
runs as `cycle` would (`Runs.finish`): the signals, completions, units and interrupts at the
same tick.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.adlink.modes import IDLE, PTP, STOPPING, VEL

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

_EPS = 1e-12  # the tolerance `Kernel.segment_ends` and `Kernel.events` take times with
#: the factors whose condition may rise in a cycle that is the core's tick alone [M §4.11]
_MID_MOVE = (1 << 9) | (1 << 10) | (1 << 11) | (1 << 5)  # IVM, IACC, IDEC, IINP
#: the axis parameters a run reads: soft limits on (+, -), the position-error level
_SPEL_EN, _SMEL_EN, _ERR_LEVEL = 0x08, 0x09, 0x124


class Runs:
    """Runs of one kernel: how many of the next cycles may be core ticks alone (`room`), the
    loop (`ticks`) and the end of its last cycle (`finish`)."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.before = np.zeros_like(k.core.axes.state)  # the core's state before the last tick
        self.moving = np.zeros(k.n, dtype=bool)  # the moving axes through the run

    def room(self, room: int) -> int:
        """Of the next `room` cycles, how many may run as core ticks alone (0: the next
        cycle is a whole `cycle`)."""
        k = self.k
        if k.emg or k.sys_events or k.prev_sys or np.count_nonzero(k.owned):
            return 0
        mode, moving = k.mode, k.core.profile.moving
        # a non-idle axis is moving on the phase table (else completions wait on it)
        if np.count_nonzero(((mode != IDLE) & ~moving)
                            | ((mode != IDLE) & (mode != PTP) & (mode != VEL)
                               & (mode != STOPPING))):
            return 0
        if np.count_nonzero(k.unit_moving) or np.count_nonzero(k.p(_ERR_LEVEL)):
            return 0
        watched = k.alm | k.pel | k.mel | k.spel | k.smel | (k.p(_SPEL_EN) != 0) \
            | (k.p(_SMEL_EN) != 0)
        if np.count_nonzero(watched & moving):
            return 0
        if k.int_main and np.count_nonzero(k.int_enable[:k.n] & _MID_MOVE):
            return 0
        if k.di_word() != k.prev_di:
            return 0
        for u in k.units:
            quiet = getattr(u, "motion_only", None)
            if not (quiet() if quiet is not None else not u.busy()):
                return 0
        t = k.core.profile.t
        due = min(_first(k.seg_end, None), _first(k.pred_at, k.pred), _first(k.postd_at, k.postd))
        if due != math.inf:  # the cycle whose tick reaches `due` runs whole (one spare)
            room = min(room, math.ceil((due - _EPS - t) / k.dt) - 2)
        return max(room, 0)

    def ticks(self, room: int) -> int:
        """Up to `room` (from `room()`) core ticks; stops right after one with events. The
        count run; the state before the last tick is kept for `finish`."""
        core = self.k.core
        tick, state, before = core.tick, core.axes.state, self.before
        np.copyto(self.moving, self.k.moving())
        for i in range(1, room + 1):
            np.copyto(before, state)
            if tick():
                return i
        return room

    def finish(self, ran: int) -> None:
        """The kernel's work of the run's `ran` cycles after the ticks, as `Kernel.cycle` does
        it for the last: DIR as the cycle before left it, the signals before the tick, then
        the completions, the units' after-motion work and the status and interrupts."""
        k = self.k
        k.cycles += ran
        k.follow_direction(self.moving, self.before)
        k.logic(self.before, self.moving)
        k.completions()
        t = k.core.profile.t
        for u in k.units:
            u.after_motion(t)
        k.events()


def _first(times: np.ndarray, done: np.ndarray | None) -> float:
    """The earliest of `times` (of the axes whose event is not `done` yet)."""
    return float(times.min() if done is None else np.where(done, math.inf, times).min())
