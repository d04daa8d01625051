"""Helpers of the planner tests: axis vectors and sampling `Piece` lists."""

from __future__ import annotations

import numpy as np

from vdevd.devices.pmac.pieces import NAXES, Move, Piece

AX = {a: k for k, a in enumerate("ABCUVWXYZ")}


def vec(**axes: float) -> np.ndarray:
    """A nine-axis vector from letters: vec(X=1, Y=2)."""
    v = np.zeros(NAXES)
    for a, x in axes.items():
        v[AX[a]] = x
    return v


def move(target: np.ndarray, names: str, **params: object) -> Move:
    named = np.array([a in names for a in "ABCUVWXYZ"])
    return Move(target, named, dict(params))


def sample(pieces: list[Piece], dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, positions and velocities every `dt` through the pieces, plus the very end."""
    ends = np.cumsum([p.dur for p in pieces])
    ts = np.append(np.arange(0.0, ends[-1], dt), ends[-1])
    which = np.minimum(np.searchsorted(ends, ts, side="right"), len(pieces) - 1)
    ps, vs = [], []
    for t, k in zip(ts, which, strict=True):
        pos, vel = pieces[k].at(float(t - (ends[k] - pieces[k].dur)))
        ps.append(pos)
        vs.append(vel)
    return ts, np.array(ps), np.array(vs)


def total(pieces: list[Piece]) -> float:
    return float(sum(p.dur for p in pieces))


def joints(pieces: list[Piece]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """(end pos, end vel) of each piece with (start pos, start vel) of the next."""
    out = []
    for a, b in zip(pieces, pieces[1:], strict=False):
        pa, va = a.end()
        pb, vb = b.at(0.0)
        out.append((pa, va, pb, vb))
    return out


def accel(piece: Piece, tau: float) -> np.ndarray:
    c = piece.coef
    return 2 * c[2] + 6 * c[3] * tau
