"""PVT mode: position-velocity-time segments [Turbo SRM "PVT{data}", "{axis}{data}:{data}";
Turbo UM "PVT-Mode Moves"].

`PVT{t}` sets the segment time in ms; each move `X{p}:{v}` gives the end position (or distance,
ABS/INC resolved by the runner) and the signed end velocity of every axis it names, in user units
per Isx90 ms. From the start position and velocity (the end of the previous segment), the end
position and velocity and the segment time the card computes "the unique cubic position profile
(parabolic velocity profile)": the Hermite cubic. An axis named without a velocity, and an axis
not named, ends its segment at zero velocity (SRM: "if no velocity is given for the segment,
Turbo PMAC assumes an ending velocity of zero").

Segment time: with I42 = 0 (default) the time is held with 12 bits of fraction, 0 to 4095.9998
ms; with I42 = 1 it is rounded to whole ms, up to 8,388,607 [SRM PVT]. TA, TS and F do nothing
here. A zero segment time stops the program with a run-time error (ASSUMPTION: the SRM only says
the time is positive).

End of a PVT sequence (a mode change, DWELL, the end of the program): the card adds nothing; the
trajectory stops at the last programmed point, so a last segment with a non-zero end velocity
stops abruptly there (ASSUMPTION: the manuals only advise ending on zero velocity, "BLOCKSTART
... the last of which has a zero end velocity").

A stop command (Q, `/`) that ends the motion on a point of non-zero velocity adds a deceleration
(`PvtPlanner.stop`): from that point the axes go on along their velocity vector and slow at a
constant rate to rest, in the PVT segment time or longer, as long as no motor decelerates faster
than its Ixx15 (the SRM's "controlled stop" rate of A); they stop v·T/2 past the point, and R
goes on from there (ASSUMPTION: the manuals retrieved say nothing of a PVT stop on a moving point).

Streamed into a rotary buffer (README "Rotary buffers"), a segment is final at once, so nothing
runs on while the next point is awaited: a point in the buffer before the servo cycle in which
the segment before it ends gives the stored program's trajectory; a later one finds the sequence
ended (`flush`) on the last point and its segment starts from rest (ASSUMPTION: the cycle).
"""

from __future__ import annotations

from typing import cast

import numpy as np

from vdevd.devices.pmac.pieces import NAXES, Move, Piece, Planner
from vdevd.devices.pmac.planerr import RUN_TIME_ERROR, PlanError

#: I42 = 0: the PVT time register holds ms with 12 fraction bits, below 4096 ms [SRM PVT]
FRACTION = 4096
MAX_MS_FRACTIONAL = 4096 - 1 / FRACTION
#: I42 = 1: whole ms up to 2^23 - 1
MAX_MS_WHOLE = 8_388_607


def velocity_per_second(v: float, isx90: float) -> float:
    """A programmed velocity (units per Isx90 ms) in units per second [SRM "{axis}{data}:{data}"]."""
    return v * 1000.0 / isx90


def segment_time(seconds: float, i42: int = 0) -> float:
    """The segment time the card holds for a PVT time given in seconds [SRM PVT: I42]."""
    ms = seconds * 1000.0
    if i42:
        ms = min(float(round(ms)), MAX_MS_WHOLE)
    else:
        ms = min(round(ms * FRACTION) / FRACTION, MAX_MS_FRACTIONAL)
    return ms / 1000.0


def hermite_pieces(pos: np.ndarray, vel: np.ndarray, dur: np.ndarray) -> list[Piece]:
    """The Hermite cubics through `pos[k]`/`vel[k]` (shape (n+1, NAXES)) with durations `dur[k]`
    (shape (n,)), all at once: the PVT segment form for many points."""
    d = dur[:, None]
    p0, p1, v0, v1 = pos[:-1], pos[1:], vel[:-1], vel[1:]
    dp = p1 - p0
    c2 = (3 * dp - (2 * v0 + v1) * d) / (d * d)
    c3 = ((v0 + v1) * d - 2 * dp) / (d * d * d)
    coef = np.stack([p0, v0, c2, c3], axis=1).astype(float)   # (n, 4, NAXES)
    return [Piece(float(t), c) for t, c in zip(dur, coef, strict=True)]


def decelerate(p: np.ndarray, v: np.ndarray, dur: float) -> Piece:
    """From (p, v) to rest at constant deceleration v/dur: the Hermite to p + v·dur/2, 0."""
    dur = dur if dur > 0 else 1e-3
    return Piece.hermite(p, v, p + v * dur / 2, np.zeros(NAXES), dur)


class PvtPlanner(Planner):
    """PVT segments: each move is final at once (no blending), so `add` returns its piece."""

    def __init__(self, start: np.ndarray, velocity: np.ndarray | None = None) -> None:
        super().__init__(start)
        self.velocity = (np.zeros(NAXES) if velocity is None
                         else np.array(velocity, dtype=float))
        self.seg_time = 0.0   # the last segment's time, s (the stop's shortest time)

    def add(self, move: Move) -> list[Piece]:
        """The segment to `move.target`: params "PVT" (seconds), "V" (end velocities, units/s,
        per axis; missing or unnamed axes 0), optional "I42"."""
        dur = segment_time(float(cast(float, move.params["PVT"])),
                           int(cast(int, move.params.get("I42", 0))))
        if dur <= 0:
            raise PlanError(RUN_TIME_ERROR, "PVT segment time 0")
        v = move.params.get("V")
        end_v = np.zeros(NAXES) if v is None else np.array(v, dtype=float)
        end_v = np.where(move.named, end_v, 0.0)
        piece = Piece.hermite(self.position, self.velocity, move.target.astype(float), end_v, dur)
        self.seg_time = dur
        self.position = move.target.astype(float)
        self.velocity = end_v
        return [piece]

    def stop(self, min_time: float = 0.0) -> list[Piece]:
        """Q or `/` (module docstring): the deceleration to rest from the last point, constant
        along the velocity vector, in max(segment time, `min_time`) seconds; none at rest."""
        if not np.any(self.velocity):
            return []
        piece = decelerate(self.position, self.velocity, max(self.seg_time, min_time))
        self.position = piece.end()[0]
        self.velocity = np.zeros(NAXES)
        return [piece]

    def flush(self) -> list[Piece]:
        """Nothing to add: the sequence ends at its last point (module docstring)."""
        self.velocity = np.zeros(NAXES)
        return []
