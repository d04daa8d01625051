"""SPLINE1 and SPLINE2 modes: cubic B-splines through the programmed points [Turbo UM "Cubic
Spline Mode", "Added Pieces"; PMAC UM "Splined Moves"].

Every move is one segment of the segment time. The card computes way-points WPi = (Pi-1 + 4Pi +
Pi+1)/6 and velocities Vi = (Pi+1 - Pi-1)/2T at the segment boundaries and runs the Hermite cubic
between them: the uniform cubic B-spline whose control points are the programmed points, so the
path passes inside them by (Disti+1 - Disti)/6 [UM]. At the beginning and the end of a sequence
it adds a zero-distance segment of the same time, so the axes start and stop with an S-curve:
n moves take n + 2 segment times [UM "Added Pieces"].

SPLINE1 keeps one segment time: a new time in the middle of a sequence brings the sequence to a
stop (its end segment is added) and starts a new one [PMAC UM]. SPLINE2 lets the time change per
segment; the manual says only that "similar calculations are done for the non-uniform spline":
ASSUMPTION, the non-uniform cubic B-spline whose knot intervals are the segment times (it is the
SPLINE1 spline when the times are equal). The segment time is the move's "TM" parameter when the
program set TM, else its "TA" (seconds) (ASSUMPTION: the Turbo SRM pages on SPLINE1 were not
retrieved; the PMAC manuals use TA, the digest TM).

A segment is final when the points it spans are known: with SPLINE1 the next point (the times
ahead are the segment time), with SPLINE2 the next two (the non-uniform spline's span depends on
the times around it), or at `flush`. `labels` tells the runner which returned piece begins which
move (the added start segment begins the first move), so its look-ahead counts the moves
executing as the path runs them (README "Calculation and look-ahead").
"""

from __future__ import annotations

from typing import cast

import numpy as np

from vdevd.devices.pmac.pieces import Move, Piece, Planner
from vdevd.devices.pmac.planerr import RUN_TIME_ERROR, PlanError

#: the cubic of a span is fitted exactly through its values at these fractions of the span
_FRACTIONS = np.array([0.0, 1 / 3, 2 / 3, 1.0])


def _de_boor(span: int, x: float, knots: list[float], ctrl: list[np.ndarray]) -> np.ndarray:
    """The cubic B-spline at `x` in knot span `span` (knots[span] <= x <= knots[span+1]): de
    Boor's algorithm, vectorised over the axes."""
    d = [ctrl[j + span - 3] for j in range(4)]
    for r in range(1, 4):
        for j in range(3, r - 1, -1):
            lo, hi = knots[j + span - 3], knots[j + 1 + span - r]
            alpha = (x - lo) / (hi - lo)
            d[j] = (1.0 - alpha) * d[j - 1] + alpha * d[j]
    return d[3]


def span_piece(span: int, knots: list[float], ctrl: list[np.ndarray]) -> Piece:
    """Knot span `span` of the B-spline as one cubic `Piece` (the span is a cubic; its values at
    four times fix it)."""
    t0, t1 = knots[span], knots[span + 1]
    dur = t1 - t0
    tau = _FRACTIONS * dur
    values = np.stack([_de_boor(span, t0 + t, knots, ctrl) for t in tau])
    vander = np.vander(tau, 4, increasing=True)
    coef = np.linalg.solve(vander, values)
    # the span's ends are the way-points exactly (no round-off drift from the solve)
    coef[0] = values[0]
    return Piece(float(dur), coef)


