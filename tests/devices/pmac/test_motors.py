"""Motors of the Turbo PMAC driven tick by tick, no I/O [spec pmac.md §2.6, §2.7, §1.5]."""

from __future__ import annotations

import numpy as np
import pytest

from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.motors import MotorError, Motors
from vdevd.devices.pmac.status import MotorStatus1 as S1
from vdevd.devices.pmac.status import MotorStatus2 as S2

PERIOD_NS = 442_711  # I10 default 3,713,707 / 8,388,608 ms [§2.7]
PERIOD_MS = PERIOD_NS / 1e6


def ticks(ms: float) -> int:
    return round(ms / PERIOD_MS)


def make(plant: str = "servo") -> Motors:
    return Motors(IVars(8), PERIOD_NS, plant)


@pytest.fixture
def mo() -> Motors:
    return make()


def set_iv(mo: Motors, n: int, value: float) -> None:
    mo.ivars.values[n] = value
    mo.on_ivar(n)


def drive(mo: Motors, m: int, *, plus_limit: bool | None = None,
          minus_limit: bool | None = None, home: bool | None = None,
          amp_fault: bool | None = None) -> None:
    """Motor m's flag inputs (None: unchanged) as the card's axis world drives them, through
    `Motors.apply_inputs`: PLIMn, MLIMn, HMFLn read 1, the amplifier reports a fault."""
    levels = [mo.plim.copy(), mo.mlim.copy(), mo.hmfl.copy(), mo.amp_fault_in.copy()]
    for row, level in zip(levels, (plus_limit, minus_limit, home, amp_fault), strict=True):
        if level is not None:
            row[m] = level
    mo.apply_inputs(*levels)


def lose_encoder(mo: Motors, m: int, lost: bool) -> None:
    """Motor m's encoder stops counting while `lost`, through `Motors.set_encoder_losses`."""
    losses = mo.core.encoder_loss.copy()
    losses[m] = lost
    mo.set_encoder_losses(losses)


def run(mo: Motors, count: int) -> int:
    events = 0
    for _ in range(count):
        events |= mo.tick()
    return events


def settle(mo: Motors, m: int = 0, limit: int = 20_000) -> None:
    """Tick until motor m's move has ended and it is in position."""
    for _ in range(limit):
        mo.tick()
        if mo.reports.status_words()[1][m] & S2.IN_POSITION:
            return
    raise AssertionError("motor did not settle")


def w1(mo: Motors, m: int = 0) -> int:
    return int(mo.reports.status_words()[0][m])


def w2(mo: Motors, m: int = 0) -> int:
    return int(mo.reports.status_words()[1][m])


def cmd_velocity(mo: Motors, m: int = 0) -> float:
    """Commanded velocity over the next tick, counts/ms."""
    before = mo.reports.commanded()[m]
    mo.tick()
    return float(mo.reports.commanded()[m] - before) / PERIOD_MS


# -- power-up ---------------------------------------------------------------------------------------------
def test_factory_power_up_every_motor_activated_and_killed(mo: Motors) -> None:
    word1, word2 = mo.reports.status_words()
    # activated, open loop (amp disabled), integration mode (Ixx34 = 1) [§2.6]
    assert word1.tolist() == [0x850000] * 8
    assert word2.tolist() == [0] * 8
    assert mo.reports.position().tolist() == [0.0] * 8
    assert mo.reports.dac().tolist() == [0.0] * 8


def test_ixx80_bit0_closes_the_loop_at_power_up() -> None:
    iv = IVars(8)
    iv.values[180] = 1
    mo = Motors(iv, PERIOD_NS)
    assert w1(mo) == 0x800000 | S1.AMP_ENABLED | S1.INTEGRATION_MODE | S1.DESIRED_VELOCITY_ZERO
    assert w2(mo) == S2.IN_POSITION
    assert w1(mo, 1) == 0x850000


def test_deactivated_motor_reports_zero_words(mo: Motors) -> None:
    set_iv(mo, 800, 0)
    assert mo.reports.status_words()[0][7] == 0


