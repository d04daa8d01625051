"""LINEAR and RAPID move planners of a motion program [spec pmac.md §2.8; Turbo UM "Linear
Blended Moves", "Rapid Moves"; Turbo SRM TA, TS, TM, F, Ixx16, Ixx17, Ixx19-Ixx22, Ixx90].

LINEAR. A move of `T` seconds goes at constant velocity Δp/T from corner to corner; the change
from one move's velocity to the next takes TA, centred on the corner, with S-curve TS at both
ends of the change, so the path is the polyline with its corners rounded and each move's time
measured between the middles of its blends (a lone move from rest takes T + TA) [UM]:
- T = TM (move time mode), or the vector distance of the feedrate axes (FRAX, X Y Z by
  default; all the named axes when no feedrate axis moves: ASSUMPTION) over F;
- TA < 2·TS: TA = 2·TS; T < TA: T = TA; TA of a move ≤ 2·(T − TA/2) of the move before
  (blends do not overlap) [Quick Reference "Linear Blended Moves"];
- Ixx16 (Isx13 = 0): a move that asks a motor for more than Ixx16 counts/ms is slowed down,
  every axis in proportion (T lengthened) [SRM Ixx16];
- Ixx17: a blend that asks a motor for more than Ixx17 counts/ms² is lengthened in proportion
  (TA and TS), within the no-overlap bound above (ASSUMPTION: the firmware also stretches the
  moves, "When Too Effective" [UM]; here a blend never grows past it).

RAPID. Each axis goes to its target on its own jog-type profile: speed Ixx22 (Ixx16 with
Ixx90 = 1), accelerations from Ixx19-Ixx21 as jogs [SRM Ixx22, Ixx90]; the runner gives each
axis the numbers of its motor (`Move.params` "MAXV", "MAXA", "JERK", per axis, user units and
seconds). The move ends when the slowest axis ends; nothing blends into or out of it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from vdevd.devices.pmac.pieces import NAXES, Move, Piece, Planner

#: the shortest blend, seconds (TA = TS = 0 is a division by zero on the card [UM]: ASSUMPTION)
MIN_TA = 1e-3


def ramp(p: np.ndarray, v: np.ndarray, schedule: list[tuple[float, np.ndarray]]) -> list[Piece]:
    """The pieces of a motion from (p, v) at rest acceleration, following `schedule`: each
    entry holds the jerk vector for `dur` seconds; acceleration, velocity and position are
    integrated piece to piece."""
    out: list[Piece] = []
    a = np.zeros(NAXES)
    p, v = p.astype(float), v.astype(float)
    for dur, jerk in schedule:
        if dur <= 0:
            continue
        coef = np.stack([p, v, a / 2, jerk / 6])
        piece = Piece(dur, coef)
        out.append(piece)
        p, v = piece.end()
        a = a + jerk * dur
    return out


def blend(p: np.ndarray, v0: np.ndarray, v1: np.ndarray, ta: float, ts: float) -> list[Piece]:
    """The change from velocity v0 to v1 in `ta` seconds with S-curve `ts` at both ends (ts ≤
    ta/2): peak acceleration Δv/(ta − ts), jerk it/ts."""
    dv = v1 - v0
    if ts <= 0:
        return ramp(p, v0, [(ta, np.zeros(NAXES))]) if not dv.any() else \
            _const_accel(p, v0, dv / ta, ta)
    acc = dv / (ta - ts)
    jerk = acc / ts
    return ramp(p, v0, [(ts, jerk), (ta - 2 * ts, np.zeros(NAXES)), (ts, -jerk)])


def _const_accel(p: np.ndarray, v: np.ndarray, a: np.ndarray, dur: float) -> list[Piece]:
    return [Piece(dur, np.stack([p.astype(float), v.astype(float), a / 2, np.zeros(NAXES)]))]


def cruise(p: np.ndarray, v: np.ndarray, dur: float) -> list[Piece]:
    """Constant velocity v for `dur` seconds."""
    if dur <= 0:
        return []
    z = np.zeros(NAXES)
    return [Piece(dur, np.stack([p.astype(float), v.astype(float), z, z]))]


class LinearPlanner(Planner):
    """Blended LINEAR moves; holds back the cruise of the last move until the next move (or
    `flush`) says how it is left."""

    def __init__(self, start: np.ndarray) -> None:
        super().__init__(start)
        self.tail = self.position.copy()  # where the emitted pieces end
        self.vel = np.zeros(NAXES)        # velocity of the last move (0: at rest)
        self.left = 0.0                   # cruise time of the last move to its corner, s
        self.last_ta = 0.0                # the last move's own TA (its deceleration)
        self.last_ts = 0.0
        self.begin = 0  # index in add()'s pieces where the added move begins

    def add(self, move: Move) -> list[Piece]:
        prm = move.params
        ta_in, ts = _ta_ts(prm)
        dist = move.target - self.position
        duration = self._time(dist, prm, ta_in)
        vel = dist / duration
        ta, ts_b = ta_in, ts
        scale = prm.get("MOTOR_SCALE")
        amax = prm.get("MOTOR_MAXA")
        if isinstance(scale, np.ndarray) and isinstance(amax, np.ndarray) and len(amax):
            dvm = np.abs(scale @ (vel - self.vel))
            with np.errstate(divide="ignore", invalid="ignore"):
                need = np.where(amax > 0, dvm / (ta - ts_b) / amax, 0.0) if ta > ts_b else 0.0
            r = float(np.max(need)) if np.size(need) else 0.0
            if r > 1:
                ta, ts_b = ta * r, ts_b * r
        if self.vel.any():  # blends do not overlap [Quick Reference]
            bound = 2 * self.left
            if ta > bound:
                ts_b = min(ts_b * bound / ta, bound / 2)
                ta = bound
        out = cruise(self.tail, self.vel, self.left - ta / 2) if self.vel.any() else []
        self.begin = len(out)  # the blend begins the new move (program_runner's look-ahead)
        p = out[-1].end()[0] if out else self.tail
        out += blend(p, self.vel, vel, ta, min(ts_b, ta / 2))
        self.tail = out[-1].end()[0] if out else self.tail
        self.vel = vel
        self.left = duration - ta / 2
        self.last_ta, self.last_ts = ta_in, ts
        self.position = move.target.astype(float).copy()
        return out

    def _time(self, dist: np.ndarray, prm: dict[str, object], ta: float) -> float:
        """The move time T, s: TM, or distance over F, at least TA, lengthened for Ixx16."""
        tm = prm.get("TM")
        if tm is not None:
            duration = float(tm)  # type: ignore[arg-type]
        else:
            frax = prm.get("FRAX")
            mask = np.asarray(frax, dtype=bool) if frax is not None else np.zeros(NAXES, bool)
            d = float(np.linalg.norm(dist[mask]))
            if d == 0:
                d = float(np.linalg.norm(dist))
            f = float(prm.get("F", 0.0))  # type: ignore[arg-type]
            duration = d / f if f > 0 else 0.0
        duration = max(duration, ta)
        scale, vmax = prm.get("MOTOR_SCALE"), prm.get("MOTOR_MAXV")
        if isinstance(scale, np.ndarray) and isinstance(vmax, np.ndarray) and len(vmax) \
                and duration > 0:
            vm = np.abs(scale @ dist) / duration
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where(vmax > 0, vm / vmax, 0.0)
            if np.size(r) and float(np.max(r)) > 1:
                duration *= float(np.max(r))
        return duration

    def advance(self, most: float = math.inf) -> list[Piece]:
        """At most `most` seconds more of the held move's cruise, never past where a stop in its
        own TA would begin (TA/2 before its corner), for a calculation that must go on without
        the next move yet (a rotary buffer waiting for its next line, program_runner.py): the
        next move added still blends from there, in at most twice the cruise left (the bound of
        `add`; its own TA at least)."""
        if not self.vel.any():
            return []
        keep = min(self.last_ta, 2 * self.left) / 2
        out = cruise(self.tail, self.vel, min(self.left - keep, most))
        if out:
            self.tail = out[-1].end()[0]
            self.left -= out[-1].dur
        return out

    def flush(self) -> list[Piece]:
        """Decelerate to a stop at the last move's end in its own TA."""
        if not self.vel.any():
            self.tail = self.position.copy()
            return []
        ta = min(self.last_ta, 2 * self.left)
        ts = min(self.last_ts, ta / 2)
        out = cruise(self.tail, self.vel, self.left - ta / 2)
        p = out[-1].end()[0] if out else self.tail
        out += blend(p, self.vel, np.zeros(NAXES), ta, ts)
        last = out[-1]
        coef = last.coef.copy()  # end exactly on the corner, free of rounding
        coef[0] += self.position - last.end()[0]
        out[-1] = Piece(last.dur, coef)
        self.tail, self.vel, self.left = self.position.copy(), np.zeros(NAXES), 0.0
        return out


