"""Point-to-point, jog, stop and abort profiles: planned in closed form, evaluated vectorised.

Method. A command plans, from the axis's commanded state (p, v, a) at that instant, a list of
*phases* of constant jerk (trapezoid: jerk 0 and a step in acceleration; S-curve: the seven
jerk-limited segments) with absolute start times. Planning is scalar Python at command time, for
the commanded axes only (a trapezoid's peak speed in closed form, an S-curve's by bisection); the
phases go into per-axis rows of a phase table (MAX_PHASES columns). A trapezoid move's chain
(`plan_move`, `to_phases`, `load`) and the commit after a plan run as one compiled call each
(vdevd.rt.profile_kernel, the same operations; this module's Python is their reference). From a
moving state a move first brings the acceleration to zero (S-curve), and if it cannot stop before
the target it stops (with dec) and comes back: a retarget behind the axis reverses within the same
bounds.

Each tick is vectorised over all axes with no Python loop:
- while no phase boundary is due (one Python float compare against the earliest end over all
  axes), every axis advances by the exact one-tick step of constant jerk, two numpy calls on the
  adjacent rows (cmd_pos, cmd_vel, cmd_acc) of `Axes.cmd_pva`:
      x <- M @ x + (j dt^3/6, j dt^2/2, j dt),   M = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]
  (j = 0 in a trapezoid phase, whose acceleration is set on entering it);
- on a tick that crosses a boundary (a few per move), the crossing axes step their phase index
  (vectorised, one pass per skipped phase), and every axis is evaluated in closed form from its
  phase start, which also drops the rounding the steps accumulated:
      acc = a0 + j*tau,   vel = v0 + tau*(a0 + acc)/2,   pos = p0 + tau*(v0 + tau*(a0/3 + acc/6)).
A move's last phase is a hold at the integer target, so the end position is exact in counts.
Sampling the continuous profile keeps finite-difference velocity, acceleration and jerk within
vmax, acc/dec and jerk, up to float rounding of the positions (~1e-12 of their magnitude).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from vdevd.rt import profile_kernel as pk
from vdevd.rt.axes import Axes, ProfileMode

INF = math.inf
_TRAPEZOID = int(ProfileMode.TRAPEZOID)
_nonzero = np.count_nonzero
_min = np.minimum.reduce


class Phase(NamedTuple):
    """Constant jerk from absolute time `t0` for `dur` seconds, starting at (p0, v0, a0) (a
    named tuple: immutable, and built at a fraction of a frozen dataclass's cost)."""

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
    trapezoid = jerk <= 0 or math.isinf(jerk)

    def over(vp: float) -> float:
        if trapezoid:  # `ramp`'s one segment in closed form: the same operations, no lists
            t_up = abs(vp - u) / (acc if vp > u else dec) if vp != u else 0.0
            t_down = vp / dec if vp != 0 else 0.0
            return (u + vp) / 2 * t_up + vp / 2 * t_down - length
        up = change_velocity(u, vp, acc, dec, jerk)
        return (u + vp) / 2 * sum(d for d, _, _ in up) + ramp_distance(vp, 0.0, dec, jerk) - length

    vp = vmax
    over_vmax = over(vmax)
    if over_vmax > 0 and trapezoid and u <= vmax:
        # trapezoid: (vp^2 - u^2)/(2 acc) + vp^2/(2 dec) = length, solved for the peak speed
        vp = min(vmax, math.sqrt((2 * acc * dec * length + dec * u * u) / (acc + dec)))
        for _ in range(4):  # undo rounding that would leave a negative cruise
            if over(vp) <= 0 or vp <= u:
                break
            vp = math.nextafter(vp, 0.0)
    elif over_vmax > 0:
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
    make = Phase._make
    for dur, j, a0 in segs:
        phases.append(make((t, dur, p, v, a0, j)))
        # Phase.end_state, inline (a command plans every axis it names)
        p, v = p + dur * (v + dur * (a0 / 2 + j * dur / 6)), v + dur * (a0 + j * dur / 2)
        t += dur
    if hold is not None:
        phases.append(Phase(t, INF, float(hold), 0.0, 0.0, 0.0))
    else:
        phases.append(Phase(t, INF, p, v, 0.0, 0.0))
    return phases


#: columns of the phase table: the longest plan is an S-curve that first ramps its acceleration to
#: zero (1), stops (3), accelerates (3), cruises (1), decelerates (3) and holds (1)
MAX_PHASES = 16


class ProfileGenerator:
    """The commanded state of every axis, from its row of planned phases.

    Commands (`move`, `jog`, `stop`, `hold`) plan one axis each; call `commit()` once after
    planning a batch so the tick sees the new plans. `moving[a]` is True while a plan that ends
    at rest has not ended, or while a jog runs.
    """

    def __init__(self, axes: Axes, dt: float, jstep: np.ndarray | None = None,
                 compiled: bool | None = None) -> None:
        """`jstep`: where the (3, n) jerk step lives (rows of a motion core's coefficient
        block; its own otherwise). `compiled`: plan trapezoid moves and commit with the compiled
        calls (vdevd.rt.profile_kernel); None: when they are available, False: in Python and
        numpy (the reference)."""
        n = axes.n
        self.axes = axes
        self.t = 0.0
        self.ticks = 0
        self._t_base, self._ticks_base = 0.0, 0  # where the tick length last changed
        # phase table: start time, end time, p0, v0, a0, jerk; row = axis, column = phase
        self.table = np.zeros((6, n, MAX_PHASES))
        self.pt0, self.pend, self.pp0, self.pv0, self.pa0, self.pj = self.table
        self.pend[:] = INF
        self.k = np.zeros(n, dtype=np.intp)  # the current column of each axis
        # the current phase of each axis: rows of one block (pk.CUR_*), which the
        # compiled planner writes
        self._cur = np.zeros((pk.CUR_ROWS, n))
        (self.t0, self.t_end, self.p0, self.v0, self.a0, self.a0_3, self.j) = self._cur
        self.t_end[:] = INF
        self.moving = np.zeros(n, dtype=bool)
        self.mode = np.zeros(n, dtype=np.int64)  # ProfileMode of each axis
        self.next_t = INF
        self.active = False
        self.jerky = False
        #: counts the phases entered (plans, boundaries): a tracked path may take the cheap step
        #: while it is unchanged (`retrack`)
        self.plans = 0
        # one tick of constant jerk: (pos, vel, acc) <- M @ (pos, vel, acc) + jstep, where jstep
        # is (j dt^3/6, j dt^2/2, j dt) of each axis's current phase
        self._jstep = np.zeros((3, n)) if jstep is None else jstep
        self._set_matrices(dt)
        self._tau = np.zeros(n)
        self._tmp = np.zeros(n)
        self._pva = axes.cmd_pva
        jit = compiled is None or compiled
        self._move = pk.move_compiled() if jit else None
        self._commit = pk.commit_compiled() if jit else None
        if compiled and (self._move is None or self._commit is None):
            raise RuntimeError("the compiled profile planner is not available (numba)")

    def _set_matrices(self, dt: float) -> None:
        self.dt = dt
        self._m3 = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        self._jcoef = np.array([dt**3 / 6, dt * dt / 2, dt])[:, None]

    def set_dt(self, dt: float) -> None:
        """A new tick length from the next tick on (the card's period changed): the clock goes
        on from the present time, and plans keep their times."""
        self._t_base, self._ticks_base = self.t, self.ticks
        self.plans += 1
        self._set_matrices(dt)
        self._jstep[:] = self._jcoef * self.j

    # -- planning (command time, one axis at a time) -------------------------------------------
    def state(self, axis: int) -> tuple[float, float, float]:
        ax = self.axes
        return float(ax.cmd_pos[axis]), float(ax.cmd_vel[axis]), float(ax.cmd_acc[axis])

    def _prepare(self, axis: int, jerk: float) -> tuple[float, float, list[Segment]]:
        """The state to plan from; with jerk limiting, first bring acceleration to zero."""
        p, v, a = self.state(axis)
        if a == 0 or jerk <= 0:
            return p, v, []  # a trapezoid may step its acceleration
        dur = abs(a) / jerk
        seg = (dur, -math.copysign(jerk, a), a)
        p, v, _ = Phase(0.0, dur, p, v, a, seg[1]).end_state()
        return p, v, [seg]

    def move(self, axis: int, target: int, vmax: float, acc: float, dec: float,
             jerk: float) -> None:
        """Point-to-point to the integer `target`, from the present commanded state."""
        if (jerk <= 0 and self._move is not None and isinstance(vmax, float)
                and isinstance(acc, float) and isinstance(dec, float)):
            # `plan_move`, `to_phases` and `load` compiled (ints take the Python path: its sums
            # of ints are exact)
            self.plans += 1
            self._move(self.table, self._cur, self._pva, self._jstep, self._jcoef, self.k,
                       self.moving, self.mode, axis, self.t, float(target), vmax, acc, dec,
                       _TRAPEZOID)
            return
        p0, v0, a0 = self.state(axis)
        if jerk <= 0:  # `_prepare`'s trapezoid case: from the state as it is
            segs = plan_move(p0, v0, float(target), vmax, acc, dec, jerk)
        else:
            p, v, first = self._prepare(axis, jerk)
            segs = first + plan_move(p, v, float(target), vmax, acc, dec, jerk)
        self.load(axis, to_phases(self.t, p0, v0, a0, segs, hold=target),
                  mode=ProfileMode.SCURVE if jerk > 0 else ProfileMode.TRAPEZOID)

    def jog(self, axis: int, velocity: float, acc: float, dec: float, jerk: float) -> None:
        """Ramp to a signed velocity and keep it (through zero, with dec then acc, on reversal)."""
        p0, v0, a0 = self.state(axis)
        _, v, first = self._prepare(axis, jerk)
        segs = first + change_velocity(v, velocity, acc, dec, jerk)
        phases = to_phases(self.t, p0, v0, a0, segs, hold=None)
        end = phases[-1]  # the exact velocity asked for, not the ramp's rounded end
        phases[-1] = Phase(end.t0, INF, end.p0, float(velocity), 0.0, 0.0)
        self.load(axis, phases, endless=velocity != 0, mode=ProfileMode.JOG)

    def stop(self, axis: int, dec: float, jerk: float,
             mode: ProfileMode = ProfileMode.STOPPING) -> None:
        """Decelerate to standstill with `dec` (and `jerk` if > 0)."""
        p0, v0, a0 = self.state(axis)
        _, v, first = self._prepare(axis, jerk)
        segs = first + ramp(v, 0.0, dec, jerk)
        phases = to_phases(self.t, p0, v0, a0, segs, hold=None)
        end = phases[-1]
        phases[-1] = Phase(end.t0, INF, end.p0, 0.0, 0.0, 0.0)
        self.load(axis, phases, mode=mode)

    def shift(self, axis: int, distance: float) -> None:
        """Move the axis's whole plan and its commanded position by `distance` (a redefinition
        of zero that keeps the motion: MotionCore.shift_position)."""
        self.plans += 1
        self.pp0[axis, :] += distance
        self.p0[axis] += distance
        self.axes.cmd_pos[axis] += distance

    def shift_many(self, idx: np.ndarray, distances: np.ndarray) -> None:
        """`shift` for the axes `idx` at once, the command only (a follower's increment of the
        sample superimposed on its own motion: the Galil's electronic gearing and cam)."""
        self.plans += 1
        self.pp0[idx, :] += distances[:, None]
        self.p0[idx] += distances
        self.axes.cmd_pos[idx] += distances

    def hold(self, axis: int, position: float) -> None:
        """Stop the profile at once and hold `position` (abort, servo on/off, define position)."""
        self.load(axis, [Phase(self.t, INF, position, 0.0, 0.0, 0.0)])

    def reach(self, axis: int, position: float) -> None:
        """Run in a straight line from the commanded position now to `position` at the next
        tick (a path sampled once a tick, e.g. a contour): the commanded velocity is the
        path's. It runs on at that velocity until the next plan, so the caller plans every
        tick and ends with `hold`."""
        here = float(self.axes.cmd_pos[axis])
        self.load(axis, [Phase(self.t, INF, here, (position - here) / self.dt, 0.0, 0.0)])

    def retrack(self, idx: np.ndarray, positions: np.ndarray) -> None:
        """`reach_many` again for axes that `reach_many` set tracking and nothing re-planned
        since (`plans` unchanged): only their phase's start moves to now (what `reach_many`
        then `commit` would leave for them, with no other axis re-evaluated)."""
        ax = self.axes
        here = ax.cmd_pos[idx]
        v = (positions - here) / self.dt
        self.t0[idx] = self.t
        self.p0[idx] = here
        self.v0[idx] = v
        ax.cmd_vel[idx] = v
        if not self.active and v.any():  # (stepping an axis with no velocity adds zeros)
            self.active = True

    def reach_many(self, idx: np.ndarray, positions: np.ndarray) -> None:
        """`reach` for the axes `idx` at once (vectorised: a path every axis of which is
        sampled once a tick, e.g. contouring or a cam follower): each runs in a straight line
        from its commanded position now to its `positions` entry at the next tick, and on at
        that velocity until the next plan. Call `commit` after."""
        here = self.axes.cmd_pos[idx]
        t, cols = self.t, self.table[:, idx, 0]
        cols[0], cols[1], cols[2] = t, INF, here
        cols[3] = (positions - here) / self.dt
        cols[4] = cols[5] = 0.0
        self.table[:, idx, 0] = cols
        self.pend[idx, :] = INF
        self.k[idx] = 0
        self._enter(idx)
        self.moving[idx] = True
        self.mode[idx] = ProfileMode.JOG

    def load(self, axis: int, phases: list[Phase], endless: bool = False,
             mode: ProfileMode = ProfileMode.IDLE) -> None:
        """Make `phases` the axis's plan from now (the first is current at once)."""
        if len(phases) > MAX_PHASES:
            raise ValueError(f"a plan of {len(phases)} phases (at most {MAX_PHASES})")
        m = len(phases)
        rows = np.array(phases).T  # t0, dur, p0, v0, a0, j
        tab = self.table[:, axis, :m]
        tab[...] = rows
        tab[1] += rows[0]  # the end of each phase: t0 + dur
        self.pend[axis, m - 1:] = INF
        self.k[axis] = 0
        # `_enter_one(axis)` of column 0, its values taken from the first phase (the same
        # floats the table holds) instead of read back from the table
        t0, _, p0, v0, a0, j = phases[0]
        self.plans += 1
        self.t0[axis] = t0
        self.t_end[axis] = self.pend[axis, 0]
        self.p0[axis] = p0
        self.v0[axis] = v0
        a0, j = float(a0), float(j)
        self.a0[axis] = a0
        self.a0_3[axis] = a0 / 3
        self.j[axis] = j
        self._jstep[:, axis] = self._jcoef[:, 0] * j
        self.axes.cmd_acc[axis] = a0
        self.moving[axis] = moving = m > 1 or endless
        self.mode[axis] = mode if moving else ProfileMode.IDLE

    def commit(self) -> None:
        """After planning: refresh the tick's summary and evaluate the commanded state now."""
        if self._commit is not None:  # `_refresh` and `evaluate` in one compiled call
            self.next_t, self.jerky, self.active = self._commit(self._cur, self._pva, self.t)
            return
        self._refresh()
        self.evaluate()

    # -- the tick ----------------------------------------------------------------------------------
    def skip(self, k: int) -> None:
        """Move the clock k ticks with no axis profiling and no phase boundary due (the core at
        rest: MotionCore.skip): what k calls of `advance` would do then."""
        self.ticks += k
        self.t = self._t_base + (self.ticks - self._ticks_base) * self.dt

    def advance(self) -> np.ndarray | None:
        """Move the clock one tick; the axes whose plan ended this tick (None when no phase
        boundary was due)."""
        self.ticks += 1
        self.t = t = self._t_base + (self.ticks - self._ticks_base) * self.dt
        if t < self.next_t:
            if self.active:  # exact within a phase of constant jerk, up to rounding
                self._step()
            return None
        return self.boundary(t)

    def _step(self) -> None:
        """(p, v, a) <- M (p, v, a) + jstep, added left to right as the compiled kernel does
        (not np.dot: BLAS orders and fuses its sums by CPU), so both paths agree to the bit."""
        p, v, a = self._pva
        j0, j1, j2 = self._jstep
        m, tmp = self._m3, self._tmp
        np.multiply(m[0, 1], v, tmp)
        p += tmp
        np.multiply(m[0, 2], a, tmp)
        p += tmp
        p += j0
        np.multiply(m[1, 2], a, tmp)
        v += tmp
        v += j1
        a += j2

    def boundary(self, t: float) -> np.ndarray:
        """`advance` at a tick where a phase boundary is due (t >= next_t, the clock already
        moved): enter the axes' next phases; the axes whose plan ended."""
        idx = np.flatnonzero(self.t_end <= t)  # never in their last phase (it ends at INF)
        k = self.k[idx] + 1
        ends = self.pend[idx, k]
        late = ends <= t
        while np.count_nonzero(late):  # phases shorter than a tick: one pass per phase skipped
            k += late
            ends = self.pend[idx, k]
            late = ends <= t
        self.k[idx] = k
        self._enter(idx)
        finished = idx[np.isinf(ends) & (self.v0[idx] == 0) & self.moving[idx]]
        self.moving[finished] = False
        self.mode[finished] = ProfileMode.IDLE
        self.commit()
        return finished

    def _enter(self, idx: np.ndarray) -> None:
        """Make the current table column of axes `idx` their current phase."""
        self.plans += 1
        k = self.k[idx]
        self.t0[idx] = self.pt0[idx, k]
        self.t_end[idx] = self.pend[idx, k]
        self.p0[idx] = self.pp0[idx, k]
        self.v0[idx] = self.pv0[idx, k]
        a0 = self.pa0[idx, k]
        self.a0[idx] = a0
        self.a0_3[idx] = a0 / 3
        j = self.pj[idx, k]
        self.j[idx] = j
        self._jstep[:, idx] = self._jcoef * j
        self.axes.cmd_acc[idx] = a0  # constant within a trapezoid phase

    def _enter_one(self, a: int) -> None:
        """`_enter` of one axis, with scalar indexing (a command plans one axis at a time):
        the same values, a fifth of the cost."""
        self.plans += 1
        k = int(self.k[a])
        self.t0[a] = self.pt0[a, k]
        self.t_end[a] = self.pend[a, k]
        self.p0[a] = self.pp0[a, k]
        self.v0[a] = self.pv0[a, k]
        a0 = self.pa0[a, k]
        self.a0[a] = a0
        self.a0_3[a] = a0 / 3
        j = self.pj[a, k]
        self.j[a] = j
        self._jstep[:, a] = self._jcoef[:, 0] * j
        self.axes.cmd_acc[a] = a0

    def _refresh(self) -> None:
        # count_nonzero: the truth of `any` (NaN counts, -0.0 does not) without the method's
        # Python layers, a quarter of its cost at every plan and phase boundary
        self.next_t = float(_min(self.t_end))
        self.jerky = jerky = bool(_nonzero(self.j))
        self.active = bool(jerky or _nonzero(self.v0) or _nonzero(self.a0))

    def evaluate(self) -> None:
        """Commanded position, velocity and acceleration of every axis at `self.t`, in closed
        form from the start of each axis's phase."""
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
