"""The profile generator's command-time work compiled (decision 0011's pattern, issue 18): a
trapezoid point-to-point move planned and loaded in one call (`move_py`), and the summary and
closed-form evaluation after a plan or at a phase boundary (`commit_py`).

`ProfileGenerator.move` with jerk 0 is, in Python, `plan_move` -> `to_phases` -> `load` (~8 us an
axis: a few hundred scalar Python operations, two lists of tuples and a numpy array of them);
`commit` is `_refresh` and `evaluate` (~3.5 us: a dozen numpy calls on n-element arrays). Here
each is one call of ~1 us. Both do what their Python and numpy counterparts do, with the same IEEE
operations in the same order (products and sums as Python evaluates them, left to right; no fused
multiply-add: numba compiles without fastmath), so the phase table, the current phase and the
commanded state agree to the bit with the Python path, which stays the reference
(`ProfileGenerator(compiled=False)`, and the fallback without numba or with VDEVD_JIT=0).
tests/rt/test_profile_kernel.py compares both.

Blocks, as `ProfileGenerator` lays them out: `table` (6, n, MAX_PHASES) the phase table (start,
end, p0, v0, a0, jerk), `cur` (7, n) the current phase (CUR_* rows), `pva` (3, n) the commanded
position, velocity and acceleration (`Axes.cmd_pva`), `jstep` (3, n) the jerk step and `jcoef`
(3, 1) its coefficients, `k` the current column, `moving` and `mode` the summary per axis.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np

from vdevd.rt import kernel

#: rows of `ProfileGenerator`'s current-phase block
CUR_T0, CUR_T_END, CUR_P0, CUR_V0, CUR_A0, CUR_A0_3, CUR_J = range(7)
CUR_ROWS = 7
INF = math.inf


def _over(vp: float, u: float, acc: float, dec: float, length: float) -> float:
    """`plan_move`'s `over` of a trapezoid: the distance a ramp from u to vp and down to rest
    covers beyond `length`."""
    t_up = abs(vp - u) / (acc if vp > u else dec) if vp != u else 0.0
    t_down = vp / dec if vp != 0 else 0.0
    return (u + vp) / 2 * t_up + vp / 2 * t_down - length


def move_py(table: Any, cur: Any, pva: Any, jstep: Any, jcoef: Any, k: Any, moving: Any,
            mode: Any, axis: int, t: float, target: float, vmax: float, acc: float, dec: float,
            mode_moving: int) -> int:
    """`ProfileGenerator.move(axis, target, vmax, acc, dec, 0.0)` from the state in `pva` at time
    `t`: the phases into the table, the first entered, the summary set (mode `mode_moving` while
    it moves, else 0: IDLE); the number of phases. `target` is a whole number (the hold)."""
    p_start, v_start = pva[0, axis], pva[1, axis]
    # -- plan_move: segments (duration, jerk, acceleration) into three small arrays ------------
    durs = np.empty(6)
    accs = np.empty(6)
    jerks = np.empty(6)
    n = 0
    p, v = p_start, v_start
    dist = target - p
    # ramp_distance(v, 0.0, dec, 0.0): the mean velocity times `ramp`'s duration (sum([]) = 0)
    dv = 0.0 - v
    ramp_d = abs(dv) / dec if not (dv == 0 or dec <= 0) else 0.0
    stop = (v + 0.0) / 2 * ramp_d
    if v != 0 and (dist == 0 or (v > 0) != (dist > 0) or abs(stop) > abs(dist)):
        if not (dv == 0 or dec <= 0):  # ramp(v, 0.0, dec, 0.0)
            durs[n], jerks[n], accs[n] = abs(dv) / dec, 0.0, math.copysign(1.0, dv) * dec
            n += 1
        p, v = p + stop, 0.0
        dist = target - p
    first = n  # the body's segments (from here) take the direction's sign
    if dist != 0:
        s, length, u = math.copysign(1.0, dist), abs(dist), abs(v)
        vp = vmax
        over_vmax = _over(vmax, u, acc, dec, length)
        if over_vmax > 0 and u <= vmax:
            vp = min(vmax, math.sqrt((2 * acc * dec * length + dec * u * u) / (acc + dec)))
            for _ in range(4):  # undo rounding that would leave a negative cruise
                if _over(vp, u, acc, dec, length) <= 0 or vp <= u:
                    break
                vp = np.nextafter(vp, 0.0)
        elif over_vmax > 0:
            if u <= vmax:
                lo, hi = u, vmax
            else:
                lo, hi = vmax, u
            for _ in range(80):
                mid = (lo + hi) / 2
                if (_over(mid, u, acc, dec, length) > 0) == (u <= vmax):
                    hi = mid
                else:
                    lo = mid
            vp = lo if u <= vmax else hi
        cruise = -_over(vp, u, acc, dec, length) / vp if vp > 0 else 0.0
        # change_velocity(u, vp, acc, dec, 0.0)
        if u != 0 and vp != 0 and (u > 0) != (vp > 0):
            dv = 0.0 - u  # ramp(u, 0.0, dec), then ramp(0.0, vp, acc)
            if not (dv == 0 or dec <= 0):
                durs[n], jerks[n], accs[n] = abs(dv) / dec, 0.0, math.copysign(1.0, dv) * dec
                n += 1
            dv = vp - 0.0
            if not (dv == 0 or acc <= 0):
                durs[n], jerks[n], accs[n] = abs(dv) / acc, 0.0, math.copysign(1.0, dv) * acc
                n += 1
        else:
            amax = acc if abs(vp) > abs(u) else dec
            dv = vp - u
            if not (dv == 0 or amax <= 0):
                durs[n], jerks[n], accs[n] = abs(dv) / amax, 0.0, math.copysign(1.0, dv) * amax
                n += 1
        if cruise > 0:
            durs[n], jerks[n], accs[n] = cruise, 0.0, 0.0
            n += 1
        dv = 0.0 - vp  # ramp(vp, 0.0, dec)
        if not (dv == 0 or dec <= 0):
            durs[n], jerks[n], accs[n] = abs(dv) / dec, 0.0, math.copysign(1.0, dv) * dec
            n += 1
        for i in range(first, n):
            jerks[i] = s * jerks[i]
            accs[i] = s * accs[i]
    # -- to_phases from (t, p_start, v_start), then the hold at the target; load ------------------
    p, v = p_start, v_start
    for i in range(n):
        dur, j, a0 = durs[i], jerks[i], accs[i]
        table[0, axis, i] = t
        table[1, axis, i] = dur + t
        table[2, axis, i] = p
        table[3, axis, i] = v
        table[4, axis, i] = a0
        table[5, axis, i] = j
        p, v = p + dur * (v + dur * (a0 / 2 + j * dur / 6)), v + dur * (a0 + j * dur / 2)
        t += dur
    table[0, axis, n] = t
    table[2, axis, n] = target
    table[3, axis, n] = 0.0
    table[4, axis, n] = 0.0
    table[5, axis, n] = 0.0
    m = n + 1
    for i in range(n, table.shape[2]):
        table[1, axis, i] = INF
    k[axis] = 0
    # `ProfileGenerator._enter_one` of column 0
    a0, j = table[4, axis, 0], table[5, axis, 0]
    cur[CUR_T0, axis] = table[0, axis, 0]
    cur[CUR_T_END, axis] = table[1, axis, 0]
    cur[CUR_P0, axis] = table[2, axis, 0]
    cur[CUR_V0, axis] = table[3, axis, 0]
    cur[CUR_A0, axis] = a0
    cur[CUR_A0_3, axis] = a0 / 3
    cur[CUR_J, axis] = j
    for r in range(3):
        jstep[r, axis] = jcoef[r, 0] * j
    pva[2, axis] = a0
    moving[axis] = m > 1
    mode[axis] = mode_moving if m > 1 else 0
    return m


def commit_py(cur: Any, pva: Any, t: float) -> tuple[float, bool, bool]:
    """`ProfileGenerator._refresh` then `evaluate` at time `t`: (next_t, jerky, active), and the
    commanded state of every axis written to `pva` in closed form from its phase's start."""
    n = cur.shape[1]
    next_t = cur[CUR_T_END, 0]
    jerky = False
    active = False
    for i in range(n):  # np.minimum.reduce (NaN wins), count_nonzero (NaN counts, -0.0 not)
        x = cur[CUR_T_END, i]
        if x != x or x < next_t:
            next_t = x
        if cur[CUR_J, i] != 0:
            jerky = True
        if cur[CUR_V0, i] != 0 or cur[CUR_A0, i] != 0:
            active = True
    active = jerky or active
    if not jerky:  # constant acceleration (cmd_acc set on entering the phase)
        for i in range(n):
            tau = t - cur[CUR_T0, i]
            vel = cur[CUR_V0, i] + cur[CUR_A0, i] * tau
            pva[1, i] = vel
            pva[0, i] = cur[CUR_P0, i] + ((cur[CUR_V0, i] + vel) * tau) * 0.5
        return next_t, jerky, active
    for i in range(n):
        tau = t - cur[CUR_T0, i]
        acc = cur[CUR_J, i] * tau + cur[CUR_A0, i]
        pva[2, i] = acc
        pva[1, i] = cur[CUR_V0, i] + ((cur[CUR_A0, i] + acc) * tau) * 0.5
        pva[0, i] = cur[CUR_P0, i] + ((acc * _SIXTH + cur[CUR_A0_3, i]) * tau + cur[CUR_V0, i]) * tau
    return next_t, jerky, active