def _ta_ts(prm: dict[str, object]) -> tuple[float, float]:
    """TA and TS in seconds: TA at least 2·TS, never 0 [UM]."""
    ta = float(prm.get("TA", 0.0))  # type: ignore[arg-type]
    ts = float(prm.get("TS", 0.0))  # type: ignore[arg-type]
    ta = max(ta, 2 * ts, MIN_TA)
    return ta, min(ts, ta / 2)


class RapidPlanner(Planner):
    """RAPID moves: every axis on its own jog-type profile, at rest at both ends."""

    def add(self, move: Move) -> list[Piece]:
        prm = move.params
        start = self.position.copy()
        dist = move.target - start
        vmax = np.asarray(prm.get("MAXV", np.zeros(NAXES)), dtype=float)
        amax = np.asarray(prm.get("MAXA", np.zeros(NAXES)), dtype=float)
        jerk = np.asarray(prm.get("JERK", np.zeros(NAXES)), dtype=float)
        profiles = []
        for k in np.flatnonzero(dist).tolist():  # per axis: few axes, once per move
            if vmax[k] <= 0 or amax[k] <= 0:
                continue
            profiles.append((k, _axis_profile(float(dist[k]), float(vmax[k]), float(amax[k]),
                                              float(jerk[k]))))
        self.position = move.target.astype(float).copy()
        return cut_pieces(profiles, start, lambda k, prof, t0: _shifted(prof, t0, float(start[k])),
                          self.position)


