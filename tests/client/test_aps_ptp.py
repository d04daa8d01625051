"""vdevclient.aps single-axis motion against a lockstep daemon with an AMP-208C: PTP T- and
S-curves with their times, auto-planning, status bits around a move, pre/post-distance events,
the 10-command buffer and its speed connections, synchronous start, on-the-fly changes,
velocity moves, stops, the unit factor [M §4.2-4.6, §4.8, §4.9.5; spec adlink.md §2.4-2.9]."""

from __future__ import annotations

import math
from collections.abc import Iterator
from ctypes import byref, c_double, c_int32

import pytest
import vdevclient
from vdevclient import aps

from tests.client.aps_rack import aps_session, f64, i32, step_ms

MTS = {name: 1 << getattr(aps, f"MTS_{name}") for name in
       ("CSTP", "VM", "ACC", "DEC", "DIR", "MDN", "WAIT", "ASTP", "PRED", "POSTD")}


@pytest.fixture
def rack() -> Iterator[vdevclient.Rack]:
    with aps_session() as (_, r):
        for a in range(8):
            assert aps.APS_set_servo_on(a, 1) == 0
        yield r


def status(axis: int) -> set[str]:
    word = aps.APS_motion_status(axis)
    return {name for name, bit in MTS.items() if word & bit}


def cmd(axis: int) -> float:
    return f64(aps.APS_get_command_f, axis)


def move(axis: int, pos: float, vm: float = 1000.0, acc: float = 10000.0, dec: float = 10000.0,
         vs: float = 0.0, ve: float = 0.0, sf: float = 0.0, option: int = 0) -> int:
    return aps.APS_ptp_all(axis, option, pos, vs, vm, ve, acc, dec, sf, None)


# -- T- and S-curves [M §4.2.3] ---------------------------------------------------------------------
def test_t_curve_ptp_takes_the_trapezoid_time_and_shows_acc_vm_dec(rack: vdevclient.Rack) -> None:
    """D 10000, Vm 1000, Acc = Dec 10000: 0.1 s up, 9.9 s at Vm, 0.1 s down = 10.1 s [M §4.2.3.1]."""
    assert move(0, 10000.0) == 0
    assert status(0) >= {"ACC"} and not status(0) & {"MDN", "CSTP"}  # at once (spec Q10)
    step_ms(rack, 50)
    assert status(0) & {"ACC", "VM", "DEC"} == {"ACC"}
    assert cmd(0) == pytest.approx(0.5 * 10000 * 0.05**2)
    step_ms(rack, 1000)
    assert status(0) & {"ACC", "VM", "DEC"} == {"VM"}
    assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(1000.0)
    step_ms(rack, 9000)
    assert status(0) & {"ACC", "VM", "DEC"} == {"DEC"}
    step_ms(rack, 49)
    assert "MDN" not in status(0)
    step_ms(rack, 1)  # 10.1 s
    assert status(0) >= {"MDN", "CSTP", "DIR"} and not status(0) & {"ACC", "VM", "DEC", "ASTP"}
    assert cmd(0) == 10000.0 and f64(aps.APS_get_position_f, 0) == 10000.0
    assert i32(aps.APS_get_command_counter, 0) == 10000 and i32(aps.APS_get_stop_code, 0) == 0


@pytest.mark.parametrize("sf, t_acc", [(1.0, 0.2), (0.5, 0.15)])
def test_s_curve_stretches_the_ramps_by_one_plus_s(rack: vdevclient.Rack, sf: float,
                                                   t_acc: float) -> None:
    """Acc is the peak: T_acc = (1 + S) dv / A [M §4.2.3.2; spec §2.5, Q19]."""
    assert move(0, 10000.0, sf=sf) == 0
    total_ms = round((t_acc + 10000 / 1000) * 1000)  # ramps of t_acc at both ends, cruise
    step_ms(rack, total_ms - 1)
    assert "MDN" not in status(0)
    step_ms(rack, 1)
    assert "MDN" in status(0) and cmd(0) == 10000.0


