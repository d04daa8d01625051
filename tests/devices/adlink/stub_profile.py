"""A constant-acceleration trapezoid with the interface of `vdevd.devices.adlink.profile` (written in
parallel), so the group engine can be tested on its own; the S-factor is ignored."""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class StubPlan:
    v0: float
    distance: float
    end_velocity: float
    phases: list[tuple[float, float]]  # (duration, acceleration)
    endless: bool = False
    segs: list[tuple[float, float, float, float]] = field(default_factory=list)  # (t, s, v, a) at starts

    def __post_init__(self) -> None:
        t, s, v = 0.0, 0.0, self.v0
        for duration, a in self.phases:
            self.segs.append((t, s, v, a))
            t, s, v = t + duration, s + v * duration + 0.5 * a * duration * duration, v + a * duration
        self._duration = t

    def duration(self) -> float:
        return self._duration

    def state(self, t: float) -> tuple[float, float, float]:
        if t >= self._duration:
            return self.distance, self.end_velocity, 0.0
        t = max(t, 0.0)
        for t0, s0, v0, a in reversed(self.segs):
            if t >= t0:
                tau = t - t0
                return min(s0 + v0 * tau + 0.5 * a * tau * tau, self.distance), v0 + a * tau, a
        raise AssertionError("unreachable")

    def decel_start(self) -> float:
        for t0, _, _, a in self.segs:
            if a < 0:
                return t0
        return self._duration

    def phase_at(self, t: float) -> int:
        if t >= self._duration:
            return 0
        a = self.state(t)[2]
        return 1 if a > 0 else 2 if a == 0 else 3

    def time_at(self, s: float) -> float:
        if s >= self.distance:
            return self._duration
        for (t0, s0, v0, a), (duration, _) in zip(reversed(self.segs), reversed(self.phases), strict=True):
            if s >= s0:
                if a == 0:
                    return t0 + (s - s0) / v0
                root = math.sqrt(max(v0 * v0 + 2 * a * (s - s0), 0.0))
                return t0 + min((root - v0) / a, duration)
        return 0.0


def plan_ptp(distance: float, vs: float, vm: float, ve: float, acc: float, dec: float, sf: float) -> StubPlan:
    if distance <= 0.0:
        return StubPlan(vs, 0.0, ve, [])
    a1 = acc if vm >= vs else -dec
    d1 = (vm * vm - vs * vs) / (2 * a1)
    d3 = (vm * vm - ve * ve) / (2 * dec)
    vp = vm
    if d1 + d3 > distance:
        vp = math.sqrt((2 * distance * acc * dec + dec * vs * vs + acc * ve * ve) / (acc + dec))
        d1 = (vp * vp - vs * vs) / (2 * a1)
        d3 = (vp * vp - ve * ve) / (2 * dec)
    phases = [((vp - vs) / a1, a1), ((distance - d1 - d3) / vp, 0.0), ((vp - ve) / dec, -dec)]
    return StubPlan(vs, distance, ve, [(d, a) for d, a in phases if d > 0])


def plan_stop(v0: float, dec: float, sf: float) -> StubPlan:
    return StubPlan(v0, v0 * v0 / (2 * dec), 0.0, [(v0 / dec, -dec)] if v0 > 0 else [])
