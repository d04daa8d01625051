"""The TA/TS blend of blended moves as a smoothing kernel: distance along a path in time
[Turbo SRM "TA{data}", "TS{data}"; Turbo UM "Linear Blended Moves"].

A blended move sequence runs every move at its own constant speed; at each boundary (the start,
between moves, the end) the speed changes over the acceleration time, centred on the boundary:
TS of S-curve (linearly changing acceleration) at both ends of a TA total, TA = 2·TS + TC; a TS
above TA/2 makes the total 2·TS [SRM TS]. That is the step of speed smoothed by a unit-area
trapezoid of total width max(TA, 2·TS) with ramps TS: the sum of two uniform variables of widths
`a` = width − TS and `b` = TS. `ramp` gives the distance fraction (the double integral of the
kernel), `ramp_rate` the speed fraction, both vectorised over times, centred on 0.
"""

from __future__ import annotations

import numpy as np

#: times below this (seconds) count as 0: the card holds TA and TS in whole ms
_TINY = 1e-9


def widths(ta: float, ts: float) -> tuple[float, float]:
    """The two uniform widths (a, b), a ≥ b, of the TA/TS kernel (seconds)."""
    ta, ts = (ta if ta > _TINY else 0.0), (ts if ts > _TINY else 0.0)
    total = max(ta, 2.0 * ts)
    b = min(ts, total / 2.0)
    return total - b, b


def _pos3(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0) ** 3


def _pos2(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0) ** 2


def ramp(t: np.ndarray, a: float, b: float) -> np.ndarray:
    """∫∫ kernel: 0 before −(a+b)/2, t after (a+b)/2, the S-curve blend between (seconds)."""
    w = a + b
    x = np.asarray(t, dtype=float) + w / 2.0
    if a <= _TINY:
        return np.maximum(x, 0.0)
    xc = np.clip(x, 0.0, w)      # the polynomials only inside the kernel (no cancellation)
    inside = (xc * xc / (2.0 * a) if b <= _TINY
              else (xc ** 3 - _pos3(xc - a) - _pos3(xc - b)) / (6.0 * a * b))
    return inside + np.maximum(x - w, 0.0)


def ramp_rate(t: np.ndarray, a: float, b: float) -> np.ndarray:
    """d ramp / dt: the kernel's cumulative distribution, 0 to 1."""
    w = a + b
    x = np.asarray(t, dtype=float) + w / 2.0
    if a <= _TINY:
        return (x >= 0.0).astype(float)
    xc = np.clip(x, 0.0, w)
    if b <= _TINY:
        return xc / a
    return np.clip((xc * xc - _pos2(xc - a) - _pos2(xc - b)) / (2.0 * a * b), 0.0, 1.0)


def breakpoints(a: float, b: float) -> np.ndarray:
    """Times (centred) where `ramp` changes polynomial: between them it is one cubic."""
    h = (a + b) / 2.0
    return np.unique(np.array([-h, -h + b, -h + a, h]))
