"""Vector (contour) paths: straight and circular segments run at a vector velocity (spec oms.md
§4.3 "Vector / contouring", §5.2, App C example 3 [S App C L1360-1374]).

Each segment keeps the `VV v,vend` in force when it was defined: it cruises at v and ends at
vend (`VV v` alone: it runs on at v), the last segment ends at rest. The path is planned when its
definition ends (`VE`): the speed at every junction is the lowest of the segment's vend, the
velocities of the two segments that meet there, and what the acceleration `VA` can reach within
the segments on either side (the whole path is known, so a segment that must slow down more than
it can within itself slows the ones before it). Each segment is then a trapezoid of the path
coordinate s between its junction speeds, evaluated in closed form every update cycle at a time
that the velocity override (`VO`, `VOA`, 0-200 %) stretches. Pure functions and small state
objects; the firmware writes the positions into the core.
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Line:
    start: tuple[float, ...]
    end: tuple[float, ...]
    io_on: int = 0
    io_off: int = 0
    velocity: float = 1.0  # VV v in force when the segment was defined
    end_velocity: float | None = None  # VV ...,vend; None: runs on at `velocity`

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

    @property
    def radius(self) -> float:
        return math.dist(self.start[:2], self.centre)

    @property
    def length(self) -> float:
        return abs(self.sweep) * self.radius

    def at(self, s: float) -> tuple[float, ...]:
        r = self.radius
        if r == 0:
            return self.start
        a0 = math.atan2(self.start[1] - self.centre[1], self.start[0] - self.centre[0])
        a = a0 + math.copysign(s / r, self.sweep)
        return (self.centre[0] + r * math.cos(a), self.centre[1] + r * math.sin(a),
                *self.start[2:])

    @property
    def end(self) -> tuple[float, ...]:
        return self.at(self.length)


Segment = Line | Arc


@dataclass(frozen=True)
class Leg:
    """One segment's speed profile: from `entry` ramp at `accel` to `peak`, cruise, ramp down
    to `exit`, over `length` counts of path."""

    length: float
    entry: float
    peak: float
    exit: float
    accel: float

    @property
    def ramp_up(self) -> float:
        return (self.peak - self.entry) / self.accel

    @property
    def ramp_down(self) -> float:
        return (self.peak - self.exit) / self.accel

    @property
    def cruise(self) -> float:
        """The distance at `peak` (what the two ramps leave)."""
        up = (self.peak ** 2 - self.entry ** 2) / (2 * self.accel)
        down = (self.peak ** 2 - self.exit ** 2) / (2 * self.accel)
        return max(0.0, self.length - up - down)

    @property
    def duration(self) -> float:
        if self.length <= 0:
            return 0.0
        return self.ramp_up + self.cruise / self.peak + self.ramp_down

    def s_at(self, tau: float) -> float:
        """Path coordinate within the leg, `tau` seconds after its start."""
        a, v, up = self.accel, self.peak, self.ramp_up
        if tau <= up:
            return self.entry * tau + a * tau * tau / 2
        s_up = (v * v - self.entry ** 2) / (2 * a)
        flat = self.cruise / v
        if tau <= up + flat:
            return s_up + v * (tau - up)
        w = min(tau - up - flat, self.ramp_down)
        return min(self.length, s_up + self.cruise + v * w - a * w * w / 2)


def junction_speeds(lengths: list[float], velocities: list[float],
                    ends: list[float | None], accel: float) -> list[float]:
    """The speed at the end of each segment (App C: `VV1000,1000` runs on, `VV1000,0` stops):
    at most the segment's vend (its velocity when None), the velocities on both sides and what
    `accel` reaches from the junction before (forward) and down to the one after (backward);
    the last is 0."""
    n = len(lengths)
    wanted = [v if e is None else e for v, e in zip(velocities, ends, strict=True)]
    cap = [min(velocities[i], velocities[i + 1], wanted[i]) for i in range(n - 1)] + [0.0]
    out: list[float] = []
    before = 0.0
    for i in range(n):
        before = min(cap[i], math.sqrt(before * before + 2 * accel * lengths[i]))
        out.append(before)
    for i in range(n - 2, -1, -1):
        out[i] = min(out[i], math.sqrt(out[i + 1] ** 2 + 2 * accel * lengths[i + 1]))
    return out


def plan_legs(lengths: list[float], velocities: list[float], ends: list[float | None],
              accel: float) -> list[Leg]:
    """Each segment's trapezoid between its junction speeds (a triangle when too short to
    reach its velocity)."""
    junctions = junction_speeds(lengths, velocities, ends, accel)
    legs, entry = [], 0.0
    for length, v, out in zip(lengths, velocities, junctions, strict=True):
        peak = min(v, math.sqrt(max(0.0, accel * length + (entry * entry + out * out) / 2)))
        legs.append(Leg(length, entry, max(peak, entry, out), out, accel))
        entry = out
    return legs


@dataclass
class Contour:
    """A contour being defined (`VP`, `VC`) and then run (after `VE`)."""

    axes: tuple[int, ...]
    start: tuple[float, ...]
    velocity: float  # VV v for the segments defined from now
    acceleration: float
    end_velocity: float | None = None  # VV ...,vend for them; None: run on
    segments: list[Segment] = field(default_factory=list)
    io_on: int = 0  # VIO bits for the next segment
    io_off: int = 0
    # the run
    t: float = 0.0
    total: float = 0.0
    legs: list[Leg] = field(default_factory=list)
    _bounds: list[float] = field(default_factory=list)  # s at each segment's start
    _starts: list[float] = field(default_factory=list)  # t at each segment's start

    @property
    def here(self) -> tuple[float, ...]:
        return self.segments[-1].end if self.segments else self.start

    def line_to(self, end: tuple[float, ...]) -> None:
        self.segments.append(Line(self.here, end, self.io_on, self.io_off, self.velocity,
                                  self.end_velocity))
        self.io_on = self.io_off = 0

    def arc(self, centre: tuple[float, float], degrees: float) -> None:
        self.segments.append(Arc(self.here, centre, math.radians(degrees), self.io_on,
                                 self.io_off, self.velocity, self.end_velocity))
        self.io_on = self.io_off = 0

    def moved_axes(self) -> tuple[int, ...]:
        """The axes the path moves: those whose coordinate changes, X and Y for an arc."""
        moved = {0, 1} if any(isinstance(s, Arc) for s in self.segments) else set()
        for seg in self.segments:
            moved |= {a for a, (p, q) in enumerate(zip(self.start, seg.end, strict=True))
                      if p != q}
        return tuple(sorted(moved)) or (0,)

    def plan(self) -> None:
        """At VE: the junction speeds, each segment's profile, where and when each starts."""
        segs = self.segments
        self.legs = plan_legs([s.length for s in segs], [s.velocity for s in segs],
                              [s.end_velocity for s in segs], self.acceleration)
        self._bounds, self._starts = [0.0], [0.0]
        for seg, leg in zip(segs, self.legs, strict=True):
            self._bounds.append(self._bounds[-1] + seg.length)
            self._starts.append(self._starts[-1] + leg.duration)
        self.total = self._bounds[-1]

    @property
    def duration(self) -> float:
        return self._starts[-1] if self._starts else 0.0

    def s_at(self, t: float) -> float:
        """Path coordinate at (override-stretched) time t."""
        if t <= 0 or self.total <= 0:
            return 0.0
        if t >= self.duration:
            return self.total
        i = min(bisect_right(self._starts, t) - 1, len(self.legs) - 1)
        return self._bounds[i] + self.legs[i].s_at(t - self._starts[i])

    def position(self, s: float) -> tuple[tuple[float, ...], int]:
        """Axis positions at s and the index of the segment it is in."""
        # the first segment that ends at or after s (a boundary belongs to the one ending there)
        i = min(bisect_left(self._bounds, s, 1) - 1, len(self.segments) - 1)
        seg = self.segments[i]
        return seg.at(min(s - self._bounds[i], seg.length)), i