def test_a_short_move_lowers_vm_and_keeps_acc(rack: vdevclient.Rack) -> None:
    """D 25 with A 10000: Vm' = sqrt(A D) = 500 < Vm, the move takes 2 Vm'/A = 0.1 s, it never
    shows VM [M §4.2.3.1 Fig 4-5]."""
    assert move(0, 25.0) == 0
    seen = set()
    for _ in range(99):
        step_ms(rack, 1)
        seen |= status(0)
    assert "VM" not in seen and "MDN" not in status(0)
    assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(10.0, abs=1e-6)
    step_ms(rack, 1)
    assert "MDN" in status(0) and cmd(0) == 25.0


def test_start_and_end_velocity(rack: vdevclient.Rack) -> None:
    """Vs: the pulse train starts at Vs at once; the first cycle already moves Vs x 1 ms."""
    assert move(0, 10000.0, vs=500.0) == 0
    step_ms(rack, 1)
    assert cmd(0) == pytest.approx(500 * 0.001 + 0.5 * 10000 * 0.001**2)


def test_negative_move_clears_dir(rack: vdevclient.Rack) -> None:
    assert move(0, -100.0) == 0
    step_ms(rack, 500)
    assert status(0) >= {"MDN"} and "DIR" not in status(0) and cmd(0) == -100.0


# -- unit factor [M §4.2.2] ----------------------------------------------------------------------
def test_unit_factor_scales_pulses_not_user_positions(rack: vdevclient.Rack) -> None:
    """G01: 10000 counts/rev, 10 mm pitch, unit um, gear 2:1 -> 2 pulses per user unit."""
    assert aps.APS_set_axis_param_f(1, aps.PRA_POS_UNIT_FACTOR, 2.0) == 0
    assert move(1, 1000.0) == 0
    step_ms(rack, 2000)
    assert cmd(1) == 1000.0
    assert i32(aps.APS_get_command_counter, 1) == 2000 and i32(aps.APS_get_encoder, 1) == 2000
    assert f64(aps.APS_get_position_f, 1) == 1000.0


def test_relative_and_absolute_i32_moves_take_pulses(rack: vdevclient.Rack) -> None:
    assert aps.APS_set_axis_param_f(2, aps.PRA_POS_UNIT_FACTOR, 4.0) == 0
    assert aps.APS_relative_move(2, 400, 1000) == 0
    step_ms(rack, 2000)
    assert i32(aps.APS_get_command_counter, 2) == 400 and cmd(2) == 100.0
    assert aps.APS_absolute_move(2, 800, 1000) == 0
    step_ms(rack, 2000)
    assert i32(aps.APS_get_command_counter, 2) == 800


def test_relative_option_adds_to_the_command_position(rack: vdevclient.Rack) -> None:
    assert move(0, 100.0) == 0
    step_ms(rack, 500)
    assert move(0, 50.0, option=aps.OPT_RELATIVE) == 0
    step_ms(rack, 500)
    assert cmd(0) == 150.0


# -- pre/post-distance events [M §4.8.1 bits 18-19] ------------------------------------------------
def test_pre_and_post_distance_events(rack: vdevclient.Rack) -> None:
    assert aps.APS_set_axis_param_f(0, aps.PRA_PRE_EVENT_DIST, 2000.0) == 0
    assert aps.APS_set_axis_param_f(0, aps.PRA_POST_EVENT_DIST, 3000.0) == 0
    assert move(0, 10000.0) == 0  # at Vm after 0.1 s: travelled 50 + 1000 (t - 0.1)
    step_ms(rack, 2000)  # travelled 1950
    assert not status(0) & {"PRED", "POSTD"}
    step_ms(rack, 100)  # 2050
    assert status(0) & {"PRED", "POSTD"} == {"PRED"}
    step_ms(rack, 5000)  # 7050: remaining 2950 < 3000
    assert status(0) >= {"PRED", "POSTD"}
    assert move(0, 0.0) == 0  # the next move clears both
    assert not status(0) & {"PRED", "POSTD"}


# -- the motion buffer and speed connections [M §4.6.4] ----------------------------------------------
def test_buffered_commands_run_one_after_the_other(rack: vdevclient.Rack) -> None:
    assert move(0, 100.0) == 0
    for pos in (200.0, 300.0):
        assert move(0, pos, option=aps.PTP_OPT_BUFFERED) == 0
    assert i32(aps.APS_get_mq_usage, 0) == 3 and i32(aps.APS_get_mq_free_space, 0) == 7
    step_ms(rack, 200)  # the first (0.2 s: a triangle of 100 at A 10000) is done
    assert 100.0 <= cmd(0) < 200.0 and "MDN" not in status(0)
    step_ms(rack, 1000)
    assert cmd(0) == 300.0 and "MDN" in status(0) and i32(aps.APS_get_mq_usage, 0) == 0