_SIXTH = 1 / 6
Move = Callable[..., int]
Commit = Callable[[Any, Any, float], tuple[float, bool, bool]]


@cache
def commit_compiled() -> Commit | None:
    """`commit_py` compiled, or None (as `move_compiled`)."""
    return kernel._jit(commit_py, (np.zeros((CUR_ROWS, 1)), np.zeros((11, 1))[0:3], 0.0),
                       "the compiled profile commit", "the profile evaluates with numpy")


@cache
def move_compiled() -> Move | None:
    """`move_py` compiled (numba's cache after the first time), or None: no numba, VDEVD_JIT=0,
    or compiling failed (logged once)."""
    if not kernel.jit_disabled():
        try:
            from numba.extending import register_jitable
        except ImportError:
            pass
        else:
            register_jitable(_over)  # callable from compiled code (and still plain Python)
    return kernel._jit(move_py, _probe_args(), "the compiled trapezoid planner",
                       "trapezoid moves plan in Python")


def _probe_args() -> tuple[Any, ...]:
    """Arguments of the planner's one signature (the layouts `ProfileGenerator` passes)."""
    n = 1
    state = np.zeros((11, n))
    coef = np.zeros((kernel.ROWS, n))
    return (np.zeros((6, n, 16)), np.zeros((CUR_ROWS, n)), state[0:3], coef[kernel.JSTEP:kernel.JSTEP + 3],
            np.zeros((3, 1)), np.zeros(n, dtype=np.intp), np.zeros(n, dtype=bool),
            np.zeros(n, dtype=np.int64), 0, 0.0, 1.0, 1.0, 1.0, 1.0, 1)
