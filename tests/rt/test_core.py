"""The motion core as a whole: plants, limits, following error, servo on/off, events."""

from __future__ import annotations

import numpy as np
import pytest

from tests.rt.trace import idle, record
from vdevd.rt import AxisFlag, MotionCore, PlantKind

MS = 1_000_000


def core_with(plant: PlantKind, n: int = 2) -> MotionCore:
    core = MotionCore(n, MS, plant)
    core.servo_on(slice(None))
    return core


def settle(core: MotionCore, ticks: int) -> None:
    for _ in range(ticks):
        core.tick()
    core.update_in_position()


@pytest.mark.parametrize("dt_ns", [125_000, 250_000, 1_000_000, 2_000_000])
def test_servo_with_default_gains_tracks_and_settles_in_position(dt_ns: int) -> None:
    core = MotionCore(2, dt_ns, PlantKind.SERVO)
    core.servo_on(slice(None))
    core.move_absolute(slice(None), [10_000, -2_500], 50_000, 500_000, 500_000)
    worst = 0.0
    while not idle(core):
        core.tick()
        worst = max(worst, float(np.abs(core.axes.ferr).max()))
    assert worst <= 3  # feed-forward: a few counts while moving at 50000 counts/s
    settle(core, int(0.3e9 / dt_ns))
    for _ in range(int(0.2e9 / dt_ns)):  # holds within a count (it hunts at the quantisation)
        core.tick()
        assert (np.abs(core.axes.encoder - [10_000, -2_500]) <= 1).all()
    core.update_in_position()
    assert (core.axes.flags & AxisFlag.IN_POSITION).all()


def test_servo_output_and_integrator_limits() -> None:
    core = core_with(PlantKind.SERVO, 1)
    core.pid.set(0, out_limit=2.0, il=5.0)
    core.plant.set(0, viscous=1e6)  # a stalled motor: the error cannot close
    core.move_absolute(0, 1000, 1e5, 1e6, 1e6)
    settle(core, 200)
    assert abs(core.axes.out[0]) == pytest.approx(2.0)
    assert abs(core.pid.integ[0]) == pytest.approx(5.0)


def test_stepper_moves_in_whole_steps_and_ends_on_target() -> None:
    core = core_with(PlantKind.STEPPER, 1)
    core.move_absolute(0, 777, 10_000, 1e5, 1e5)
    trace = []
    while not idle(core):
        core.tick()
        trace.append(core.axes.pos[0])
    assert all(float(p).is_integer() for p in trace)
    assert core.axes.encoder[0] == 777 and core.axes.pos[0] == 777


def test_mixed_plants_on_one_card() -> None:
    core = MotionCore(3, MS, [PlantKind.SERVO, PlantKind.IDEAL, PlantKind.STEPPER])
    core.servo_on(slice(None))
    core.move_absolute(slice(None), 500, 20_000, 2e5, 2e5)
    record(core, 5000, idle)
    settle(core, 300)
    assert list(core.axes.encoder) == [500, 500, 500]


def test_hard_limit_stops_a_move_toward_it_and_allows_moving_away() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.limits.limit_dec[:] = 1e6
    core.jog(0, 20_000, 1e5, 1e5)
    record(core, 300, lambda c: False)
    core.set_inputs(hard_limit_pos=[True])
    flags = core.axes.flags[0]
    assert flags & AxisFlag.HARD_LIMIT_POS and flags & AxisFlag.STOPPED_BY_LIMIT
    events = 0
    for _ in range(200):
        events |= core.tick()
    assert events & AxisFlag.DONE and core.axes.cmd_vel[0] == 0.0
    core.jog(0, 5_000, 1e5, 1e5)  # toward the active limit: refused
    assert core.tick() & AxisFlag.STOPPED_BY_LIMIT and idle(core)
    core.jog(0, -5_000, 1e5, 1e5)  # away from it: allowed
    record(core, 100, lambda c: False)
    assert core.axes.cmd_vel[0] == -5_000


def test_soft_limit_stops_a_jog_exactly_at_the_limit() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.set_soft_limits(0, -1_000, 1_000)
    core.jog(0, 10_000, 1e6, 1e6)
    trace = record(core, 2000, idle)
    flags = core.axes.flags[0]
    assert flags & AxisFlag.SOFT_LIMIT_POS and flags & AxisFlag.STOPPED_BY_LIMIT
    assert flags & AxisFlag.DONE and trace.max() == 1_000 and trace[-1, 0] == 1_000


