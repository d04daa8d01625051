"""ADLINK's sample programs for the APS API (PCI-8254/8 `Motion.c` and its VB twin, spec
adlink.md [X5]; the same API as the AMP-204C/208C), their flows run as the spec cites them
against a lockstep daemon: the motion-done check, the 2-D contour of two half circles, the
DI-mapped jog, the forced JOG-ON edge, the point table with a DO synchronised to its first
point, gearing on the master's command."""

from __future__ import annotations

from ctypes import byref, c_double, c_int32

import pytest
from vdevclient import aps

from tests.client.aps_rack import aps_session, f64, i32, step_ms


def motion_done(axis: int) -> tuple[bool, bool]:
    """`check_motion_done_example` [X5]: MDN, then ASTP tells a normal end from an abnormal."""
    sts = aps.APS_motion_status(axis)
    return bool(sts >> aps.MTS_MDN & 1), bool(sts >> aps.MTS_ASTP & 1)


def test_check_motion_done_normal_and_abnormal_ends() -> None:
    with aps_session() as (_, rack):
        assert aps.APS_set_servo_on(0, 1) == 0
        assert aps.APS_ptp(0, aps.OPT_RELATIVE, 5000.0, None) == 0
        ms = 0
        while not motion_done(0)[0]:  # the sample's polling loop, one cycle a turn
            step_ms(rack, 1)
            ms += 1
            assert ms < 1000
        assert motion_done(0) == (True, False) and i32(aps.APS_get_stop_code, 0) == 0
        assert aps.APS_ptp(0, aps.OPT_RELATIVE, 1e6, None) == 0
        step_ms(rack, 100)
        rack.card("amp0").control("set_estop", active=True)
        step_ms(rack, 1)
        assert motion_done(0) == (True, True) and i32(aps.APS_get_stop_code, 0) == aps.STOP_EMG


def test_contour_of_two_exact_half_circles() -> None:
    """The 2-D contour sample drives two half circles with APS_arc2_ce_all(..., Dir = 0): the
    2-D centre-end form accepts 180 deg (spec §2.12, G20) and the end points are exact."""
    with aps_session() as (_, rack):
        axes = (c_int32 * 2)(0, 1)
        for a in (0, 1):
            assert aps.APS_set_servo_on(a, 1) == 0
        c2 = c_double * 2
        assert aps.APS_arc2_ce_all(axes, aps.OPT_ABSOLUTE, c2(50.0, 0.0), c2(100.0, 0.0), 0,
                                   None, 0, 1000, 0, 1e5, 1e5, 0, None) == 0
        assert aps.APS_arc2_ce_all(axes, aps.OPT_ABSOLUTE | aps.ITP_OPT_BUFFERED, c2(50.0, 0.0),
                                   c2(0.0, 0.0), 0, None, 0, 1000, 0, 1e5, 1e5, 0, None) == 0
        step_ms(rack, 84)  # 79 of a half circle of r 50 (157 at 1000/s): at its bottom
        assert f64(aps.APS_get_command_f, 1) < -49.0  # CCW from (0, 0) about (50, 0): y < 0
        step_ms(rack, 400)
        assert motion_done(0) == (True, False)
        assert [f64(aps.APS_get_command_f, a) for a in (0, 1)] == [0.0, 0.0]


def test_jog_on_two_digital_inputs() -> None:
    """PRA_JG_MAP_DI_EN = 0x3, PRA_JG_P_JOG_DI = 0, PRA_JG_N_JOG_DI = 1, JG_DELAY 5000 [X5]."""
    with aps_session() as (_, rack):
        card = rack.card("amp0")
        assert aps.APS_set_servo_on(2, 1) == 0
        for no, value in ((aps.PRA_JG_MAP_DI_EN, 0x3), (aps.PRA_JG_P_JOG_DI, 0),
                          (aps.PRA_JG_N_JOG_DI, 1), (aps.PRA_JG_DELAY, 5000)):
            assert aps.APS_set_axis_param(2, no, value) == 0
        assert aps.APS_set_axis_param_f(2, aps.PRA_JG_VM, 1000.0) == 0
        card.control("set_di", channel=0, level=True)
        step_ms(rack, 100)
        assert aps.APS_motion_status(2) >> aps.MTS_JOG & 1
        assert f64(aps.APS_get_command_velocity_f, 2) == pytest.approx(1000.0)
        card.control("set_di", channel=0, level=False)
        step_ms(rack, 100)
        assert motion_done(2) == (True, False) and not aps.APS_motion_status(2) >> aps.MTS_JOG & 1
        here = f64(aps.APS_get_command_f, 2)
        card.control("set_di", channel=1, level=True)
        step_ms(rack, 100)
        assert f64(aps.APS_get_command_f, 2) < here  # the negative JOG-ON