class SplinePlanner(Planner):
    """SPLINE1 (`uniform=True`) or SPLINE2 moves of one sequence at a time."""

    def __init__(self, start: np.ndarray, uniform: bool = True) -> None:
        super().__init__(start)
        self.uniform = uniform
        self._reset()

    def _reset(self) -> None:
        self.ctrl: list[np.ndarray] = []
        self.knots: list[float] = []
        self.emitted = 0          # spans emitted, counted from the first (span index 3)
        self.base = 0             # spans (and leading points and knots) dropped (`_trim`)
        self.seg_time = 0.0
        #: (index in the pieces last returned, moves before the last one added) of each piece
        #: that begins a move of the sequence
        self.labels: list[tuple[int, int]] = []

    def add(self, move: Move) -> list[Piece]:
        """One spline segment to `move.target` in the segment time: "TM" (seconds) when the
        program gave one, else "TA"."""
        tm = move.params.get("TM")
        t = float(cast(float, tm if tm is not None else move.params.get("TA", 0.0)))
        if t <= 0:
            raise PlanError(RUN_TIME_ERROR, "spline segment time 0")
        out: list[Piece] = []
        if self.ctrl and self.uniform and t != self.seg_time:
            out += self.flush()   # SPLINE1: a new segment time stops the sequence first
        before = [(k, lag + 1) for k, lag in self.labels] if out else []
        if not self.ctrl:          # the added zero-distance start segment [UM "Added Pieces"]
            p0 = self.position.copy()
            self.ctrl = [p0, p0, p0]
            self.knots = [0.0, t, 2 * t, 3 * t, 4 * t]
        self.seg_time = t
        self.ctrl.append(move.target.astype(float))
        self.knots.append(self.knots[-1] + t)
        self.position = move.target.astype(float)
        first = self.emitted
        ready = self._ready()
        self.labels = before + self._labels(first, len(out), len(self.ctrl) - 3 + self.base)
        self._trim()
        return out + ready

    def _trim(self) -> None:
        """Drop the points and knots no span still to come uses (span 3 + e uses points e..e+3
        and knots e+1..e+6): the planner stays small over a sequence of any length."""
        d = self.emitted
        if d:
            del self.ctrl[:d], self.knots[:d]
            self.base += d
            self.emitted = 0

    def _labels(self, first: int, offset: int, moves: int) -> list[tuple[int, int]]:
        """The labels of spans `first`.. (counted as `emitted`) returned after `offset` pieces,
        of a sequence of `moves` points: span 3 + m is move m's segment (span 3, the added
        start segment, begins move 1)."""
        out = []
        for k, e in enumerate(range(first + self.base, self.emitted + self.base)):
            m = e if e >= 2 else (1 if e == 0 else 0)   # span 3 + e
            if m and m <= moves:
                out.append((offset + k, moves - m))
        return out

    def _ready(self) -> list[Piece]:
        """Spans whose control points and knots are all known (SPLINE1: the knots ahead are the
        segment time's)."""
        out: list[Piece] = []
        while True:
            span = 3 + self.emitted
            knots = self.knots
            if self.uniform and self.seg_time > 0:
                knots = knots + [knots[-1] + self.seg_time * (i + 1) for i in range(3)]
            if span > len(self.ctrl) - 1 or span + 3 > len(knots) - 1:
                return out
            out.append(span_piece(span, knots, self.ctrl))
            self.emitted += 1

    def flush(self) -> list[Piece]:
        """The end of the sequence: the added zero-distance end segment, then every span left."""
        if not self.ctrl:
            return []
        end, t = self.ctrl[-1], self.seg_time
        first = self.emitted
        moves = len(self.ctrl) - 3 + self.base
        self.ctrl += [end, end]
        for _ in range(4):
            self.knots.append(self.knots[-1] + t)
        out = self._ready()
        labels = self._labels(first, 0, moves)
        self._reset()
        self.labels = labels
        return out


class Spline1Planner(SplinePlanner):
    """SPLINE1: one segment time per sequence."""

    def __init__(self, start: np.ndarray) -> None:
        super().__init__(start, uniform=True)


class Spline2Planner(SplinePlanner):
    """SPLINE2: the segment time may change at every move."""

    def __init__(self, start: np.ndarray) -> None:
        super().__init__(start, uniform=False)
