"""The compiled trapezoid planner and commit (vdevd.rt.profile_kernel) against the Python chain
and numpy calls they replace (`plan_move` -> `to_phases` -> `load`, `_refresh` and `evaluate`;
decision 0011's pattern): the same move from the same commanded state on two profile generators,
the phase table, the current phase, the commanded state and the summary compared to the bit, then
ticked on (phase boundaries commit) and compared again."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from vdevd.rt import MotionCore, kernel
from vdevd.rt import profile_kernel as pk
from vdevd.rt.axes import Axes
from vdevd.rt.profiles import ProfileGenerator

DT = 200e-6


def pair(n: int = 3) -> tuple[ProfileGenerator, ProfileGenerator]:
    if kernel.jit_disabled():
        pytest.skip("VDEVD_JIT=0: the Python path only")
    assert pk.move_compiled() is not None, "numba is a dependency: the planner must compile"
    fast = ProfileGenerator(Axes(n), DT, compiled=True)
    ref = ProfileGenerator(Axes(n), DT, compiled=False)
    assert fast._move is not None and ref._move is None and ref._commit is None
    return fast, ref


def same(fast: ProfileGenerator, ref: ProfileGenerator, what: str) -> None:
    assert (fast.next_t, fast.jerky, fast.active) == (ref.next_t, ref.jerky, ref.active), what
    for name in ("table", "_cur", "k", "moving", "mode", "_jstep"):
        a, b = getattr(fast, name), getattr(ref, name)
        # bit patterns: -0.0 against 0.0 differs too; NaN never appears
        assert a.tobytes() == b.tobytes(), f"{what}: {name}\n{a}\n!=\n{b}"
    assert fast.axes.state.tobytes() == ref.axes.state.tobytes(), what
    assert fast.plans == ref.plans, what


def set_state(g: ProfileGenerator, axis: int, p: float, v: float, a: float) -> None:
    g.axes.cmd_pos[axis], g.axes.cmd_vel[axis], g.axes.cmd_acc[axis] = p, v, a


CASES = [  # (p, v, a, target, vmax, acc, dec)
    (0.0, 0.0, 0.0, 1000.0, 5e4, 1e6, 1e6),  # trapezoid from rest
    (0.0, 0.0, 0.0, 3.0, 5e4, 1e6, 1e6),  # triangle
    (0.0, 0.0, 0.0, -7.0e6, 3e5, 2e6, 5e5),  # backwards, unequal acc/dec
    (10.0, 0.0, 0.0, 10.0, 5e4, 1e6, 1e6),  # already there: a hold
    (10.5, 2e4, 0.0, 10.0, 5e4, 1e6, 1e6),  # moving, target behind: stop, come back
    (0.0, 4e4, 1e6, 100.0, 5e4, 1e6, 1e6),  # cannot stop before the target
    (0.0, 4e4, 0.0, 1e6, 5e4, 1e6, 1e6),  # moving toward it, room to spare
    (0.0, 9e4, -1e6, 1e7, 5e4, 1e6, 2e6),  # faster than the new vmax: slows to it (bisection)
    (0.0, -9e4, 0.0, -1e7, 5e4, 3e6, 1e6),  # the same backwards
    (-3.25, -1e3, 0.0, 5.0, 1.0, 1e6, 1e6),  # moving away, slow vmax
    (0.0, 3e4, 0.0, 0.0, 5e4, 1e6, 1e6),  # back to where it started
    (2.0**40, 1.5e5, 0.0, 2.0**40 + 1e9, 1.6e5, 8.19e5, 8.19e5),  # far out
    (461.42578125, 15380.859375, 256347.65625, float(0x234567), 163840.0, 256347.65625,
     256347.65625),  # the Octavia's AXMOVE (bench/mx4.py), re-targeted while it accelerates
]


@pytest.mark.parametrize("case", CASES)
def test_the_compiled_move_plans_what_the_python_chain_plans(case: tuple[float, ...]) -> None:
    p, v, a, target, vmax, acc, dec = case
    fast, ref = pair()
    for g in (fast, ref):
        g.t = 0.0123
        set_state(g, 1, p, v, a)
        g.move(1, int(target), vmax, acc, dec, 0.0)
    same(fast, ref, f"{case}")
    for g in (fast, ref):
        g.commit()
    same(fast, ref, f"{case} committed")
    for tick in range(400):
        ended = [g.advance() for g in (fast, ref)]
        assert (ended[0] is None) == (ended[1] is None), tick
        same(fast, ref, f"{case} tick {tick}")


def test_random_retargets_agree_to_the_bit() -> None:
    """Moves replanned every few ticks from whatever state the last left (mid-ramp, cruising,
    stopping, reversing), with random limits, on three axes."""
    rnd = random.Random(18)
    fast, ref = pair()
    for step in range(600):
        axis = rnd.randrange(3)
        target = rnd.choice([0, 1, -1, rnd.randint(-10**6, 10**6), rnd.randint(-50, 50)])
        vmax = rnd.choice([1.0, 5e4, rnd.uniform(1.0, 3e5), 1e-3])
        acc = rnd.choice([1e6, rnd.uniform(1e2, 1e7)])
        dec = rnd.choice([acc, rnd.uniform(1e2, 1e7)])
        for g in (fast, ref):
            g.move(axis, target, vmax, acc, dec, 0.0)
            g.commit()
        same(fast, ref, f"step {step}")
        for _ in range(rnd.randrange(1, 40)):
            for g in (fast, ref):
                g.advance()
            same(fast, ref, f"step {step} ticking")


def test_int_limits_and_s_curves_plan_in_python_and_commit_alike() -> None:
    """Ints plan in Python (exact int sums), and jerk > 0 is the S-curve's; the commits (the
    jerky closed form while the S-curve runs) and the boundaries are compiled: both agree."""
    fast, ref = pair()
    for g in (fast, ref):
        g.move(0, 5000, 20000, 10**6, 10**6, 0.0)
        g.move(1, -5000, 2e4, 1e6, 1e6, 1e8)
        g.jog(2, 3e3, 2e5, 2e5, 5e7)
        g.commit()
    same(fast, ref, "ints and an S-curve")
    assert fast.jerky
    for tick in range(3000):
        for g in (fast, ref):
            g.advance()
        same(fast, ref, f"tick {tick}")
        if tick == 1500:
            for g in (fast, ref):
                g.stop(2, 1e5, 0.0)
                g.commit()


def test_motion_cores_built_either_way_move_alike() -> None:
    if kernel.jit_disabled():
        pytest.skip("VDEVD_JIT=0: the Python path only")
    cores = [MotionCore(2, 1e6, compiled=c) for c in (True, False)]
    for core in cores:
        core.servo_on(slice(None))
        core.move_one(0, 12345.0, 3e4, 2e5, 4e5)
        core.move_one(1, -777.0, 1e4, 3e5, 3e5)
    assert cores[0].profile._move is not None and cores[1].profile._move is None
    for tick in range(1500):
        events = [core.tick() for core in cores]
        assert events[0] == events[1], tick
        assert cores[0].axes.state.tobytes() == cores[1].axes.state.tobytes(), tick
    assert cores[0].axes.cmd_pos.tolist() == [12345.0, -777.0]
    assert not math.isnan(float(np.sum(cores[0].axes.state)))
