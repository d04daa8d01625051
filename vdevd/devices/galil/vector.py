"""The path planner of coordinated motion: linear (LI) and vector (VP, CR) segments, sampled
once a servo period (manual ch. 6 "Linear Interpolation Mode", "Vector Mode").

Pure: no card, no axes. A `Sequence` holds the segment buffer (at most `MAX_SEGMENTS` waiting,
[M Ch6 §Specifying Linear Segments]) and moves a point along the path every sample: the vector
speed VS (times the ratio VR) with trapezoidal ramps of VA and VD along the path, `<n` (VS n from
the segment's start) and `>m` (speed m at the segment's end, one pending at a time) per segment
[M Ch6 §Specifying Vector Speed for Each Segment], LE/VE (decelerate to a stop at the end; without
it the motion stops at once at the last vector), ST (decelerate at VD) and VT (S-curve: a moving
average of 1/VT samples over the path position, as IT smooths independent moves, spec §5.3).
Positions are in the sequence's local coordinates (0 where BGS started it) [M Ch6 §Specifying
Vector Segments]; arcs are evaluated on their circle, so every sample lies on the radius.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

#: segments the buffer holds: LM? reads 511 when it is empty [M Ch6 §Specifying Linear Segments]
MAX_SEGMENTS = 511
#: the longest segment and the wrap of _LE / LE? (spec §4.3 TC 31; [M Ch6] "resets after
#: 2147483647")
MAX_LENGTH = 2_147_483_647.0
#: how close to a whole count a computed end point snaps to it (trig noise: cos 90 deg)
_SNAP = 1e-7


def _snap(x: float) -> float:
    r = round(x)
    return float(r) if abs(x - r) < _SNAP else x


@dataclass
class Segment:
    """One segment: a line from `start` to `end` (any number of coordinates), or an arc of the
    plane's circle of `radius` about `center` from angle `theta0` through `dtheta` (radians,
    CCW positive) [M Ch6 §Specifying Vector Segments]. `speed` is `<n`, `end_speed` is `>m`."""

    start: tuple[float, ...]
    end: tuple[float, ...]
    length: float
    speed: float | None = None
    end_speed: float | None = None
    center: tuple[float, float] | None = None
    radius: float = 0.0
    theta0: float = 0.0
    dtheta: float = 0.0
    s0: float = 0.0  # where it starts along the sequence

    def point(self, u: float) -> tuple[float, ...]:
        """The point `u` counts along the segment (0 <= u <= length)."""
        if self.center is None:
            f = u / self.length
            return tuple(a + (b - a) * f for a, b in zip(self.start, self.end, strict=True))
        ang = self.theta0 + self.dtheta * (u / self.length)
        cx, cy = self.center
        return (cx + self.radius * math.cos(ang), cy + self.radius * math.sin(ang))

    def heading(self, u: float) -> float:
        """The direction of travel at `u`, radians (lines: constant; arcs: the tangent)."""
        if self.center is None:  # in the plane of the first two coordinates
            dy = self.end[1] - self.start[1] if len(self.end) > 1 else 0.0
            return math.atan2(dy, self.end[0] - self.start[0])
        ang = self.theta0 + self.dtheta * (u / self.length)
        return ang + math.copysign(math.pi / 2, self.dtheta)


def line(start: tuple[float, ...], end: tuple[float, ...], speed: float | None = None,
         end_speed: float | None = None) -> Segment:
    """A straight segment (LI increments added to `start`, or VP's end point)."""
    length = math.sqrt(sum((b - a) ** 2 for a, b in zip(start, end, strict=True)))
    return Segment(start, end, length, speed, end_speed)


def arc(start: tuple[float, float], radius: float, theta_deg: float, dtheta_deg: float,
        speed: float | None = None, end_speed: float | None = None) -> Segment:
    """CR r,θ,Δθ from `start`: the circle's center is where `start` sits at angle θ; the arc
    ends at θ + Δθ [M Ch6 §Specifying Vector Segments]."""
    t0, dt = math.radians(theta_deg), math.radians(dtheta_deg)
    cx = start[0] - radius * math.cos(t0)
    cy = start[1] - radius * math.sin(t0)
    end = (_snap(cx + radius * math.cos(t0 + dt)), _snap(cy + radius * math.sin(t0 + dt)))
    return Segment(start, end, radius * abs(dt), speed, end_speed, (cx, cy), radius, t0, dt)


class Sequence:
    """The segments of one coordinate plane and the motion along them. Segments are numbered
    from 0 in the order given; `waiting` holds those from `base` on (the buffer)."""

    def __init__(self, dims: int, dt: float) -> None:
        self.dims = dims
        self.dt = dt
        self.waiting: deque[Segment] = deque()
        self.base = 0  # the number of the first segment in `waiting`
        self.count = 0  # segments given
        self.last_end: tuple[float, ...] = (0.0,) * dims  # where the next segment starts
        self.total = 0.0  # the length given so far (_LE)
        self.ended = False  # LE / VE given
        self.started = False  # BGS given
        self.done = False  # the motion has ended (complete, stopped or aborted)
        self.stopping = False  # ST: decelerate to a stop at VD
        self.s = 0.0  # the raw path (before VT's smoothing)
        self.v = 0.0
        self.out = 0.0  # the smoothed path: where the axes are (_AV)
        self.completed = 0  # segments the output has passed (_CS)
        self.raw = 0  # the segment the raw path is in
        self.speed: float | None = None  # the `<n` in force since the raw path entered its segment
        self._window: deque[float] = deque([0.0])
        self._window_sum = 0.0
        self._heading: float | None = None  # the output's last heading (TN), unwrapped
        self.first_heading = 0.0  # the direction the first segment starts in (_TN)
        # caches of the sample path (None: look again): the output's segment, where the raw
        # path's segment ends, the next `>m` ahead (its end along the path, its speed)
        self._out_seg: Segment | None = None
        self._raw_end = -math.inf
        self._brake: tuple[float, float] | None = None
        self._brake_dirty = True

    # -- the buffer --------------------------------------------------------------------------------
    @property
    def free(self) -> int:
        """_LM: the segments that can still be given (511 when the buffer is empty; a sequence
        that has ended, stopped or been aborted left nothing in it)."""
        if self.done:
            return MAX_SEGMENTS
        return MAX_SEGMENTS - (self.count - min(self.completed, self.count))

    def add(self, seg: Segment) -> None:
        """Append a segment that starts at `last_end` (the caller checked room and length)."""
        seg.s0 = self.total
        if not self.count:
            self.first_heading = seg.heading(0.0)
        self.waiting.append(seg)
        self.count += 1
        self.total += seg.length
        self.last_end = seg.end
        self._out_seg = None
        self._brake_dirty = True

    def segment(self, k: int) -> Segment:
        """Segment number k (clamped to those in the buffer)."""
        w = self.waiting
        return w[min(max(k - self.base, 0), len(w) - 1)]

    # -- the motion --------------------------------------------------------------------------------
    def start(self, smoothing: int) -> None:
        """BGS: the path starts at 0, at rest; `smoothing` samples of VT's moving average."""
        self.started = True
        self._window = deque([0.0] * max(1, smoothing))
        self._window_sum = 0.0
        first = self.waiting[0] if self.waiting else None
        self.speed = first.speed if first is not None else None

    def advance(self, vs: float, va: float, vd: float) -> bool:
        """One sample: the raw path and the output move; False once the motion has ended (the
        output at rest where the raw path stopped for good). `vs` is VS x VR."""
        if self.done:
            return False
        self._advance_raw(vs, va, vd)
        win = self._window
        s = self.s
        if len(win) > 1:
            win.append(s)
            self._window_sum += s - win.popleft()
            # the average lies between the output's last place and the raw path (a running
            # sum drifts by rounding): keep it there, so the output never goes back
            self.out = min(max(self._window_sum / len(win), self.out), s)
        else:
            self.out = s
        at_rest = self.v == 0.0 and (self.stopping or (self.ended and s >= self.total))
        if at_rest and (len(win) <= 1 or all(x == s for x in win)):
            self.out = s
            self.done = True
        out, count = self.out, self.count
        seg = self._out_seg or self._out_segment()
        while self.completed < count and out >= seg.s0 + seg.length - 1e-9:
            self.completed += 1
            seg = self._out_seg = self.segment(self.completed)
        if self.base < self.completed - 1:
            self._release()
        return not self.done

    def _advance_raw(self, vs: float, va: float, vd: float) -> None:
        if self.stopping:
            vs = 0.0
        elif self.speed is not None:
            vs = self.speed * self.ratio
        v, dt = self.v, self.dt
        target = min(v + va * dt, vs) if v <= vs else max(v - vd * dt, vs)
        # braking: the end of an ended sequence and the next `>m` ahead (one at a time)
        s, ddt = self.s, vd * dt
        if self.ended:
            c = 2.0 * vd * (self.total - s) - ddt * v
            cap = 0.0 if c < 0.0 else 0.5 * (-ddt + math.sqrt(ddt * ddt + 4.0 * c))
            if cap < target:
                target = cap
        if self._brake_dirty:
            self._brake = self._next_brake()
        brake = self._brake
        if brake is not None and brake[0] > s + 1e-9:
            v_end = brake[1]
            c = v_end * v_end + 2.0 * vd * (brake[0] - s) - ddt * v
            cap = v_end if c < 0.0 else 0.5 * (-ddt + math.sqrt(ddt * ddt + 4.0 * c))
            # never harder than VD: a speed that cannot be met is reached later [M Ch6]
            cap = max(cap, v - ddt)
            if cap < target:
                target = cap
        if target < 0.0:
            target = 0.0
        step = 0.5 * (v + target) * dt
        if self.s + step >= self.total - 1e-9:
            # the end of an ended sequence, or a starved buffer: the motion stops at once at
            # the last vector, without deceleration [M Ch6 §Specifying Linear Segments]
            self.s, self.v = self.total, 0.0
        else:
            self.s += step
            self.v = target
        self._enter_segments()

    ratio = 1.0  # VR, which scales `<n` as it scales VS [M Ch6 §Changing Feedrate]

    def _enter_segments(self) -> None:
        """The raw path passes into the next segment (the `<n` of one it enters applies)."""
        if self.s < self._raw_end - 1e-9:
            return
        while self.raw < self.count - 1:
            seg = self.segment(self.raw)
            if self.s < seg.s0 + seg.length - 1e-9:
                break
            self.raw += 1
            self._brake_dirty = True
            nxt = self.segment(self.raw)
            if nxt.speed is not None:
                self.speed = nxt.speed
        seg = self.segment(self.raw)
        self._raw_end = seg.s0 + seg.length

    def _next_brake(self) -> tuple[float, float] | None:
        """The first `>m` from the raw path's segment on: (its end along the path, m)."""
        self._brake_dirty = False
        for k in range(self.raw - self.base, len(self.waiting)):
            seg = self.waiting[k]
            if seg.end_speed is not None:
                return seg.s0 + seg.length, seg.end_speed
        return None

    def _out_segment(self) -> Segment:
        seg = self._out_seg = self.segment(self.completed)
        return seg

    def _release(self) -> None:
        """Segments both paths have passed leave the buffer (the last one stays: it places
        the output)."""
        w = self.waiting
        while self.base < min(self.completed, self.raw) and len(w) > 1:
            w.popleft()
            self.base += 1

    # -- where the output is -----------------------------------------------------------------------
    def _locate(self) -> tuple[Segment, float]:
        """The segment the output is in and the distance into it."""
        seg = self._out_seg or self._out_segment()
        u = self.out - seg.s0
        return seg, seg.length if u >= seg.length - 1e-9 else max(u, 0.0)

    def position(self) -> tuple[float, ...]:
        """The output's point in local coordinates."""
        if not self.waiting:
            return self.last_end
        seg, u = self._locate()
        return seg.end if u >= seg.length else seg.point(u)

    def heading(self) -> float:
        """The output's direction of travel, radians, unwrapped along the path (TN)."""
        if not self.waiting:
            return self._heading or 0.0
        seg, u = self._locate()
        h = seg.heading(u)
        if self._heading is not None:
            h += 2 * math.pi * round((self._heading - h) / (2 * math.pi))
        self._heading = h
        return h

    def intersection(self) -> tuple[float, ...]:
        """_VP: the last intersection the output passed (the start of its segment; at the end
        of the sequence its end)."""
        if not self.waiting:
            return self.last_end
        if self.completed >= self.count:
            return self.last_end
        return self.segment(self.completed).start