def test_following_error_trip_is_an_event() -> None:
    core = core_with(PlantKind.SERVO, 1)
    core.set_fe_limit(0, 20)
    core.plant.set(0, peak_torque=1.0)  # too weak to follow
    core.move_absolute(0, 100_000, 1e5, 1e6, 1e6)
    ticks, events = core.run(5000)
    assert events & AxisFlag.FE_TRIP and ticks < 5000
    assert core.axes.flags[0] & AxisFlag.FE_TRIP
    assert abs(core.axes.ferr[0]) > 20
    core.servo_on(0)
    assert not core.axes.flags[0] & AxisFlag.FE_TRIP


def test_run_stops_right_after_the_event_tick() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.move_absolute(0, 10, 1000, 1e5, 1e5)
    ticks, events = core.run(10_000)
    assert events & AxisFlag.DONE
    assert core.profile.ticks == ticks and core.axes.cmd_pos[0] == 10
    assert core.run(5) == (5, 0)


def test_servo_off_opens_the_loop_and_the_command_follows() -> None:
    core = core_with(PlantKind.SERVO, 1)
    core.jog(0, 20_000, 1e6, 1e6)
    record(core, 100, lambda c: False)
    core.servo_off(0)
    assert not core.axes.flags[0] & AxisFlag.SERVO_ON
    record(core, 50, lambda c: False)
    assert core.axes.out[0] == 0.0
    assert core.axes.cmd_pos[0] == core.axes.pos[0]
    assert abs(core.axes.vel[0]) < 20_000  # coasting down under viscous friction


def test_set_position_defines_position_without_motion() -> None:
    core = core_with(PlantKind.SERVO, 1)
    core.set_position(0, 5000)
    settle(core, 100)
    assert core.axes.encoder[0] == 5000 and core.axes.ferr[0] == 0
    assert abs(core.axes.vel[0]) < 1e-9


def test_encoder_quantises_and_encoder_loss_freezes_it() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.jog(0, 1234.5, 1e6, 1e6)
    record(core, 100, lambda c: False)
    assert core.axes.encoder[0] == np.floor(core.axes.pos[0])
    core.set_inputs(encoder_loss=[True])
    frozen = core.axes.encoder[0]
    record(core, 100, lambda c: False)
    assert core.axes.encoder[0] == frozen and core.axes.pos[0] > frozen + 100
    assert core.axes.flags[0] & AxisFlag.ENCODER_LOSS


def test_amplifier_fault_aborts_and_turns_the_servo_off() -> None:
    core = core_with(PlantKind.SERVO, 1)
    core.jog(0, 5_000, 1e6, 1e6)
    record(core, 20, lambda c: False)
    core.set_inputs(amp_fault=[True])
    events = core.tick()
    assert events & AxisFlag.AMP_FAULT and events & AxisFlag.DONE
    flags = core.axes.flags[0]
    assert flags & AxisFlag.AMP_FAULT and flags & AxisFlag.ABORTED
    assert not flags & AxisFlag.SERVO_ON
    core.servo_on(0)  # refused while the fault is active
    assert not core.axes.flags[0] & AxisFlag.SERVO_ON


def test_bad_motion_parameters_are_refused() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    with pytest.raises(ValueError):
        core.move_absolute(0, 100, 0, 1e5, 1e5)
    with pytest.raises(ValueError):
        core.jog(0, 100, -1, 1e5)


def test_abort_with_a_deceleration_ramps_down_and_reports_aborted_done() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.jog(0, 10_000, 1e6, 1e6)
    record(core, 50, lambda c: False)
    core.abort(0, dec=1e5)
    assert core.axes.flags[0] & AxisFlag.ABORTED and core.axes.flags[0] & AxisFlag.MOVING
    ticks, events = core.run(1000)
    assert events == AxisFlag.DONE | AxisFlag.ABORTED and ticks in (100, 101)
    assert core.axes.cmd_vel[0] == 0.0


def test_move_relative_after_a_jog_starts_from_the_present_position() -> None:
    core = core_with(PlantKind.IDEAL, 2)
    core.move_relative(slice(None), [100, -100], 10_000, 1e6, 1e6)
    core.move_relative(slice(None), [100, -100], 10_000, 1e6, 1e6)  # from the last target
    record(core, 1000, idle)
    assert list(core.axes.cmd_pos) == [200, -200]
    core.jog(0, 5_000, 1e6, 1e6)
    record(core, 30, lambda c: False)
    core.stop(0)
    record(core, 1000, idle)
    here = float(np.rint(core.axes.cmd_pos[0]))
    core.move_relative(0, 10, 10_000, 1e6, 1e6)
    record(core, 1000, idle)
    assert core.axes.cmd_pos[0] == here + 10


