"""APS gearing, gantry and safety protection through the client against a lockstep daemon
[M §4.9.1, §4.10; spec adlink.md §2.15, §2.22, §4.5, §4.12]. One AMP-208C, 1 ms cycle, unit
factor 1 (user units = pulses); axis 0 the master, axis 1 the slave."""

from __future__ import annotations

from collections.abc import Iterator
from ctypes import byref, c_int32
from typing import Any

import pytest
from vdevclient import aps
from vdevmaps.adlink import Bar

from tests.client.aps_rack import amp, aps_session, f64, i32, step_ms

M, S = 0, 1


@pytest.fixture
def rack() -> Iterator[Any]:
    with aps_session() as (_, r):
        for a in range(4):
            assert aps.APS_set_servo_on(a, 1) == 0
        step_ms(r, 1)
        yield r


def cmd(a: int) -> float:
    return f64(aps.APS_get_command_f, a)


def fbk(a: int) -> float:
    return f64(aps.APS_get_position_f, a)


def vel(a: int) -> float:
    return f64(aps.APS_get_command_velocity_f, a)


def code(a: int) -> int:
    return i32(aps.APS_get_stop_code, a)


def gear(a: int) -> int:
    return i32(aps.APS_get_gear_status, a)


def msts(a: int, bit: int) -> bool:
    return bool(aps.APS_motion_status(a) >> bit & 1)


def mio(a: int, bit: int) -> bool:
    return bool(aps.APS_motion_io_status(a) >> bit & 1)


def backdoor(r: Any, verb: str, **kw: Any) -> None:
    r.card("amp0").control(verb, **kw)


def set_gear(master: int, slave: int, ratio: float = 1.0, rate: float = 1e9) -> None:
    assert aps.APS_set_axis_param(slave, aps.PRA_GEAR_MASTER, master) == 0
    assert aps.APS_set_axis_param_f(slave, aps.PRA_GEAR_RATIO, ratio) == 0
    assert aps.APS_set_axis_param_f(slave, aps.PRA_GEAR_ENGAGE_RATE, rate) == 0


# -- standard gear [M §4.9.1.1] ---------------------------------------------------------------

def test_standard_gear_ramps_in_at_the_engage_rate_then_follows_at_ratio_2(rack: Any) -> None:
    """Engage rate = ratio / engage time (Fig 4-52): ratio 2 at 4 /s is in after 0.5 s."""
    set_gear(M, S, ratio=2.0, rate=4.0)
    assert aps.APS_vel(M, 0, 1000.0) == 0
    step_ms(rack, 20)  # the master at its speed (acc 1e6: 1 ms)
    assert aps.APS_start_gear(S, aps.GEAR_STANDARD) == 0
    assert gear(S) == 1 and msts(S, aps.MTS_GER) and not msts(M, aps.MTS_GER)
    step_ms(rack, 250)  # half way: r = 1
    assert vel(S) == pytest.approx(1000.0, rel=1e-2)
    assert msts(S, aps.MTS_ACC) and not msts(S, aps.MTS_CSTP)
    step_ms(rack, 260)
    assert vel(S) == pytest.approx(2000.0)
    assert msts(S, aps.MTS_VM) and msts(S, aps.MTS_DIR)
    m0, s0 = cmd(M), cmd(S)
    step_ms(rack, 100)
    assert cmd(M) - m0 == pytest.approx(100.0)
    assert cmd(S) - s0 == pytest.approx(200.0)
    assert fbk(S) == pytest.approx(cmd(S), abs=1.0)  # the drive follows in the same cycle


def test_standard_gear_ratio_change_is_ramped(rack: Any) -> None:
    set_gear(M, S, ratio=1.0, rate=10.0)
    aps.APS_vel(M, 0, 1000.0)
    aps.APS_start_gear(S, 1)
    step_ms(rack, 200)
    assert vel(S) == pytest.approx(1000.0)
    assert aps.APS_set_axis_param_f(S, aps.PRA_GEAR_RATIO, -1.0) == 0
    step_ms(rack, 100)  # 2 / 10 per s: half way to -1
    assert vel(S) == pytest.approx(0.0, abs=20.0)
    step_ms(rack, 110)
    assert vel(S) == pytest.approx(-1000.0)
    assert not msts(S, aps.MTS_DIR)


