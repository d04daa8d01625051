"""Hard limits, soft limits and the following-error limit."""

from __future__ import annotations

import numpy as np

from tests.rt.trace import idle, record
from vdevd.rt import AxisFlag, Limits, MotionCore, PlantKind

MS = 1_000_000
STOP = AxisFlag.STOPPED_BY_LIMIT


def ideal(n: int = 1) -> MotionCore:
    core = MotionCore(n, MS, PlantKind.IDEAL)
    core.servo_on(slice(None))
    return core


def test_soft_target_clamps_to_the_last_whole_count_inside() -> None:
    lim = Limits(1)
    lim.soft_lo[0], lim.soft_hi[0] = -10.5, 20.5
    assert lim.soft_target(0, 0.0, 100.0) == (20.0, AxisFlag.SOFT_LIMIT_POS)
    assert lim.soft_target(0, 0.0, -100.0) == (-10.0, AxisFlag.SOFT_LIMIT_NEG)
    assert lim.soft_target(0, 0.0, 15.0) == (15.0, 0)
    assert lim.soft_target(0, 20.0, 30.0) == (20.0, AxisFlag.SOFT_LIMIT_POS)  # refused
    assert lim.soft_target(0, 30.0, 0.0) == (0.0, 0)  # back inside: allowed


def test_following_error_mask() -> None:
    lim = Limits(3)
    lim.set_fe_limit(slice(None), [5.0, 0.0, 1.0])  # 0 disables
    assert lim.fe_exceeded(np.array([4.0, 1e9, -0.5])) is None
    over = lim.fe_exceeded(np.array([-6.0, 1e9, 0.5]))
    assert over is not None and list(over) == [True, False, False]


def test_move_past_a_soft_limit_stops_exactly_at_it_with_flags() -> None:
    core = ideal(2)
    core.set_soft_limits(slice(None), [-500, -500], [800.7, 800.7])
    core.move_absolute(slice(None), [5000, -5000], 20_000, 1e6, 2e5)
    trace = record(core, 10_000, idle)
    assert list(core.axes.cmd_pos) == [800.0, -500.0]
    assert trace[:, 0].max() == 800.0 and trace[:, 1].min() == -500.0
    assert core.axes.flags[0] & AxisFlag.SOFT_LIMIT_POS and core.axes.flags[0] & STOP
    assert core.axes.flags[1] & AxisFlag.SOFT_LIMIT_NEG and core.axes.flags[1] & STOP
    core.move_absolute(0, 900, 20_000, 1e6, 1e6)  # further out: refused, reported
    assert core.tick() & AxisFlag.SOFT_LIMIT_POS and core.axes.cmd_pos[0] == 800.0
    core.move_absolute(0, 0, 20_000, 1e6, 1e6)  # back in: allowed, flags cleared
    record(core, 10_000, idle)
    assert core.axes.cmd_pos[0] == 0 and not core.axes.flags[0] & (AxisFlag.SOFT_LIMIT_POS | STOP)


def test_hard_limit_during_a_move_decelerates_with_the_limit_deceleration() -> None:
    core = ideal()
    core.limits.limit_dec[:] = 4e5
    core.move_absolute(0, 100_000, 20_000, 1e5, 1e5)
    record(core, 500, lambda c: False)
    core.set_inputs(hard_limit_pos=[True])
    assert core.run(10_000) == (1, AxisFlag.HARD_LIMIT_POS | STOP)  # reported at the next tick
    ticks, events = core.run(10_000)
    assert events == AxisFlag.DONE | STOP and 1 + ticks in (50, 51)  # 20000 / 4e5 s = 50 ms
    flags = core.axes.flags[0]
    assert flags & AxisFlag.HARD_LIMIT_POS and flags & STOP and not flags & AxisFlag.MOVING
    core.set_inputs(hard_limit_pos=[False])
    assert not core.axes.flags[0] & AxisFlag.HARD_LIMIT_POS


def test_hard_limit_behind_a_moving_axis_does_not_stop_it() -> None:
    core = ideal()
    core.jog(0, -10_000, 1e6, 1e6)
    core.set_inputs(hard_limit_pos=[True])
    record(core, 20, lambda c: False)
    assert core.axes.cmd_vel[0] == -10_000 and not core.axes.flags[0] & STOP


def test_following_error_trip_latches_once() -> None:
    core = MotionCore(2, MS, PlantKind.SERVO)
    core.servo_on(slice(None))
    core.set_fe_limit(slice(None), [10, 0])  # 0 disables axis 1
    core.plant.set(slice(None), peak_torque=1.0)
    core.move_absolute(slice(None), 100_000, 1e5, 1e6, 1e6)
    ticks, events = core.run(5000)
    assert events == AxisFlag.FE_TRIP
    assert core.axes.flags[0] & AxisFlag.FE_TRIP and not core.axes.flags[1] & AxisFlag.FE_TRIP
    assert core.run(50) == (50, 0)  # latched: no second event


def test_negative_hard_limit_refuses_moves_toward_it_and_allows_moves_away() -> None:
    core = ideal()
    core.set_inputs(hard_limit_neg=[True])
    assert core.axes.flags[0] & AxisFlag.HARD_LIMIT_NEG
    core.move_absolute(0, -100, 10_000, 1e6, 1e6)
    assert core.tick() == STOP | AxisFlag.DONE and core.axes.cmd_pos[0] == 0
    core.move_absolute(0, 100, 10_000, 1e6, 1e6)
    ticks, events = core.run(10_000)
    assert events == AxisFlag.DONE and core.axes.cmd_pos[0] == 100
    assert not core.axes.flags[0] & STOP


def test_hard_limit_stop_uses_the_moves_deceleration_by_default_and_keeps_other_axes_going() -> None:
    core = ideal(2)
    core.move_absolute(slice(None), 100_000, 20_000, 1e5, 2e5)
    record(core, 500, lambda c: False)
    core.set_inputs(hard_limit_pos=[True, False])
    ticks, events = core.run(10_000)
    assert ticks == 1 and events == AxisFlag.HARD_LIMIT_POS | STOP
    ticks, events = core.run(10_000)
    assert events == AxisFlag.DONE | STOP and ticks in (99, 100, 101)  # 20000 / 2e5 s = 100 ms
    assert core.axes.cmd_vel[1] == 20_000 and core.axes.flags[1] & AxisFlag.MOVING
