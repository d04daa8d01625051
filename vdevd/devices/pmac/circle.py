"""CIRCLE1 (clockwise) and CIRCLE2 (counter-clockwise) moves [Turbo SRM "CIRCLE1", "CIRCLE2",
"NORMAL", "{axis}{data}...{vector}{data}", "R{data}", Isx13, Isx96, Isx97; PMAC SRM p.295].

The arc lies in the plane through the start point normal to the `NORMAL` vector (default K-1: the
XY plane); "if a right thumb points in the direction of the normal vector, the right fingers will
curl in the direction of a clockwise arc": CIRCLE1 turns positively about the normal, CIRCLE2
negatively. Only X, Y and Z take part; the motion along the normal and every other axis named are
interpolated linearly to finish in the same time (helical moves). The centre is the I J K vector
from the start point (INC(R), the default) or from the XYZ origin (ABS(R): the runner passes
"IJK_INC" False, or "IJK_ABS" True); an end point at another distance from the centre than the
start is reached on a spiral (radius linear in angle: ASSUMPTION on the spiral's form). An IJK arc
of less than Isx97 half-circles (0: 2^-20) is a full circle. With `R{r}` the card finds the centre
itself: r > 0 the short arc (<= 180°), r < 0 the long one; an end farther than 2|r| is reached on a
half-circle spiral, unless the excess is above Isx96 (when Isx96 > 0): the program stops at the
start of the move with the circle-radius-error bit [SRM Isx96]. R with the end on the start moves
nothing (no full circle with R).

Speed: F along the path (the circle axes are feedrate axes, with the other FRAX axes), or the move
time TM; the acceleration to, from and between the moves of a sequence is the TA/TS blend of each
move's distance along its own path (blend.py), the position the sum of the moves' displacements, as
LINEAR moves blend [SRM TA; UM "Circular Interpolation": CIRCLE moves blend as LINEAR moves do]: a
corner between moves is cut over the blend, the velocity vector turning with no jump. A move takes
at least its acceleration time [PMAC UM "Short Moves"], at most 8,388,607 ms.

Segmentation: the card computes the path every Isx13 ms and fine-interpolates with cubics [SRM
Isx13]: each segment here is the Hermite cubic of the exact positions and velocities at its ends.
With Isx13 = 0 "CIRCLE mode moves are executed as LINEAR moves" [SRM Isx13]: the straight line to
the end point with the same speed and blend, cut where the blend changes form (exact).

Params of a `Move`: "CIRCLE" (1 or 2), "NORMAL" (I J K), "IJK" (array) or "R", "IJK_INC" (or "IJK_ABS"), "F"
(units/s) or "TM" (s) (TM when it is given: the program's last TM came after its F), "TA", "TS"
(s), "SEG" (Isx13, s), "FRAX" (bool mask of the nine axes; default X Y Z), "Isx96" (units), "Isx97"
(half-circles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from vdevd.devices.pmac import blend
from vdevd.devices.pmac.pieces import NAXES, Move, Piece, Planner
from vdevd.devices.pmac.planerr import CIRCLE_RADIUS_ERROR, RUN_TIME_ERROR, PlanError
from vdevd.devices.pmac.pvt import hermite_pieces

#: X Y Z in the nine-axis arrays (A B C U V W X Y Z)
XYZ = slice(6, 9)
DEFAULT_NORMAL = np.array([0.0, 0.0, -1.0])
DEFAULT_FRAX = np.array([False] * 6 + [True] * 3)
#: Isx97 = 0 means 2^-20 half-circles [SRM Isx97]
MIN_ARC_DEFAULT = 2.0 ** -20
MAX_MOVE_TIME = 8_388.607
_EPS = 1e-12


@dataclass
class _Element:
    """One move of the sequence: its path (arc or line) and its place in time and distance."""

    start: np.ndarray
    end: np.ndarray
    arc: bool
    centre: np.ndarray          # in the plane through the start point
    e1: np.ndarray
    e2: np.ndarray
    normal: np.ndarray
    sweep: float                # signed angle (radians)
    rho0: float
    rho1: float
    rise: float                 # displacement along the normal
    length: float               # path length (or 1 for a move of non-feedrate axes only)
    speed: float
    t0: float                   # start of its constant-speed interval, seconds
    dur: float
    kern: tuple[float, float]   # blend kernel at its start boundary
    stop: tuple[float, float] | None = None   # its stop's kernel when last (None: kern)

    def at(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions and d/du along the move at fractions `u` (n,), shape (n, NAXES)."""
        d = self.end - self.start
        pos = self.start + u[:, None] * d
        dpos = np.broadcast_to(d, pos.shape).copy()
        if self.arc:
            th = self.sweep * u
            c, s = np.cos(th)[:, None], np.sin(th)[:, None]
            rho = (self.rho0 + (self.rho1 - self.rho0) * u)[:, None]
            radial = c * self.e1 + s * self.e2
            tangent = -s * self.e1 + c * self.e2
            pos[:, XYZ] = self.centre + rho * radial + (u * self.rise)[:, None] * self.normal
            dpos[:, XYZ] = ((self.rho1 - self.rho0) * radial + rho * self.sweep * tangent
                            + self.rise * self.normal)
        return pos, dpos