def test_standard_gear_uses_each_axis_user_units(rack: Any) -> None:
    """Δslave = r × Δmaster in the user units of each axis (spec §2.15 ASSUMPTION)."""
    assert aps.APS_set_axis_param_f(M, aps.PRA_POS_UNIT_FACTOR, 10.0) == 0
    set_gear(M, S, ratio=1.0)
    aps.APS_start_gear(S, 1)
    assert aps.APS_ptp_v(M, aps.OPT_RELATIVE, 50.0, 100.0) == 0
    step_ms(rack, 700)
    assert cmd(M) == pytest.approx(50.0)
    assert cmd(S) == pytest.approx(50.0)
    counts = c_int32()
    aps.APS_get_command(S, byref(counts))
    assert counts.value == 50


def test_standard_slave_superposes_its_own_ptp(rack: Any) -> None:
    """Q13: a standard slave takes its own commands, added to the geared motion."""
    set_gear(M, S, ratio=2.0)
    aps.APS_start_gear(S, 1)
    assert aps.APS_ptp_v(M, aps.OPT_RELATIVE, 300.0, 1000.0) == 0
    assert aps.APS_ptp_v(S, aps.OPT_RELATIVE, 100.0, 1000.0) == 0
    step_ms(rack, 50)
    assert msts(S, aps.MTS_GER) and not msts(S, aps.MTS_MDN)
    step_ms(rack, 400)
    assert cmd(M) == pytest.approx(300.0)
    assert cmd(S) == pytest.approx(700.0)
    assert msts(S, aps.MTS_MDN) and msts(S, aps.MTS_CSTP) and gear(S) == 1


def test_release_by_start_gear_0_leaves_the_slave_where_it_is(rack: Any) -> None:
    set_gear(M, S)
    aps.APS_vel(M, 0, 1000.0)
    aps.APS_start_gear(S, 1)
    step_ms(rack, 50)
    assert aps.APS_start_gear(S, aps.GEAR_DISABLE) == 0
    assert gear(S) == 0 and not msts(S, aps.MTS_GER)
    here = cmd(S)
    step_ms(rack, 50)
    assert cmd(S) == here and msts(S, aps.MTS_CSTP)
    assert vel(M) == pytest.approx(1000.0)
    assert aps.APS_start_gear(S, 0) == 0  # released already: nothing to do


@pytest.mark.parametrize("how", ["alarm", "pel", "stop", "emg_stop", "servo_off"])
def test_standard_release_by_the_slave_leaves_the_master_moving(rack: Any, how: str) -> None:
    """[M §4.9.1.1] Release (2) EMG/ALM/PEL/MEL of the slave, (3) stop, emg_stop or servo-off
    sent to the slave; the moving master is not affected."""
    set_gear(M, S)
    aps.APS_vel(M, 0, 1000.0)
    aps.APS_start_gear(S, 1)
    step_ms(rack, 50)
    if how == "alarm":
        backdoor(rack, "set_alarm", axis=S, active=True)
    elif how == "pel":
        backdoor(rack, "set_limit", axis=S, side="positive", active=True)
    elif how == "stop":
        assert aps.APS_stop_move(S) == 0
    elif how == "emg_stop":
        assert aps.APS_emg_stop(S) == 0
    else:
        assert aps.APS_set_servo_on(S, 0) == 0
    step_ms(rack, 5)
    assert gear(S) == 0 and not msts(S, aps.MTS_GER)
    here = cmd(S)
    step_ms(rack, 20)
    assert cmd(S) == here and msts(S, aps.MTS_CSTP)
    assert vel(M) == pytest.approx(1000.0) and not msts(M, aps.MTS_ASTP)
    expected = {"alarm": aps.STOP_ALM, "pel": aps.STOP_PEL, "stop": aps.STOP_USER,
                "emg_stop": aps.STOP_USER_EMG, "servo_off": aps.STOP_SVNO}[how]
    assert code(S) == expected


def test_a_stopped_slave_decelerates_from_the_gear_speed_at_its_sd_dec(rack: Any) -> None:
    set_gear(M, S, ratio=2.0)
    aps.APS_set_axis_param_f(S, aps.PRA_SD_DEC, 1e5)
    aps.APS_vel(M, 0, 1000.0)
    aps.APS_start_gear(S, 1)
    step_ms(rack, 50)
    here = cmd(S)
    aps.APS_stop_move(S)
    step_ms(rack, 10)
    assert msts(S, aps.MTS_DEC)
    step_ms(rack, 20)
    assert cmd(S) - here == pytest.approx(2000.0**2 / 2e5, abs=2.5)  # v^2 / 2 SD_DEC
    assert msts(S, aps.MTS_MDN) and code(S) == aps.STOP_USER