def test_commands_take_masks_and_index_arrays() -> None:
    core = core_with(PlantKind.IDEAL, 4)
    core.move_absolute(np.array([True, False, True, False]), [10, 30], 1000, 1e5, 1e5)
    core.move_absolute(np.array([3]), 40, 1000, 1e5, 1e5)
    record(core, 1000, idle)
    assert list(core.axes.cmd_pos) == [10, 0, 30, 40]
    assert list(core.profile.mode) == [0, 0, 0, 0]


def test_done_is_latched_until_the_next_motion_command_and_reported_once() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.move_absolute(0, 100, 10_000, 1e6, 1e6)
    assert core.axes.flags[0] & AxisFlag.MOVING and not core.axes.flags[0] & AxisFlag.DONE
    assert core.run(10_000)[1] == AxisFlag.DONE
    assert core.run(10) == (10, 0)  # an event once, the flag stays
    assert core.axes.flags[0] & AxisFlag.DONE and not core.axes.flags[0] & AxisFlag.MOVING
    core.move_absolute(0, 200, 10_000, 1e6, 1e6)
    assert core.axes.flags[0] & AxisFlag.MOVING and not core.axes.flags[0] & AxisFlag.DONE


def test_in_position_is_refreshed_by_run() -> None:
    core = core_with(PlantKind.IDEAL, 2)
    core.move_absolute(0, 1000, 10_000, 1e5, 1e5)
    core.run(5)
    assert list(core.axes.flags & AxisFlag.IN_POSITION) == [0, AxisFlag.IN_POSITION]
    core.run(10_000)
    assert (core.axes.flags & AxisFlag.IN_POSITION).all()


def test_ferr_is_the_command_minus_the_encoder_after_every_tick() -> None:
    core = core_with(PlantKind.SERVO, 3)
    core.jog(slice(None), [3000.0, -700.5, 0.0], 1e5, 1e5)
    for _ in range(300):
        core.tick()
        assert (core.axes.ferr == core.axes.cmd_pos - core.axes.encoder).all()


def test_servo_on_after_coasting_holds_where_the_motor_is() -> None:
    core = core_with(PlantKind.SERVO, 1)
    core.jog(0, 20_000, 1e6, 1e6)
    record(core, 100, lambda c: False)
    core.servo_off(0)
    record(core, 200, lambda c: False)  # coasting down
    core.plant.set(0, viscous=1e3)  # then a brake
    record(core, 200, lambda c: False)
    here = int(core.axes.encoder[0])
    core.servo_on(0)
    assert core.axes.cmd_pos[0] == here and core.axes.flags[0] & AxisFlag.SERVO_ON
    settle(core, 200)
    assert abs(int(core.axes.encoder[0]) - here) <= 1


def test_a_stepper_on_a_mixed_card_reports_its_pulse_rate() -> None:
    core = MotionCore(2, MS, [PlantKind.SERVO, PlantKind.STEPPER])
    core.servo_on(slice(None))
    core.jog(slice(None), 2500.0, 1e6, 1e6)
    record(core, 100, lambda c: False)
    rates = []
    for _ in range(100):
        core.tick()
        rates.append(core.axes.vel[1])
    assert set(rates) <= {2000.0, 3000.0} and np.mean(rates) == 2500.0  # 2.5 pulses per ms
    assert abs(core.axes.ferr[1]) <= 1 and abs(core.axes.ferr[0]) <= 2


def test_set_position_during_a_move_stops_it_and_reports_aborted_done() -> None:
    core = core_with(PlantKind.IDEAL, 1)
    core.move_absolute(0, 10_000, 10_000, 1e5, 1e5)
    record(core, 50, lambda c: False)
    core.set_position(0, -3)
    assert core.tick() == AxisFlag.DONE | AxisFlag.ABORTED
    assert core.axes.encoder[0] == -3 and core.axes.cmd_pos[0] == -3 and idle(core)


def test_parameters_are_changed_through_set_only() -> None:
    core = core_with(PlantKind.SERVO, 2)
    with pytest.raises(ValueError):
        core.pid.kp[0] = 1.0  # read-only: a direct write would be ignored by the compiled gains
    with pytest.raises(ValueError):
        core.plant.inertia[0] = 2.0
    core.pid.set(1, kp=3.0)
    core.plant.set(1, inertia=2.0)
    assert core.pid.kp[1] == 3.0 and core.plant.inertia[1] == 2.0


def test_snapshot_lists_every_field() -> None:
    core = core_with(PlantKind.IDEAL, 2)
    core.move_absolute(slice(None), [5, -5], 1000, 1e5, 1e5)
    core.run(1000)
    snap = core.axes.snapshot()
    assert snap["cmd_pos"] == [5.0, -5.0] and snap["encoder"] == [5, -5]
    assert set(snap) == {"cmd_pos", "cmd_vel", "cmd_acc", "pos", "vel", "ferr", "out", "encoder",
                         "flags"}


