"""The MAXk's velocity profiles of a move from rest, with a base velocity [S §2.14, App C; spec
oms.md §5.2]: linear (the default), parabolic and S-curve, chosen per axis (card option
`profiles`).

Every profile starts at VB at once, ramps up to a peak of at most VL, cruises, ramps down to VB
and stops from VB at the target, exactly in counts; a move too short to reach VL peaks lower, so
that it is a ramp up and a ramp down. The ramps differ:
- linear: acceleration AC throughout; a triangle peaks at sqrt(VB² + AC·|d|). Total time with
  VB = 0: |d|/VL + VL/AC (trapezoid) or 2·sqrt(|d|/AC) (triangle).
- parabolic: the acceleration starts at AC and falls linearly to 0 at the peak (the velocity is a
  parabola in time); the ramp down is its mirror in time. A ramp by Δv takes 2·Δv/AC and covers
  (2·Δv/AC)·(VB + 2·Δv/3); the short move's peak solves that in closed form.
- scurve: jerk-limited, the acceleration rises from 0 to AC and falls back to 0 over a ramp (the
  four jerk quarters of acceleration and deceleration), with the axis's jerk AC²/(VL − VB): a
  full ramp also takes 2·Δv/AC. A short move keeps that jerk and peaks lower, in speed and in
  acceleration (found by bisection).
The phases (constant jerk each) go into the core's profile generator (`MotionCore.move_planned`);
the last one holds the integer target.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from vdevd.rt.profiles import Phase, Segment, to_phases
from vdevd.rt.profiles import ramp as jerk_ramp
from vdevd.rt.profiles import ramp_distance as jerk_ramp_distance

INF = math.inf

#: a profile's planner: (t, p, goal, vb, vl, ac) -> the phases from time t at rest at p to rest
#: at the integer goal
Planner = Callable[[float, float, float, float, float, float], list[Phase]]


def linear(t: float, p: float, goal: float, vb: float, vl: float, ac: float) -> list[Phase]:
    """Phases from time t at rest at p to rest at the integer `goal`: VB jump, AC ramp, VL
    cruise, AC ramp down to VB, stop."""
    d = goal - p
    if d == 0:
        return [Phase(t, INF, goal, 0.0, 0.0, 0.0)]
    s, length = math.copysign(1.0, d), abs(d)
    vb = min(vb, vl)
    peak = min(vl, math.sqrt(vb * vb + ac * length))
    ramp = (peak - vb) / ac
    ramp_distance = (peak * peak - vb * vb) / (2 * ac)
    cruise = max(0.0, (length - 2 * ramp_distance) / peak)
    phases = [Phase(t, ramp, p, s * vb, s * ac, 0.0),
              Phase(t + ramp, cruise, p + s * ramp_distance, s * peak, 0.0, 0.0),
              Phase(t + ramp + cruise, ramp, goal - s * ramp_distance, s * peak, -s * ac, 0.0)]
    end = Phase(t + 2 * ramp + cruise, INF, goal, 0.0, 0.0, 0.0)
    return [ph for ph in phases if ph.dur > 0] + [end]


def parabolic(t: float, p: float, goal: float, vb: float, vl: float, ac: float) -> list[Phase]:
    """Phases from time t at rest at p to rest at the integer `goal`: VB jump, a ramp whose
    acceleration falls linearly from AC to 0 (one phase of constant jerk), cruise, the mirror
    ramp down to VB, stop."""
    d = goal - p
    if d == 0:
        return [Phase(t, INF, goal, 0.0, 0.0, 0.0)]
    s, length = math.copysign(1.0, d), abs(d)
    vb = min(vb, vl)
    dv = vl - vb
    if 2 * _parabolic_distance(vb, dv, ac) > length:
        # 2·(2·dv/AC)·(VB + 2·dv/3) = |d|, the root of (8/3)·dv² + 4·VB·dv − AC·|d| = 0
        # in the form that does not cancel when VB is large
        dv = 2 * ac * length / (4 * vb + math.sqrt(16 * vb * vb + 32 / 3 * ac * length))
    peak = vb + dv
    segs: list[Segment] = []
    if dv > 0:
        rise = 2 * dv / ac
        segs.append((rise, -s * ac / rise, s * ac))
    cruise = (length - 2 * _parabolic_distance(vb, dv, ac)) / peak if peak > 0 else 0.0
    if cruise > 0:
        segs.append((cruise, 0.0, 0.0))
    if dv > 0:
        segs.append((rise, -s * ac / rise, 0.0))
    return to_phases(t, p, s * vb, 0.0, segs, hold=goal)


def _parabolic_distance(vb: float, dv: float, ac: float) -> float:
    """Distance of a parabolic ramp from VB by dv: its time 2·dv/AC times its mean velocity."""
    return 2 * dv / ac * (vb + 2 * dv / 3)


def scurve(t: float, p: float, goal: float, vb: float, vl: float, ac: float, *,
           jerk: float | None = None) -> list[Phase]:
    """Phases from time t at rest at p to rest at the integer `goal`: VB jump, a jerk-limited
    ramp (acceleration at most AC, jerk at most `jerk`), cruise, the mirror ramp down to VB,
    stop. The card's jerk is AC²/(VL − VB), which makes a full ramp 0 → AC → 0 with no constant
    acceleration; a larger `jerk` gives the constant-acceleration segments of the 7-segment
    profile."""
    d = goal - p
    if d == 0:
        return [Phase(t, INF, goal, 0.0, 0.0, 0.0)]
    s, length = math.copysign(1.0, d), abs(d)
    vb = min(vb, vl)
    if jerk is None:
        jerk = ac * ac / (vl - vb) if vl > vb else INF

    def distance(peak: float) -> float:
        return 2 * jerk_ramp_distance(vb, peak, ac, jerk)

    peak = vl
    if distance(vl) > length:  # a lower peak: bisection on the monotonic ramp distance
        lo, hi = vb, vl
        for _ in range(200):
            mid = (lo + hi) / 2
            if not lo < mid < hi:
                break
            if distance(mid) > length:
                hi = mid
            else:
                lo = mid
        peak = lo
    segs = jerk_ramp(vb, peak, ac, jerk)
    cruise = (length - distance(peak)) / peak if peak > 0 else 0.0
    if cruise > 0:
        segs.append((cruise, 0.0, 0.0))
    segs += jerk_ramp(peak, vb, ac, jerk)
    return to_phases(t, p, s * vb, 0.0, [(dur, s * j, s * a) for dur, j, a in segs], hold=goal)


#: the planner of each value of the card option `profiles` (params.PROFILES)
PLANNERS: dict[str, Planner] = {"linear": linear, "parabolic": parabolic, "scurve": scurve}


def planner(name: str) -> Planner:
    """The planner of a profile name; ValueError if the card has no such profile."""
    if name not in PLANNERS:
        raise ValueError(f"profiles: {name!r} is not one of {list(PLANNERS)}")
    return PLANNERS[name]
