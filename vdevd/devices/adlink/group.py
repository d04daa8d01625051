"""Motion of one interpolation group of the ADLINK AMP-204C/208C over time [M §4.7.3], spec §2.13:
the motion buffer of segments (a path from `path.py` and a scalar profile plan along it) and the
seven continuous-interpolation transitions, sans-I/O.

The command position is a superposition: `base + sum(path.at(s0 + s(t - t0)) - path.at(s0))` over
the running segments. A queued segment's path starts where the previous one ends (the caller
resolves relative targets against `target`), so once every overlap has run out the sum is the
last path's end, which the engine then takes exactly. Blending (methods 5-7) starts the next
segment while the previous one finishes its own profile (BLD while they overlap); aborting with
blend or stop (methods 1, 3) replaces every running segment by its stop profile from the present
speed along its own path, and re-issues the new command from the point where those stops end.

Time is float seconds of simulated time (the caller converts its integer nanoseconds); events
(segment ends, blend starts) happen at their exact times whatever the tick rate.
"""

from __future__ import annotations

import enum
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from vdevd.devices.adlink.path import ERR_PARAMETERS_INVALID, Path, PathError, Vector

ERR_COMMAND_IN_PROCESS = -15
"""`ERR_CommandInProcess` [X4]: the motion buffer is full (spec §2.9 ASSUMPTION, Q7)."""

QUEUE_DEPTH = 10
"""Commands the motion buffer holds besides the running ones [M §4.6.4] (spec §2.13)."""

_START_TOLERANCE = 1e-9


class Transition(enum.IntEnum):
    """Speed connection of a new interpolation command: `Option` bits 12-15 [M §4.7.3], [X2]."""

    ABORT_BLEND = 0  # ITP_OPT_ABORT_BLEND 0x0000
    ABORT_FORCE = 1  # ITP_OPT_ABORT_FORCE 0x1000
    ABORT_STOP = 2  # ITP_OPT_ABORT_STOP 0x2000
    BUFFERED = 3  # ITP_OPT_BUFFERED 0x3000
    BLEND_DEC_EVENT = 4  # ITP_OPT_BLEND_DEC_EVENT 0x4000
    BLEND_RES_DIST = 5  # ITP_OPT_BLEND_RES_DIST 0x5000
    BLEND_RES_DIST_PERCENT = 6  # ITP_OPT_BLEND_RES_DIST_PERCENT 0x6000

    @classmethod
    def from_option(cls, option: int) -> Transition:
        return cls((option >> 12) & 0xF)


_ABORTING = (Transition.ABORT_BLEND, Transition.ABORT_FORCE, Transition.ABORT_STOP)


class Plan(Protocol):
    """The scalar profile along a path (`profile.py`): s, v, a over time from 0."""

    @property
    def distance(self) -> float: ...
    @property
    def endless(self) -> bool: ...

    def duration(self) -> float: ...
    def state(self, t: float) -> tuple[float, float, float]: ...
    def decel_start(self) -> float: ...
    def phase_at(self, t: float) -> int: ...
    def time_at(self, s: float) -> float: ...


PlanFactory = Callable[[float, float | None], Plan]
"""`factory(distance, v0)`: the command's plan over `distance`; `v0` None starts at the command's
own Vs, a number at that speed (abort-force keeps the present speed)."""

StopPlanner = Callable[[float, float, float], Plan]
"""`plan_stop(v0, dec, sf)`."""


@dataclass(frozen=True, slots=True)
class GroupFlags:
    """Per-group motion status [M §4.8.1]: the phase bits are those of the newest segment."""

    moving: bool
    accelerating: bool
    constant: bool
    decelerating: bool
    blending: bool
    done: bool


IDLE_FLAGS = GroupFlags(False, False, False, False, False, True)


@dataclass(slots=True)
class _Run:
    """A running segment: `plan` drives `path` from path length `s0` (non-zero for stop runs)."""

    path: Path
    plan: Plan
    t0: float
    s0: float
    p0: Vector
    t_end: float
    end_point: Vector

    @classmethod
    def begin(cls, path: Path, plan: Plan, t0: float, s0: float = 0.0) -> _Run:
        t_end = math.inf if plan.endless else t0 + plan.duration()
        s_end = s0 + plan.distance
        end_point = path.end if s_end >= path.length else path.at(s_end)
        return cls(path, plan, t0, s0, path.at(s0), t_end, end_point)

    def s(self, now: float) -> tuple[float, float]:
        """Path length reached and path speed at `now`."""
        s, v, _ = self.plan.state(now - self.t0)
        return self.s0 + s, v


@dataclass(slots=True)
class _Pending:
    path: Path
    plan: Plan
    mode: Transition
    para: float
    t_submit: float


