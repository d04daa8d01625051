"""Vector (contour) paths: straight and circular segments run at a vector velocity (spec oms.md
§4.3 "Vector / contouring", §5.2, App C example 3 [S App C L1360-1374]; the EPICS MAXv
trajectory scan [E-traj L1296-1430]).

Each segment keeps the `VV v,vend` and the `VA` in force when it was defined. It is entered at
the speed the segment before it left (rest for the first), ramps at its own VA to v (up, or down
when entered faster), cruises, and ends at vend (`VV v` alone: it runs on at v); the last segment
ends at rest. This is how [E-traj] drives the card: `VA[n]a;VV[n]v` per point, the card ramping
from the last point's speed to v within the segment. The path is planned when its definition
ends (`VE`): the speed at every junction is the lowest of the segment's vend, its velocity and
what the segments' VA can reach within the segments on either side (the whole path is known, so
a segment that must slow down more than it can within itself slows the ones before it). Each
segment is then a trapezoid of the path coordinate s between its junction speeds, evaluated in
closed form every update cycle at a time that the velocity override (`VO`, `VOA`, 0-200 %)
stretches and a halt (`VH1`) ramps to a stop. Pure functions and small state objects; the
firmware writes the positions into the core.
"""

from __future__ import annotations

import enum
import math
from bisect import bisect_left, bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Line:
    start: tuple[float, ...]
    end: tuple[float, ...]
    io_on: int = 0
    io_off: int = 0
    velocity: float = 1.0  # VV v in force when the segment was defined
    end_velocity: float | None = None  # VV ...,vend; None: runs on at `velocity`
    acceleration: float = 1.0  # VA in force when the segment was defined

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    def at(self, s: float) -> tuple[float, ...]:
        if self.length == 0:
            return self.end
        f = s / self.length
        return tuple(a + (b - a) * f for a, b in zip(self.start, self.end, strict=True))


@dataclass(frozen=True)
class Arc:
    """Around `centre` (first two path axes) by `sweep` radians; negative sweep is clockwise
    (spec §8.14)."""

    start: tuple[float, ...]
    centre: tuple[float, float]
    sweep: float
    io_on: int = 0
    io_off: int = 0
    velocity: float = 1.0
    end_velocity: float | None = None
    acceleration: float = 1.0

    @property
    def radius(self) -> float:
        return math.dist(self.start[:2], self.centre)

    @property
    def length(self) -> float:
        return abs(self.sweep) * self.radius

    def at(self, s: float) -> tuple[float, ...]:
        r = self.radius
        if r == 0 or s == 0:
            return self.start  # exactly (cos/sin would not give it back to the last bit)
        a0 = math.atan2(self.start[1] - self.centre[1], self.start[0] - self.centre[0])
        a = a0 + math.copysign(s / r, self.sweep)
        return (self.centre[0] + r * math.cos(a), self.centre[1] + r * math.sin(a),
                *self.start[2:])

    @property
    def end(self) -> tuple[float, ...]:
        return self.at(self.length)


Segment = Line | Arc


@dataclass(frozen=True)
class Point:
    """`VP`'s fields as sent: per axis a position (absolute) or a distance from where the segment
    starts (relative), None to keep the axis there; fractions are cut."""

    fields: tuple[float | None, ...]
    relative: bool

    def end(self, here: tuple[float, ...]) -> tuple[float, ...]:
        out = list(here)
        for a, v in enumerate(self.fields):
            if v is not None:
                out[a] = here[a] + math.trunc(v) if self.relative else float(math.trunc(v))
        return tuple(out)

    def segment(self, here: tuple[float, ...], like: Segment) -> Line:
        """The segment from `here`, with `like`'s speeds and outputs."""
        return Line(here, self.end(here), like.io_on, like.io_off, like.velocity,
                    like.end_velocity, like.acceleration)