# -- jogging ----------------------------------------------------------------------------------------------
def test_jog_plus_reaches_ixx22_then_jog_stop_holds_in_position(mo: Motors) -> None:
    set_iv(mo, 60, 15)  # I60: velocity over 256 servo cycles
    mo.jog(0, 1)
    assert w1(mo) & S1.AMP_ENABLED and not w1(mo) & S1.OPEN_LOOP
    assert not w1(mo) & S1.DESIRED_VELOCITY_ZERO
    assert not w2(mo) & S2.IN_POSITION
    max_fe = 0.0
    for _ in range(ticks(800)):  # factory S-curve limited by Ixx19: 410 ms to speed
        mo.tick()
        max_fe = max(max_fe, abs(float(mo.reports.following_error()[0])))
    assert mo.reports.velocity()[0] == pytest.approx(32 * PERIOD_MS, abs=0.05)  # counts/servo cycle
    assert cmd_velocity(mo) == pytest.approx(32.0)
    assert max_fe < 1000 / 10  # well below Ixx12 = 16000/16 counts
    assert not w2(mo) & S2.IN_POSITION
    mo.jog_stop(0)
    settle(mo)
    assert w1(mo) & S1.DESIRED_VELOCITY_ZERO
    assert abs(mo.reports.following_error()[0]) < 160 / 16
    assert mo.reports.position()[0] > 0


def test_jog_minus_runs_negative(mo: Motors) -> None:
    mo.jog(0, -1)
    run(mo, ticks(600))
    assert cmd_velocity(mo) == pytest.approx(-32.0)
    assert mo.reports.position()[0] < 0
    assert mo.reports.dac()[0] < 0


def test_jog_to_position_ends_there_with_move_timer(mo: Motors) -> None:
    mo.jog_to(0, 5000)
    mo.tick()
    assert w1(mo) & S1.MOVE_TIMER_ACTIVE
    settle(mo)
    assert not w1(mo) & S1.MOVE_TIMER_ACTIVE
    assert mo.reports.commanded()[0] == 5000
    assert abs(mo.reports.position()[0] - 5000) < 160 / 16


def test_jog_to_without_position_returns_to_pre_jog_position(mo: Motors) -> None:
    mo.jog_to(0, 3000)
    settle(mo)
    mo.jog(0, 1)
    run(mo, ticks(300))
    mo.jog_to(0, None)
    settle(mo)
    assert mo.reports.commanded()[0] == 3000


def test_jog_relative_from_actual_and_from_commanded(mo: Motors) -> None:
    mo.jog(0, 1)
    run(mo, ticks(600))  # at speed: actual lags commanded by the following error
    fe = float(mo.reports.following_error()[0])
    assert fe > 1
    mo.jog_relative(0, 1000, from_actual=True)
    assert mo.reports.target()[0] == np.rint(mo.reports.position()[0] + 1000)
    mo.jog_relative(0, 1000, from_actual=False)
    assert mo.reports.target()[0] == np.rint(mo.reports.commanded()[0] + 1000)
    actual_target = float(mo.reports.target()[0])
    settle(mo)
    assert abs(mo.reports.position()[0] - actual_target) < 10


def test_jog_variable_uses_the_jog_register(mo: Motors) -> None:
    mo.jog_register[0] = 2500
    mo.jog_variable(0, "=")
    settle(mo)
    assert mo.reports.commanded()[0] == 2500
    mo.jog_variable(0, ":")
    settle(mo)
    assert mo.reports.commanded()[0] == 5000
    with pytest.raises(ValueError):
        mo.jog_variable(0, "?")


def test_srm_accel_time_example_takes_200_ms() -> None:
    """Ixx20=100, Ixx21=0, Ixx22=50 asks 0.5 counts/ms^2; Ixx19=0.25 makes it 200 ms [SRM p.100]."""
    mo = make("ideal")
    for yy, value in ((19, 0.25), (20, 100), (21, 0), (22, 50)):
        set_iv(mo, 100 + yy, value)
    mo.jog(0, 1)
    first = cmd_velocity(mo)
    assert cmd_velocity(mo) - first == pytest.approx(0.25 * PERIOD_MS)  # 0.25 counts/ms^2
    run(mo, ticks(100) - 2)
    assert cmd_velocity(mo) == pytest.approx(25.0, abs=0.2)
    run(mo, ticks(99) - 1)
    assert cmd_velocity(mo) < 50
    run(mo, 3)
    assert cmd_velocity(mo) == pytest.approx(50.0)