def _axis_profile(d: float, vmax: float, amax: float, jerk: float) -> list[Phase]:
    """A rest-to-rest move of d units as phases (duration, acceleration at its start, jerk):
    S-curve when jerk > 0, the peak speed lowered when the move is too short to reach vmax."""
    sign = 1.0 if d > 0 else -1.0
    d = abs(d)

    def accel(v: float) -> tuple[float, float, float]:  # (jerk time, const time, distance)
        if jerk > 0:
            a = min(amax, math.sqrt(v * jerk))
            tj = a / jerk
            tc = max(v / a - tj, 0.0) if a > 0 else 0.0
        else:
            tj, tc = 0.0, v / amax
        return tj, tc, v * (2 * tj + tc) / 2

    v = vmax
    if 2 * accel(v)[2] > d:
        lo, hi = 0.0, vmax
        for _ in range(60):
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if 2 * accel(mid)[2] < d else (lo, mid)
        v = lo
    tj, tc, da = accel(v)
    a = sign * (v / (tj + tc) if tj + tc > 0 else 0.0)
    j = a / tj if tj > 0 else 0.0
    flat = max((d - 2 * da) / v, 0.0) if v > 0 else 0.0
    phases = [(tj, 0.0, j), (tc, a, 0.0), (tj, a, -j), (flat, 0.0, 0.0),
              (tj, 0.0, -j), (tc, -a, 0.0), (tj, -a, j)]
    return [ph for ph in phases if ph[0] > 0]


#: one phase of an axis's RAPID profile: (seconds, acceleration at its start, jerk)
Phase = tuple[float, float, float]


def cut_pieces(profiles: list[tuple[int, list[Phase]]], base: np.ndarray,
               state: Callable[[int, list[Phase], float], np.ndarray],
               end: np.ndarray) -> list[Piece]:
    """Per-axis phase profiles as pieces, cut wherever any axis changes phase: the axes without
    a profile stay at `base`, axis k's cubic from each cut t0 is `state(k, prof, t0)`; the last
    piece is moved to end exactly on `end` (free of rounding). RAPID moves and `!` (altdest.py)."""
    cuts = sorted({0.0, *(t for _, prof in profiles for t in _breaks(prof))})
    out: list[Piece] = []
    for t0, t1 in zip(cuts, cuts[1:], strict=False):
        if t1 - t0 <= 1e-12:
            continue
        coef = np.zeros((4, NAXES))
        coef[0] = base
        for k, prof in profiles:
            coef[:, k] = state(k, prof, t0)
        out.append(Piece(t1 - t0, coef))
    if out:
        last = out[-1]
        coef = last.coef.copy()
        coef[0] += end - last.end()[0]
        out[-1] = Piece(last.dur, coef)
    return out


def _breaks(prof: list[Phase]) -> list[float]:
    t, out = 0.0, []
    for dur, _, _ in prof:
        t += dur
        out.append(t)
    return out


def _shifted(prof: list[Phase], t0: float, p0: float) -> np.ndarray:
    """The cubic coefficients of the axis's profile from t0 on (its state at t0 integrated from
    rest at p0); past its end the axis holds."""
    p, v, t = p0, 0.0, 0.0
    for dur, a, jerk in prof:
        if t + dur > t0 + 1e-12:
            tau = t0 - t
            pp = p + v * tau + a * tau * tau / 2 + jerk * tau ** 3 / 6
            vv = v + a * tau + jerk * tau * tau / 2
            return np.array([pp, vv, (a + jerk * tau) / 2, jerk / 6])
        p += v * dur + a * dur * dur / 2 + jerk * dur ** 3 / 6
        v += a * dur + jerk * dur * dur / 2
        t += dur
    return np.array([p, 0.0, 0.0, 0.0])
