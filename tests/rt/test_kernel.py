"""The compiled tick (vdevd.rt.kernel) against the numpy path it follows (decision 0011): the
same commands on two cores, compared after every tick. Every feature the tick has is exercised:
servo, stepper (rate-limited or not), ideal and mixed axes, S-curves, jogs through zero, stops
and aborts, limits, following-error trips, PID limits and integrator hold, servo off, encoder
scale, slip and loss, jams and a period change. Both paths do the same IEEE operations in the
same order (no BLAS sums), so everything agrees to the bit."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable

import numpy as np
import pytest

from vdevd.rt import AxisFlag, MotionCore, PlantKind, kernel
from vdevd.rt.plants import StepperPlant

S, V, ID = PlantKind.SERVO, PlantKind.STEPPER, PlantKind.IDEAL
MS = 1_000_000
Script = dict[int, Callable[[MotionCore], None]]


def run_both(kinds: list[PlantKind], script: Script, ticks: int, dt_ns: float = MS,
             setup: Callable[[MotionCore], None] | None = None,
             watch: Callable[[MotionCore], None] | None = None) -> tuple[MotionCore, int]:
    """Run `script` (tick number -> command) on a compiled and a numpy core; compare each
    tick. The compiled core and the union of the events."""
    if kernel.jit_disabled():  # a run of the suite on the numpy path: nothing to compare
        pytest.skip("VDEVD_JIT=0: the numpy path only")
    assert kernel.compiled() is not None, "numba is a dependency: the compiled core must load"
    cores = [MotionCore(len(kinds), dt_ns, kinds, compiled=c) for c in (True, False)]
    for core in cores:
        core.servo_on(slice(None))
        if setup:
            setup(core)
    fast, ref = cores
    seen = 0
    assert fast._kernel is not None and ref._kernel is None
    for t in range(ticks):
        if t in script:
            for core in cores:
                script[t](core)
        ev_fast, ev_ref = fast.tick(), ref.tick()
        assert ev_fast == ev_ref, f"tick {t}: events {ev_fast:#x} != {ev_ref:#x}"
        seen |= ev_fast
        np.testing.assert_array_equal(fast.axes.state, ref.axes.state, err_msg=f"tick {t}")
        np.testing.assert_array_equal(fast.axes.encoder, ref.axes.encoder, err_msg=f"tick {t}")
        np.testing.assert_array_equal(fast.axes.flags, ref.axes.flags, err_msg=f"tick {t}")
        np.testing.assert_array_equal(fast.stepper.gen, ref.stepper.gen, err_msg=f"tick {t}")
        np.testing.assert_array_equal(fast.coef, ref.coef, err_msg=f"tick {t}")
        if watch:
            watch(fast)
    return fast, seen


def test_servo_moves_scurves_jogs_stops_and_aborts() -> None:
    script: Script = {
        0: lambda c: c.move_absolute(slice(None), [20_000, -5_000, 7_777, 1], 60_000, 400_000,
                                     300_000, [0, 5e6, 2e7, 0]),
        150: lambda c: c.move_absolute(1, 3_000, 40_000, 300_000, 300_000),  # retarget on the fly
        400: lambda c: c.jog([0, 3], [-30_000, 25_000], 500_000, 500_000, 1e7),
        600: lambda c: c.jog(0, 30_000, 500_000, 500_000),  # through zero
        800: lambda c: c.stop(slice(None)),
        900: lambda c: c.move_relative(2, 4_000, 20_000, 200_000, 200_000),
        950: lambda c: c.abort(2, 100_000),
        1000: lambda c: c.abort(slice(None)),
    }
    fast, _ = run_both([S, S, S, S], script, 1400)
    assert np.abs(fast.axes.pos).max() > 1000  # it did move


def test_pid_limits_integrator_hold_and_following_error_trip() -> None:
    def setup(c: MotionCore) -> None:
        c.pid.set(slice(None), ki=[0.002, 0.004, 0.0, 0.003], il=[30.0, np.inf, np.inf, 5.0],
                  out_limit=[np.inf, 80.0, 120.0, np.inf])
        c.pid.set_hold(moving=[True, False, False, True], saturated=True)
        c.set_fe_limit([1, 2], [np.inf, 40.0])
    script: Script = {
        0: lambda c: c.move_absolute(slice(None), [30_000, 30_000, 30_000, -8_000], 200_000, 4e6,
                                     4e6),
        500: lambda c: c.servo_on(slice(None)),  # clears the trip
        520: lambda c: c.jog(slice(None), 10_000, 1e6, 1e6),
        600: lambda c: c.set_jammed([0, 3], True),  # the error grows: the integrators limit
        640: lambda c: c.set_jammed([0, 3], False),
        900: lambda c: c.pid.set_hold(moving=False, saturated=False),
        1000: lambda c: c.stop(slice(None), 2e5),
    }
    limited = np.zeros(4, dtype=bool)

    def watch(c: MotionCore) -> None:
        limited[:] |= np.abs(c.pid.integ) == c.pid.il

    _, seen = run_both([S, S, S, S], script, 1500, setup=setup, watch=watch)
    assert seen & AxisFlag.FE_TRIP
    assert limited.tolist() == [True, False, False, True]


def test_steppers_rate_limited_or_not_ideal_and_mixed_axes() -> None:
    def setup(c: MotionCore) -> None:
        c.stepper.set(1, 30_000.0)
    script: Script = {
        0: lambda c: c.move_absolute(slice(None), [5_000, 9_000, -3_000, 4_000], 50_000, 5e5, 5e5),
        300: lambda c: c.jog(slice(None), -20_000, 4e5, 4e5, 1e7),
        500: lambda c: c.stepper.set(1, np.inf),
        700: lambda c: c.servo_off([0, 1]),
        800: lambda c: c.servo_on([0, 1]),
        850: lambda c: c.set_kind(3, V),
        900: lambda c: c.move_absolute(slice(None), [0, 1_500, 0, -2_000], 80_000, 6e5, 6e5),
    }
    fast, _ = run_both([S, V, ID, S], script, 1300, setup=setup)
    assert fast.axes.encoder.tolist()[1:] == [1_500, 0, -2_000]


def test_all_steppers_and_all_ideal() -> None:
    script: Script = {0: lambda c: c.move_absolute(slice(None), [1_234, -4_321], 30_000, 3e5, 3e5)}
    run_both([V, V], script, 400)
    run_both([ID, ID], script, 400)


def test_encoder_scale_slip_loss_jam_limits_and_redefinitions() -> None:
    script: Script = {
        0: lambda c: c.set_encoder_scale(1, 2.5),
        1: lambda c: c.jog(slice(None), 20_000, 5e5, 5e5),
        100: lambda c: c.slip_encoder(0, 37),
        150: lambda c: c.set_inputs(encoder_loss=[False, False, True]),
        200: lambda c: c.set_inputs(encoder_loss=[False, False, False]),
        250: lambda c: c.set_jammed(1, True),
        300: lambda c: c.set_jammed(1, False),
        350: lambda c: c.set_inputs(hard_limit_pos=[True, False, False]),
        400: lambda c: c.set_position(slice(None), [10, 20, 30]),
        450: lambda c: c.redefine_and_stop(2, 500.0, 3e5),
        500: lambda c: c.set_inputs(hard_limit_pos=[False, False, False], home=[False, True, False]),
        520: lambda c: c.home(1, -10_000, 3e5, 3e5),
        560: lambda c: c.set_inputs(home=[False, False, False]),
        600: lambda c: c.set_inputs(amp_fault=[False, True, False]),
    }
    run_both([S, S, S], script, 900)


def test_a_period_change_between_ticks() -> None:
    script: Script = {
        0: lambda c: c.move_absolute(slice(None), [40_000, -7_000], 60_000, 4e5, 4e5, [0, 1e7]),
        200: lambda c: c.set_period(442_708.37),
        700: lambda c: c.set_period(2 * MS),
    }
    run_both([S, V], script, 1200)


class _Smoothed(StepperPlant):
    """A card's own stepper (as the Galil's KS smoothing): a step the kernel does not know."""

    def step(self, cmd_pos: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        self.gen += (cmd_pos - self.gen) * 0.25
        new = np.rint(self.gen)
        vel[...] = (new - pos) / self.dt
        pos[...] = new


def test_a_card_s_own_stepper_plant_runs_on_the_numpy_path() -> None:
    def setup(c: MotionCore) -> None:
        c.stepper = _Smoothed(c.n, c.dt)
    script: Script = {0: lambda c: c.move_absolute(slice(None), [2_000, 3_000], 30_000, 3e5, 3e5)}
    fast, _ = run_both([V, S], script, 300, setup=setup)
    assert not fast._own_stepper
    assert fast.stepper.gen[0] == pytest.approx(2_000, abs=1)


def test_without_numba_or_with_vdevd_jit_0_the_numpy_path_serves(
        monkeypatch: pytest.MonkeyPatch) -> None:
    env = dict(os.environ, VDEVD_JIT="0")
    code = ("from vdevd.rt import MotionCore, kernel; "
            "assert kernel.compiled() is None; assert MotionCore(2, 1e6)._kernel is None; "
            "print('numpy')")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "numpy"
    monkeypatch.setattr(kernel, "compiled", lambda: None)  # as without numba
    assert MotionCore(2, 1e6)._kernel is None
    with pytest.raises(RuntimeError, match="not available"):
        MotionCore(2, 1e6, compiled=True)


def test_a_tracked_path_sampled_every_tick() -> None:
    """MotionCore.track (contouring, cam and gear followers) on both paths."""
    def at(t: int) -> Callable[[MotionCore], None]:
        return lambda c: c.track([0, 2], [3000 * np.sin(t / 40), -7.5 * t])

    script: Script = {t: at(t) for t in range(1, 300)}
    script[300] = lambda c: c.hold([0, 2])
    fast, seen = run_both([S, S, ID], script, 400)
    assert seen & AxisFlag.DONE


def _stage(core: MotionCore, every: int, size: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """A stage block of 4 signals x every axis on `core` (`stage_into`), its ring of `size`
    samples taken whenever full; the samples taken, a list that grows."""
    from vdevd.rt.axes import Axes
    cells = np.array([(r, a) for a in range(core.n)
                      for r in (Axes.FB, Axes.CMD_POS, Axes.OUT, Axes.FERR)])
    block = np.zeros((kernel.STAGE_HEAD + size, max(kernel.STAGE_COLS, len(cells))))
    block[kernel.STAGED:kernel.LIMIT + 1, 0] = (0, every, every, len(cells), 0, size)
    block[kernel.CELL_ROWS, :len(cells)] = cells[:, 0]
    block[kernel.CELL_AXES, :len(cells)] = cells[:, 1]
    taken: list[np.ndarray] = []

    def on_full() -> None:
        assert block[kernel.SLOT, 0] == 0  # wrapped
        taken.append(block[kernel.STAGE_HEAD:, :len(cells)].copy())
        block[kernel.STAGED, 0] = 0

    core.stage_into(block, on_full)
    return block, taken


@pytest.mark.parametrize("every", [1, 3])
def test_staged_samples_are_the_state_after_whole_ticks_and_change_nothing(every: int) -> None:
    """RECORD (a scope recording, decision 0016): the compiled and the numpy path stage, every
    `every` ticks, the state after the whole tick - on ticks at a phase boundary, after a
    following-error trip (the PID's output comes from the call after the check), across period
    changes and with a card's own stepper - and tick exactly as a core that stages nothing."""
    if kernel.jit_disabled():
        pytest.skip("VDEVD_JIT=0: the numpy path only")
    kinds = [S, S, V, ID]
    fast, ref, plain = (MotionCore(4, MS, kinds, compiled=c) for c in (True, False, True))
    stages = [_stage(c, every, 16) for c in (fast, ref)]
    expected: list[np.ndarray] = []
    script: Script = {
        0: lambda c: c.move_absolute(slice(None), [30_000, 30_000, 9_000, -8_000], 200_000,
                                     4e6, 4e6),
        300: lambda c: c.servo_on(slice(None)),  # clears the trip
        320: lambda c: c.jog(slice(None), 10_000, 1e6, 1e6),
        400: lambda c: c.set_period(442_708.37),
        500: lambda c: c.set_jammed([0], True),
        560: lambda c: c.set_jammed([0], False),
        600: lambda c: setattr(c, "stepper", _Smoothed(c.n, c.dt)),  # the numpy path serves
        700: lambda c: c.stop(slice(None), 2e5),
    }
    cores = (fast, ref, plain)
    for core in cores:
        core.servo_on(slice(None))
        core.set_fe_limit([0, 1], 40.0)
    seen = 0
    from vdevd.rt.axes import Axes
    rows = [Axes.FB, Axes.CMD_POS, Axes.OUT, Axes.FERR]
    for t in range(900):
        if t in script:
            for core in cores:
                script[t](core)
        events = [c.tick() for c in cores]
        assert events[0] == events[1] == events[2], f"tick {t}"
        seen |= events[0]
        for core in (ref, plain):
            np.testing.assert_array_equal(fast.axes.state, core.axes.state, err_msg=f"tick {t}")
        if (t + 1) % every == 0:
            expected.append(plain.axes.state[rows].T.ravel())
    assert seen & AxisFlag.FE_TRIP and seen & AxisFlag.DONE
    assert not fast._own_stepper
    for block, emptied in stages:
        m = int(block[kernel.STAGED, 0])
        got = np.concatenate(emptied + [block[kernel.STAGE_HEAD:kernel.STAGE_HEAD + m, :16]])
        np.testing.assert_array_equal(got, np.array(expected))
    fast.stop_staging()
    assert fast.staging is None and fast.profile._m3.shape == (3, 3)
    assert fast.profile._m3[0, 1] == fast.dt  # the step of the period now