# -- homing -----------------------------------------------------------------------------------------------
def test_home_on_the_home_flag_with_offset_ends_at_position_zero(mo: Motors) -> None:
    set_iv(mo, 7012, 2)  # I7mn2 = 2: capture on flag high; I7mn3 = 0: HOMEn [SRM p.223]
    set_iv(mo, 126, 500 * 16)  # Ixx26: 500 counts past the trigger
    mo.home(0)
    assert w1(mo) & S1.HOME_SEARCH_IN_PROGRESS
    assert not w2(mo) & S2.HOME_COMPLETE
    run(mo, ticks(500))
    assert mo.reports.position()[0] > 0
    drive(mo, 0, home=True)
    mo.tick()
    assert w2(mo) & S2.HOME_COMPLETE
    assert not w1(mo) & S1.HOME_SEARCH_IN_PROGRESS
    assert w1(mo) & S1.MOVE_TIMER_ACTIVE  # post-trigger move
    trigger = int(mo.reports.capture()[0])
    assert mo.hmfl[0] and mo.homing.captured[0]  # HMFL reads 1, position captured
    drive(mo, 0, home=False)
    settle(mo)
    assert mo.reports.commanded()[0] == 0
    assert abs(mo.reports.position()[0]) < 10
    # EncoderPos = MotorPos + capture + Ixx26/16
    assert abs(int(mo.reports.encoder()[0]) - (trigger + 500)) < 10


def test_home_on_the_index_pulse_by_default(mo: Motors) -> None:
    mo.homing.index_period[0] = 4000  # as the card's axis world sets it
    set_iv(mo, 123, -32)  # Ixx23 < 0: search in the negative direction
    mo.home(0)
    mo.tick()  # the index at count 0 is where the motor stands: triggers at once
    assert w2(mo) & S2.HOME_COMPLETE
    assert mo.reports.capture()[0] == 0
    mo.jog_to(0, 10_000)
    settle(mo)
    mo.home(0)
    events = run(mo, ticks(1000))
    assert events & 1 << 14  # AxisFlag.HOMED
    assert mo.reports.capture()[0] == 8000  # the first index below 10000
    settle(mo)
    assert mo.reports.commanded()[0] == 0


def test_hmz_makes_the_commanded_position_zero(mo: Motors) -> None:
    mo.jog_to(0, 1234)
    settle(mo)
    mo.home_zero(0)
    assert mo.reports.commanded()[0] == 0
    assert w2(mo) & S2.HOME_COMPLETE
    run(mo, 10)
    assert abs(mo.reports.position()[0]) < 10


def test_ixx23_zero_homes_without_moving(mo: Motors) -> None:
    set_iv(mo, 123, 0)
    mo.home(0)
    assert w2(mo) & S2.HOME_COMPLETE
    assert not w1(mo) & S1.HOME_SEARCH_IN_PROGRESS
    assert mo.reports.commanded()[0] == 0


# -- limits -----------------------------------------------------------------------------------------------
def test_hardware_limit_stops_motion_toward_it_but_not_away(mo: Motors) -> None:
    mo.jog(0, 1)
    run(mo, ticks(500))
    drive(mo, 0, plus_limit=True)
    mo.tick()
    assert w1(mo) & S1.ABORT_DECELERATION  # decelerating at Ixx15 = 0.25 counts/ms^2
    assert w1(mo) & S1.POS_END_LIMIT
    run(mo, ticks(130))  # 32 / 0.25 = 128 ms
    settle(mo)
    assert w2(mo) & S2.STOPPED_ON_POSITION_LIMIT
    assert not w1(mo) & S1.ABORT_DECELERATION
    here = float(mo.reports.commanded()[0])
    mo.jog(0, 1)
    run(mo, 100)
    assert mo.reports.commanded()[0] == here  # refused toward the limit
    mo.jog(0, -1)
    run(mo, 100)
    assert mo.reports.commanded()[0] < here  # away from it is allowed
    assert not w2(mo) & S2.STOPPED_ON_POSITION_LIMIT


def test_minus_limit_refuses_negative_jog(mo: Motors) -> None:
    drive(mo, 0, minus_limit=True)
    mo.jog(0, -1)
    run(mo, 100)
    assert mo.reports.commanded()[0] == 0
    assert w1(mo) & S1.NEG_END_LIMIT


