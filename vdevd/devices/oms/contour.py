"""Vector (contour) paths: straight and circular segments run at a vector velocity (spec oms.md
§4.3 "Vector / contouring", App C example 3 [S App C L1360-1374]).

A path is planned when its definition ends (`VE`): its length, then a trapezoid of the path
coordinate s (VA to VV, down to rest at the end, or to the end velocity of `VV v,vend`), evaluated
in closed form every update cycle at a time that the velocity override `VO` (0-200 %) stretches.
Pure functions and a small state object; the firmware writes the positions into the core.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Line:
    start: tuple[float, ...]
    end: tuple[float, ...]
    io_on: int = 0
    io_off: int = 0

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


@dataclass
class Contour:
    """A contour being defined (`VP`, `VC`) and then run (after `VE`)."""

    axes: tuple[int, ...]
    start: tuple[float, ...]
    velocity: float
    acceleration: float
    segments: list[Segment] = field(default_factory=list)
    io_on: int = 0  # VIO bits for the next segment
    io_off: int = 0
    # the run
    t: float = 0.0
    total: float = 0.0
    _bounds: list[float] = field(default_factory=list)

    @property
    def here(self) -> tuple[float, ...]:
        return self.segments[-1].end if self.segments else self.start

    def line_to(self, end: tuple[float, ...]) -> None:
        self.segments.append(Line(self.here, end, self.io_on, self.io_off))
        self.io_on = self.io_off = 0

    def arc(self, centre: tuple[float, float], degrees: float) -> None:
        self.segments.append(Arc(self.here, centre, math.radians(degrees), self.io_on,
                                 self.io_off))
        self.io_on = self.io_off = 0

    def moved_axes(self) -> tuple[int, ...]:
        """The axes the path moves: those whose coordinate changes, X and Y for an arc."""
        moved = {0, 1} if any(isinstance(s, Arc) for s in self.segments) else set()
        for seg in self.segments:
            moved |= {a for a, (p, q) in enumerate(zip(self.start, seg.end, strict=True))
                      if p != q}
        return tuple(sorted(moved)) or (0,)

    def plan(self) -> None:
        self._bounds = [0.0]
        for seg in self.segments:
            self._bounds.append(self._bounds[-1] + seg.length)
        self.total = self._bounds[-1]
        v, a, d = self.velocity, self.acceleration, self.total
        if d <= 0:
            self.ramp = self.cruise = 0.0
            return
        if v * v / a > d:  # a triangle
            v = math.sqrt(a * d)
        self.peak = v
        self.ramp = v / a
        self.cruise = (d - v * v / a) / v

    @property
    def duration(self) -> float:
        return 2 * self.ramp + self.cruise if self.total > 0 else 0.0

    def s_at(self, t: float) -> float:
        """Path coordinate at time t of the trapezoid."""
        if self.total <= 0:
            return 0.0
        a, v, r, c = self.acceleration, self.peak, self.ramp, self.cruise
        if t <= 0:
            return 0.0
        if t < r:
            return a * t * t / 2
        if t < r + c:
            return a * r * r / 2 + v * (t - r)
        if t < 2 * r + c:
            u = 2 * r + c - t
            return self.total - a * u * u / 2
        return self.total

    def position(self, s: float) -> tuple[tuple[float, ...], int]:
        """Axis positions at s and the index of the segment it is in."""
        i = 0
        while i + 1 < len(self.segments) and s > self._bounds[i + 1]:
            i += 1
        seg = self.segments[i]
        return seg.at(min(s - self._bounds[i], seg.length)), i
