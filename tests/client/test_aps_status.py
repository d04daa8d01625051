"""vdevclient.aps status and counters against a lockstep daemon: the I32 and F64 getters, the
error position and feedback velocity of a lagging servo drive, the motion I/O word bit by bit,
the CPU-load functions, and a few point-table pushes in 3-D [M §4.1.1.4, §4.1.2, §4.2.1,
§4.8.1, §4.9.6]."""

from __future__ import annotations

import math
from ctypes import byref, c_int32

import pytest
from vdevclient import aps

from tests.client.aps_rack import amp, aps_session, f64, i32, step_ms

MIO = {name: 1 << getattr(aps, f"MIO_{name}") for name in
       ("ALM", "PEL", "MEL", "ORG", "EMG", "EZ", "INP", "SVON", "SPEL", "SMEL")}


def mio(axis: int) -> set[str]:
    word = aps.APS_motion_io_status(axis)
    return {name for name, bit in MIO.items() if word & bit}


def test_i32_getters_round_the_f64_positions() -> None:
    with aps_session() as (_, rack):
        assert aps.APS_set_servo_on(0, 1) == 0
        assert aps.APS_set_axis_param_f(0, aps.PRA_POS_UNIT_FACTOR, 4.0) == 0
        assert aps.APS_ptp_all(0, 0, 10.75, 0, 100, 0, 1e4, 1e4, 0, None) == 0
        step_ms(rack, 1000)
        assert i32(aps.APS_get_command, 0) == 11 and i32(aps.APS_get_position, 0) == 11
        assert i32(aps.APS_get_target_position, 0) == 11
        assert f64(aps.APS_get_target_position_f, 0) == 10.75
        assert i32(aps.APS_get_command_counter, 0) == 43 and i32(aps.APS_get_encoder, 0) == 43
        assert aps.APS_set_command(0, -5) == 0 and aps.APS_set_position(0, 6) == 0
        assert i32(aps.APS_get_command, 0) == -5 and i32(aps.APS_get_position, 0) == 6
        assert f64(aps.APS_get_error_position_f, 0) == -11.0
        assert i32(aps.APS_get_error_position, 0) == -11
        assert i32(aps.APS_get_gear_status, 0) == 0
        assert aps.APS_vel_all(0, 0, 0, -50.0, 0, 1e4, 1e4, 0, None) == 0
        step_ms(rack, 100)
        assert i32(aps.APS_get_command_velocity, 0) == -50
        assert f64(aps.APS_get_feedback_velocity_f, 0) == pytest.approx(-50.0)
        assert i32(aps.APS_get_feedback_velocity, 0) == -50
        assert aps.APS_stop_move_multi(1, (c_int32 * 1)(0)) == 0


def test_a_servo_drive_lags_and_shows_inp_when_it_settles() -> None:
    with aps_session(amp(drive="servo")) as (_, rack):
        assert aps.APS_set_servo_on(1, 1) == 0
        assert "SVON" in mio(1)
        assert aps.APS_vel(1, 0, 20000.0, None) == 0
        step_ms(rack, 3)
        assert f64(aps.APS_get_error_position_f, 1) > 0.5  # the drive lags while it speeds up
        step_ms(rack, 500)
        assert f64(aps.APS_get_feedback_velocity_f, 1) == pytest.approx(20000.0, rel=0.05)
        assert "INP" not in mio(1)
        assert aps.APS_stop_move(1) == 0
        step_ms(rack, 1000)
        assert abs(f64(aps.APS_get_error_position_f, 1)) <= 1.0 and "INP" in mio(1)