class Group:
    """One interpolation group: `axes[0]` is the reference axis whose speed parameters make the
    plans [M §4.7]. `sd_dec`/`sd_sf` (07h `PRA_SD_DEC`, 20h `PRA_SF` of the reference axis) are the
    deceleration the aborting transitions stop the old motion with."""

    def __init__(self, axes: tuple[int, ...], plan_stop: StopPlanner | None = None) -> None:
        self.axes = tuple(axes)
        self.sd_dec = 1e6
        self.sd_sf = 0.0
        self._plan_stop = plan_stop
        self._runs: list[_Run] = []
        self._newest: _Run | None = None  # the last command started: what a blend follows
        self._queue: deque[_Pending] = deque()
        self._base: Vector | None = None
        self._snap: Vector | None = None  # where the motion rests once every run is over
        self._t_idle = -math.inf
        self._next_event = math.inf
        self._last: Vector | None = None
        self._reported = True

    # -- commands ------------------------------------------------------------------------------

    def submit(self, path: Path, plan_factory: PlanFactory, mode: int, trans_para: float, now: float) -> int:
        """Accept one interpolation command (absolute geometry); 0, -10 or -15 as APS returns."""
        try:
            transition = Transition(mode)
        except ValueError:
            return ERR_PARAMETERS_INVALID
        if path.dims != len(self.axes) or not math.isfinite(trans_para):
            return ERR_PARAMETERS_INVALID
        if transition is Transition.BLEND_RES_DIST and trans_para < 0.0:
            return ERR_PARAMETERS_INVALID
        if transition is Transition.BLEND_RES_DIST_PERCENT and not 0.0 <= trans_para <= 100.0:
            return ERR_PARAMETERS_INVALID
        self._advance(now)
        if not self._runs:
            self._base = path.start.copy()
            self._last = None
            self._start(path, plan_factory(path.length, None), now)
            return 0
        if transition not in _ABORTING:
            if len(self._queue) >= QUEUE_DEPTH:
                return ERR_COMMAND_IN_PROCESS
            target = self.target
            if target is None or not _same_point(path.start, target):
                return ERR_PARAMETERS_INVALID
            plan = plan_factory(path.length, None)
            self._queue.append(_Pending(path, plan, transition, trans_para, now))
            self._schedule()
            return 0
        here = self._position(now)
        if not _same_point(path.start, here):
            return ERR_PARAMETERS_INVALID
        if transition is Transition.ABORT_FORCE:
            speed = float(np.linalg.norm(self._velocity(now)))
            self._runs.clear()
            self._queue.clear()
            self._base = here
            self._start(path, plan_factory(path.length, speed), now)
            return 0
        runs, base = self._stopping(now, here, self.sd_dec, self.sd_sf)
        rest = base + sum((r.end_point - r.p0 for r in runs), np.zeros_like(base))
        try:
            path = path.rebased(rest)
        except PathError:
            return ERR_PARAMETERS_INVALID
        self._runs, self._base = runs, base
        self._queue.clear()
        self._snap = None
        plan = plan_factory(path.length, None)
        if transition is Transition.ABORT_BLEND:
            self._start(path, plan, now)
        else:
            self._queue.append(_Pending(path, plan, Transition.BUFFERED, 0.0, now))
            self._schedule()
        return 0

    def stop(self, now: float, dec: float, sf: float) -> None:
        """Decelerate along the path(s) to rest and clear the buffer (`APS_stop_move`)."""
        self._advance(now)
        if not self._runs:
            self._queue.clear()
            return
        self._runs, self._base = self._stopping(now, self._position(now), dec, sf)
        self._queue.clear()
        self._snap = None
        self._schedule()

    def abort(self, now: float | None = None) -> None:
        """Stop at once (`APS_emg_stop`): at `now`, or where the last `positions` call put the axes."""
        if now is not None and self._runs:
            self._advance(now)
            self._last = self._position(now)
        if self._runs or self._queue:
            self._base = self._last if self._last is not None else self._base
            self._runs.clear()
            self._queue.clear()
            self._snap = None
            self._reported = False
            self._schedule()

    # -- state ---------------------------------------------------------------------------------

    def positions(self, now: float) -> Vector | None:
        """Absolute command positions of the axes at `now`; the first call that finds the group
        idle returns where it came to rest, later ones None (idle costs nothing)."""
        if now >= self._next_event:
            self._advance(now)
        if not self._runs:
            if self._reported or self._base is None:
                return None
            self._reported = True
            return self._base.copy()
        self._last = self._position(now)
        return self._last

    def velocity(self, now: float) -> Vector | None:
        """Axis velocities at `now` (per-axis speed and DIR), None when idle."""
        self._advance(now)
        return self._velocity(now) if self._runs else None

    def flags(self, now: float) -> GroupFlags:
        self._advance(now)
        if not self._runs:
            return IDLE_FLAGS
        newest = self._runs[-1]
        phase = newest.plan.phase_at(now - newest.t0)
        return GroupFlags(True, phase == 1, phase == 2, phase == 3, len(self._runs) > 1, False)

    def travelled(self, now: float) -> float:
        """Path length covered by the newest segment (pre/post-distance events)."""
        self._advance(now)
        return self._runs[-1].s(now)[0] if self._runs else 0.0

    def remaining(self, now: float) -> float:
        """Path length left of the newest segment's path."""
        self._advance(now)
        return self._runs[-1].path.length - self._runs[-1].s(now)[0] if self._runs else 0.0

    @property
    def queued(self) -> int:
        """Commands waiting in the buffer (`APS_get_mq_usage`)."""
        return len(self._queue)

    @property
    def target(self) -> Vector | None:
        """Where the buffered motion ends: the start point of the next queued command."""
        if self._queue:
            return self._queue[-1].path.end
        if self._runs:
            if self._snap is not None:
                return self._snap
            assert self._base is not None
            return self._base + sum((r.end_point - r.p0 for r in self._runs), np.zeros_like(self._base))
        return self._base

    # -- engine --------------------------------------------------------------------------------

    def _position(self, now: float) -> Vector:
        assert self._base is not None
        pos = self._base.copy()
        for r in self._runs:
            pos += r.path.at(r.s(now)[0]) - r.p0
        return pos

    def _velocity(self, now: float) -> Vector:
        assert self._base is not None
        vel = np.zeros_like(self._base)
        for r in self._runs:
            s, v = r.s(now)
            vel += v * r.path.tangent_at(s)
        return vel

    def _start(self, path: Path, plan: Plan, t0: float) -> None:
        self._newest = _Run.begin(path, plan, t0)
        self._runs.append(self._newest)
        self._snap = path.end
        self._reported = False
        self._schedule()

    def _stopping(self, now: float, here: Vector, dec: float, sf: float) -> tuple[list[_Run], Vector]:
        """Each run replaced by its stop from the present speed along its own path (kept when its
        own profile ends sooner); returns the runs and the base that keeps `here` continuous."""
        plan_stop = self._stop_planner()
        runs: list[_Run] = []
        base = here.copy()
        for r in self._runs:
            s, v = r.s(now)
            stop = plan_stop(abs(v), dec, sf)
            if r.s0 + r.plan.distance - s <= stop.distance:
                runs.append(r)
                base -= r.path.at(s) - r.p0
            else:
                runs.append(_Run.begin(r.path, stop, now, s))
        return runs, base

    def _stop_planner(self) -> StopPlanner:
        if self._plan_stop is None:
            from vdevd.devices.adlink.profile import plan_stop  # written alongside this module

            self._plan_stop = plan_stop
        return self._plan_stop

    def _trigger(self) -> float:
        """When the head of the buffer starts [M §4.7.3 methods 4-7]."""
        head = self._queue[0]
        if not self._runs:
            return max(head.t_submit, self._t_idle)
        prev = self._newest
        if head.mode is Transition.BUFFERED:
            t = max(r.t_end for r in self._runs)
        elif prev is None or not any(r is prev for r in self._runs):
            # the previous command already ended (a zero-length one, say) while older runs
            # overlap on: the blend starts now, never at a trigger time of an older run
            t = max(r.t0 for r in self._runs) if prev is None else prev.t_end
        elif head.mode is Transition.BLEND_DEC_EVENT:
            t = prev.t0 + prev.plan.decel_start()
        else:
            distance = prev.plan.distance
            residue = head.para if head.mode is Transition.BLEND_RES_DIST else distance * head.para / 100.0
            t = prev.t0 + prev.plan.time_at(max(distance - residue, 0.0))
        return max(t, head.t_submit)

    def _schedule(self) -> None:
        t = min((r.t_end for r in self._runs), default=math.inf)
        if self._queue:
            t = min(t, self._trigger())
        self._next_event = t

    def _advance(self, now: float) -> None:
        """Process segment ends and buffered starts up to `now`, in time order."""
        while self._next_event <= now:
            t = self._next_event
            ending = min(self._runs, key=lambda r: r.t_end, default=None)
            if ending is not None and ending.t_end <= t:
                self._retire(ending)
            else:
                head = self._queue.popleft()
                if not self._runs:
                    self._base = head.path.start.copy()
                self._start(head.path, head.plan, t)
            self._schedule()

    def _retire(self, run: _Run) -> None:
        assert self._base is not None
        self._runs.remove(run)
        if self._runs:
            self._base = self._base + (run.end_point - run.p0)
            return
        self._base = self._snap.copy() if self._snap is not None else self._base + (run.end_point - run.p0)
        self._t_idle = run.t_end
        self._last = None


def _same_point(a: Vector, b: Vector) -> bool:
    return bool(np.allclose(a, b, rtol=_START_TOLERANCE, atol=_START_TOLERANCE))
