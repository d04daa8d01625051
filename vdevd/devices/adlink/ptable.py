"""The two point tables of the AMP-204C/208C [M §4.9.6; spec adlink.md §2.21, §4.11], a kernel unit.

A table is a FIFO of 50 points (lines, arcs, spirals, dwells) bound to 2-6 axes, each point with
the modal profile and transition in force when it was pushed and the instructions (DO, VAO table)
set since the previous push. Running, the points go one by one into an interpolation group
(`group.Group`, user units): a point is handed over as soon as the one before it starts, so the
group's transitions (buffered, blending at the deceleration, at a residual distance or percent,
[M §4.7.3]) join them exactly; it leaves the table when it starts (spec §2.21 ASSUMPTION), and its
instructions run in that cycle. A point is planned to end at its Ve only when a motion point
follows it in the table by then, else at rest: a table that runs empty stops at its last point
(Q14). Dwells are zero-length segments with a duration (`DwellPlan`); an arc on some of the
table's columns (Index[]) is embedded in the table's space (`Embedded`), the others standing still.
"""

from __future__ import annotations

import math
import struct
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from vdevmaps.adlink import Bar
from vdevmaps.aps_defs import (
    PRA_PT_STOP_DO,
    PRA_PT_STOP_ENDO,
    PRA_SD_DEC,
    PRA_SF,
    PT_BUFFER_POINTS,
    PT_TABLE_COUNT,
    PTSTS_EMPTY,
    PTSTS_FULL,
    PTSTS_WORKING,
    STOP_NORMAL,
    STOP_USER,
    STOP_USER_EMG,
)

from vdevd.devices.adlink import profile
from vdevd.devices.adlink.group import Group, Transition
from vdevd.devices.adlink.modes import UNIT
from vdevd.devices.adlink.path import Line, Path, PathError, Vector

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

_STATUS = struct.Struct("<HHHHIi")  # PTSTS {BitSts, Free, Usage, pad; RunningCnt} + the last error
_STATUS_STRIDE = 16
#: the kernel's phase for table axes that hold (dwell, or waiting for INP): no ACC/VM/DEC bit
PHASE_HOLD = 4
#: the transition of a point that waits for INP before it starts (`APS_pt_set_trans_inp`)
TRANS_INP = -1
_USER_STOPS = (STOP_NORMAL, STOP_USER, STOP_USER_EMG)


class Embedded:
    """A path on some columns of the table's axes (`Index[]` of the arc structures, spec §2.21
    ASSUMPTION) in the table's space: the other columns keep the point's start. It answers what
    `group.Group` asks of a path (dims, start, end, length, at, tangent_at, rebased)."""

    def __init__(self, inner: Path, cols: tuple[int, ...], start: Vector) -> None:
        self.inner = inner
        self.cols = list(cols)
        self._fixed = np.array(start, dtype=np.float64)
        self.start = self._embed(inner.start)
        self.end = self._embed(inner.end)
        self.length = inner.length

    @property
    def dims(self) -> int:
        return int(self._fixed.size)

    def _embed(self, p: Vector) -> Vector:
        out = self._fixed.copy()
        out[self.cols] = p
        return out

    def at(self, s: Any) -> Vector:
        p = self.inner.at(s)
        if p.ndim == 1:
            return self._embed(p)
        out = np.tile(self._fixed, (p.shape[0], 1))
        out[:, self.cols] = p
        return out

    def tangent_at(self, s: Any) -> Vector:
        d = self.inner.tangent_at(s)
        if d.ndim == 1:
            out = np.zeros_like(self._fixed)
            out[self.cols] = d
            return out
        full = np.zeros((d.shape[0], self.dims))
        full[:, self.cols] = d
        return full

    def rebased(self, start: Any) -> Embedded:
        s = np.array(start, dtype=np.float64)
        return Embedded(self.inner.rebased(s[self.cols]), tuple(self.cols), s)


@dataclass(frozen=True)
class DwellPlan:
    """A dwell [M §4.9.6.1]: no travel for `time` seconds (spec §2.21: PTB stays 1). Whatever the
    next point's transition, it starts at the dwell's end (its deceleration and residual distance
    are both there)."""

    time: float
    distance: float = 0.0
    endless: bool = False

    def duration(self) -> float:
        return self.time

    def state(self, t: float) -> tuple[float, float, float]:
        return 0.0, 0.0, 0.0

    def decel_start(self) -> float:
        return self.time

    def phase_at(self, t: float) -> int:
        return 0

    def time_at(self, s: float) -> float:
        return self.time