def test_motion_io_word_bit_by_bit() -> None:
    with aps_session() as (_, rack):
        card = rack.card("amp0")
        assert mio(2) == set()
        assert aps.APS_set_servo_on(2, 1) == 0
        assert mio(2) == {"SVON", "INP"}
        card.control("set_limit", axis=2, side="positive", active=True)
        card.control("set_limit", axis=2, side="negative", active=True)
        card.control("set_home", axis=2, active=True)
        card.control("set_alarm", axis=2, active=True)
        card.control("set_estop", active=True)
        step_ms(rack, 1)
        assert mio(2) >= {"PEL", "MEL", "ORG", "ALM", "EMG", "SVON"}
        assert aps.APS_set_axis_param(2, aps.PRA_EL_LOGIC, 1) == 0  # inverted: off reads on
        step_ms(rack, 1)
        assert not mio(2) & {"PEL", "MEL"}
        card.control("set_estop", active=False)
        card.control("set_alarm", axis=2, active=False)
        assert aps.APS_set_axis_param(2, aps.PRA_SPEL_EN, 1) == 0
        assert aps.APS_set_axis_param_f(2, aps.PRA_SPEL_POS, -1.0) == 0
        step_ms(rack, 1)
        assert "SPEL" in mio(2) and "EMG" not in mio(2) and "ALM" not in mio(2)
        card.control("set_index", axis=3, period=100, phase=0.5)
        assert aps.APS_set_servo_on(3, 1) == 0
        assert aps.APS_vel(3, 0, 10.0, None) == 0  # 0.01 count per cycle: crosses 0.5 at 50 ms
        seen = False
        for _ in range(100):
            step_ms(rack, 1)
            seen |= "EZ" in mio(3)
        assert seen


def test_cpu_load_functions() -> None:
    """M §4.1.2 with the APS_ prefix (spec Q1): loads in 0.01 % of the cycle."""
    with aps_session() as (_, rack):
        step_ms(rack, 20)
        v = c_int32(-1)
        for fn in (aps.APS_get_motion_control_timing, aps.APS_get_host_control_timing,
                   aps.APS_get_max_motion_control_timing, aps.APS_get_max_host_control_timing,
                   aps.APS_get_over_cycle_count, aps.APS_get_over_cycle_event):
            v.value = -1
            assert fn(0, byref(v)) == 0 and v.value >= 0
        assert aps.APS_reset_max_motion_control_timing(0) == 0
        assert aps.APS_reset_max_host_control_timing(0) == 0
        assert aps.APS_reset_over_cycle_count(0) == 0
        assert aps.APS_get_over_cycle_count(0, byref(v)) == 0 and v.value == 0
        assert aps.APS_get_motion_control_timing(5, byref(v)) == aps.ERR_ParametersInvalid


def test_point_table_3d_arcs_spirals_and_the_buffer_reset() -> None:
    with aps_session() as (_, rack):
        for a in range(3):
            assert aps.APS_set_servo_on(a, 1) == 0
        axes = (c_int32 * 3)(0, 1, 2)
        assert aps.APS_pt_enable(0, 0, 3, axes) == 0
        for setter, value in ((aps.APS_pt_set_vm, 200.0), (aps.APS_pt_set_acc, 1e4),
                              (aps.APS_pt_set_dec, 1e4)):
            assert setter(0, 0, value) == 0
        st = aps.PTSTS()
        arc = aps.PTA3CA(Index=(0, 1, 2), Center=(10.0, 0.0, 0.0), Normal=(0.0, 0.0, 1.0),
                         Angle=math.pi / 2)
        assert aps.APS_pt_arc3_ca(0, 0, byref(arc), byref(st)) == 0
        hca = aps.PTHCA(Index=(0, 1, 2), Center=(10.0, 10.0, 0.0), Normal=(0.0, 0.0, 1.0),
                        Angle=math.pi, DeltaH=5.0, FinalR=10.0)
        assert aps.APS_pt_spiral_ca(0, 0, byref(hca), byref(st)) == 0
        hce = aps.PTHCE(Index=(0, 1, 2), Center=(10.0, 10.0, 0.0), Normal=(0.0, 0.0, 1.0),
                        End=(10.0, 0.0, 5.0), Dir=0)
        assert aps.APS_pt_spiral_ce(0, 0, byref(hce), byref(st)) == 0
        hce.End = (0.0, 10.0, 10.0)
        assert aps.APS_pt_sprial_ce(0, 0, byref(hce), byref(st)) == 0
        assert st.PntBufUsageSpace == 4
        assert aps.APS_reset_pt_buffer(0, 0) == 0
        assert aps.APS_get_pt_status(0, 0, byref(st)) == 0 and st.PntBufUsageSpace == 0
        assert aps.APS_pt_arc3_ca(0, 0, byref(arc), byref(st)) == 0
        assert aps.APS_pt_start(0, 0) == 0
        step_ms(rack, 2000)
        assert f64(aps.APS_get_command_f, 0) == pytest.approx(10.0, abs=1e-9)
        # (S - C) = (-10, 0) turned +90 deg about +z (right-hand rule) is (0, -10)
        assert f64(aps.APS_get_command_f, 1) == pytest.approx(-10.0, abs=1e-9)