def test_ixx24_bit17_disables_the_hardware_limits(mo: Motors) -> None:
    set_iv(mo, 124, 0x020001)
    drive(mo, 0, plus_limit=True)
    mo.jog(0, 1)
    run(mo, 200)
    assert mo.reports.commanded()[0] > 0
    assert not w1(mo) & S1.POS_END_LIMIT


def test_software_limit_stops_a_jog_beyond_it(mo: Motors) -> None:
    set_iv(mo, 113, 5000)  # Ixx13: + software limit, counts
    mo.jog(0, 1)
    run(mo, ticks(2000))
    settle(mo)
    assert mo.reports.position()[0] > 5000  # the actual position passed it, then Ixx15 stopped it
    assert w1(mo) & S1.POS_END_LIMIT
    assert w2(mo) & S2.STOPPED_ON_POSITION_LIMIT
    here = float(mo.reports.commanded()[0])
    mo.jog(0, 1)
    run(mo, 100)
    assert mo.reports.commanded()[0] == here
    mo.jog_to(0, 0)
    settle(mo)
    assert not w1(mo) & S1.POS_END_LIMIT


def test_limit_bits_freeze_while_killed(mo: Motors) -> None:
    mo.jog_stop(0)
    drive(mo, 0, plus_limit=True)
    assert w1(mo) & S1.POS_END_LIMIT
    mo.kill(0)
    drive(mo, 0, plus_limit=False)
    assert w1(mo) & S1.POS_END_LIMIT


# -- faults -----------------------------------------------------------------------------------------------
def test_following_error_warning_then_fatal_kills_every_motor(mo: Motors) -> None:
    mo.jog_stop(1)
    mo.jog(0, 1)
    run(mo, ticks(600))
    lose_encoder(mo, 0, True)  # the loop loses its feedback: the error grows
    warned = False
    events = 0
    for _ in range(ticks(200)):
        events |= mo.tick()
        if w2(mo) & S2.WARNING_FOLLOWING_ERROR and not w2(mo) & S2.FATAL_FOLLOWING_ERROR:
            warned = True
        if events & 1 << 3:  # AxisFlag.FE_TRIP
            break
    assert warned
    assert w2(mo) & S2.FATAL_FOLLOWING_ERROR and w2(mo) & S2.WARNING_FOLLOWING_ERROR
    words = mo.reports.status_words()[0]
    assert not (words & S1.AMP_ENABLED).any()  # Ixx24 bits 21-22 = 00: kill all motors
    assert not w2(mo, 1) & S2.FATAL_FOLLOWING_ERROR
    lose_encoder(mo, 0, False)
    mo.tick()
    mo.jog_stop(0)
    assert w1(mo) & S1.AMP_ENABLED
    assert not w2(mo) & (S2.FATAL_FOLLOWING_ERROR | S2.WARNING_FOLLOWING_ERROR)


def test_fatal_following_error_kills_only_this_motor_with_ixx24_bit22(mo: Motors) -> None:
    set_iv(mo, 124, 0x400001)
    mo.jog_stop(1)
    mo.jog(0, 1)
    run(mo, ticks(600))
    lose_encoder(mo, 0, True)
    run(mo, ticks(200))
    assert not w1(mo) & S1.AMP_ENABLED
    assert w1(mo, 1) & S1.AMP_ENABLED


def test_amplifier_fault_kills_all_and_blocks_enable_until_cleared(mo: Motors) -> None:
    mo.jog_stop(0)
    mo.jog_stop(1)
    drive(mo, 0, amp_fault=True)
    assert w2(mo) & S2.AMP_FAULT_ERROR
    assert not w1(mo) & S1.AMP_ENABLED and not w1(mo, 1) & S1.AMP_ENABLED
    assert not w2(mo, 1) & S2.AMP_FAULT_ERROR
    mo.jog_stop(0)
    assert not w1(mo) & S1.AMP_ENABLED
    drive(mo, 0, amp_fault=False)
    mo.jog_stop(0)
    assert w1(mo) & S1.AMP_ENABLED
    assert not w2(mo) & S2.AMP_FAULT_ERROR


def test_ixx24_bit20_ignores_the_amplifier_fault(mo: Motors) -> None:
    set_iv(mo, 124, 0x100001)
    mo.jog_stop(0)
    drive(mo, 0, amp_fault=True)
    assert w1(mo) & S1.AMP_ENABLED