@dataclass
class Modal:
    """The modal settings of a table [M §4.9.6.1]: kept until changed, used by every push."""

    relative: bool = False
    vs: float = 0.0
    vm: float = 1e5
    ve: float = 0.0
    acc: float = 1e6
    dec: float = 1e6
    sf: float = 0.0
    trans: int = int(Transition.BUFFERED)
    bp: float = 0.0


@dataclass
class Point:
    """A pushed point: its path (absolute, user units), the profile and transition in force when
    it was pushed, a dwell's time (None for a motion point), and its instructions."""

    path: Path | Embedded
    vs: float
    vm: float
    ve: float
    acc: float
    dec: float
    sf: float
    trans: int
    bp: float
    dwell: float | None = None
    actions: list[tuple[str, int, int]] = field(default_factory=list)


class Table:
    """One point table: its axes, modal settings, FIFO and run state."""

    def __init__(self, no: int) -> None:
        self.no = no
        self.clear()

    def clear(self) -> None:
        """Disabled, with nothing in it (power-up, APS_pt_enable, APS_pt_disable)."""
        self.enabled = False
        self.axes: tuple[int, ...] = ()
        self.modal = Modal()
        self.buffer: deque[Point] = deque()
        self.actions: list[tuple[str, int, int]] = []  # waiting for the next push
        self.count = 0  # RunningCnt: points started since enable
        self.error = 0  # APS_pt_get_error
        self.running = False
        self.stopping = False
        self.rolling = False
        self.code = STOP_NORMAL  # the stop code the run ends with
        self.group: Group | None = None
        self.submitted = 0  # points handed to the group, and of them started
        self.started = 0
        self.head_in_group = False
        self.last: Vector | None = None  # where the group's axes are (user units)
        self.last_start: Vector | None = None  # the start of the last point started (roll back)
        self.holding = False

    def bits(self) -> int:
        n = len(self.buffer)
        return ((PTSTS_WORKING if self.running else 0) | (PTSTS_FULL if n >= PT_BUFFER_POINTS else 0)
                | (PTSTS_EMPTY if n == 0 else 0))

    def status(self) -> tuple[int, int, int, int]:
        """PTSTS: BitSts, PntBufFreeSpace, PntBufUsageSpace, RunningCnt."""
        n = len(self.buffer)
        return self.bits(), PT_BUFFER_POINTS - n, n, self.count


