"""The jog-type profile of a Turbo PMAC motor from its I-variables, no state [SRM p.100-101,
Ixx19-Ixx22; A L3286]: what `Motors` gives the motion core for jogs, J/, jogs to a position and
the post-trigger move of a home search. Speeds in counts/ms as the I-variables have them;
accelerations and jerks in counts/s^2 and counts/s^3 as the core has them.
"""

from __future__ import annotations

import numpy as np


def jog_accel(values: np.ndarray, m: int, dv: float) -> tuple[float, float]:
    """(acceleration counts/s^2, jerk counts/s^3) of motor m (0-based; `values` the I-variables)
    for a jog-type velocity change of dv counts/ms [SRM p.100-101]: accel time Ixx20, S-curve
    time Ixx21 (pure S-curve of 2*Ixx21 when Ixx21 > Ixx20/2), every time lengthened in
    proportion so that the peak acceleration does not exceed Ixx19; Ixx20 = Ixx21 = 0 is taken
    as 1 ms."""
    base = 100 * (m + 1)
    ta, ts, amax = float(values[base + 20]), float(values[base + 21]), float(values[base + 19])
    if ta <= 0 and ts <= 0:
        ta = 1.0
    total = max(ta, 2 * ts)
    ts = min(ts, total / 2)
    acc = abs(dv) / (total - ts) if dv else (amax if amax > 0 else 1.0)
    if amax > 0 and acc > amax:
        ts *= acc / amax
        acc = amax
    jerk = acc / ts if ts > 0 else 0.0
    return acc * 1e6, jerk * 1e9


def jog_speed(values: np.ndarray, m: int, to_position: bool = False) -> float:
    """|Ixx22| of motor m, counts/ms; a jog to a position saturates at 768M/Ixx08 counts/s
    (V1.938, was 256M/Ixx08 [A L3286])."""
    speed = abs(float(values[100 * (m + 1) + 22]))
    if to_position:
        speed = min(speed, 768e6 / float(values[100 * (m + 1) + 8]) / 1000)
    return speed