def test_buffered_relative_targets_follow_the_last_queued_one(rack: vdevclient.Rack) -> None:
    assert move(0, 100.0) == 0
    assert move(0, 50.0, option=aps.PTP_OPT_BUFFERED | aps.OPT_RELATIVE) == 0
    step_ms(rack, 2000)
    assert cmd(0) == 150.0


def test_the_buffer_holds_ten_commands(rack: vdevclient.Rack) -> None:
    assert move(0, 1e6) == 0
    for k in range(9):
        assert move(0, 1e6 + k + 1, option=aps.PTP_OPT_BUFFERED) == 0
    assert move(0, 2e6, option=aps.PTP_OPT_BUFFERED) == aps.ERR_CommandInProcess
    assert i32(aps.APS_get_mq_usage, 0) == 10


@pytest.mark.parametrize("mode, junction", [
    (aps.PTP_OPT_BLEND_LOW, 500.0), (aps.PTP_OPT_BLEND_HIGH, 1000.0),
    (aps.PTP_OPT_BLEND_PREVIOUS, 1000.0), (aps.PTP_OPT_BLEND_NEXT, 500.0)])
def test_blended_commands_join_at_the_junction_speed(rack: vdevclient.Rack, mode: int,
                                                    junction: float) -> None:
    """Vm 1000 then Vm 500: the junction speed is min / max / previous / next [M §4.6.4,
    Figs 4-22..4-25; spec §2.9 table]."""
    assert move(0, 5000.0, vm=1000.0) == 0
    assert move(0, 10000.0, vm=500.0, option=mode) == 0
    v_at_junction = None
    for _ in range(12000):
        step_ms(rack, 1)
        if cmd(0) >= 5000.0:
            v_at_junction = f64(aps.APS_get_command_velocity_f, 0)
            break
    assert v_at_junction == pytest.approx(junction, abs=10.0 + 10.0)  # within a cycle's change
    step_ms(rack, 20000)
    assert cmd(0) == 10000.0 and "MDN" in status(0)


def test_a_reversal_joins_at_zero_speed(rack: vdevclient.Rack) -> None:
    assert move(0, 1000.0) == 0
    assert move(0, 0.0, option=aps.PTP_OPT_BLEND_HIGH) == 0
    step_ms(rack, 5000)
    assert cmd(0) == 0.0 and "MDN" in status(0)


# -- synchronous start [M §4.9.5] --------------------------------------------------------------------
def test_opt_wait_holds_axes_until_move_trigger(rack: vdevclient.Rack) -> None:
    assert move(0, 100.0, option=aps.OPT_WAIT) == 0
    assert move(1, 200.0, option=aps.OPT_WAIT) == 0
    assert status(0) >= {"WAIT", "CSTP"} and "MDN" not in status(0)
    step_ms(rack, 10)
    assert cmd(0) == 0.0 and cmd(1) == 0.0
    axes = (c_int32 * 2)(0, 1)
    assert aps.APS_move_trigger(2, axes) == 0
    assert "WAIT" not in status(0) and "ACC" in status(0)
    step_ms(rack, 1)
    assert cmd(0) == cmd(1) > 0  # the same cycle, the same profile so far
    step_ms(rack, 2000)
    assert cmd(0) == 100.0 and cmd(1) == 200.0


def test_stop_move_cancels_a_waiting_command(rack: vdevclient.Rack) -> None:
    assert move(0, 100.0, option=aps.OPT_WAIT) == 0
    assert aps.APS_stop_move(0) == 0
    assert aps.APS_move_trigger(1, (c_int32 * 1)(0)) == 0
    step_ms(rack, 100)
    assert cmd(0) == 0.0 and "MDN" in status(0) and i32(aps.APS_get_stop_code, 0) == 9