@dataclass(frozen=True)
class Turn:
    """`VC`'s fields as sent: the centre, absolute or from where the arc starts, and the
    degrees (negative: clockwise)."""

    centre: tuple[float, float]
    relative: bool
    degrees: float

    def centre_from(self, here: tuple[float, ...]) -> tuple[float, float]:
        if self.relative:
            return here[0] + self.centre[0], here[1] + self.centre[1]
        return self.centre

    def segment(self, here: tuple[float, ...], like: Segment) -> Arc:
        """The arc from `here`, with `like`'s speeds and outputs."""
        return Arc(here, self.centre_from(here), math.radians(self.degrees), like.io_on,
                   like.io_off, like.velocity, like.end_velocity, like.acceleration)


Step = Point | Turn


@dataclass(frozen=True)
class Leg:
    """One segment's speed profile: from `entry` ramp at `accel` to `peak` (down when entered
    faster than its velocity), cruise at `peak`, ramp down to `exit`, over `length` counts of
    path."""

    length: float
    entry: float
    peak: float
    exit: float
    accel: float

    @property
    def ramp_up(self) -> float:
        """The time of the first ramp, entry -> peak (up or down)."""
        return abs(self.peak - self.entry) / self.accel

    @property
    def ramp_down(self) -> float:
        return (self.peak - self.exit) / self.accel

    @property
    def _s_up(self) -> float:
        return abs(self.peak ** 2 - self.entry ** 2) / (2 * self.accel)

    @property
    def cruise(self) -> float:
        """The distance at `peak` (what the two ramps leave)."""
        down = (self.peak ** 2 - self.exit ** 2) / (2 * self.accel)
        return max(0.0, self.length - self._s_up - down)

    @property
    def duration(self) -> float:
        if self.length <= 0:
            return 0.0
        return self.ramp_up + self.cruise / self.peak + self.ramp_down

    def s_at(self, tau: float) -> float:
        """Path coordinate within the leg, `tau` seconds after its start."""
        a, v, up = self.accel, self.peak, self.ramp_up
        if tau <= up:
            return self.entry * tau + math.copysign(a, v - self.entry) * tau * tau / 2
        flat = self.cruise / v
        if tau <= up + flat:
            return self._s_up + v * (tau - up)
        w = min(tau - up - flat, self.ramp_down)
        return min(self.length, self._s_up + self.cruise + v * w - a * w * w / 2)

    def v_at(self, tau: float) -> float:
        """Path speed within the leg, `tau` seconds after its start."""
        a, v, up = self.accel, self.peak, self.ramp_up
        if tau <= up:
            return self.entry + math.copysign(a, v - self.entry) * tau
        flat = self.cruise / v
        return v - a * min(max(0.0, tau - up - flat), self.ramp_down)

    def a_at(self, tau: float) -> float:
        """Path acceleration within the leg, `tau` seconds after its start."""
        up = self.ramp_up
        if tau < up:
            return math.copysign(self.accel, self.peak - self.entry)
        down_from = up + self.cruise / self.peak
        return -self.accel if down_from <= tau < down_from + self.ramp_down else 0.0


def _per_segment(accel: float | Sequence[float], n: int) -> list[float]:
    return [float(accel)] * n if isinstance(accel, (int, float)) else list(accel)


def junction_speeds(lengths: list[float], velocities: list[float],
                    ends: list[float | None], accel: float | Sequence[float]) -> list[float]:
    """The speed at the end of each segment (App C: `VV1000,1000` runs on, `VV1000,0` stops):
    at most the segment's vend (its velocity when None) and its velocity, what its `accel`
    (one value, or one per segment) reaches from the junction before (forward) and what the
    next segment's can bring down to the one after (backward); the last is 0. A slower
    segment after it does not lower it: that segment slows down within itself [E-traj]."""
    n = len(lengths)
    acc = _per_segment(accel, n)
    cap = [v if e is None else min(v, e) for v, e in zip(velocities, ends, strict=True)]
    cap[-1] = 0.0
    out: list[float] = []
    before = 0.0
    for i in range(n):
        before = min(cap[i], math.sqrt(before * before + 2 * acc[i] * lengths[i]))
        out.append(before)
    for i in range(n - 2, -1, -1):
        out[i] = min(out[i], math.sqrt(out[i + 1] ** 2 + 2 * acc[i + 1] * lengths[i + 1]))
    return out


