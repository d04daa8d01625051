"""A motion core whose servo period changes while it runs (MotionCore.set_period, a card's
update-rate command): plans keep their simulated times, steps follow the new tick length."""

from __future__ import annotations

import pytest

from vdevd.rt import MotionCore, PlantKind

MS = 1_000_000


def ticks_for(core: MotionCore, seconds: float) -> int:
    return round(seconds / core.dt)


@pytest.mark.parametrize("kind", [PlantKind.IDEAL, PlantKind.STEPPER])
def test_a_jog_covers_the_same_distance_in_the_same_time_at_either_rate(kind: PlantKind) -> None:
    core = MotionCore(1, MS, kind)
    core.servo_on(0)
    core.jog(0, 10_000.0, 100_000.0, 100_000.0)
    core.run(ticks_for(core, 0.5))
    core.set_period(MS // 2)
    core.run(ticks_for(core, 0.5))
    # 0.1 s ramp (500 counts) then 0.9 s at 10000 counts/s
    assert core.axes.cmd_pos[0] == pytest.approx(9500.0)
    assert core.profile.t == pytest.approx(1.0)


def test_a_move_planned_before_the_change_ends_at_its_planned_time_and_place() -> None:
    core = MotionCore(1, MS, PlantKind.IDEAL)
    core.servo_on(0)
    core.move_absolute(0, 2000, 10_000.0, 100_000.0, 100_000.0)  # 0.3 s in all
    core.run(ticks_for(core, 0.1))
    core.set_period(MS // 4)
    done_after = 0
    for i in range(1, 2000):
        _, events = core.run(1)
        if events:
            done_after = i
            break
    assert done_after == 800  # the remaining 0.2 s at 250 us a tick
    assert core.axes.pos[0] == 2000.0


def test_a_servo_axis_follows_a_move_across_the_change() -> None:
    core = MotionCore(1, MS, PlantKind.SERVO)
    core.servo_on(0)
    core.move_absolute(0, 20_000, 50_000.0, 500_000.0, 500_000.0)
    core.run(100)
    core.set_period(MS // 2)
    core.run(2000)
    assert abs(core.axes.encoder[0] - 20_000) <= 2


def test_a_period_that_is_not_positive_is_refused() -> None:
    with pytest.raises(ValueError, match="positive"):
        MotionCore(1, MS).set_period(0)