# -- kill, enable, open loop --------------------------------------------------------------------------------
def test_kill_opens_the_loop_and_jog_stop_reenables_in_place(mo: Motors) -> None:
    mo.jog_to(0, 2000)
    settle(mo)
    mo.kill(0)
    assert w1(mo) & S1.OPEN_LOOP and not w1(mo) & S1.AMP_ENABLED
    assert not w1(mo) & S1.DESIRED_VELOCITY_ZERO
    assert mo.reports.dac()[0] == 0
    run(mo, 20)
    here = float(mo.reports.position()[0])
    mo.jog_stop(0)
    assert w1(mo) & S1.AMP_ENABLED and not w1(mo) & S1.OPEN_LOOP
    assert mo.reports.commanded()[0] == here
    settle(mo)


def test_abort_decelerates_at_ixx15_and_enables_a_killed_motor(mo: Motors) -> None:
    mo.abort(2)
    assert w1(mo, 2) & S1.AMP_ENABLED
    mo.jog(0, 1)
    run(mo, ticks(600))
    mo.abort(0)
    mo.tick()
    assert w1(mo) & S1.ABORT_DECELERATION
    run(mo, ticks(140))
    assert w1(mo) & S1.DESIRED_VELOCITY_ZERO


def test_enable_refused_with_phase_clock_error(mo: Motors) -> None:
    mo.jog_stop(1)
    mo.set_phase_clock_error(True)
    for command in (lambda: mo.jog_stop(0), lambda: mo.jog(0, 1), lambda: mo.home(0),
                    lambda: mo.abort(0), lambda: mo.jog_to(0, 100)):
        with pytest.raises(MotorError) as err:
            command()
        assert err.value.code == 18
    mo.jog_stop(1)  # already enabled: nothing to refuse
    mo.set_phase_clock_error(False)
    mo.jog_stop(0)
    assert w1(mo) & S1.AMP_ENABLED


def test_open_loop_output_is_a_percentage_of_ixx69(mo: Motors) -> None:
    mo.open_loop(0, 50)
    mo.tick()
    assert mo.reports.dac()[0] == 10240
    assert w1(mo) & S1.OPEN_LOOP and w1(mo) & S1.AMP_ENABLED
    run(mo, 50)
    assert mo.reports.position()[0] > 0
    assert mo.reports.following_error()[0] == 0


def test_round_commanded_position(mo: Motors) -> None:
    mo.jog_stop(0)
    mo.core.axes.cmd_pos[0] = 10.4
    mo.core.profile.hold(0, 10.4)
    mo.round_commanded(0)
    assert mo.reports.commanded()[0] == 10


def test_ideal_plant_follows_exactly() -> None:
    mo = make("ideal")
    mo.jog_to(0, 1000)
    for _ in range(ticks(500)):
        mo.tick()
        assert abs(mo.reports.following_error()[0]) < 1
    settle(mo)
    assert mo.reports.position()[0] == 1000
    assert mo.reports.following_error()[0] == 0


def test_reset_kills_and_zeroes_everything(mo: Motors) -> None:
    mo.jog_to(0, 1000)
    settle(mo)
    mo.home_zero(0)
    mo.reset()
    assert mo.reports.position()[0] == 0
    assert w1(mo) == 0x850000
    assert not w2(mo) & S2.HOME_COMPLETE


def test_encoder_counter_wraps_at_24_bits() -> None:
    mo = make("ideal")
    mo.jog_to(0, -5)
    settle(mo)
    assert mo.reports.encoder()[0] == 0xFFFFFB


def test_high_true_fault_polarity_still_faults_the_motor(mo: Motors) -> None:
    """The FAULT bit itself is the Servo IC's X:b+0 bit 15 (test_world.py)."""
    set_iv(mo, 124, 0x800001)  # Ixx24 bit 23: a 1 in the fault bit is a fault [A L1873]
    mo.jog_stop(0)
    drive(mo, 0, amp_fault=True)
    assert w2(mo) & S2.AMP_FAULT_ERROR


def test_in_position_needs_ixx88_plus_1_scans(mo: Motors) -> None:
    set_iv(mo, 188, 5)
    mo.jog_stop(0)
    run(mo, 5)
    assert not w2(mo) & S2.IN_POSITION
    run(mo, 1)
    assert w2(mo) & S2.IN_POSITION
