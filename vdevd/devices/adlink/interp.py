"""The interpolation unit of the AMP-204C/208C kernel [M §4.7, §4.8.1, §4.9.5; spec adlink.md
§2.10-2.14, §2.20]: the groups of axes that lines, arcs and helices drive, each a `group.Group`
(its motion buffer and the seven transitions of §4.7.3) sampled once a motion cycle onto the
motion core.

One group per axis array (the first element the reference axis, whose Vs, Vm, Ve, Acc, Dec, SF
make the vector profile [M §4.7]); an axis is in at most one active group. Paths and plans are
in user units (each axis's own unit factor turns them into pulses), so a group may mix axes of
different factors. All members share CSTP/MDN/ACC/VM/DEC/BLD/PRED/POSTD; DIR is each axis's own
(spec §2.10 ASSUMPTION). A stop of any member (APS_stop_move, APS_emg_stop, a limit, an alarm)
stops the whole group along its path with the same stop code on every member (spec Q13).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import (
    STOP_USER,
    STOP_USER_EMG,
    ERR_CommandInProcess,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink import motion, profile
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.group import Group, Plan, PlanFactory, Transition
from vdevd.devices.adlink.modes import IDLE, STOPPING, UNIT
from vdevd.devices.adlink.path import Path

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

log = logging.getLogger(__name__)

QUEUE = motion.QUEUE  # the group's buffer is the reference axis's 10 commands (spec §2.13)
_QUEUED = (Transition.BUFFERED, Transition.BLEND_DEC_EVENT, Transition.BLEND_RES_DIST,
           Transition.BLEND_RES_DIST_PERCENT)
_HALT_NONE, _HALT_DEC, _HALT_NOW = 0, 1, 2


@dataclass(frozen=True, slots=True)
class Vector:
    """A command's vector profile (user units of the reference axis) [M §4.7]."""

    vs: float
    vm: float
    ve: float
    acc: float
    dec: float
    sf: float

    def factory(self) -> PlanFactory:
        """Plans along a path: from the command's Vs, or on from a present speed (abort-force)."""

        def make(distance: float, v0: float | None) -> Plan:
            if v0 is None or v0 <= 0:
                return profile.plan_ptp(distance, self.vs, self.vm, self.ve, self.acc, self.dec,
                                        self.sf)
            return profile.plan_from(v0, distance, self.vm, self.ve, self.acc, self.dec, self.sf)

        return make


@dataclass(slots=True)
class Command:
    """One accepted interpolation command: its absolute path and profile."""

    path: Path
    vector: Vector
    transition: Transition
    para: float


@dataclass(slots=True)
class Entry:
    """A group of the unit: its axes, engine and state."""

    axes: tuple[int, ...]
    group: Group
    idx: np.ndarray
    moving: bool = False
    halt: int = _HALT_NONE
    pending: list[Command] = field(default_factory=list)  # waiting for APS_move_trigger
    counts: np.ndarray | None = None  # where the last cycle's track put the axes (pulses)
    travelled: float = 0.0
    dec: float = 0.0  # the running command's Dec and SF: the aborting transitions' stop
    sf: float = 0.0