def test_a_core_at_rest_skips_ticks_exactly_as_it_would_run_them() -> None:
    """MotionCore.rest_state is equal around a tick only at a fixed point; skip(k) then leaves
    what k ticks leave (the profile clock), so a move planned afterwards runs the same bits
    (decision 0008)."""
    def core() -> MotionCore:
        c = MotionCore(3, 1e6, [PlantKind.SERVO, PlantKind.STEPPER, PlantKind.IDEAL])
        c.servo_on(slice(None))
        c.move_absolute(slice(None), [4000, -700, 123], 40_000, 400_000, 400_000)
        return c

    ticked, skipped = core(), core()
    assert ticked.rest_state() is None  # a profile runs
    n = 0
    while True:
        before = skipped.rest_state()
        skipped.tick()
        n += 1
        if before is not None and skipped.rest_state() == before:
            break
        assert n < 5000, "the core never came to rest"
    skipped.skip(2500)
    for _ in range(n + 2500):
        ticked.tick()
    assert skipped.rest_state() == ticked.rest_state()
    assert skipped.profile.t == ticked.profile.t
    for c in (ticked, skipped):
        c.move_relative(slice(None), [-1000, 50, 7], 40_000, 400_000, 400_000)
    for _ in range(300):
        ticked.tick()
        skipped.tick()
        assert ticked.axes.state.tobytes() == skipped.axes.state.tobytes()


def test_track_runs_a_path_given_every_tick_and_hold_ends_it() -> None:
    """The caller gives the next tick's commanded positions; the axes reach them exactly (an
    ideal plant follows) with the path's velocity, MOVING until `hold`, which reports DONE."""
    core = core_with(PlantKind.IDEAL, 3)
    for k in range(1, 6):
        core.track([0, 2], [10.0 * k, -3.0 * k])
        assert core.tick() == 0
        assert core.axes.cmd_pos.tolist() == [10.0 * k, 0.0, -3.0 * k]
        assert core.axes.cmd_vel.tolist() == [10_000.0, 0.0, -3_000.0]
    assert core.axes.flags[0] & AxisFlag.MOVING and not core.axes.flags[1] & AxisFlag.MOVING
    core.hold([0, 2])
    assert core.tick() & AxisFlag.DONE
    assert core.axes.cmd_vel.tolist() == [0.0, 0.0, 0.0]
    assert not core.axes.flags[0] & AxisFlag.MOVING
    with pytest.raises(ValueError):
        core.track(0, float("nan"))


def test_track_again_takes_the_cheap_step_and_equals_planning_every_tick() -> None:
    """A path given every tick: the cheap step (nothing re-planned since the last call) leaves
    the tracked axes exactly where re-planning them every tick does; another plan in between
    (an idle axis's move) makes the next call plan again."""
    def run(replan: bool) -> list[list[float]]:
        core = core_with(PlantKind.SERVO, 3)
        out = []
        for k in range(1, 400):
            if replan:
                core.profile.plans += 1  # as if something had planned: the full path
            s = max(k - 3, 0)  # three ticks at rest first: the path starts with no velocity
            core.track([0, 2], [1000 * np.sin(s / 30), -2.5 * s])
            if k == 200:
                core.move_absolute(1, 500, 20_000, 200_000, 200_000)
            core.tick()
            out.append(core.axes.state[:, [0, 2]].ravel().tolist())
        return out

    fast = run(False)
    assert fast == run(True)
    assert fast[-1][0] == pytest.approx(1000 * np.sin(396 / 30)) and fast[-1][1] == -2.5 * 396


def test_hold_at_positions_ends_a_tracked_path_where_it_is_told() -> None:
    """The last straight piece of a path reaches its point within the rounding of time (a
    count boundary can fall a hair short); `hold` with positions stops on the path's points
    themselves, whatever the commanded position shows."""
    core = core_with(PlantKind.IDEAL, 2)
    for k in range(1, 6):
        core.track([0, 1], [7.0 * k, -3.0 * k])
        core.tick()
    core.hold([0, 1], [35.0, -14.5])
    assert core.tick() & AxisFlag.DONE
    core.tick()
    assert core.axes.cmd_pos.tolist() == [35.0, -14.5]
    assert core.axes.cmd_vel.tolist() == [0.0, 0.0]
    assert core.axes.encoder.tolist() == [35, -15]
    with pytest.raises(ValueError):
        core.hold(0, float("inf"))
