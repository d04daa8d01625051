"""Profiles, checked against invariants over seeded random cases (STYLE.md 5): velocity,
acceleration and jerk bounds, end position exact in counts, no overshoot from rest."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.rt.trace import check_bounds, idle, record
from vdevd.rt import AxisFlag, MotionCore, PlantKind

DTS = st.sampled_from([125_000, 250_000, 500_000, 1_000_000, 2_000_000])
PROPS = settings(derandomize=True, max_examples=40, deadline=None)


@st.composite
def axis_moves(draw: st.DrawFn, jerk: bool) -> dict[str, float]:
    """A move that finishes within a few seconds: distance <= vmax, acc/dec >= 2 vmax."""
    vmax = draw(st.floats(100, 200_000))
    acc = draw(st.floats(2 * vmax, 50 * vmax))
    dec = draw(st.floats(2 * vmax, 50 * vmax))
    dist = draw(st.one_of(st.sampled_from([0, 1, -1, 2]), st.integers(-int(vmax), int(vmax))))
    start = draw(st.integers(-1000, 1000))
    j = draw(st.floats(20 * max(acc, dec), 500 * max(acc, dec))) if jerk else 0.0
    return {"vmax": vmax, "acc": acc, "dec": dec, "dist": dist, "start": start, "jerk": j}


def ideal_core(n: int, dt_ns: int) -> MotionCore:
    core = MotionCore(n, dt_ns, PlantKind.IDEAL)
    core.servo_on(slice(None))
    return core


def run_moves(moves: list[dict[str, float]], dt_ns: int) -> tuple[MotionCore, np.ndarray]:
    core = ideal_core(len(moves), dt_ns)
    core.set_position(slice(None), [m["start"] for m in moves])
    core.move_absolute(slice(None), [m["start"] + m["dist"] for m in moves],
                       [m["vmax"] for m in moves], [m["acc"] for m in moves],
                       [m["dec"] for m in moves], [m["jerk"] for m in moves])
    trace = record(core, 200_000, idle)
    return core, trace


def assert_moves(moves: list[dict[str, float]], dt_ns: int, jerk: bool) -> None:
    core, trace = run_moves(moves, dt_ns)
    dt = dt_ns / 1e9
    targets = np.array([m["start"] + m["dist"] for m in moves])
    assert idle(core)
    assert (core.axes.cmd_pos == targets).all()  # exact, not approximately
    assert (core.axes.encoder == targets).all()
    assert (core.axes.flags & AxisFlag.DONE).all()
    check_bounds(trace, dt, np.array([m["vmax"] for m in moves]),
                 np.array([max(m["acc"], m["dec"]) for m in moves]),
                 np.array([m["jerk"] for m in moves]) if jerk else None)
    direction = np.sign(targets - trace[0])
    progress = np.diff(trace, axis=0) * direction
    assert (progress >= -1e-9).all()  # monotonic from rest
    assert ((trace - targets) * direction <= 1e-9).all()  # never past the target


@PROPS
@given(moves=st.lists(axis_moves(jerk=False), min_size=1, max_size=4), dt_ns=DTS)
def test_trapezoid_moves_respect_limits_and_end_exactly(moves: list[dict[str, float]],
                                                        dt_ns: int) -> None:
    assert_moves(moves, dt_ns, jerk=False)


@PROPS
@given(moves=st.lists(axis_moves(jerk=True), min_size=1, max_size=4), dt_ns=DTS)
def test_scurve_moves_respect_limits_and_end_exactly(moves: list[dict[str, float]],
                                                     dt_ns: int) -> None:
    assert_moves(moves, dt_ns, jerk=True)


@PROPS
@given(first=axis_moves(jerk=False), second=st.integers(-100_000, 100_000),
       frac=st.floats(0.05, 0.95), jerk=st.booleans(), dt_ns=DTS)
def test_retarget_on_the_fly_keeps_bounds_and_ends_exactly(
    first: dict[str, float], second: int, frac: float, jerk: bool, dt_ns: int
) -> None:
    j = 50 * max(first["acc"], first["dec"]) if jerk else 0.0
    core = ideal_core(1, dt_ns)
    core.move_absolute(0, first["dist"] * 10 + 1, first["vmax"], first["acc"], first["dec"], j)
    head = record(core, 200_000, idle)
    cut = max(2, int(len(head) * frac))
    core2 = ideal_core(1, dt_ns)  # replay up to the cut, then retarget
    core2.move_absolute(0, first["dist"] * 10 + 1, first["vmax"], first["acc"], first["dec"], j)
    before = record(core2, cut - 1, lambda c: False)
    target = int(second % (2 * int(first["vmax"]) + 1)) - int(first["vmax"])
    core2.move_absolute(0, target, first["vmax"], first["acc"], first["dec"], j)
    after = record(core2, 400_000, idle)
    trace = np.concatenate([before, after[1:]])
    assert core2.axes.cmd_pos[0] == target
    check_bounds(trace, dt_ns / 1e9, np.array([first["vmax"]]),
                 np.array([max(first["acc"], first["dec"])]), np.array([j]) if jerk else None)


@PROPS
@given(v1=st.floats(-50_000, 50_000), v2=st.floats(-50_000, 50_000),
       acc=st.floats(1e5, 1e7), dec=st.floats(1e5, 1e7), dt_ns=DTS)
def test_jog_changes_speed_on_the_fly_within_acc_and_dec(
    v1: float, v2: float, acc: float, dec: float, dt_ns: int
) -> None:
    dt = dt_ns / 1e9
    core = ideal_core(1, dt_ns)
    core.jog(0, v1, acc, dec)
    a = record(core, 2000, lambda c: c.profile.t > 0.6)
    core.jog(0, v2, acc, dec)
    b = record(core, 2000, lambda c: c.profile.t > 1.4)
    trace = np.concatenate([a, b[1:]])
    check_bounds(trace, dt, None, np.array([max(acc, dec)]))
    assert abs(core.axes.cmd_vel[0] - v2) <= 1e-6 * (abs(v2) + 1)
    assert abs((trace[-1, 0] - trace[-2, 0]) / dt - v2) <= 1e-6 * abs(v2) + 1e-3


@PROPS
@given(move=axis_moves(jerk=False), frac=st.floats(0.1, 0.9), dt_ns=DTS)
def test_stop_decelerates_to_standstill_within_dec(move: dict[str, float], frac: float,
                                                   dt_ns: int) -> None:
    core = ideal_core(1, dt_ns)
    core.move_absolute(0, 10 * int(move["vmax"]), move["vmax"], move["acc"], move["dec"])
    head = record(core, int(frac * 2 / (dt_ns / 1e9)) + 2, lambda c: False)
    core.stop(0)
    tail = record(core, 200_000, idle)
    trace = np.concatenate([head, tail[1:]])
    check_bounds(trace, dt_ns / 1e9, np.array([move["vmax"]]),
                 np.array([max(move["acc"], move["dec"])]))
    assert core.axes.cmd_vel[0] == 0.0
    assert core.axes.flags[0] & AxisFlag.DONE and not core.axes.flags[0] & AxisFlag.MOVING


def test_abort_stops_the_profile_at_once() -> None:
    core = ideal_core(1, 1_000_000)
    core.jog(0, 10_000, 1e6, 1e6)
    record(core, 50, lambda c: False)
    held = core.axes.cmd_pos[0]
    core.abort(0)
    assert core.tick() & AxisFlag.DONE
    record(core, 10, lambda c: False)
    assert core.axes.cmd_pos[0] == held
    assert core.axes.flags[0] & AxisFlag.ABORTED
