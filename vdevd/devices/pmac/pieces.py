"""Piecewise-cubic trajectories of a coordinate system's axes: what the move planners of a motion
program produce and the servo cycle samples [spec pmac.md §2.8 (programs)].

Every move mode the card has is a cubic (or is cut into cubics) in time per axis: a LINEAR or
RAPID move is constant-velocity sections joined by acceleration blends of TA/TS (a TS ramp is a
cubic); a PVT segment is the Hermite cubic of its end points and velocities [Turbo SRM "PVT"];
SPLINE1/2 are cubic B-splines; a CIRCLE move is segmented every Isx13 ms and the segments fitted
with cubics, as the card does. So a planner yields `Piece`s and the program runner only evaluates
them, vectorised over the nine axes.

Units: axis user units and seconds; an axis array has one column per letter of `coord.AXES`
(A B C U V W X Y Z), axes a move does not name hold their value.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: axes of a coordinate system (A B C U V W X Y Z, the order of coord.AXES)
NAXES = 9


@dataclass(frozen=True)
class Piece:
    """`dur` seconds of p(τ) = c0 + c1·τ + c2·τ² + c3·τ³ per axis, τ in seconds from the start of
    the piece; `coef` has shape (4, NAXES)."""

    dur: float
    coef: np.ndarray

    @staticmethod
    def hermite(p0: np.ndarray, v0: np.ndarray, p1: np.ndarray, v1: np.ndarray,
                dur: float) -> Piece:
        """The cubic from position/velocity (p0, v0) to (p1, v1) in `dur` seconds (the PVT
        segment's form)."""
        d = dur
        dp = p1 - p0
        c2 = (3 * dp - (2 * v0 + v1) * d) / (d * d)
        c3 = ((v0 + v1) * d - 2 * dp) / (d * d * d)
        return Piece(d, np.stack([p0, v0, c2, c3]).astype(float))

    @staticmethod
    def hold(p: np.ndarray, dur: float) -> Piece:
        """Standing still at `p` for `dur` seconds (DWELL, DELAY)."""
        z = np.zeros_like(p, dtype=float)
        return Piece(dur, np.stack([p.astype(float), z, z, z]))

    def at(self, tau: float) -> tuple[np.ndarray, np.ndarray]:
        """Position and velocity (units, units/s) at τ seconds into the piece."""
        c = self.coef
        pos = c[0] + tau * (c[1] + tau * (c[2] + tau * c[3]))
        vel = c[1] + tau * (2 * c[2] + tau * 3 * c[3])
        return pos, vel

    def end(self) -> tuple[np.ndarray, np.ndarray]:
        """Position and velocity at the end of the piece."""
        return self.at(self.dur)


@dataclass(frozen=True)
class Move:
    """One move statement as the program runner resolved it: where it goes, in which mode, with
    the coordinate system's move parameters at the time it was read [spec pmac.md §2.8].

    `target` holds every axis (ABS/INC resolved, axes not named keep their position), `named` the
    axes the statement names. `params` carries the mode's numbers by their program names, already
    in seconds and user units per second where they are times or speeds: "TA", "TS", "TM", "F"
    (and "FRAX" mask handling done by the runner), "PVT" (the segment time), "V" (per-axis
    end velocities for PVT, an array), "IJK" (circle centre vector, an array), "R" (radius),
    "NORMAL" (the circle plane normal, an array), "CIRCLE" (1 clockwise, 2 counter-clockwise),
    "SEG" (Isx13 segmentation time, 0 off), "MAXV"/"MAXA" (per-axis limits, arrays) where used."""

    target: np.ndarray
    named: np.ndarray
    params: dict[str, object]


class Planner:
    """A move mode's planner for one coordinate system (LINEAR, RAPID, CIRCLE, PVT, SPLINE): fed
    the moves in program order, it returns the pieces that are final so far. A planner that
    blends (LINEAR with TA/TS, SPLINE) holds back the end of its last move until the next move or
    `flush` tells it how to leave; the runner calls `flush` at a mode change, a DWELL/DELAY, the
    end of the program or a stop, and the pieces flushed end where the last move ends."""

    def __init__(self, start: np.ndarray) -> None:
        self.position = np.array(start, dtype=float)

    def add(self, move: Move) -> list[Piece]:
        raise NotImplementedError

    def flush(self) -> list[Piece]:
        return []
