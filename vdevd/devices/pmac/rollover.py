"""Rotary-axis position rollover, Ixx27, for programmed absolute moves of the A, B, C axes
[Turbo SRM Ixx27 "Motor xx Position Rollover Range"; V1.937 negative mode, A L3258].

Ixx27 > 0 (standard): an ABS move of an A/B/C axis whose motor has Ixx27 counts per revolution
takes the shortest way round to the destination modulo one revolution (never more than half a
revolution). Ixx27 < 0 (alternate): the destination's sign gives the direction and is part of the
value (A-90 goes to -90 = +270 degrees turning negative); every move is less than one revolution.
Incremental moves are not affected. The axis position itself is not wrapped: the programmed
position goes on from where the move ends (the motor position registers do not roll over).

ASSUMPTIONS: the revolution in axis units is |Ixx27| over the counts per unit of the first motor
of the C.S. defined to the axis alone (`#n->{scale}A`); a destination already on the present
point (modulo a revolution) does not move.
"""

from __future__ import annotations

import numpy as np

from vdevd.devices.pmac.coord import AXES
from vdevd.devices.pmac.pieces import NAXES

#: the rotary axes rollover applies to [SRM Ixx27]
ROTARY = np.array([a in "ABC" for a in AXES])


def revolutions(ixx27: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Per axis the signed revolution in axis units (0: no rollover), from the C.S.'s motors'
    Ixx27 (`ixx27`, one per row of `scale`, counts) and their scale matrix (counts per unit)."""
    rev = np.zeros(NAXES)
    for r in np.flatnonzero(ixx27).tolist():  # few motors, once per move with rollover set
        cols = np.flatnonzero(scale[r])
        if len(cols) != 1 or not ROTARY[cols[0]] or rev[cols[0]]:
            continue
        rev[cols[0]] = float(ixx27[r]) / abs(float(scale[r, cols[0]]))
    return rev


def destination(start: np.ndarray, target: np.ndarray, absolute: np.ndarray,
                rev: np.ndarray) -> np.ndarray:
    """The unwrapped end point of a move from `start` to the programmed `target` for the axes
    named in absolute mode (`absolute`), per the rollover mode of each axis (`rev`)."""
    out = target.copy()
    pos = absolute & (rev > 0)
    if pos.any():
        r = rev[pos]
        out[pos] = start[pos] + (np.mod(target[pos] - start[pos] + r / 2, r) - r / 2)
    neg = absolute & (rev < 0)
    if neg.any():
        r = -rev[neg]
        t, s = target[neg], start[neg]
        ahead = np.mod(np.mod(t, r) - s, r)      # turning positive
        back = np.mod(s - np.mod(t, r), r)       # turning negative
        out[neg] = s + np.where(t >= 0, ahead, -back)
    return out