def plan_legs(lengths: list[float], velocities: list[float], ends: list[float | None],
              accel: float | Sequence[float]) -> list[Leg]:
    """Each segment's trapezoid between its junction speeds (a triangle when too short to
    reach its velocity; first down to its velocity when entered faster)."""
    acc = _per_segment(accel, len(lengths))
    junctions = junction_speeds(lengths, velocities, ends, acc)
    legs, entry = [], 0.0
    for length, v, a, out in zip(lengths, velocities, acc, junctions, strict=True):
        if entry > v:  # down to v first (out is at most v)
            peak = v
        else:
            reach = math.sqrt(max(0.0, a * length + (entry * entry + out * out) / 2))
            peak = max(min(v, reach), entry, out)
        legs.append(Leg(length, entry, peak, out, a))
        entry = out
    return legs


class ContourState(enum.Enum):
    """Where a contour is once its definition has ended (VE)."""

    QUEUED = "queued"  # its VE waits in the axis queues
    READY = "ready"  # its VE reached every axis queue's head; the task's contour before runs
    WAITING = "waiting"  # at its start, waiting for VG[n] (after VH[n]0)
    RUNNING = "running"
    ENDED = "ended"  # ran to its end, or a flush of one of its axes ended it (KS, ST, ...)


@dataclass
class Contour:
    """A contour being defined (`VP`, `VC`) and then run (after `VE`)."""

    axes: tuple[int, ...]
    start: tuple[float, ...]
    velocity: float  # VV v for the segments defined from now
    acceleration: float  # VA for them
    end_velocity: float | None = None  # VV ...,vend for them; None: run on
    segments: list[Segment] = field(default_factory=list)
    steps: list[Step] = field(default_factory=list)  # the VP/VC each segment was made from
    io_on: int = 0  # VIO bits for the next segment
    io_off: int = 0
    notify: bool = False  # VID: set the done flags of its axes at its end
    task: int = 1
    # the run
    state: ContourState = ContourState.QUEUED
    stopping: bool = False  # ST, SA, SI or a soft limit: ramping down on its path to end
    over_travel: set[int] = field(default_factory=set)  # axes whose limit it ran into
    entered: int = -1  # the last segment whose VIO it has set
    t: float = 0.0  # path time, s
    rate: float = 0.0  # path seconds per second this cycle: the override, eased by a halt
    easing: bool = False  # halted, or resuming from a halt
    total: float = 0.0
    legs: list[Leg] = field(default_factory=list)
    _bounds: list[float] = field(default_factory=list)  # s at each segment's start
    _starts: list[float] = field(default_factory=list)  # t at each segment's start

    @property
    def here(self) -> tuple[float, ...]:
        return self.segments[-1].end if self.segments else self.start

    def add(self, step: Step) -> None:
        """VP or VC: a segment from where the path is, at the speeds in force now, with the
        outputs VIO set for it."""
        like = Line((), (), self.io_on, self.io_off, self.velocity, self.end_velocity,
                    self.acceleration)
        self.segments.append(step.segment(self.here, like))
        self.steps.append(step)
        self.io_on = self.io_off = 0

    def rebase(self, start: tuple[float, ...]) -> None:
        """The path from `start`, where its axes are when it starts (README "Start"): each
        segment made again from its VP/VC (absolute fields stay, relative ones follow), the
        speeds kept, the path planned again."""
        if start == self.start:
            return
        self.start, made = start, self.segments
        self.segments = []
        for step, seg in zip(self.steps, made, strict=True):
            self.segments.append(step.segment(self.here, seg))
        self.plan()

    def path_axes(self) -> tuple[int, ...]:
        """The contour's axes: those a `VP` gives a field for, X and Y for an arc (README).
        Fixed at `VE`: they hold the contour in their queues, and it holds them while it runs."""
        named = {0, 1} if any(isinstance(s, Turn) for s in self.steps) else set()
        for step in self.steps:
            if isinstance(step, Point):
                named |= {a for a, v in enumerate(step.fields) if v is not None}
        return tuple(sorted(named)) or (0,)

    def plan(self) -> None:
        """At VE: the junction speeds, each segment's profile, where and when each starts."""
        segs = self.segments
        self.legs = plan_legs([s.length for s in segs], [s.velocity for s in segs],
                              [s.end_velocity for s in segs], [s.acceleration for s in segs])
        self._bounds, self._starts = [0.0], [0.0]
        for seg, leg in zip(segs, self.legs, strict=True):
            self._bounds.append(self._bounds[-1] + seg.length)
            self._starts.append(self._starts[-1] + leg.duration)
        self.total = self._bounds[-1]

    def begin(self) -> None:
        """It starts: path time 0, at rest."""
        self.state = ContourState.RUNNING
        self.t = self.rate = 0.0
        self.easing = self.stopping = False
        self.over_travel = set()
        self.entered = -1

    @property
    def duration(self) -> float:
        return self._starts[-1] if self._starts else 0.0

    def _leg(self, t: float) -> int:
        return min(bisect_right(self._starts, t) - 1, len(self.legs) - 1)

    def s_at(self, t: float) -> float:
        """Path coordinate at (override-stretched) time t."""
        if t <= 0 or self.total <= 0:
            return 0.0
        if t >= self.duration:
            return self.total
        i = self._leg(t)
        return self._bounds[i] + self.legs[i].s_at(t - self._starts[i])

    def speed_at(self, t: float) -> float:
        """Path speed at path time t, counts/s at 100 %."""
        if t <= 0 or t >= self.duration:
            return 0.0
        i = self._leg(t)
        return self.legs[i].v_at(t - self._starts[i])

    def accel_at(self, t: float) -> float:
        """Path acceleration at path time t, counts/s² at 100 %."""
        if t <= 0 or t >= self.duration:
            return 0.0
        i = self._leg(t)
        return self.legs[i].a_at(t - self._starts[i])

    def pace(self, override: float, held: bool, dt: float) -> float:
        """The rate of path time for the next `dt` seconds: the override at once; but a halt
        (VH1, or a stop) brings it to 0, and a resume back to the override, changing the path
        speed at the contour's first VA (its default: E-traj's cruise segments have VA 1).
        The speed is rate·v(t), so it changes by v·Δrate + rate²·a(t)·dt: the rate changes by
        what brings that to ±VA·dt, net of the path's own acceleration a(t)."""
        want = 0.0 if held else override
        self.easing |= held
        if not self.easing:
            self.rate = want
            return want
        v = self.speed_at(self.t)
        own = self.rate * self.rate * self.accel_at(self.t)
        va = self.segments[0].acceleration
        if want > self.rate:
            step = max(0.0, va - own) * dt / v if v > 0 else math.inf
            self.rate = min(self.rate + step, want)
        else:
            step = max(0.0, va + own) * dt / v if v > 0 else math.inf
            self.rate = max(self.rate - step, want)
        self.easing = held or self.rate != want
        return self.rate

    def position(self, s: float) -> tuple[tuple[float, ...], int]:
        """Axis positions at s and the index of the segment it is in."""
        # the first segment that ends at or after s (a boundary belongs to the one ending there)
        i = min(bisect_left(self._bounds, s, 1) - 1, len(self.segments) - 1)
        seg = self.segments[i]
        return seg.at(min(s - self._bounds[i], seg.length)), i
