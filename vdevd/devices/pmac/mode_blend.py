"""Blending between LINEAR and CIRCLE moves [Turbo SRM "LINEAR", "CIRCLE1", "CIRCLE2", Isx13;
Turbo UM "Circular Interpolation": a sequence of LINEAR and CIRCLE moves blends as LINEAR moves
do, TA/TS at each corner, without a stop].

In segmentation mode (Isx13 > 0, the mode in which CIRCLE moves are arcs) a change between
LINEAR, CIRCLE1 and CIRCLE2 does not end the sequence: the CIRCLE planner (circle.py) carries it
on, taking LINEAR moves as straight elements of its path, with the same TA/TS blend along the
path at each boundary; a LINEAR sequence running into a CIRCLE move hands its last move, still
held at its speed, over to the CIRCLE planner as the first element. A sequence of LINEAR moves
alone keeps the LINEAR planner (corner rounding, Ixx16/Ixx17). The blend at a LINEAR/CIRCLE
boundary is circle.py's (each move's displacement blended over TA/TS, the corner cut).
ASSUMPTION: Isx13 = 0 keeps the stop at each change (CIRCLE moves are then straight LINEAR-like
moves of their own planner).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac import blend
from vdevd.devices.pmac.circle import DEFAULT_FRAX, CirclePlanner, _Element
from vdevd.devices.pmac.linear import LinearPlanner

if TYPE_CHECKING:
    from vdevd.devices.pmac.program_runner import CsProgram

BLENDED = ("LINEAR", "CIRCLE1", "CIRCLE2")


def carry_on(r: CsProgram, new_mode: str) -> bool:
    """At a move-mode statement: True when the sequence goes on in the CIRCLE planner (which
    `r.planner` now is), False when the runner ends it as before."""
    iv = r.fw.ivars.values
    if not iv[5000 + 100 * r.cs + 13] or new_mode not in BLENDED or r.mode not in BLENDED:
        return False
    p = r.planner
    if isinstance(p, CirclePlanner):
        return True
    if isinstance(p, LinearPlanner) and new_mode != "LINEAR":
        prm = r._params()
        frax = np.asarray(prm.get("FRAX", DEFAULT_FRAX), dtype=bool)
        r.planner = from_linear(p, frax, float(prm["SEG"]),
                                blend.widths(float(prm["TA"]), float(prm["TS"])))
        return True
    return False


def from_linear(p: LinearPlanner, frax: np.ndarray, seg: float,
                stop: tuple[float, float]) -> CirclePlanner:
    """A CIRCLE planner that goes on from where the LINEAR planner's pieces end: its held move
    (from `tail` to the corner at `vel`, `left` seconds) becomes a straight first element already
    at speed (no blend at its start), segmented every `seg` s, stopping in the LINEAR moves'
    TA/TS kernel `stop` when the sequence ends on it (Q, `/`)."""
    c = CirclePlanner(p.position)
    c.seg = seg
    if not p.vel.any() or p.left <= 0:
        return c
    d = p.position - p.tail
    length = float(np.linalg.norm(d[frax])) or float(np.linalg.norm(d)) or 1.0
    z = np.zeros(3)
    c.elements.append(_Element(p.tail.copy(), p.position.copy(), False, z, z, z, z, 0.0, 0.0,
                               0.0, 0.0, length, length / p.left, 0.0, p.left,
                               blend.widths(0.0, 0.0), stop))
    return c
