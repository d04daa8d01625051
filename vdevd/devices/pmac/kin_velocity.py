"""Inverse kinematics with velocities: PVT moves of a kinematic coordinate system [Turbo UM
"Kinematic Calculations", "Velocity Calculation Flag"; SRM OPEN INVERSE].

"In every move mode other than PVT mode, Turbo PMAC sets the variable Q10 for the coordinate
system to 0 automatically as a flag to the inverse-kinematic program not to compute velocity
values" [UM]: in PVT mode Q10 is 1, the axis velocities are in Q11-Q19 (A B C U V W X Y Z) beside
the positions in Q1-Q9, and the program leaves each `#xx->I` motor's velocity in P(100+xx) beside
its position in Pxx. Each PVT segment's end points are transformed so, and the motor follows the
cubic (Hermite) through its positions and velocities at both ends of the segment, as a PVT move
of its own, instead of the inverse of every servo cycle's axis positions.

ASSUMPTIONS: the velocity units are the PVT program's, axis units per Isx90 ms in Q11-Q19 and
counts per Isx90 ms in P101-P132; SPLINE moves keep Q10 = 0 (the UM names PVT only).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac.kinematics import Q_AXES, Q_VELOCITY_FLAG
from vdevd.devices.pmac.pieces import Piece

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

#: the axis velocities Q11-Q19; the motor velocities P101-P132
Q_VELOCITIES = Q_AXES + 10
P_VELOCITY = 100


def inverse_with_velocity(fw: Firmware, cs: int, motors: list[int], pos: np.ndarray,
                          vel: np.ndarray, per_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The motors' positions (counts) and velocities (counts/s) for axis positions `pos` and
    velocities `vel` (units/s): the inverse program with Q10 = 1."""
    q = fw.q[cs - 1]
    q[Q_AXES] = pos
    q[Q_VELOCITIES] = vel * per_s
    q[Q_VELOCITY_FLAG] = 1.0
    try:
        fw.kinematics.run(cs, "INVERSE")
    finally:
        q[Q_VELOCITY_FLAG] = 0.0
    p = np.array([fw.p[m] for m in motors], dtype=float)
    v = np.array([fw.p[P_VELOCITY + m] for m in motors], dtype=float) / per_s
    return p, v


def motor_cubic(start: tuple[np.ndarray, np.ndarray], end: tuple[np.ndarray, np.ndarray],
                dur: float) -> np.ndarray:
    """The cubic (4, motors) in the piece's own time through (p0, v0) at 0 and (p1, v1) at dur."""
    (p0, v0), (p1, v1) = start, end
    if dur <= 0:
        return np.stack([p1, np.zeros_like(p1), np.zeros_like(p1), np.zeros_like(p1)])
    d = p1 - p0
    c2 = (3 * d / dur - 2 * v0 - v1) / dur
    c3 = (-2 * d / dur + v0 + v1) / dur ** 2
    return np.stack([p0, v0, c2, c3])


def motor_cubics(fw: Firmware, cs: int, motors: list[int], pieces: list[Piece],
                 per_s: float) -> list[np.ndarray]:
    """Each piece's motor cubic (`motor_cubic`), the inverse run once per piece boundary."""
    out: list[np.ndarray] = []
    if not pieces:
        return out
    c = pieces[0].coef
    start = inverse_with_velocity(fw, cs, motors, c[0], c[1], per_s)
    for piece in pieces:
        p, v = piece.end()
        end = inverse_with_velocity(fw, cs, motors, p, v, per_s)
        out.append(motor_cubic(start, end, piece.dur))
        start = end
    return out
