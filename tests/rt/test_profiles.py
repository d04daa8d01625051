"""Profiles, checked against invariants over seeded random cases (STYLE.md 5): velocity,
acceleration (acc when speeding up, dec when slowing down) and jerk bounds, end position exact in
counts, no overshoot and monotonic progress from rest, time-optimal trapezoids.

Bounds are checked on finite differences of the commanded position sampled every tick. Slack:
positions are floats, so a position of magnitude P carries rounding of about 1e-12 * P after the
~1e4 increments of a phase; that, divided by dt, dt^2, dt^3, is the absolute slack, plus 1e-9
relative.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tests.rt.trace import idle, record
from vdevd.rt import AxisFlag, MotionCore, PlantKind

DTS = st.sampled_from([125_000, 250_000, 500_000, 1_000_000, 2_000_000])
PROPS = settings(derandomize=True, max_examples=40, deadline=None)
REL = 1e-9


def ideal_core(n: int, dt_ns: int) -> MotionCore:
    core = MotionCore(n, dt_ns, PlantKind.IDEAL)
    core.servo_on(slice(None))
    return core


def after(seconds: float) -> Callable[[MotionCore], bool]:
    return lambda core: core.profile.t >= seconds


def check_limits(trace: np.ndarray, dt: float, vmax: np.ndarray | None, acc: np.ndarray,
                 dec: np.ndarray, jerk: np.ndarray | None = None) -> None:
    """Per axis: |v| <= vmax; a in [-dec, acc] while moving forward and [-acc, dec] backward
    (speeding up uses acc, slowing down dec), |a| <= max(acc, dec) across a reversal; |j| <= jerk.

    A second difference averages the acceleration over two ticks, during which the velocity
    stays within max(acc, dec) * dt of both mean velocities: a window whose mean velocities are
    beyond that, with the same sign, has no reversal in it.
    """
    eps = 1e-12 * (np.abs(trace).max() + 1.0)
    vel = np.diff(trace, axis=0) / dt
    accel = np.diff(vel, axis=0) / dt
    if vmax is not None:
        over = np.abs(vel) - (vmax * (1 + REL) + 2 * eps / dt)
        assert (over <= 0).all(), f"velocity over by {over.max()}"
    slack = 4 * eps / dt**2
    up, down = acc * (1 + REL) + slack, dec * (1 + REL) + slack
    sure = np.maximum(up, down) * dt
    fwd = (vel[:-1] > sure) & (vel[1:] > sure)
    bwd = (vel[:-1] < -sure) & (vel[1:] < -sure)
    hi = np.where(fwd, up, np.where(bwd, down, np.maximum(up, down)))
    lo = np.where(fwd, down, np.where(bwd, up, np.maximum(up, down)))
    assert (accel <= hi).all(), f"acceleration over by {(accel - hi).max()}"
    assert (-accel <= lo).all(), f"deceleration over by {(-accel - lo).max()}"
    if jerk is not None:
        jerks = np.abs(np.diff(accel, axis=0)) / dt
        over = jerks - (jerk * (1 + REL) + 8 * eps / dt**3)
        assert (over <= 0).all(), f"jerk over by {over.max()}"


def trapezoid_time(dist: float, vmax: float, acc: float, dec: float) -> float:
    """Duration of the time-optimal trapezoid over `dist` from rest to rest."""
    dist = abs(dist)
    if dist >= vmax * vmax / 2 * (1 / acc + 1 / dec):
        return dist / vmax + vmax / (2 * acc) + vmax / (2 * dec)
    peak = math.sqrt(2 * dist * acc * dec / (acc + dec))
    return peak / acc + peak / dec


@st.composite
def axis_moves(draw: st.DrawFn, jerk: bool) -> dict[str, float]:
    """A move that ends within a few seconds: |distance| <= 3 vmax, acc/dec >= 2 vmax; distances
    0, 1, 2 and up to millions of counts."""
    vmax = draw(st.floats(100, 2e6))
    acc = draw(st.floats(2 * vmax, 50 * vmax))
    dec = draw(st.floats(2 * vmax, 50 * vmax))
    span = int(3 * vmax)
    dist = draw(st.one_of(st.sampled_from([0, 1, -1, 2, -2]), st.integers(-span, span)))
    start = draw(st.integers(-100_000, 100_000))
    j = draw(st.floats(20 * max(acc, dec), 500 * max(acc, dec))) if jerk else 0.0
    return {"vmax": vmax, "acc": acc, "dec": dec, "dist": dist, "start": start, "jerk": j}


def column(moves: list[dict[str, float]], key: str) -> np.ndarray:
    return np.array([m[key] for m in moves], dtype=float)


def assert_moves_from_rest(moves: list[dict[str, float]], dt_ns: int, jerk: bool) -> None:
    dt = dt_ns / 1e9
    core = ideal_core(len(moves), dt_ns)
    core.set_position(slice(None), column(moves, "start"))
    targets = column(moves, "start") + column(moves, "dist")
    core.move_absolute(slice(None), targets, column(moves, "vmax"), column(moves, "acc"),
                       column(moves, "dec"), column(moves, "jerk"))
    trace = record(core, 200_000, idle)
    assert idle(core)
    assert (core.axes.cmd_pos == targets).all()  # exact, not approximately
    assert (core.axes.pos == targets).all() and (core.axes.encoder == targets).all()
    assert (core.axes.cmd_vel == 0).all() and (core.axes.cmd_acc == 0).all()
    flags = core.axes.flags
    assert (flags & AxisFlag.DONE).all() and not (flags & AxisFlag.MOVING).any()
    check_limits(trace, dt, column(moves, "vmax"), column(moves, "acc"), column(moves, "dec"),
                 column(moves, "jerk") if jerk else None)
    direction = np.sign(targets - trace[0])
    eps = 1e-12 * (np.abs(trace).max() + 1.0)  # float rounding of positions (module docstring)
    assert (np.diff(trace, axis=0) * direction >= -eps).all()  # monotonic from rest
    assert ((trace - targets) * direction <= eps).all()  # never past the target
    if not jerk:  # time-optimal: done on the first tick after the continuous trapezoid's end
        longest = max(trapezoid_time(m["dist"], m["vmax"], m["acc"], m["dec"]) for m in moves)
        assert len(trace) - 1 <= math.ceil(longest / dt * (1 + REL)) or longest == 0


@PROPS
@given(moves=st.lists(axis_moves(jerk=False), min_size=1, max_size=4), dt_ns=DTS)
@example(moves=[{"vmax": 2e6, "acc": 4e6, "dec": 1e8, "dist": -10_000_000, "start": 7,
                 "jerk": 0.0}], dt_ns=1_000_000)
def test_trapezoid_moves_end_exactly_within_limits_without_overshoot(
    moves: list[dict[str, float]], dt_ns: int
) -> None:
    assert_moves_from_rest(moves, dt_ns, jerk=False)


@PROPS
@given(moves=st.lists(axis_moves(jerk=True), min_size=1, max_size=4), dt_ns=DTS)
def test_scurve_moves_end_exactly_within_limits_without_overshoot(
    moves: list[dict[str, float]], dt_ns: int
) -> None:
    assert_moves_from_rest(moves, dt_ns, jerk=True)


def test_a_trapezoid_has_the_textbook_shape() -> None:
    """10000 counts at 50000 counts/s, acc 5e5, dec 2.5e5: 0.1 s up (2500 counts), 0.05 s of
    cruise (2500), 0.2 s down (5000)."""
    core = ideal_core(1, 1_000_000)
    core.move_absolute(0, 10_000, 50_000, 5e5, 2.5e5)
    trace = record(core, 1000, idle)[:, 0]
    assert len(trace) - 1 == 350
    assert np.allclose(trace[[50, 100, 150, 250]], [625, 2500, 5000, 8750], rtol=1e-12)
    assert trace[-1] == 10_000
    assert core.axes.cmd_vel[0] == 0.0


@st.composite
def retargets(draw: st.DrawFn) -> dict[str, float]:
    move = draw(axis_moves(jerk=False))
    move["jerk"] = draw(st.sampled_from([0.0, 20.0, 200.0])) * max(move["acc"], move["dec"])
    move["first"] = move["dist"] * 2 + 1
    span = int(2 * move["vmax"])
    move["second"] = draw(st.integers(-span, span))  # often behind: a reversal
    move["vmax2"] = move["vmax"] * draw(st.sampled_from([1.0, 0.5, 1.5]))  # and a new speed
    return move


@PROPS
@given(moves=st.lists(retargets(), min_size=1, max_size=3), frac=st.floats(0.02, 0.98),
       dt_ns=DTS)
def test_retarget_on_the_fly_keeps_limits_and_ends_exactly(
    moves: list[dict[str, float]], frac: float, dt_ns: int
) -> None:
    dt = dt_ns / 1e9
    n = len(moves)
    vmax, acc, dec, jerk = (column(moves, k) for k in ("vmax", "acc", "dec", "jerk"))
    core = ideal_core(n, dt_ns)
    core.move_absolute(slice(None), column(moves, "first"), vmax, acc, dec, jerk)
    cut = max(1, int(frac * max(trapezoid_time(m["first"], m["vmax"], m["acc"], m["dec"])
                                for m in moves) / dt))
    before = record(core, cut, lambda c: False)
    targets, vmax2 = column(moves, "second"), column(moves, "vmax2")
    core.move_absolute(slice(None), targets, vmax2, acc, dec, jerk)
    trace = np.concatenate([before, record(core, int(30 / dt), idle)[1:]])  # <= 8 vmax at vmax/2
    assert (core.axes.cmd_pos == targets).all()
    assert (core.axes.flags & AxisFlag.DONE).all()
    check_limits(trace, dt, np.maximum(vmax, vmax2), acc, dec, np.where(jerk > 0, jerk, np.inf))


@PROPS
@given(v1=st.lists(st.floats(-50_000, 50_000), min_size=1, max_size=3),
       v2=st.lists(st.floats(-50_000, 50_000), min_size=3, max_size=3),
       acc=st.floats(1e5, 1e7), dec=st.floats(1e5, 1e7), dt_ns=DTS)
def test_jog_changes_speed_on_the_fly_with_acc_up_and_dec_down(
    v1: list[float], v2: list[float], acc: float, dec: float, dt_ns: int
) -> None:
    n = len(v1)
    target = np.array(v2[:n])
    core = ideal_core(n, dt_ns)
    core.jog(slice(None), v1, acc, dec)
    a = record(core, 100_000, after(0.6))  # ramps of <= 0.5 s have ended
    core.jog(slice(None), target, acc, dec)
    b = record(core, 100_000, after(1.8))  # a reversal takes <= 1 s
    trace = np.concatenate([a, b[1:]])
    vmax = np.maximum(np.abs(v1), np.abs(target))
    check_limits(trace, dt_ns / 1e9, vmax, np.full(n, acc), np.full(n, dec))
    assert np.allclose(core.axes.cmd_vel, target, rtol=1e-12, atol=1e-9)
    last = (trace[-1] - trace[-2]) / (dt_ns / 1e9)
    assert np.allclose(last, target, rtol=1e-9, atol=1e-3)
    assert ((core.axes.flags & AxisFlag.MOVING) != 0).tolist() == (target != 0).tolist()


@settings(derandomize=True, max_examples=25, deadline=None)
@given(v1=st.floats(-50_000, 50_000), v2=st.floats(-50_000, 50_000), acc=st.floats(1e5, 1e7),
       dec=st.floats(1e5, 1e7), jscale=st.floats(5, 200), dt_ns=DTS)
def test_scurve_jog_reversal_keeps_jerk_bounded(v1: float, v2: float, acc: float, dec: float,
                                                jscale: float, dt_ns: int) -> None:
    jerk = jscale * max(acc, dec)
    core = ideal_core(2, dt_ns)
    core.jog(slice(None), [v1, -v1], acc, dec, jerk)
    a = record(core, 100_000, after(0.6))
    core.jog(slice(None), [v2, -v2], acc, dec, jerk)
    b = record(core, 100_000, after(2.6))  # ramps end by 2.5 s
    trace = np.concatenate([a, b[1:]])
    check_limits(trace, dt_ns / 1e9, np.full(2, max(abs(v1), abs(v2))), np.full(2, acc),
                 np.full(2, dec), np.full(2, jerk))
    assert np.allclose(core.axes.cmd_vel, [v2, -v2], rtol=1e-12, atol=1e-9)


@PROPS
@given(moves=st.lists(axis_moves(jerk=False), min_size=1, max_size=3), frac=st.floats(0.05, 0.95),
       stop_dec=st.one_of(st.none(), st.floats(0.2, 5.0)), dt_ns=DTS)
def test_stop_decelerates_to_standstill_within_dec(
    moves: list[dict[str, float]], frac: float, stop_dec: float | None, dt_ns: int
) -> None:
    """stop() with the move's dec, or with a given dec (here stop_dec times the move's)."""
    dt = dt_ns / 1e9
    vmax, acc, dec = (column(moves, k) for k in ("vmax", "acc", "dec"))
    core = ideal_core(len(moves), dt_ns)
    core.move_absolute(slice(None), 10 * vmax, vmax, acc, dec)
    head = record(core, int(frac * 3 / dt) + 1, lambda c: False)
    down = dec if stop_dec is None else stop_dec * dec
    core.stop(slice(None), None if stop_dec is None else down)
    tail = record(core, 400_000, idle)
    trace = np.concatenate([head, tail[1:]])
    check_limits(trace, dt, vmax, acc, np.maximum(dec, down))
    check_limits(tail, dt, vmax, acc, down)
    assert (core.axes.cmd_vel == 0).all()
    short = down >= dec  # then it stops before the move's target
    assert ((trace - 10 * vmax)[:, short] <= 1e-12 * (np.abs(trace).max() + 1.0)).all()
    flags = core.axes.flags
    assert (flags & AxisFlag.DONE).all() and not (flags & AxisFlag.MOVING).any()


def test_stop_of_a_jog_through_a_reversal_uses_dec() -> None:
    core = ideal_core(1, 250_000)
    core.jog(0, 20_000, 1e5, 4e5)
    record(core, 2000, after(0.5))
    core.jog(0, -20_000, 1e5, 4e5)  # slowing down with dec...
    record(core, 100, lambda c: False)
    core.stop(0)  # ...and the stop goes on with the jog's dec
    trace = record(core, 10_000, idle)
    check_limits(trace, 250e-6, np.array([20_000.0]), np.array([1e5]), np.array([4e5]))
    assert len(trace) - 1 in (100, 101)  # 10000 counts/s at 4e5 counts/s^2: 25 ms
    assert core.axes.cmd_vel[0] == 0.0


def test_abort_stops_the_profile_at_once() -> None:
    core = ideal_core(1, 1_000_000)
    core.jog(0, 10_000, 1e6, 1e6)
    record(core, 50, lambda c: False)
    held = core.axes.cmd_pos[0]
    core.abort(0)
    assert core.tick() & AxisFlag.DONE
    record(core, 10, lambda c: False)
    assert core.axes.cmd_pos[0] == held and core.axes.cmd_vel[0] == 0
    assert core.axes.flags[0] & AxisFlag.ABORTED


def test_zero_length_move_is_done_at_once() -> None:
    core = ideal_core(2, 1_000_000)
    core.move_absolute(slice(None), [0, 3], 1000, 1e4, 1e4)
    assert core.axes.flags[0] & AxisFlag.DONE and not core.axes.flags[0] & AxisFlag.MOVING
    assert core.tick() == AxisFlag.DONE  # reported by the next tick
    ticks, events = core.run(1000)
    assert events == AxisFlag.DONE and core.axes.cmd_pos.tolist() == [0, 3]