def _num(move: Move, key: str, default: float = 0.0) -> float:
    v = move.params.get(key)
    return default if v is None else float(cast(float, v))


def _arc_geometry(start: np.ndarray, end: np.ndarray, move: Move
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float, float, float, float]:
    """(centre, e1, e2, normal, sweep, rho0, rho1, rise) of the arc from `start` to `end`; raises
    PlanError for a radius the card refuses."""
    nv = np.array(move.params.get("NORMAL", DEFAULT_NORMAL), dtype=float)
    norm = float(np.linalg.norm(nv))
    n = DEFAULT_NORMAL if norm < _EPS else nv / norm
    sigma = 1.0 if int(cast(int, move.params.get("CIRCLE", 1))) == 1 else -1.0
    s, e = start[XYZ], end[XYZ]
    rise = float(np.dot(e - s, n))
    ep = e - rise * n                       # the end point brought into the start's plane
    r = move.params.get("R")
    if r is not None:
        rad = float(cast(float, r))
        chord = ep - s
        dist = float(np.linalg.norm(chord))
        if dist < _EPS:
            return s, np.zeros(3), np.zeros(3), n, 0.0, 0.0, 0.0, rise
        excess = dist - 2 * abs(rad)
        isx96 = _num(move, "Isx96")
        if excess > 0 and isx96 > 0 and excess > isx96:
            raise PlanError(CIRCLE_RADIUS_ERROR, "end point beyond 2R")
        mid = s + chord / 2
        half = np.sqrt(max(rad * rad - dist * dist / 4, 0.0))
        side = np.cross(n, chord / dist)
        arcs = [(c, _sweep(s - c, ep - c, n, sigma, min_arc=0.0))
                for c in (mid + half * side, mid - half * side)]
        short = [a for a in arcs if a[1] <= np.pi + 1e-9]
        long_ = [a for a in arcs if a[1] >= np.pi - 1e-9]
        centre, sweep = (short or arcs)[0] if rad > 0 else (long_ or arcs)[0]
    else:
        ijk = np.array(move.params["IJK"], dtype=float)
        inc = move.params.get("IJK_INC", not move.params.get("IJK_ABS", False))
        centre = s + ijk if inc else ijk
        centre = centre - np.dot(centre - s, n) * n   # into the start's plane
        isx97 = _num(move, "Isx97") or MIN_ARC_DEFAULT
        sweep = _sweep(s - centre, ep - centre, n, sigma, min_arc=isx97 * np.pi)
    r0, r1 = s - centre, ep - centre
    rho0, rho1 = float(np.linalg.norm(r0)), float(np.linalg.norm(r1))
    if rho0 < _EPS:
        raise PlanError(CIRCLE_RADIUS_ERROR, "centre on the start point")
    e1 = r0 / rho0
    e2 = np.cross(n, e1)
    return centre, e1, e2, n, sigma * sweep, rho0, rho1, rise