def test_jog_start_zero_then_one_forces_a_rising_edge() -> None:
    """The samples write 0 then 1 to APS_jog_start to be sure of an edge [X5]."""
    with aps_session() as (_, rack):
        assert aps.APS_set_servo_on(3, 1) == 0
        assert aps.APS_set_axis_param(3, aps.PRA_JG_DIR, 1) == 0  # positive (the manual: Q6)
        assert aps.APS_jog_start(3, 0) == 0 and aps.APS_jog_start(3, 1) == 0
        step_ms(rack, 200)
        assert f64(aps.APS_get_command_f, 3) > 0
        assert aps.APS_jog_start(3, 0) == 0
        step_ms(rack, 200)
        assert motion_done(3)[0]


def test_point_table_with_a_do_synchronised_to_its_first_point() -> None:
    """"Set do command to sync with 1st point" [X5], Index = {0, 1}, a line then an arc."""
    with aps_session() as (_, rack):
        for a in (0, 1):
            assert aps.APS_set_servo_on(a, 1) == 0
        assert aps.APS_pt_enable(0, 0, 2, (c_int32 * 2)(0, 1)) == 0
        assert aps.APS_pt_set_absolute(0, 0) == 0
        assert aps.APS_pt_set_trans_buffered(0, 0) == 0
        assert aps.APS_pt_set_acc(0, 0, 1e4) == 0 and aps.APS_pt_set_vm(0, 0, 500.0) == 0
        st = aps.PTSTS()
        assert aps.APS_pt_ext_set_do_ch(0, 0, 3, 1) == 0
        line = aps.PTLINE(Dim=2)
        line.Pos[0], line.Pos[1] = 100.0, 0.0
        assert aps.APS_pt_line(0, 0, byref(line), byref(st)) == 0
        arc = aps.PTA2CE(Index=(0, 1), Center=(100.0, 50.0), End=(100.0, 100.0), Dir=0)
        assert aps.APS_pt_arc2_ce(0, 0, byref(arc), byref(st)) == 0
        do = c_int32(-1)
        assert aps.APS_read_d_output(0, 0, byref(do)) == 0 and not do.value >> 3 & 1
        assert aps.APS_pt_start(0, 0) == 0
        step_ms(rack, 1)
        assert aps.APS_read_d_output(0, 0, byref(do)) == 0 and do.value >> 3 & 1
        step_ms(rack, 2000)
        assert aps.APS_get_pt_status(0, 0, byref(st)) == 0 and st.RunningCnt == 2
        assert [f64(aps.APS_get_command_f, a) for a in (0, 1)] == pytest.approx([100.0, 100.0])


def test_gear_sample_selects_the_master_command() -> None:
    """PRA_GEAR_MASTER, PRA_GEAR_RATIO, then APS_start_gear(slave, 1); status 1 [X5]."""
    with aps_session() as (_, rack):
        for a in (4, 5):
            assert aps.APS_set_servo_on(a, 1) == 0
        assert aps.APS_set_axis_param(5, aps.PRA_GEAR_MASTER, 4) == 0
        assert aps.APS_set_axis_param_f(5, aps.PRA_GEAR_RATIO, -0.5) == 0
        assert aps.APS_start_gear(5, 1) == 0
        status = c_int32()
        assert aps.APS_get_gear_status(5, byref(status)) == 0 and status.value == 1
        assert aps.APS_ptp(4, 0, 1000.0, None) == 0
        step_ms(rack, 1000)
        assert f64(aps.APS_get_command_f, 5) == pytest.approx(-500.0)
        assert aps.APS_motion_status(5) >> aps.MTS_GER & 1
