"""Point-to-point, jog, stop and abort profiles: planned in closed form, evaluated vectorised.

Method. A command plans, from the axis's commanded state (p, v, a) at that instant, a list of
*phases* of constant jerk (trapezoid: jerk 0 and a step in acceleration; S-curve: the seven
jerk-limited segments). Planning is scalar Python at command time (only the commanded axes).
Each tick evaluates the current phase of every axis with a handful of in-place ufuncs:

    acc = a0 + j*tau,   vel = v0 + tau*(a0 + acc)/2,   pos = p0 + tau*(v0 + tau*(a0/3 + acc/6))

A move's last phase is a hold at the target given as an integer, so the end position is exact in
counts; sampling the continuous profile keeps finite-difference velocity and acceleration within
vmax and max(acc, dec). Phase boundaries are absolute times: the next one across all axes is one
Python float, so the tick path tests it with no numpy call.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from vdevd.rt.axes import Axes

INF = math.inf


@dataclass(frozen=True, slots=True)
class Phase:
    """Constant jerk from absolute time `t0` for `dur` seconds, starting at (p0, v0, a0)."""

    t0: float
    dur: float
    p0: float
    v0: float
    a0: float
    j: float

    def end_state(self) -> tuple[float, float, float]:
        d, a, j = self.dur, self.a0, self.j
        p = self.p0 + d * (self.v0 + d * (a / 2 + j * d / 6))
        return p, self.v0 + d * (a + j * d / 2), a + j * d


Segment = tuple[float, float, float]  # (duration, jerk, acceleration at its start)


def ramp(v_from: float, v_to: float, amax: float, jerk: float) -> list[Segment]:
    """Segments changing velocity from v_from to v_to, zero acceleration at both ends when
    jerk-limited, with |a| <= amax (and |j| <= jerk when jerk > 0)."""
    dv = v_to - v_from
    if dv == 0 or amax <= 0:
        return []
    s, adv = math.copysign(1.0, dv), abs(dv)
    if jerk <= 0 or math.isinf(jerk):
        return [(adv / amax, 0.0, s * amax)]
    if adv >= amax * amax / jerk:
        tj = amax / jerk
        ta = adv / amax - tj
        segs = [(tj, s * jerk, 0.0), (ta, 0.0, s * amax), (tj, -s * jerk, s * amax)]
        return [seg for seg in segs if seg[0] > 0]
    tj = math.sqrt(adv / jerk)
    return [(tj, s * jerk, 0.0), (tj, -s * jerk, s * jerk * tj)]


def ramp_distance(v_from: float, v_to: float, amax: float, jerk: float) -> float:
    """Signed distance covered by `ramp` (symmetric acceleration: the mean velocity)."""
    return (v_from + v_to) / 2 * sum(d for d, _, _ in ramp(v_from, v_to, amax, jerk))


def change_velocity(v: float, v_to: float, acc: float, dec: float, jerk: float) -> list[Segment]:
    """Velocity change that speeds up with `acc` and slows down with `dec`, through zero if the
    direction reverses."""
    if v != 0 and v_to != 0 and (v > 0) != (v_to > 0):
        return ramp(v, 0.0, dec, jerk) + ramp(0.0, v_to, acc, jerk)
    return ramp(v, v_to, acc if abs(v_to) > abs(v) else dec, jerk)


def plan_move(p: float, v: float, target: float, vmax: float, acc: float, dec: float,
              jerk: float) -> list[Segment]:
    """Segments from (p, v, a=0) to rest at `target` within vmax/acc/dec/jerk.

    If the axis cannot stop before the target (or moves away from it), it first stops, then
    moves back: bounds hold, the target is reached exactly, but it is passed.
    """
    segs: list[Segment] = []
    dist = target - p
    stop = ramp_distance(v, 0.0, dec, jerk)
    if v != 0 and (dist == 0 or (v > 0) != (dist > 0) or abs(stop) > abs(dist)):
        segs += ramp(v, 0.0, dec, jerk)
        p, v = p + stop, 0.0
        dist = target - p
    if dist == 0:
        return segs
    s, length, u = math.copysign(1.0, dist), abs(dist), abs(v)

    def over(vp: float) -> float:
        up = change_velocity(u, vp, acc, dec, jerk)
        return (u + vp) / 2 * sum(d for d, _, _ in up) + ramp_distance(vp, 0.0, dec, jerk) - length

    vp = vmax
    if over(vmax) > 0:
        lo, hi = (u, vmax) if u <= vmax else (vmax, u)
        for _ in range(80):
            mid = (lo + hi) / 2
            if (over(mid) > 0) == (u <= vmax):
                hi = mid
            else:
                lo = mid
        vp = lo if u <= vmax else hi
    cruise = -over(vp) / vp if vp > 0 else 0.0
    body = change_velocity(u, vp, acc, dec, jerk)
    if cruise > 0:
        body.append((cruise, 0.0, 0.0))
    body += ramp(vp, 0.0, dec, jerk)
    return segs + [(d, s * j, s * a) for d, j, a in body]


def to_phases(t: float, p: float, v: float, a: float, segs: Iterable[Segment],
              hold: float | None) -> list[Phase]:
    """Absolute phases for `segs` from time t and state (p, v, a), then an endless last phase:
    a hold at `hold` if given (snapping the end exactly), else constant velocity."""
    phases: list[Phase] = []
    for dur, j, a0 in segs:
        ph = Phase(t, dur, p, v, a0, j)
        phases.append(ph)
        p, v, a = ph.end_state()
        t += dur
    if hold is not None:
        phases.append(Phase(t, INF, float(hold), 0.0, 0.0, 0.0))
    else:
        phases.append(Phase(t, INF, p, v, 0.0, 0.0))
    return phases


class ProfileGenerator:
    """The commanded state of every axis, from its queue of planned phases."""

    def __init__(self, axes: Axes, dt: float) -> None:
        n = axes.n
        self.axes = axes
        self.dt = dt
        self.t = 0.0
        self.ticks = 0
        # the current phase of each axis
        self.t0 = np.zeros(n)
        self.p0 = np.zeros(n)
        self.v0 = np.zeros(n)
        self.a0 = np.zeros(n)
        self.a0_3 = np.zeros(n)
        self.j = np.zeros(n)
        self.t_end = np.full(n, INF)
        self.queues: list[deque[Phase]] = [deque() for _ in range(n)]
        self.moving = np.zeros(n, dtype=bool)
        self.next_t = INF
        self.active = False
        self.jerky = False
        self._tau = np.zeros(n)
        self._tmp = np.zeros(n)

    # -- planning --------------------------------------------------------------------------------
    def state(self, axis: int) -> tuple[float, float, float]:
        ax = self.axes
        return float(ax.cmd_pos[axis]), float(ax.cmd_vel[axis]), float(ax.cmd_acc[axis])

    def _prepare(self, axis: int, jerk: float) -> tuple[float, float, float, list[Segment]]:
        """The state to plan from; with jerk limiting, first bring acceleration to zero."""
        p, v, a = self.state(axis)
        if a == 0:
            return p, v, 0.0, []
        if jerk <= 0:
            return p, v, 0.0, []  # a trapezoid may step its acceleration
        dur = abs(a) / jerk
        seg = (dur, -math.copysign(jerk, a), a)
        p, v, _ = Phase(0.0, dur, p, v, a, seg[1]).end_state()
        return p, v, 0.0, [seg]

    def move(self, axis: int, target: int, vmax: float, acc: float, dec: float,
             jerk: float) -> None:
        p0, v0, a0 = self.state(axis)
        p, v, _, first = self._prepare(axis, jerk)
        segs = first + plan_move(p, v, float(target), vmax, acc, dec, jerk)
        self.load(axis, to_phases(self.t, p0, v0, a0, segs, hold=target))

    def jog(self, axis: int, velocity: float, acc: float, dec: float, jerk: float) -> None:
        p0, v0, a0 = self.state(axis)
        _, v, _, first = self._prepare(axis, jerk)
        segs = first + change_velocity(v, velocity, acc, dec, jerk)
        self.load(axis, to_phases(self.t, p0, v0, a0, segs, hold=None), endless=velocity != 0)

    def stop(self, axis: int, dec: float, jerk: float) -> None:
        p0, v0, a0 = self.state(axis)
        _, v, _, first = self._prepare(axis, jerk)
        segs = first + ramp(v, 0.0, dec, jerk)
        phases = to_phases(self.t, p0, v0, a0, segs, hold=None)
        end = phases[-1]
        phases[-1] = Phase(end.t0, INF, end.p0, 0.0, 0.0, 0.0)
        self.load(axis, phases)

    def hold(self, axis: int, position: float) -> None:
        """Stop the profile at once and hold `position` (abort, servo off, define position)."""
        self.load(axis, [Phase(self.t, INF, position, 0.0, 0.0, 0.0)])

    def load(self, axis: int, phases: list[Phase], endless: bool = False) -> None:
        """Make `phases` the axis's plan from now; the first is current at once."""
        q = self.queues[axis]
        q.clear()
        q.extend(phases)
        self._enter(axis, q.popleft())
        self.moving[axis] = len(phases) > 1 or endless
        self._refresh()
        self.evaluate()

    def _enter(self, axis: int, ph: Phase) -> None:
        self.t0[axis], self.p0[axis], self.v0[axis] = ph.t0, ph.p0, ph.v0
        self.a0[axis], self.j[axis] = ph.a0, ph.j
        self.axes.cmd_acc[axis] = ph.a0  # constant within a trapezoid phase
        self.a0_3[axis] = ph.a0 / 3
        self.t_end[axis] = ph.t0 + ph.dur

    def _refresh(self) -> None:
        self.next_t = float(self.t_end.min())
        self.jerky = bool(self.j.any())
        self.active = bool(self.v0.any() or self.a0.any() or self.jerky)

    # -- the tick ----------------------------------------------------------------------------------
    def advance(self) -> list[int]:
        """Move the clock one tick; the axes whose profile ended this tick."""
        self.ticks += 1
        self.t = t = self.ticks * self.dt
        finished: list[int] = []
        if t >= self.next_t:
            for axis in np.flatnonzero(self.t_end <= t).tolist():
                q = self.queues[axis]
                while q and q[0].t0 + q[0].dur <= t:
                    q.popleft()
                if q:
                    self._enter(axis, q.popleft())
                if math.isinf(self.t_end[axis]) and self.moving[axis] and self.v0[axis] == 0:
                    self.moving[axis] = False
                    finished.append(axis)
            self._refresh()
        if self.active or finished:
            self.evaluate()
        return finished

    def evaluate(self) -> None:
        """Commanded position, velocity and acceleration of every axis at `self.t`."""
        ax, tau, tmp = self.axes, self._tau, self._tmp
        np.subtract(self.t, self.t0, out=tau)
        if not self.jerky:  # constant acceleration (cmd_acc set on entering the phase)
            np.multiply(self.a0, tau, out=tmp)
            np.add(self.v0, tmp, out=ax.cmd_vel)
            np.add(self.v0, ax.cmd_vel, out=tmp)  # the mean velocity over tau, times 2
            tmp *= tau
            tmp *= 0.5
            np.add(self.p0, tmp, out=ax.cmd_pos)
            return
        np.multiply(self.j, tau, out=ax.cmd_acc)
        ax.cmd_acc += self.a0
        np.add(self.a0, ax.cmd_acc, out=tmp)
        tmp *= tau
        tmp *= 0.5
        np.add(self.v0, tmp, out=ax.cmd_vel)
        np.multiply(ax.cmd_acc, 1 / 6, out=tmp)
        tmp += self.a0_3
        tmp *= tau
        tmp += self.v0
        tmp *= tau
        np.add(self.p0, tmp, out=ax.cmd_pos)
