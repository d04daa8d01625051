"""MotionCore.push (backdoor `push`, issue 23 §3): the mechanics moved by hand. The stage and the
encoder move, the command does not; a servo-off axis stays where pushed, a servo-on one is pulled
back by its loop, an ideal one at the next tick, a stepper keeps its step count while its encoder
slips. Both tick paths (compiled and numpy) see the same push."""

from __future__ import annotations

import numpy as np
import pytest

from tests.rt.test_kernel import ID, MS, S, V, run_both
from vdevd.rt import MotionCore, PlantKind


def core_on(kinds: list[PlantKind], compiled: bool = False) -> MotionCore:
    core = MotionCore(len(kinds), MS, kinds, compiled=compiled)
    core.servo_on(slice(None))
    return core


def ticks(core: MotionCore, n: int) -> None:
    for _ in range(n):
        core.tick()


def test_a_servo_off_axis_stays_where_pushed_and_its_encoder_reads_it() -> None:
    core = core_on([S, S])
    core.servo_off(0)
    ticks(core, 10)
    core.push(0, 100)
    ax = core.axes
    assert ax.encoder[0] == 100 and ax.fb[0] == 100  # read at once, before any tick
    assert ax.cmd_pos[0] == 0 and ax.ferr[0] == -100  # the command did not move
    assert core.physical()[0] == 100
    ticks(core, 200)
    assert ax.encoder[0] == 100 and ax.cmd_pos[0] == 100 and ax.ferr[0] == 0  # stays; the
    assert ax.encoder[1] == 0  # command follows the open loop's actual position


def test_a_servo_on_axis_sees_a_following_error_that_its_loop_pulls_back() -> None:
    core = core_on([S])
    core.push(0, 500)
    ax = core.axes
    assert ax.ferr[0] == -500 and ax.cmd_pos[0] == 0
    ticks(core, 1)
    assert ax.ferr[0] < -400  # the plant's inertia: not back in one tick
    errors = []
    for _ in range(50):
        ticks(core, 10)
        errors.append(abs(float(ax.ferr[0])))
    assert errors[-1] <= 1 and max(errors[:3]) > 10  # it decays, as the dynamics allow
    assert ax.cmd_pos[0] == 0


def test_an_ideal_axis_with_its_servo_on_follows_its_command_at_the_next_tick() -> None:
    core = core_on([ID])
    core.push(0, 100)
    assert core.axes.encoder[0] == 100
    ticks(core, 1)
    assert core.axes.encoder[0] == 0 and core.axes.ferr[0] == 0


def test_a_stepper_keeps_its_step_count_while_its_stage_and_encoder_move() -> None:
    core = core_on([V])
    core.move_absolute(0, 1000, 1e5, 1e6, 1e6)
    ticks(core, 200)
    assert core.axes.pos[0] == 1000
    core.push(0, -30)
    ax = core.axes
    assert ax.pos[0] == 1000 and core.physical()[0] == 970  # the steps lost
    assert ax.encoder[0] == 970 and ax.ferr[0] == 30
    ticks(core, 50)
    assert ax.pos[0] == 1000 and ax.encoder[0] == 970
    core.set_position(0, 0)  # a redefinition of zero: the stage stays where it was pushed
    ticks(core, 5)
    assert core.physical()[0] == 970 and ax.encoder[0] == 0


def test_the_encoder_scale_and_a_lost_encoder_apply_to_the_push() -> None:
    core = core_on([S, S])
    core.servo_off(slice(None))
    core.set_encoder_scale(0, 2.0)
    core.set_inputs(encoder_loss=[False, True])
    core.push(slice(None), 100)
    assert core.axes.encoder.tolist() == [200, 0]
    ticks(core, 20)
    assert core.axes.encoder.tolist() == [200, 0] and core.physical().tolist() == [100, 100]


def test_a_jammed_stage_stays_where_pushed() -> None:
    core = core_on([S])
    core.set_jammed(0, True)
    core.push(0, 250)
    ticks(core, 100)
    assert core.axes.pos[0] == 250 and core.axes.ferr[0] == -250


def test_counts_that_are_not_finite_are_refused_and_change_nothing() -> None:
    core = core_on([S])
    before = core.axes.state.copy()
    for bad in (np.nan, np.inf, -np.inf):
        with pytest.raises(ValueError, match="counts must be finite"):
            core.push(0, bad)
    np.testing.assert_array_equal(core.axes.state, before)


def test_a_core_at_rest_is_no_longer_at_rest_after_a_push() -> None:
    core = core_on([S])
    core.servo_off(0)
    ticks(core, 5)
    rest = core.rest_state()
    assert rest is not None
    core.push(0, 7)
    assert core.rest_state() != rest


def test_both_tick_paths_see_the_push() -> None:
    """Servo on and off, ideal, stepper and a jammed servo, pushed mid-move and at rest."""
    def setup(c: MotionCore) -> None:
        c.servo_off(1)
        c.set_jammed(4, True)

    script = {
        5: lambda c: c.move_absolute([0, 2, 3], 2000, 1e5, 1e6, 1e6),
        20: lambda c: c.push(slice(None), [300, -120, 40, 25, 60]),
        250: lambda c: c.push([0, 3], [-45, 7]),
    }
    fast, _ = run_both([S, S, ID, V, S], script, 600, setup=setup)
    assert fast.axes.encoder[1] == -120 and fast.axes.pos[4] == 60