def _sweep(r0: np.ndarray, r1: np.ndarray, n: np.ndarray, sigma: float, min_arc: float) -> float:
    """The angle (0, 2π] turned from r0 to r1 in direction `sigma` about n; below `min_arc` a
    full circle."""
    theta = float(np.arctan2(np.dot(np.cross(r0, r1), n), np.dot(r0, r1)))
    sweep = (sigma * theta) % (2 * np.pi)
    if sweep < min_arc or sweep < _EPS:
        sweep += 2 * np.pi
    return sweep


class CirclePlanner(Planner):
    """CIRCLE1/CIRCLE2 moves, blended into one sequence until `flush`."""

    def __init__(self, start: np.ndarray) -> None:
        super().__init__(start)
        self._reset()

    def _reset(self) -> None:
        self.elements: list[_Element] = []
        self.emitted_t = 0.0       # time up to which pieces were returned
        self.emitted_k = 0         # segments returned
        self.seg = 0.0
        self.begin = 0             # index in add()'s pieces where the added move begins
        self.t_begin = 0.0         # the time its `begin` piece starts (stop_commands.py `/`)
        self._starts = np.zeros(0)   # start times of the pieces `_emit` returned last

    # -- building the sequence ----------------------------------------------------------------
    def add(self, move: Move) -> list[Piece]:
        start, end = self.position.copy(), move.target.astype(float)
        self.seg = _num(move, "SEG")
        arc = self.seg > 0 and not move.params.get("LINE")   # LINE: a LINEAR move (mode_blend.py)
        frax = np.array(move.params.get("FRAX", DEFAULT_FRAX), dtype=bool)
        d = end - start
        if arc:
            centre, e1, e2, n, sweep, rho0, rho1, rise = _arc_geometry(start, end, move)
            others = frax.copy()
            others[XYZ] = False
            arc_len = abs(sweep) * (rho0 + rho1) / 2
            length = float(np.sqrt(arc_len ** 2 + rise ** 2 + np.sum(d[others] ** 2)))
        else:
            centre = e1 = e2 = n = np.zeros(3)
            sweep = rho0 = rho1 = rise = 0.0
            length = float(np.linalg.norm(d[frax]))
        ta, ts = _num(move, "TA"), _num(move, "TS")
        kern = blend.widths(ta, ts)
        accel = kern[0] + kern[1]
        f, tm = move.params.get("F"), move.params.get("TM")
        moving = length > _EPS or bool(np.any(np.abs(d) > _EPS))
        if tm is not None:
            dur = float(cast(float, tm))
        else:
            feed = float(cast(float, f if f is not None else 0.0))
            if feed <= 0:
                raise PlanError(RUN_TIME_ERROR, "feedrate 0")
            dur = length / feed
        dur = min(max(dur, accel), MAX_MOVE_TIME)
        if length <= _EPS:
            length = 1.0 if moving else 0.0   # non-feedrate axes only: a nominal path
        if dur <= 0:
            dur = _EPS
        stop = None
        if self.elements:
            last = self.elements[-1]
            t0 = last.t0 + last.dur
            room = 2 * max(t0 - self.emitted_t, 0.0)   # the blend begins after what was returned
            if accel > room:                           # (`advance`): narrowed to fit
                stop, kern = kern, (kern[0] * room / accel, kern[1] * room / accel)
        else:
            t0 = accel / 2
        self.elements.append(_Element(start, end, arc, centre, e1, e2, n, sweep, rho0, rho1, rise,
                                      length, length / dur, t0, dur, kern, stop))
        self.position = end
        # times up to the end of this move's start blend are final (the next move's blend
        # begins after it); `begin` is the piece where this move (its blend) begins, as
        # LinearPlanner's, so the runner's look-ahead counts it from there
        accel = kern[0] + kern[1]   # as narrowed
        t_begin = self.t_begin = t0 - accel / 2
        reach = accel / 2 if accel > 0 else min(self.seg or dur, dur) / 2
        out = self._emit(t0 + min(reach, dur), final=False)
        k = int(np.searchsorted(self._starts, t_begin + 1e-12, side="right")) - 1
        self.begin = min(max(k, 0), max(len(out) - 1, 0))
        if len(out):   # where that piece starts (on the Isx13 grid, at or before the blend)
            self.t_begin = float(self._starts[self.begin])
        return out

    def advance(self, most: float = math.inf) -> list[Piece]:
        """At most `most` seconds more (a segment at least) of the last move, never past where
        its stop would begin, for a calculation that must go on without the next move yet (a
        rotary buffer waiting for its next line, program_runner.py); the next move's blend is
        narrowed to begin after it (`add`)."""
        if not self.elements:
            return []
        i = len(self.elements) - 1
        last = self.elements[i]
        stop_at = last.t0 + last.dur - sum(self._kend(i)) / 2
        return self._emit(min(stop_at, self.emitted_t + max(most, self.seg)), final=False)

    def flush(self) -> list[Piece]:
        """The sequence decelerates to a stop at the last end point."""
        if not self.elements:
            return []
        last = self.elements[-1]
        out = self._emit(last.t0 + last.dur + sum(self._kend(len(self.elements) - 1)) / 2,
                         final=True)
        self._reset()
        return out

    # -- evaluating it ------------------------------------------------------------------------
    def _kend(self, i: int) -> tuple[float, float]:
        """The blend kernel at the end of element i: the next one's, or its stop."""
        els = self.elements
        if i + 1 < len(els):
            return els[i + 1].kern
        return els[i].stop or els[i].kern

    def _grid(self, horizon: float, final: bool) -> np.ndarray:
        if self.seg > 0:
            k1 = int(np.floor(horizon / self.seg + 1e-9))
            ts = np.arange(self.emitted_k, k1 + 1) * self.seg
            if final and ts[-1] < horizon - 1e-9:
                ts = np.append(ts, horizon)
            self.emitted_k = k1
            return ts
        marks = [self.emitted_t, horizon]
        for i, el in enumerate(self.elements):
            marks += list(el.t0 + blend.breakpoints(*el.kern))
            kend = self._kend(i)
            marks += list(el.t0 + el.dur + blend.breakpoints(*kend))
        ts = np.unique(np.array(marks))
        return ts[(ts >= self.emitted_t - 1e-12) & (ts <= horizon + 1e-12)]

    def _emit(self, horizon: float, final: bool) -> list[Piece]:
        self._starts = np.zeros(0)
        if horizon <= self.emitted_t + 1e-12 and not final:
            return []
        ts = self._grid(horizon, final)
        if len(ts) < 2:
            return []
        pos, vel = self._eval(ts)
        dur = np.diff(ts)
        keep = dur > 1e-12
        idx = np.flatnonzero(keep)
        pieces = hermite_pieces(np.concatenate([pos[idx], pos[-1:]]),
                                np.concatenate([vel[idx], vel[-1:]]), dur[keep])
        if final:   # end exactly where the last move ends
            pieces[-1] = Piece.hermite(pos[idx[-1]], vel[idx[-1]], self.position,
                                       np.zeros(NAXES), float(dur[keep][-1]))
        self.emitted_t = float(ts[-1])
        self._starts = ts[idx]
        self._drop()
        return pieces

    def _eval(self, ts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The sum of the moves' own blended progress, as LINEAR moves blend [SRM TA]: at a
        corner the velocity vector turns over the blend (the corner is cut), no jump."""
        els = self.elements
        pos = np.empty((len(ts), NAXES))
        pos[:] = els[0].start
        vel = np.zeros((len(ts), NAXES))
        for i, el in enumerate(els):
            if el.length <= 0:
                continue
            kend = self._kend(i)
            s = el.speed * (blend.ramp(ts - el.t0, *el.kern) - blend.ramp(ts - el.t0 - el.dur, *kend))
            sd = el.speed * (blend.ramp_rate(ts - el.t0, *el.kern)
                             - blend.ramp_rate(ts - el.t0 - el.dur, *kend))
            p, dp = el.at(np.clip(s / el.length, 0.0, 1.0))
            pos += p - el.start
            vel += dp * (sd / el.length)[:, None]
        return pos, vel

    def _drop(self) -> None:
        """Forget moves whose blends all lie before what was returned (bounded memory)."""
        while len(self.elements) > 1:
            el, nxt = self.elements[0], self.elements[1]
            if el.t0 + el.dur + sum(nxt.kern) / 2 > self.emitted_t:
                return
            self.elements.pop(0)