# -- on the fly [M §4.6.3] ------------------------------------------------------------------------------
def test_a_new_target_while_moving_replans_without_stopping(rack: vdevclient.Rack) -> None:
    assert move(0, 10000.0) == 0
    step_ms(rack, 1000)
    assert move(0, 5000.0) == 0
    step_ms(rack, 1)
    assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(1000.0)
    step_ms(rack, 6000)
    assert cmd(0) == 5000.0 and "MDN" in status(0)


def test_a_target_behind_reverses(rack: vdevclient.Rack) -> None:
    assert move(0, 10000.0) == 0
    step_ms(rack, 1000)
    here = cmd(0)
    assert move(0, here - 100.0) == 0
    step_ms(rack, 3000)
    assert cmd(0) == pytest.approx(here - 100.0) and "DIR" not in status(0)


def test_a_new_vm_for_the_same_target(rack: vdevclient.Rack) -> None:
    assert move(0, 10000.0) == 0
    step_ms(rack, 1000)
    assert aps.APS_ptp_v(0, 0, 10000.0, 2000.0, None) == 0
    step_ms(rack, 500)
    assert f64(aps.APS_get_command_velocity_f, 0) == pytest.approx(2000.0)


# -- velocity moves and stops [M §4.4] ----------------------------------------------------------------
def test_velocity_move_runs_until_stopped_and_the_target_tracks(rack: vdevclient.Rack) -> None:
    assert aps.APS_set_axis_param_f(3, aps.PRA_ACC, 10000.0) == 0
    assert aps.APS_set_axis_param_f(3, aps.PRA_SD_DEC, 20000.0) == 0
    assert aps.APS_vel(3, 0, -1000.0, None) == 0
    step_ms(rack, 1000)
    assert f64(aps.APS_get_command_velocity_f, 3) == pytest.approx(-1000.0)
    assert f64(aps.APS_get_target_position_f, 3) == pytest.approx(cmd(3))
    assert "DIR" not in status(3)
    assert aps.APS_vel(3, 0, 500.0, None) == 0  # through zero
    step_ms(rack, 1000)
    assert f64(aps.APS_get_command_velocity_f, 3) == pytest.approx(500.0)
    assert aps.APS_stop_move(3) == 0  # 500 / 20000 = 25 ms at PRA_SD_DEC
    step_ms(rack, 25)
    assert status(3) >= {"MDN", "CSTP"} and "ASTP" not in status(3)
    assert i32(aps.APS_get_stop_code, 3) == aps.STOP_USER


def test_emg_stop_stops_at_once(rack: vdevclient.Rack) -> None:
    assert aps.APS_vel(0, 0, 1000.0, None) == 0
    step_ms(rack, 500)
    assert aps.APS_emg_stop(0) == 0
    here = cmd(0)
    step_ms(rack, 10)
    assert cmd(0) == here and "MDN" in status(0)
    assert i32(aps.APS_get_stop_code, 0) == aps.STOP_USER_EMG


def test_stop_move_multi_stops_several_in_one_cycle(rack: vdevclient.Rack) -> None:
    for a in (0, 1):
        assert aps.APS_vel(a, 0, 1000.0, None) == 0
    step_ms(rack, 500)
    assert aps.APS_emg_stop_multi(2, (c_int32 * 2)(0, 1)) == 0
    step_ms(rack, 1)
    assert "MDN" in status(0) and "MDN" in status(1)


def test_velocity_move_i32(rack: vdevclient.Rack) -> None:
    assert aps.APS_set_axis_param_f(4, aps.PRA_POS_UNIT_FACTOR, 10.0) == 0
    assert aps.APS_velocity_move(4, 1000) == 0  # pulses/s
    step_ms(rack, 1000)
    assert f64(aps.APS_get_command_velocity_f, 4) == pytest.approx(100.0)