def test_start_gear_bad_inputs_change_nothing(rack: Any) -> None:
    assert aps.APS_start_gear(S, 3) == aps.ERR_ParametersInvalid
    assert aps.APS_start_gear(S, 1) == aps.ERR_ParametersInvalid  # PRA_GEAR_MASTER -1
    aps.APS_set_axis_param(S, aps.PRA_GEAR_MASTER, S)
    assert aps.APS_start_gear(S, 1) == aps.ERR_ParametersInvalid  # its own master
    assert aps.APS_start_gear(99, 1) == aps.ERR_ParametersInvalid
    assert gear(S) == 0
    set_gear(M, S)
    assert aps.APS_start_gear(S, 1) == 0
    assert aps.APS_start_gear(S, 2) == aps.ERR_CommandInProcess  # release first
    set_gear(S, 2)
    assert aps.APS_start_gear(2, 1) == aps.ERR_ParametersInvalid  # no chains
    set_gear(2, M)
    assert aps.APS_start_gear(M, 1) == aps.ERR_ParametersInvalid
    assert gear(S) == 1 and gear(2) == 0 and gear(M) == 0


# -- gantry [M §4.9.1.2] ----------------------------------------------------------------------

def test_gantry_slave_follows_1_to_1_and_refuses_its_own_commands(rack: Any) -> None:
    set_gear(M, S, ratio=3.0, rate=0.1)  # gantry: ratio and rate ignored
    assert aps.APS_start_gear(S, aps.GEAR_GANTRY) == 0
    assert gear(S) == 2 and msts(S, aps.MTS_GER)
    assert aps.APS_ptp_v(M, 0, 500.0, 2000.0) == 0
    step_ms(rack, 100)
    assert cmd(M) == pytest.approx(198.0) and cmd(S) == pytest.approx(cmd(M))
    assert fbk(S) == pytest.approx(fbk(M), abs=1.0)
    assert aps.APS_ptp(S, 0, 10.0) == aps.ERR_CommandInProcess
    assert aps.APS_vel(S, 0, 10.0) == aps.ERR_CommandInProcess
    step_ms(rack, 200)
    assert cmd(S) == pytest.approx(500.0) and msts(S, aps.MTS_CSTP)


@pytest.mark.parametrize("how", ["stop", "servo_off"])
def test_gantry_stop_or_servo_off_of_the_slave_stops_both(rack: Any, how: str) -> None:
    set_gear(M, S)
    aps.APS_start_gear(S, 2)
    aps.APS_vel(M, 0, 1000.0)
    step_ms(rack, 50)
    if how == "stop":
        aps.APS_stop_move(S)
    else:
        aps.APS_set_servo_on(S, 0)
    step_ms(rack, 5)
    assert vel(M) == 0 and vel(S) == 0
    assert code(M) == (aps.STOP_USER if how == "stop" else aps.STOP_SVNO)
    assert gear(S) == 2  # the pair stays until the user releases it


