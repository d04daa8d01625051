"""Isx13 segmentation and the special lookahead buffer of LINEAR moves [Turbo SRM Isx13, Isx20,
Ixx16, Ixx17, DEFINE LOOKAHEAD; Turbo UM "Special Lookahead"; A L1839-1843, L1408-1418].

With Isx13 > 0 the card does not run a LINEAR move's profile directly: it computes the
programmed path's points every Isx13 ms (the segments) and runs cubic splines through them.
With a lookahead buffer defined (`DEFINE LOOKAHEAD`) and Isx20 > 0, the segments pass through
the buffer first, which holds Isx20 of them: each motor's velocity is kept within Ixx16 and its
acceleration within Ixx17 by giving the segments more time (the trajectory slows, the path
stays), looking ahead over the buffered segments to decelerate in time, and always so that the
motion could stop at the end of what is buffered (the program may end there) [UM "Special
Lookahead"].

`Segmenter` takes the planner's pieces (program time, axis units) and gives the executed pieces,
one per segment: the path speed (motor counts/s, Euclidean over the C.S.'s motors) is solved at
the segment points and each segment runs from point to point in its programmed time (Isx13)
stretched by the slowing, 2·run/(speed in + speed out) where `run` is the programmed time × the
mean programmed speed at its ends, the point velocity being the programmed velocity there scaled
to the solved speed (Hermite cubics). Not slowed, a segment is the cubic of the exact
trajectory's positions and velocities at its ends over Isx13 ms, so the fine interpolation keeps
the TA/TS blend's acceleration (within what a cubic per segment can follow of it). Bounds on the
speed at a point: the programmed speed (the lookahead only slows) and Ixx16 for each motor along
the programmed direction; from point to point (a forward and a backward pass, the classic
look-ahead recurrence) no motor's velocity may change by more than Ixx17 times the segment's
time, a segment that turns the path having both ends at most at the even speed that turns it
within Ixx17 (else the forward pass could reach a corner too fast to turn and stop in it); the
last point the buffer holds is a stop.
"""

from __future__ import annotations

import numpy as np

from vdevd.devices.pmac.pieces import Piece

#: segments kept for the spline's end velocity when only segmenting (no lookahead buffer)
SEGMENT_DEPTH = 1
#: a lookahead buffer's segments and synchronous outputs [SRM DEFINE LOOKAHEAD] (ASSUMPTION:
#: the bounds)
MAX_SEGMENTS = 65535
MAX_OUTPUTS = 65535


