"""The MAXk's linear (trapezoid) velocity profile with a base velocity [S §2.14; spec oms.md §5.2].

A move from rest starts at VB at once, ramps at AC to VL, cruises, ramps down at AC to VB and
stops from VB at the target, exactly in counts. When the distance is too short to reach VL it is
a triangle whose peak is sqrt(VB² + AC·|d|). Total time with VB = 0: |d|/VL + VL/AC (trapezoid)
or 2·sqrt(|d|/AC) (triangle). The phases go into the core's profile generator
(`MotionCore.move_planned`); the last one holds the target.
"""

from __future__ import annotations

import math

from vdevd.rt.profiles import Phase

INF = math.inf


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