class Interpolation:
    """The kernel unit of the interpolation groups (modes.Unit)."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.entries: dict[tuple[int, ...], Entry] = {}
        self.of_axis: dict[int, Entry] = {}  # the active (moving or waiting) group of an axis

    # -- commands ----------------------------------------------------------------------------------
    def entry_for(self, axes: tuple[int, ...], transition: Transition) -> Entry:
        """The group of `axes`, or -15 (a member busy) / -10 (a continuation of another group's
        motion: same dimension and axis IDs only [M §4.7.3], spec §2.13)."""
        k = self.k
        if len(set(axes)) != len(axes):
            raise ApsError(ERR_ParametersInvalid, "an axis twice in the array")
        for a in axes:
            k.check_axis(a)
        for a in axes:
            other = self.of_axis.get(a)
            if other is not None:
                if other.axes == axes:
                    continue
                code = ERR_ParametersInvalid if transition in _QUEUED else ERR_CommandInProcess
                raise ApsError(code, f"axis {a} is in the group {other.axes}")
            motion.check_free(k, a)
            if k.moving()[a] or k.wait[a] or k.ger[a]:
                raise ApsError(ERR_CommandInProcess, f"axis {a} is busy")
        entry = self.entries.get(axes)
        if entry is None:
            entry = Entry(axes, Group(axes, plan_stop=profile.plan_stop),
                          np.array(axes, dtype=np.intp))
            self.entries[axes] = entry
        return entry

    def start_point(self, e: Entry, transition: Transition) -> np.ndarray:
        """Where a new command's path starts (user units): the end of the buffered motion for a
        queued transition, else the command position now (aborting: E1' [M §4.7.3 method 3])."""
        if e.pending and transition in _QUEUED:
            return e.pending[-1].path.end.copy()
        if e.moving and transition in _QUEUED:
            target = e.group.target
            if target is not None:
                return np.asarray(target, dtype=float).copy()
        return self.k.user_cmd()[e.idx].copy()

    def submit(self, e: Entry, cmd: Command, wait: bool) -> None:
        """Run, queue or hold (OPT_WAIT) an accepted command; -15 on a full buffer."""
        queued = cmd.transition in _QUEUED
        if e.halt and queued:
            raise ApsError(ERR_CommandInProcess, "the group is stopping")
        if wait and e.moving and not queued:
            raise ApsError(ERR_CommandInProcess, "an aborting command cannot wait on a moving group")
        if e.pending or wait:  # a waiting group takes the command into what the trigger starts
            behind = (bool(e.pending) or e.moving) and queued
            if behind and len(e.pending) + e.group.queued + 1 >= QUEUE:
                raise ApsError(ERR_CommandInProcess, "the motion buffer is full")
            if not behind and self.refuse(e, cmd.path):
                return
            e.pending = [*e.pending, cmd] if behind else [cmd]
            self.hold_for_trigger(e)
            return
        if e.moving and cmd.transition in _QUEUED and e.group.queued + 1 >= QUEUE:
            raise ApsError(ERR_CommandInProcess, "the motion buffer is full")
        if not e.moving and self.refuse(e, cmd.path):
            return
        self.run(e, cmd)

    def run(self, e: Entry, cmd: Command) -> None:
        k, g = self.k, e.group
        g.sd_dec, g.sd_sf = (e.dec, e.sf) if e.moving else (cmd.vector.dec, cmd.vector.sf)
        rc = g.submit(cmd.path, cmd.vector.factory(), int(cmd.transition), cmd.para, k.t)
        if rc:
            raise ApsError(rc, "the group refused the command")
        e.dec, e.sf = cmd.vector.dec, cmd.vector.sf
        fresh = not e.moving or e.halt
        e.moving, e.halt = True, _HALT_NONE
        target = g.target
        for i, a in enumerate(e.axes):
            self.of_axis[a] = e
            k.owned[a] = True
            k.unit_moving[a] = True
            motion.begin(k, a, UNIT, float(target[i]) if target is not None else float(k.target[a]))
            k.pending_start[a] = IDLE
            k.seg_end[a] = math.inf
            if fresh:
                k.pred[a] = k.postd[a] = False
                k.pred_at[a] = k.postd_at[a] = math.inf
        if fresh:
            e.travelled = 0.0
        self.show(e, k.t)

    def refuse(self, e: Entry, path: Path) -> bool:
        """EMG, ALM or a limit in a member's direction of travel: the command is ignored, every
        member takes the stop code and ASTP (spec Q15, Q13)."""
        k = self.k
        tangent = path.tangent_at(0.0)
        for i, a in enumerate(e.axes):
            if motion.refused(k, a, float(tangent[i])):
                for b in e.axes:
                    k.stop_code[b], k.astp[b] = k.stop_code[a], True
                    k.mdn[b] = not k.moving()[b]
                return True
        return False

    def hold_for_trigger(self, e: Entry) -> None:
        """OPT_WAIT [M §4.9.5.1]: WAIT on every member, MDN 0, nothing moves until
        APS_move_trigger names any of them (one idempotent start for all)."""
        k = self.k
        start = self.starter(e)
        for a in e.axes:
            self.of_axis[a] = e
            k.owned[a] = True
            k.wait[a], k.mdn[a], k.astp[a] = True, False, False
            k.pending_start[a] = UNIT
            k.unit_starts[a] = start
            k.mq_usage[a] = len(e.pending)

    def starter(self, e: Entry) -> Callable[[], None]:
        def start() -> None:
            if not e.pending:
                return  # started by another member of the same trigger
            commands, e.pending = e.pending, []
            k = self.k
            for a in e.axes:
                k.unit_starts.pop(a, None)
                k.wait[a] = False
                k.pending_start[a] = IDLE
            if not e.moving and self.refuse(e, commands[0].path):
                self.release(e)
                return
            for cmd in commands:
                try:
                    self.run(e, cmd)
                except ApsError as exc:
                    log.debug("adlink: a triggered interpolation command refused: %s", exc)

        return start

    # -- the cycle -----------------------------------------------------------------------------------
    def before_motion(self, t: float) -> None:
        """Every moving group's command positions at the coming tick (time t)."""
        k = self.k
        for e in self.moving():
            pos = e.group.positions(t)
            if pos is None:
                continue
            counts = (pos - k.cmd_off[e.idx]) * k.axis_params.row(motion.UNIT_FACTOR)[e.idx]
            k.core.track(e.idx, counts)
            e.counts = counts

    def after_motion(self, t: float) -> None:
        """Groups whose motion ended finish; the others show their phase, BLD and events."""
        for e in self.moving():
            if e.group.flags(t).moving:
                self.show(e, t)
            else:
                self.finish(e)

    def moving(self) -> list[Entry]:
        return [e for e in self.entries.values() if e.moving]

    def show(self, e: Entry, t: float) -> None:
        """The shared status of the members [M §4.8.1]: ACC/VM/DEC of the newest segment, BLD
        while segments overlap, PRED/POSTD on the path of the newest segment (spec §2.14), the
        buffer usage."""
        k = self.k
        fl = e.group.flags(t)
        phase = 1 if fl.accelerating else 2 if fl.constant else 3 if fl.decelerating else 0
        idx = e.idx
        k.phase[idx] = phase
        k.bld[idx] = fl.blending
        k.mq_usage[idx] = e.group.queued + 1 + len(e.pending)
        travelled = e.group.travelled(t)
        if travelled < e.travelled - 1e-12:  # the next segment became the newest: a new move
            k.pred[idx] = k.postd[idx] = False
        e.travelled = travelled
        ref = e.axes[0]
        pre, post = float(k.p(motion.PRE_DIST)[ref]), float(k.p(motion.POST_DIST)[ref])
        if pre > 0 and travelled >= pre:
            k.pred[idx] = True
        if post > 0 and e.group.remaining(t) <= post:
            k.postd[idx] = True

    def finish(self, e: Entry) -> None:
        """The group came to rest at its end (or a stop's): MDN on every member (a stop keeps
        its code); commands held for APS_move_trigger stay held."""
        k = self.k
        if e.counts is not None:
            k.core.hold(e.idx, e.counts)
        for a in e.axes:
            if e.halt:
                k.mode[a] = STOPPING
            k.finish(a)
        if e.pending:
            self.rest(e)
            self.hold_for_trigger(e)
        else:
            self.release(e)

    def rest(self, e: Entry) -> None:
        """The group's motion is over (its held commands aside)."""
        k = self.k
        e.moving, e.halt, e.counts = False, _HALT_NONE, None
        for a in e.axes:
            k.unit_moving[a] = k.bld[a] = False
            k.phase[a] = 0
            k.mq_usage[a] = 0
            if k.mode[a] == UNIT:
                k.mode[a] = IDLE

    def release(self, e: Entry) -> None:
        """The group lets its axes go: no motion, nothing held."""
        k = self.k
        self.rest(e)
        e.pending = []
        for a in e.axes:
            if self.of_axis.get(a) is e:
                del self.of_axis[a]
            k.unit_starts.pop(a, None)
            k.owned[a] = k.wait[a] = False
            k.pending_start[a] = IDLE

    # -- stops ---------------------------------------------------------------------------------------
    def stop_axis(self, a: int, code: int, immediate: bool) -> None:
        """The kernel stops axis a: its whole group stops (spec Q13), decelerating along the
        path at the reference axis's PRA_SD_DEC and PRA_SF, or at once; every other member is
        stopped through the kernel with the same code (ASTP unless a user stop, spec Q9)."""
        e = self.of_axis.get(a)
        if e is None:
            return
        k = self.k
        level = _HALT_NOW if immediate else _HALT_DEC
        if e.moving and e.halt >= level:
            return
        if not e.moving:
            self.release(e)
        elif immediate:
            e.group.abort(k.t)
            e.counts = None
            k.core.hold(e.idx)
            for b in e.axes:
                k.mdn[b] = True
            self.release(e)
        else:
            e.halt = level
            e.pending = []
            for b in e.axes:
                k.unit_starts.pop(b, None)
                k.wait[b] = False
                k.pending_start[b] = IDLE
            ref = e.axes[0]
            e.group.stop(k.t, float(k.p(motion.SD_DEC)[ref]), float(k.p(motion.SF)[ref]))
        others = np.array([b for b in e.axes if b != a], dtype=np.intp)
        k.stop_axes(others, code, immediate=immediate, astp=code not in (STOP_USER, STOP_USER_EMG))

    # -- the Unit protocol -----------------------------------------------------------------------------
    def busy(self) -> bool:
        return any(e.moving for e in self.entries.values())

    def reset(self) -> None:
        self.entries.clear()
        self.of_axis.clear()