class Segmenter:
    """Isx13 segments of the LINEAR path, through the lookahead's limits when it has some."""

    def __init__(self, start: np.ndarray, seg: float, depth: int, scale: np.ndarray,
                 vmax: np.ndarray, amax: np.ndarray) -> None:
        self.seg = seg                     # segment time, s
        self.lookahead = depth > 0         # a lookahead buffer, not only segmentation
        self.depth = max(int(depth), SEGMENT_DEPTH)
        self.scale = scale                 # motor counts per axis unit (rows: the C.S.'s motors)
        self.vmax = vmax                   # counts/s per motor, inf: none
        self.amax = amax                   # counts/s² per motor, 0: none
        self.limited = bool(np.any(amax > 0))
        self.pts: list[np.ndarray] = [start.astype(float).copy()]
        self.vel: list[np.ndarray] = [np.zeros_like(self.pts[0])]  # programmed velocity there
        self.nom: list[float] = []         # each pending segment's programmed time, s
        self.marks: list[int] = []         # the move number starting in each pending segment
        self.phase = 0.0                   # program time into the next piece of the next point
        self.tail: Piece | None = None     # the last piece taken (its end: the final point)
        self.mark = 0
        self.speed = 0.0                   # the path speed solved at the first point

    @property
    def pending(self) -> int:
        return len(self.nom)

    def full(self) -> bool:
        """As many segments as the buffer holds are waiting."""
        return self.pending >= self.depth

    def add(self, pieces: list[Piece], starts: int = 0) -> None:
        """The planner's pieces, sampled every Isx13 ms of program time."""
        for k, piece in enumerate(pieces):
            if k == 0 and starts:
                self.mark = starts
            t = self.phase
            while t < piece.dur - 1e-12:
                if t > 1e-12 or self.tail is not None:
                    self._point(*piece.at(t), self.seg)
                t += self.seg
            self.phase = t - piece.dur
            self.tail = piece

    def _point(self, p: np.ndarray, v: np.ndarray, nominal: float) -> None:
        self.pts.append(p)
        self.vel.append(v)
        self.nom.append(nominal)
        self.marks.append(self.mark)
        self.mark = 0

    def release(self, final: bool) -> list[tuple[Piece, int]]:
        """The pieces that leave the buffer (with their move numbers): all of them when `final`
        (the motion stops at the end), else all but the `depth` last segments."""
        if final and self.tail is not None:
            p, _ = self.tail.end()
            self._point(p, np.zeros_like(p), self.seg - self.phase if self.phase > 1e-12
                        else self.seg)
            self.tail, self.phase = None, 0.0
        out: list[tuple[Piece, int]] = []
        while self.pending > (0 if final else self.depth):
            out.append(self._release_first(final))
        return out

    def _release_first(self, final: bool) -> tuple[Piece, int]:
        """The first pending segment, the speeds solved over the segments the buffer holds
        after it (Isx20), the last of them a stop (with limits; else only the real end)."""
        n = min(self.pending, self.depth + 1)
        speed = self._speeds(n, stop=self.limited or (final and n == self.pending))
        p0, p1 = self.pts[0], self.pts[1]
        v0, v1 = speed[0], speed[1]
        run = self._run(0)   # the speed × time the segment takes at its programmed speeds
        tau = 2 * run / (v0 + v1) if run > 0 and v0 + v1 > 0 else self.nom[0]
        piece = Piece.hermite(p0, self._velocity(0, v0), p1, self._velocity(1, v1), tau)
        mark = self.marks[0]
        self.speed = v1
        del self.pts[0], self.vel[0], self.nom[0], self.marks[0]
        return piece, mark

    def _run(self, k: int) -> float:
        """Segment k's programmed time × its mean programmed speed (counts): the segment takes
        its programmed time (Isx13) exactly when the speeds are the programmed ones, 2·run/(speed
        in + speed out) when the lookahead slows it. (The chord over the mean speed would be the
        time of constant acceleration along a straight line: inside an S-curve or at the edge of
        a blend it shortens or stretches the segment and the cubic through its ends overshoots
        the programmed acceleration, up to twice it.) A segment without programmed speed: its
        chord."""
        c0 = float(np.linalg.norm(self.scale @ self.vel[k]))
        c1 = float(np.linalg.norm(self.scale @ self.vel[k + 1]))
        run = self.nom[k] * (c0 + c1) / 2
        return run if run > 0 else float(np.linalg.norm(self.scale @ (self.pts[k + 1]
                                                                       - self.pts[k])))

    def _velocity(self, k: int, speed: float) -> np.ndarray:
        """The programmed velocity at point k scaled to the path speed `speed`."""
        v = self.vel[k]
        nominal = float(np.linalg.norm(self.scale @ v))
        return v * (speed / nominal) if nominal > 0 else np.zeros_like(v)

    def _speeds(self, n: int, stop: bool) -> np.ndarray:
        """Path speeds (counts/s) at the first n + 1 points."""
        pts, vel = np.array(self.pts[:n + 1]), np.array(self.vel[:n + 1])
        dm = np.diff(pts, axis=0) @ self.scale.T          # motor counts per segment (n, motors)
        length = np.linalg.norm(dm, axis=1)
        vm = vel @ self.scale.T                           # programmed motor velocity at points
        cap = np.linalg.norm(vm, axis=1)                  # the programmed speed
        run = np.array(self.nom[:n]) * (cap[:-1] + cap[1:]) / 2   # as `_run`, every segment
        length = np.where(run > 0, run, length)
        with np.errstate(divide="ignore", invalid="ignore"):
            unit = np.where(cap[:, None] > 0, vm / cap[:, None], 0.0)  # its direction
            vcap = np.min(np.where(unit != 0, self.vmax / np.abs(unit), np.inf), axis=1) \
                if vm.shape[1] else np.full(n + 1, np.inf)
        cap = np.minimum(cap, vcap)
        v = cap.copy()
        v[0] = self.speed
        if stop:
            v[n] = 0.0
        if not self.limited:
            return v
        lim = self.amax > 0                               # where the path turns: both ends at
        turn = np.abs(np.diff(unit, axis=0))[:, lim]      # most the speed that turns it within
        turn[(cap[:-1] == 0) | (cap[1:] == 0)] = 0.0      # (from or to rest: no turn)
        with np.errstate(divide="ignore"):                # Ixx17 at an even speed, so the
            even = np.sqrt(np.min(np.where(turn > 0, self.amax[lim] * length[:, None] / turn,
                                           np.inf), axis=1, initial=np.inf))
        v[1:] = np.minimum(v[1:], even)                   # passes below never stop in a corner
        v[1:-1] = np.minimum(v[1:-1], even[1:])
        for k in range(n):                                # forward
            v[k + 1] = self._reach(v[k], unit[k], unit[k + 1], length[k], v[k + 1])
        for k in range(n - 1, 0, -1):                     # backward: to the stop
            v[k] = self._reach(v[k + 1], unit[k + 1], unit[k], length[k], v[k])
        return v

    def _reach(self, va: float, a: np.ndarray, b: np.ndarray, length: float, cap: float) -> float:
        """The highest speed x ≤ cap at the far end of a segment of `length` counts whose near
        end runs at `va` (directions a, b at the two ends) such that no motor's velocity changes
        by more than Ixx17 × the segment's time 2·length/(va + x) (`length`: `_run`)."""
        amax = self.amax
        lim = amax > 0
        budget = 2 * amax[lim] * length
        a, b = a[lim], b[lim]

        def excess(x: np.ndarray) -> np.ndarray:
            dv = np.abs(np.multiply.outer(x, b) - va * a)
            return np.max(dv * (va + x)[:, None] - budget, axis=1)

        if cap <= 0 or excess(np.array([cap]))[0] <= 0:
            return max(cap, 0.0)
        grid = np.linspace(0.0, cap, 65)
        e = excess(grid)
        ok = np.flatnonzero(e <= 0)
        if not len(ok):
            return float(grid[int(np.argmin(e))])
        lo, hi = float(grid[ok[-1]]), float(grid[min(ok[-1] + 1, 64)])
        for _ in range(24):
            mid = (lo + hi) / 2
            if excess(np.array([mid]))[0] <= 0:
                lo = mid
            else:
                hi = mid
        return lo