class PointTables:
    """The kernel unit of the two point tables."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.tables = [Table(i) for i in range(PT_TABLE_COUNT)]
        #: VAO table switches of `APS_pt_ext_set_table_no` as they ran, (ctrl, table), for a
        #: kernel without `switch_vao_table` (the VAO unit's); `vao_table` the last per controller
        self.vao_requests: list[tuple[int, int]] = []
        self.vao_table: dict[int, int] = {}

    # -- the unit -------------------------------------------------------------------------------
    def reset(self) -> None:
        self.tables = [Table(i) for i in range(PT_TABLE_COUNT)]
        self.vao_requests.clear()
        self.vao_table.clear()

    def busy(self) -> bool:
        return any(tb.running for tb in self.tables)

    def before_motion(self, t: float) -> None:
        for tb in self.tables:
            if tb.running:
                self._tick(tb, t)

    def after_motion(self, t: float) -> None:
        return None

    def publish(self) -> None:
        buf = self.k.buf
        for tb in self.tables:
            bits, free, usage, count = tb.status()
            _STATUS.pack_into(buf, Bar.PT_STATUS + tb.no * _STATUS_STRIDE, bits, free, usage, 0,
                              count & 0xFFFFFFFF, tb.error)

    def stop_axis(self, axis: int, code: int, immediate: bool) -> None:
        """The kernel stops an axis (EMG, ALM, limits, APS_stop_move/emg_stop): the table it runs
        in stops with it, at once or decelerating along the path, its buffer cleared."""
        for tb in self.tables:
            if tb.running and axis in tb.axes:
                if immediate:
                    self._abort(tb, code)
                elif not tb.stopping:
                    self.stop(tb, code)
                if code not in _USER_STOPS:
                    tb.error = code

    # -- commands -------------------------------------------------------------------------------
    def tail(self, tb: Table) -> Vector:
        """Where the next pushed point starts: the end of the last point in the table, of the
        motion under way, or the axes' command positions."""
        if tb.buffer:
            return tb.buffer[-1].path.end.copy()
        if tb.running and tb.group is not None and tb.group.target is not None:
            return tb.group.target.copy()
        return self.k.user_cmd()[list(tb.axes)].astype(np.float64)

    def start(self, tb: Table, first: Point | None = None) -> None:
        """APS_pt_start: the run begins with the table's first point (or `first`, a roll back),
        in this cycle."""
        k, axes = self.k, list(tb.axes)
        a0 = axes[0]
        group = Group(tb.axes, plan_stop=profile.plan_stop)
        group.sd_dec = float(k.p(PRA_SD_DEC)[a0])
        group.sd_sf = float(k.p(PRA_SF)[a0])
        tb.group = group
        tb.running, tb.stopping, tb.holding = True, False, False
        tb.rolling = first is not None
        tb.code = STOP_NORMAL
        tb.submitted = tb.started = 0
        tb.head_in_group = False
        tb.last = k.user_cmd()[axes].astype(np.float64)
        k.owned[axes] = True
        k.mode[axes] = UNIT
        k.unit_moving[axes] = True
        k.mdn[axes] = False
        k.astp[axes] = False
        k.wait[axes] = False
        k.ptb[axes] = True
        k.phase[axes] = PHASE_HOLD
        if first is not None:
            group.submit(cast(Path, first.path), _factory(first, 0.0), int(Transition.BUFFERED), 0.0, k.t)
        self._tick(tb, k.t)

    def roll_back(self, tb: Table, speed: float) -> None:
        """APS_pt_roll_back: back in a line to where the last started point began (vdevd's
        reading, README), at `speed` with the table's acceleration; RunningCnt unchanged."""
        if tb.last_start is None:
            return
        here = self.k.user_cmd()[list(tb.axes)].astype(np.float64)
        m = tb.modal
        line = Line(here, tb.last_start)
        self.start(tb, Point(line, 0.0, speed, 0.0, m.acc, m.dec, m.sf, int(Transition.BUFFERED), 0.0))

    def stop(self, tb: Table, code: int = STOP_USER) -> None:
        """Decelerate along the path at SD_DEC of the first axis, the buffer cleared (APS_pt_stop,
        spec §2.21 ASSUMPTION); PRA_PT_STOP_ENDO/_DO set the DO word."""
        if not tb.running or tb.group is None:
            tb.buffer.clear()
            return
        k, g, now = self.k, tb.group, self.k.t
        self._starts(tb, g, now)
        tb.buffer.clear()
        velocity = g.velocity(now)
        if velocity is None or not np.any(velocity):
            g.abort(now)  # at rest (a dwell, an INP wait): nothing to decelerate
        else:
            g.stop(now, g.sd_dec, g.sd_sf)
        tb.stopping, tb.rolling = True, False
        tb.code = code
        tb.submitted = tb.started = 0  # the group's queue was cleared
        tb.head_in_group = False
        axes = list(tb.axes)
        k.stop_code[axes] = code
        k.astp[axes] = code not in _USER_STOPS
        self._stop_do(tb)

    # -- the run --------------------------------------------------------------------------------
    def _tick(self, tb: Table, t: float) -> None:
        g = tb.group
        assert g is not None
        while self._feed(tb, g, t):
            pass
        pos = g.positions(t)
        k, axes = self.k, list(tb.axes)
        if pos is not None:
            tb.last = pos
        flags = g.flags(t)
        if flags.moving:
            assert tb.last is not None
            tb.holding = False
            k.core.track(axes, self._counts(tb, tb.last))
            k.mode[axes] = UNIT  # reclaimed from the kernel's single-axis stop (stop_axes)
            k.unit_moving[axes] = True
            phase = 1 if flags.accelerating else 2 if flags.constant else 3 if flags.decelerating \
                else PHASE_HOLD
            k.phase[axes] = phase
            k.bld[axes] = flags.blending
            return
        if not tb.buffer or tb.stopping or tb.rolling:
            self._end(tb)
            return
        if not tb.holding:  # waiting for INP before the next point
            assert tb.last is not None
            k.core.hold(axes, self._counts(tb, tb.last))
            tb.holding = True
        k.unit_moving[axes] = False  # CSTP: no command goes out; INP can come
        k.phase[axes] = 0
        k.bld[axes] = False

    def _starts(self, tb: Table, g: Group, t: float) -> bool:
        """Points the group started by t leave the table; their instructions run."""
        g.flags(t)  # the group advanced to t
        started = tb.submitted - g.queued
        changed = False
        while tb.started < started:
            tb.started += 1
            point = tb.buffer.popleft()
            tb.head_in_group = False
            tb.count += 1
            tb.last_start = point.path.start.copy()
            self.k.target[list(tb.axes)] = point.path.end
            for action in point.actions:
                self._act(action)
            changed = True
        return changed

    def _feed(self, tb: Table, g: Group, t: float) -> bool:
        """Started points leave the table, the next one goes to the group. True when something
        changed (the caller feeds again: a point may start and end within a cycle)."""
        changed = self._starts(tb, g, t)
        if tb.head_in_group or not tb.buffer or tb.stopping or tb.rolling:
            return changed
        head = tb.buffer[0]
        moving = g.flags(t).moving
        if head.trans == TRANS_INP and (moving or not bool(self.k.inp[list(tb.axes)].all())):
            return changed
        here = g.target if g.target is not None else tb.last
        assert here is not None
        path = head.path
        if not np.allclose(path.start, here, rtol=1e-9, atol=1e-9):
            try:
                path = path.rebased(here)
            except PathError as exc:
                tb.error = exc.code
                tb.buffer.popleft()
                return True
        nxt = tb.buffer[1] if len(tb.buffer) > 1 else None
        flowing = nxt is not None and nxt.dwell is None and nxt.trans != TRANS_INP
        mode = Transition.BUFFERED if head.trans == TRANS_INP or head.dwell is not None \
            else Transition(head.trans)
        factory = _dwell_factory(head.dwell) if head.dwell is not None \
            else _factory(head, head.ve if flowing else 0.0)
        rc = g.submit(cast(Path, path), factory, int(mode), head.bp, t)
        if rc:
            tb.error = rc
            tb.buffer.popleft()
            return True
        tb.submitted += 1
        tb.head_in_group = True
        return True

    def _end(self, tb: Table) -> None:
        """The run is over (the table ran empty, or stopped): the axes hold, MDN, the stop code."""
        k, axes = self.k, list(tb.axes)
        if tb.last is not None:
            k.core.hold(axes, self._counts(tb, tb.last))
        self._release(tb)

    def _abort(self, tb: Table, code: int) -> None:
        """An immediate stop: the axes hold where they are commanded now."""
        k, axes = self.k, list(tb.axes)
        if tb.group is not None:
            tb.group.abort(k.t)
        tb.buffer.clear()
        tb.code = code
        k.core.hold(axes)
        self._stop_do(tb)
        self._release(tb)

    def _release(self, tb: Table) -> None:
        k, axes = self.k, list(tb.axes)
        for a in axes:
            k.mode[a] = UNIT
            k.finish(a, tb.code)
        k.astp[axes] = tb.code not in _USER_STOPS
        k.owned[axes] = False
        k.unit_moving[axes] = False
        k.phase[axes] = 0
        k.ptb[axes] = False
        k.bld[axes] = False
        tb.running = tb.stopping = tb.rolling = tb.holding = False
        tb.group = None
        tb.head_in_group = False

    def _counts(self, tb: Table, user: Vector) -> np.ndarray:
        axes = list(tb.axes)
        return (user - self.k.cmd_off[axes]) * self.k.axis_params.row(0x86)[axes]

    # -- instructions ---------------------------------------------------------------------------
    def _act(self, action: tuple[str, int, int]) -> None:
        """An instruction of a point that starts [M §4.9.6.1 b]: a DO channel on (1) or off (Q14),
        or a VAO controller's table."""
        kind, a, b = action
        k = self.k
        if kind == "do":
            k.do_word = (k.do_word | (1 << a)) if b else (k.do_word & ~(1 << a))
            return
        switch = getattr(k, "switch_vao_table", None)
        if callable(switch):
            switch(a, b)
        self.vao_requests.append((a, b))
        self.vao_table[a] = b

    def _stop_do(self, tb: Table) -> None:
        """PRA_PT_STOP_ENDO (DO channels, a bit mask) of the first axis take the values of
        PRA_PT_STOP_DO when the table stops ([X2] comments; vdevd's reading, README)."""
        a0 = tb.axes[0]
        mask = int(self.k.p(PRA_PT_STOP_ENDO)[a0]) & 0xFFFFFF
        if mask:
            value = int(self.k.p(PRA_PT_STOP_DO)[a0])
            self.k.do_word = (self.k.do_word & ~mask) | (value & mask)


def _factory(point: Point, ve: float) -> Any:
    """The plan of a motion point: T/S-curve along the path [M §4.2.3] (v0: on the fly)."""

    def plan(distance: float, v0: float | None) -> profile.Plan:
        if v0 is None:
            return profile.plan_ptp(distance, point.vs, point.vm, ve, point.acc, point.dec, point.sf)
        return profile.plan_from(v0, distance, point.vm, ve, point.acc, point.dec, point.sf)

    return plan


def _dwell_factory(time: float) -> Any:
    def plan(distance: float, v0: float | None) -> DwellPlan:
        return DwellPlan(time)

    return plan


def dwell_time(ms: float, cycle_us: int) -> float:
    """DwTime (ms) rounded up to whole motion cycles, in seconds (spec §2.21)."""
    cycles = math.ceil(ms * 1000.0 / cycle_us - 1e-9)
    return max(cycles, 0) * cycle_us / 1e6