def test_gantry_slave_alarm_stops_the_master(rack: Any) -> None:
    set_gear(M, S)
    aps.APS_start_gear(S, 2)
    aps.APS_vel(M, 0, 1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_alarm", axis=S, active=True)
    step_ms(rack, 2)
    here = cmd(M)
    step_ms(rack, 10)
    assert cmd(M) == here and code(M) == aps.STOP_ALM and msts(M, aps.MTS_ASTP)
    assert code(S) == aps.STOP_ALM and gear(S) == 2


def test_gantry_slave_limit_stops_the_master(rack: Any) -> None:
    set_gear(M, S)
    aps.APS_start_gear(S, 2)
    aps.APS_vel(M, 0, -1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_limit", axis=S, side="negative", active=True)
    step_ms(rack, 2)
    assert vel(M) == 0 and code(M) == aps.STOP_MEL and code(S) == aps.STOP_MEL


def test_gantry_protection_level_1_decelerates_both(rack: Any) -> None:
    """|fbk_master - fbk_slave| > PRA_GANTRY_PROTECT_1: deceleration stop, code 10."""
    set_gear(M, S)
    aps.APS_set_axis_param_f(S, aps.PRA_GANTRY_PROTECT_1, 20.0)
    aps.APS_set_axis_param_f(S, aps.PRA_GANTRY_PROTECT_2, 100.0)
    aps.APS_set_axis_param_f(M, aps.PRA_SD_DEC, 1e5)
    aps.APS_start_gear(S, 2)
    aps.APS_vel(M, 0, 1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_feedback_offset", axis=S, counts=15.0)
    step_ms(rack, 2)
    assert vel(M) == pytest.approx(1000.0)  # 15 is inside level 1
    backdoor(rack, "set_feedback_offset", axis=S, counts=30.0)
    step_ms(rack, 2)
    assert msts(M, aps.MTS_DEC) and code(M) == aps.STOP_GAN_L1 and msts(M, aps.MTS_ASTP)
    assert code(S) == aps.STOP_GAN_L1
    step_ms(rack, 20)
    assert vel(M) == 0 and vel(S) == 0
    assert mio(M, aps.MIO_SVON) and mio(S, aps.MIO_SVON)


def test_gantry_protection_level_2_turns_both_servos_off(rack: Any) -> None:
    set_gear(M, S)
    aps.APS_set_axis_param_f(S, aps.PRA_GANTRY_PROTECT_1, 20.0)
    aps.APS_set_axis_param_f(S, aps.PRA_GANTRY_PROTECT_2, 100.0)
    aps.APS_start_gear(S, 2)
    aps.APS_vel(M, 0, 1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_feedback_offset", axis=S, counts=150.0)
    step_ms(rack, 2)
    assert vel(M) == 0 and code(M) == aps.STOP_GAN_L2 and code(S) == aps.STOP_GAN_L2
    assert not mio(M, aps.MIO_SVON) and not mio(S, aps.MIO_SVON)
    assert msts(M, aps.MTS_ASTP) and msts(S, aps.MTS_ASTP)


# -- EMG, ALM, limits [M §4.10.1] ----------------------------------------------------------------

def test_emg_stops_every_moving_axis_at_once_and_refuses_commands(rack: Any) -> None:
    """[M §4.10.1.1]: immediate stop, code 1, ASTP; while EMG is on motion commands are
    ignored: code 1, ASTP, and the call returns 0 (spec Q15)."""
    aps.APS_vel(0, 0, 1000.0)
    aps.APS_vel(2, 0, -500.0)
    step_ms(rack, 50)
    backdoor(rack, "set_estop", active=True)
    step_ms(rack, 1)
    here = cmd(0), cmd(2)
    step_ms(rack, 10)
    assert (cmd(0), cmd(2)) == here
    for a in (0, 2):
        assert code(a) == aps.STOP_EMG and msts(a, aps.MTS_ASTP) and mio(a, aps.MIO_EMG)
    assert code(3) == aps.STOP_NORMAL  # an idle axis is not stopped
    assert aps.APS_ptp(3, aps.OPT_RELATIVE, 100.0) == 0
    step_ms(rack, 20)
    assert cmd(3) == 0 and code(3) == aps.STOP_EMG and msts(3, aps.MTS_ASTP)
    backdoor(rack, "set_estop", active=False)
    assert aps.APS_ptp(3, aps.OPT_RELATIVE, 100.0) == 0
    step_ms(rack, 2)
    assert not msts(3, aps.MTS_ASTP)  # cleared when the next motion starts


def test_refused_commands_return_minus_13_with_the_q15_option() -> None:
    with aps_session(amp(refused_rc=-13)) as (_, r):
        backdoor(r, "set_estop", active=True)
        assert aps.APS_ptp(0, aps.OPT_RELATIVE, 100.0) == aps.ERR_FunctionNotAvailable
        assert code(0) == aps.STOP_EMG and msts(0, aps.MTS_ASTP)


def test_alarm_stops_its_axis_at_once_and_refuses_its_commands(rack: Any) -> None:
    """[M §4.10.1.2]; SVON stays as it is (spec Q11)."""
    aps.APS_vel(0, 0, 1000.0)
    aps.APS_vel(2, 0, 1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_alarm", axis=0, active=True)
    step_ms(rack, 1)
    here = cmd(0)
    step_ms(rack, 5)
    assert cmd(0) == here and code(0) == aps.STOP_ALM and msts(0, aps.MTS_ASTP)
    assert mio(0, aps.MIO_ALM) and mio(0, aps.MIO_SVON)
    assert vel(2) == pytest.approx(1000.0)
    assert aps.APS_ptp(0, aps.OPT_RELATIVE, -10.0) == 0
    step_ms(rack, 20)
    assert cmd(0) == here and code(0) == aps.STOP_ALM


def test_pel_immediate_stop_and_motion_away_allowed(rack: Any) -> None:
    """[M §4.10.1.3] PRA_EL_MODE 0 (spec Q4): the axis stops in the cycle PEL turns on;
    positive commands are ignored (code 4, ASTP), negative ones run."""
    aps.APS_vel(0, 0, 1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_limit", axis=0, side="positive", active=True)
    step_ms(rack, 1)
    here = cmd(0)
    step_ms(rack, 5)
    assert cmd(0) == here and code(0) == aps.STOP_PEL and msts(0, aps.MTS_ASTP)
    assert mio(0, aps.MIO_PEL)
    assert aps.APS_ptp(0, aps.OPT_RELATIVE, 10.0) == 0
    step_ms(rack, 20)
    assert cmd(0) == here and code(0) == aps.STOP_PEL
    assert aps.APS_ptp_v(0, aps.OPT_RELATIVE, -10.0, 1000.0) == 0
    step_ms(rack, 30)
    assert cmd(0) == pytest.approx(here - 10.0) and code(0) == aps.STOP_NORMAL
    assert not msts(0, aps.MTS_ASTP)


def test_mel_decel_mode_stops_at_sd_dec(rack: Any) -> None:
    """PRA_EL_MODE 1: deceleration at PRA_SD_DEC (spec Q4): 1000²/(2·1e5) = 5 units, 10 ms."""
    aps.APS_set_axis_param(0, aps.PRA_EL_MODE, 1)
    aps.APS_set_axis_param_f(0, aps.PRA_SD_DEC, 1e5)
    aps.APS_set_axis_param_f(0, aps.PRA_DEC, 1e7)  # not this one
    aps.APS_vel(0, 0, -1000.0)
    step_ms(rack, 50)
    backdoor(rack, "set_limit", axis=0, side="negative", active=True)
    step_ms(rack, 1)
    here = cmd(0)
    assert msts(0, aps.MTS_DEC)
    step_ms(rack, 20)
    assert here - cmd(0) == pytest.approx(5.0, abs=1.1)
    assert code(0) == aps.STOP_MEL and msts(0, aps.MTS_ASTP) and msts(0, aps.MTS_MDN)


def test_an_axis_stopping_meets_an_immediate_limit_at_once(rack: Any) -> None:
    aps.APS_set_axis_param_f(0, aps.PRA_SD_DEC, 1e4)  # a long stop: 50 units, 100 ms
    aps.APS_vel(0, 0, 1000.0)
    step_ms(rack, 20)
    aps.APS_stop_move(0)
    step_ms(rack, 10)
    backdoor(rack, "set_limit", axis=0, side="positive", active=True)
    step_ms(rack, 1)
    here = cmd(0)
    step_ms(rack, 10)
    assert cmd(0) == here and code(0) == aps.STOP_PEL


@pytest.mark.parametrize("side", ["spel", "smel"])
def test_soft_limit_stops_and_refuses_toward_it(rack: Any, side: str) -> None:
    """[M §4.10.2.1]: codes 6/7, MIO bits 11/12; SPEL when command >= SPEL_POS (spec §2.22)."""
    sign = 1.0 if side == "spel" else -1.0
    en, at = ((aps.PRA_SPEL_EN, aps.PRA_SPEL_POS) if side == "spel"
              else (aps.PRA_SMEL_EN, aps.PRA_SMEL_POS))
    stop, bit = ((aps.STOP_SPEL, aps.MIO_SPEL) if side == "spel"
                 else (aps.STOP_SMEL, aps.MIO_SMEL))
    aps.APS_set_axis_param_f(0, at, 100.0 * sign)
    aps.APS_set_axis_param(0, en, 1)
    aps.APS_ptp_v(0, aps.OPT_RELATIVE, 200.0 * sign, 1000.0)
    step_ms(rack, 300)
    assert abs(cmd(0)) == pytest.approx(100.0, abs=1.01)
    assert code(0) == stop and msts(0, aps.MTS_ASTP) and mio(0, bit)
    assert aps.APS_ptp(0, aps.OPT_RELATIVE, 10.0 * sign) == 0
    step_ms(rack, 20)
    assert abs(cmd(0)) == pytest.approx(100.0, abs=1.01) and code(0) == stop
    assert aps.APS_ptp_v(0, aps.OPT_RELATIVE, -20.0 * sign, 1000.0) == 0
    step_ms(rack, 50)
    assert abs(cmd(0)) == pytest.approx(80.0, abs=1.01) and not mio(0, bit)


def test_position_error_level_turns_the_servo_off(rack: Any) -> None:
    """[M §4.10.2.2] |command - feedback| > PRA_ERR_POS_LEVEL: servo off, code 13, ASTP."""
    aps.APS_set_axis_param_f(0, aps.PRA_ERR_POS_LEVEL, 50.0)
    aps.APS_vel(0, 0, 1000.0)
    step_ms(rack, 20)
    backdoor(rack, "set_feedback_offset", axis=0, counts=40.0)
    step_ms(rack, 5)
    assert vel(0) == pytest.approx(1000.0)
    backdoor(rack, "set_feedback_offset", axis=0, counts=60.0)
    step_ms(rack, 2)
    assert vel(0) == 0 and code(0) == aps.STOP_ERROR_LEVEL and msts(0, aps.MTS_ASTP)
    assert not mio(0, aps.MIO_SVON)


# -- watchdog [M §4.10.2.3] ----------------------------------------------------------------------

def _board_i32(fn: Any, *args: Any) -> int:
    v = c_int32()
    assert fn(0, *args, byref(v)) == 0
    return v.value


def test_watchdog_times_out_and_turns_every_servo_off(rack: Any) -> None:
    """Timeout 100 ms, checked in the 2 ms host cycle; action bit 0: servo off, moving axes
    stop with code 3 and ASTP (spec §2.22, Q27)."""
    assert aps.APS_wdt_set_action_event(0, 0, 0b011) == 0
    assert _board_i32(aps.APS_wdt_get_action_event, 0) == 0b011
    aps.APS_vel(2, 0, 1000.0)
    assert aps.APS_wdt_start(0, 0, 100) == 0
    assert _board_i32(aps.APS_wdt_get_timeout_period, 0) == 100
    step_ms(rack, 98)
    assert _board_i32(aps.APS_wdt_get_counter, 0) == 98
    assert mio(2, aps.MIO_SVON) and vel(2) == pytest.approx(1000.0)
    step_ms(rack, 2)
    assert all(not mio(a, aps.MIO_SVON) for a in range(8))
    assert vel(2) == 0 and code(2) == aps.STOP_SVNO and msts(2, aps.MTS_ASTP)
    assert code(0) == aps.STOP_NORMAL and not msts(0, aps.MTS_ASTP)  # idle: no stop
    assert rack.card("amp0").region("bar0").read(Bar.DO, 4) == bytes(4)
    step_ms(rack, 20)
    assert _board_i32(aps.APS_wdt_get_counter, 0) == 100  # it waits for a kick


def test_watchdog_kicked_in_time_does_nothing(rack: Any) -> None:
    aps.APS_wdt_set_action_event(0, 0, 1)
    aps.APS_wdt_start(0, 0, 50)
    for _ in range(5):
        step_ms(rack, 40)
        assert aps.APS_wdt_reset_counter(0, 0) == 0
    assert mio(0, aps.MIO_SVON) and _board_i32(aps.APS_wdt_get_counter, 0) == 0
    assert aps.APS_wdt_start(0, 0, 0) == 0  # 0 stops it
    step_ms(rack, 100)
    assert mio(0, aps.MIO_SVON)


def test_watchdog_is_the_prb_wdt0_board_parameters(rack: Any) -> None:
    aps.APS_set_board_param(0, aps.PRB_WDT0_ACTION, 1)
    aps.APS_set_board_param(0, aps.PRB_WDT0_LIMIT, 10)
    step_ms(rack, 6)
    assert _board_i32(aps.APS_get_board_param, aps.PRB_WDT0_COUNTER) == 6
    step_ms(rack, 4)
    assert not mio(0, aps.MIO_SVON)
    assert _board_i32(aps.APS_wdt_get_timeout_period, 0) == 10


def test_watchdog_bad_inputs(rack: Any) -> None:
    v = c_int32()
    assert aps.APS_wdt_start(0, 1, 100) == aps.ERR_ParametersInvalid
    assert aps.APS_wdt_start(0, 0, -1) == aps.ERR_ParametersInvalid
    assert aps.APS_wdt_set_action_event(0, 0, 8) == aps.ERR_ParametersInvalid
    assert aps.APS_wdt_get_counter(0, 2, byref(v)) == aps.ERR_ParametersInvalid
    assert aps.APS_wdt_get_counter(0, 0, None) == aps.ERR_ParametersInvalid
    assert aps.APS_wdt_reset_counter(7, 0) == aps.ERR_ParametersInvalid
    assert _board_i32(aps.APS_wdt_get_timeout_period, 0) == 0
    assert _board_i32(aps.APS_wdt_get_action_event, 0) == 0