# -- bad input: the documented code, nothing changed ------------------------------------------------
@pytest.mark.parametrize("call", [
    lambda: aps.APS_ptp(0, 0, math.nan, None),
    lambda: aps.APS_ptp(0, 0, math.inf, None),
    lambda: aps.APS_ptp(8, 0, 1.0, None),
    lambda: aps.APS_ptp(-1, 0, 1.0, None),
    lambda: aps.APS_ptp_v(0, 0, 1.0, 0.0, None),
    lambda: aps.APS_ptp_all(0, 0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, None),
    lambda: aps.APS_ptp_all(0, 0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.5, None),
    lambda: aps.APS_ptp_all(0, 0, 1.0, -1.0, 1.0, 0.0, 1.0, 1.0, 0.0, None),
    lambda: aps.APS_ptp(0, 0x7000, 1.0, None),
    lambda: aps.APS_vel(0, 0, math.nan, None),
    lambda: aps.APS_relative_move(0, 10, 0),
])
def test_bad_motion_arguments_are_parameters_invalid(rack: vdevclient.Rack, call) -> None:
    assert call() == aps.ERR_ParametersInvalid
    step_ms(rack, 10)
    assert status(0) >= {"MDN", "CSTP"} and cmd(0) == 0.0


def test_set_command_while_moving_is_refused(rack: vdevclient.Rack) -> None:
    assert move(0, 1000.0) == 0
    assert aps.APS_set_command_f(0, 5.0) == aps.ERR_CommandInProcess
    step_ms(rack, 2000)
    assert aps.APS_set_command_f(0, 5.0) == 0 and cmd(0) == 5.0
    assert i32(aps.APS_get_command_counter, 0) == 1000  # the raw counter is untouched
    assert aps.APS_set_position_f(0, 7.0) == 0 and f64(aps.APS_get_position_f, 0) == 7.0


def test_calls_before_initial_return_not_initial() -> None:
    v = c_double()
    assert aps.APS_get_command_f(0, byref(v)) == aps.ERR_DeviceNotInitial
    assert aps.APS_ptp(0, 0, 1.0, None) == aps.ERR_DeviceNotInitial


def test_asyncall_gets_the_return_code(rack: vdevclient.Rack) -> None:
    wait = aps.ASYNCALL()
    wait.i32_ret = 99
    assert aps.APS_ptp(0, 0, 10.0, byref(wait)) == 0
    assert wait.i32_ret == 0


def test_mdn_waits_for_inp_and_the_mdn_delay(rack: vdevclient.Rack) -> None:
    """PRA_MDM_CONDI 1: MDN rises with INP; PRA_MDN_DELAY: that many cycles after (spec §2.14)."""
    assert aps.APS_set_axis_param(0, aps.PRA_MDM_CONDI, 1) == 0
    rack.card("amp0").control("set_inp", axis=0, active=False)
    assert move(0, 25.0) == 0
    step_ms(rack, 150)
    assert "CSTP" in status(0) and "MDN" not in status(0)
    rack.card("amp0").control("set_inp", axis=0, active=True)
    step_ms(rack, 1)
    assert "MDN" in status(0)
    assert aps.APS_set_axis_param(1, aps.PRA_MDN_DELAY, 5) == 0
    assert move(1, 25.0) == 0
    step_ms(rack, 100 + 4)
    assert "MDN" not in status(1)
    step_ms(rack, 1)
    assert "MDN" in status(1)


def test_positions_beyond_the_32_bit_command_and_unknown_options_are_refused(
        rack: vdevclient.Rack) -> None:
    """A move of more than 2^31 - 1 pulses [M §1.1 "32-bit" position command], a coordinate no
    F64 holds to the pulse, an option bit no function defines: -10, nothing changed."""
    assert aps.APS_ptp(0, 0, 1e300, None) == aps.ERR_ParametersInvalid
    assert aps.APS_ptp(0, 0, 2.0**31, None) == aps.ERR_ParametersInvalid
    assert aps.APS_set_position_f(0, 1e300) == aps.ERR_ParametersInvalid
    assert aps.APS_set_command_f(0, -1e300) == aps.ERR_ParametersInvalid
    assert aps.APS_vel(0, 0x8000, 10.0, None) == aps.ERR_ParametersInvalid
    assert aps.APS_vel(0, aps.PTP_OPT_BUFFERED, 10.0, None) == aps.ERR_ParametersInvalid
    assert aps.APS_ptp(0, 0x0400, 1.0, None) == aps.ERR_ParametersInvalid
    step_ms(rack, 10)
    assert status(0) >= {"MDN", "CSTP"} and cmd(0) == 0.0 and f64(aps.APS_get_position_f, 0) == 0
    assert aps.APS_ptp(0, 0, 2.0**31 - 1, None) == 0  # the longest move
