"""The point tables of the AMP-204C/208C through vdevclient.aps [M §4.9.6; spec adlink.md §2.21, §4.11]:
the manual's flow, the 50-point FIFO and its refill, dwell, DO instructions, transitions, stops,
the status bits, refused arguments. Lockstep clock; 1 ms motion cycle.

Profiles chosen so that times are whole cycles: Vm 10 000 and Acc = Dec 1e6 give a 10 ms ramp of
50 units each way, so a 1000-unit line takes 110 ms (10 + 90 + 10).
"""

from __future__ import annotations

import math
import struct
from ctypes import byref
from typing import Any

import pytest
from vdevclient import aps
from vdevmaps.adlink import Bar

from tests.client.aps_rack import aps_session, f64, step_ms

B, PT = 0, 0  # board 0, point table 0


@pytest.fixture
def rack() -> Any:
    with aps_session() as (_, r):
        for a in range(4):
            assert aps.APS_set_servo_on(a, 1) == 0
        yield r


def enable(axes: tuple[int, ...] = (0, 1), ptb: int = PT) -> None:
    arr = (aps.I32 * len(axes))(*axes)
    assert aps.APS_pt_enable(B, ptb, len(axes), arr) == 0
    assert aps.APS_pt_set_absolute(B, ptb) == 0
    assert aps.APS_pt_set_trans_buffered(B, ptb) == 0
    assert aps.APS_pt_set_acc_dec(B, ptb, 1e6) == 0
    assert aps.APS_pt_set_vm(B, ptb, 1e4) == 0
    assert aps.APS_pt_set_ve(B, ptb, 0.0) == 0
    assert aps.APS_pt_set_vs(B, ptb, 0.0) == 0


def line(*pos: float, ptb: int = PT) -> tuple[int, aps.PTSTS]:
    prof, st = aps.PTLINE(), aps.PTSTS()
    prof.Dim = len(pos)
    for i, p in enumerate(pos):
        prof.Pos[i] = p
    return aps.APS_pt_line(B, ptb, byref(prof), byref(st)), st


def dwell(ms: float) -> tuple[int, aps.PTSTS]:
    prof, st = aps.PTDWL(), aps.PTSTS()
    prof.DwTime = ms
    return aps.APS_pt_dwell(B, PT, byref(prof), byref(st)), st


def status(ptb: int = PT) -> aps.PTSTS:
    st = aps.PTSTS()
    assert aps.APS_get_pt_status(B, ptb, byref(st)) == 0
    return st


def pos(axis: int) -> float:
    return f64(aps.APS_get_command_f, axis)


def msts(axis: int) -> int:
    return int(aps.APS_motion_status(axis))


def bit(word: int, n: int) -> int:
    return (word >> n) & 1


def do_word(rack: Any) -> int:
    return int(struct.unpack("<I", rack.card("amp0").region("bar0").read(Bar.DO, 4))[0])


def run_out(rack: Any, limit_ms: int = 5000, ptb: int = PT) -> int:
    """Step until the table stops working; the milliseconds it took."""
    for ms in range(1, limit_ms + 1):
        step_ms(rack, 1)
        if not status(ptb).BitSts & aps.PTSTS_WORKING:
            return ms
    raise AssertionError("the point table is still running")


# -- the manual's flow ---------------------------------------------------------------------------

def test_manual_example_m_4_9_6_2_enable_push_start_poll(rack: Any) -> None:
    """M §4.9.6.2's example: enable table 0 for axes 0 and 1, check the buffer is not full, push a
    line to (10000, 10000), start (with the example's third argument), poll until done."""
    arr = (aps.I32 * 2)(0, 1)
    assert aps.APS_pt_enable(B, PT, 2, byref(arr)) == 0
    st = status()
    assert not st.BitSts & 0x02
    assert st.BitSts == aps.PTSTS_EMPTY and st.PntBufFreeSpace == 50 and st.PntBufUsageSpace == 0
    rc, st = line(10000.0, 10000.0)
    assert rc == 0 and st.PntBufUsageSpace == 1 and st.PntBufFreeSpace == 49 and st.BitSts == 0
    assert aps.APS_pt_start(B, PT, 0) == 0
    st = status()
    assert st.BitSts & aps.PTSTS_WORKING and st.RunningCnt == 1 and st.PntBufUsageSpace == 0
    run_out(rack)
    assert (pos(0), pos(1)) == (10000.0, 10000.0)
    assert status().BitSts == aps.PTSTS_EMPTY and status().RunningCnt == 1
    info = aps.PTINFO()
    assert aps.APS_get_pt_info(B, PT, byref(info)) == 0
    assert info.Dimension == 2 and list(info.AxisArr)[:2] == [0, 1]


def test_lines_and_arcs_run_in_order_and_leave_the_buffer_when_they_start(rack: Any) -> None:
    """A point leaves the table when it starts; RunningCnt counts the started points (spec §2.21)."""
    enable()
    assert line(1000.0, 0.0)[0] == 0
    arc, st = aps.PTA2CE(), aps.PTSTS()
    arc.Index[0], arc.Index[1] = 0, 1
    arc.Center[0], arc.Center[1] = 1000.0, 500.0
    arc.End[0], arc.End[1] = 1000.0, 1000.0
    arc.Dir = 0
    assert aps.APS_pt_arc2_ce(B, PT, byref(arc), byref(st)) == 0 and st.PntBufUsageSpace == 2
    ca = aps.PTA2CA()
    ca.Index[0], ca.Index[1] = 0, 1
    ca.Center[0], ca.Center[1] = 500.0, 1000.0
    ca.Angle = math.pi / 2  # counter-clockwise from (1000, 1000) about (500, 1000): to (500, 1500)
    assert aps.APS_pt_arc2_ca(B, PT, byref(ca), byref(st)) == 0 and st.PntBufUsageSpace == 3
    assert aps.APS_pt_start(B, PT) == 0
    assert (status().PntBufUsageSpace, status().RunningCnt) == (2, 1)
    step_ms(rack, 105)
    assert (status().PntBufUsageSpace, status().RunningCnt) == (2, 1)  # the line runs 110 ms
    step_ms(rack, 10)
    assert (status().PntBufUsageSpace, status().RunningCnt) == (1, 2)
    run_out(rack)
    assert status().RunningCnt == 3
    assert pos(0) == pytest.approx(500.0, abs=1e-6) and pos(1) == pytest.approx(1500.0, abs=1e-6)


def test_table_longer_than_50_points_refilled_while_running_never_stops(rack: Any) -> None:
    """M §4.9.6.2: monitor the free space and refill while running; with Vs = Ve = Vm the points
    flow at Vm and only the last one stops (Q14)."""
    enable()
    for setter in (aps.APS_pt_set_vs, aps.APS_pt_set_ve):
        assert setter(B, PT, 1e4) == 0
    total, pushed = 130, 0
    while status().PntBufFreeSpace:
        pushed += 1
        assert line(100.0 * pushed, 0.0)[0] == 0
    assert pushed == 50
    assert aps.APS_pt_start(B, PT) == 0
    speeds = []
    while status().BitSts & aps.PTSTS_WORKING:
        step_ms(rack, 7)
        while pushed < total and status().PntBufFreeSpace:
            pushed += 1
            assert line(100.0 * pushed, 0.0)[0] == 0
        if status().BitSts & aps.PTSTS_WORKING:
            speeds.append(f64(aps.APS_get_command_velocity_f, 0))
    assert status().RunningCnt == total
    assert pos(0) == 100.0 * total and pos(1) == 0.0
    assert min(speeds[:-2]) == pytest.approx(1e4)  # never slowed down before the last point


def test_a_full_table_refuses_the_51st_point_with_minus_15_and_stays_unchanged(rack: Any) -> None:
    """Spec §4.11 ASSUMPTION: -15 and the buffer unchanged; Status still filled (full)."""
    enable()
    for i in range(50):
        assert line(10.0 * (i + 1), 0.0)[0] == 0
    assert aps.APS_pt_ext_set_do_ch(B, PT, 5, 1) == 0
    rc, st = line(9999.0, 9999.0)
    assert rc == aps.ERR_CommandInProcess
    assert st.BitSts == aps.PTSTS_FULL and st.PntBufFreeSpace == 0 and st.PntBufUsageSpace == 50
    assert aps.APS_pt_start(B, PT) == 0
    rc, st = line(9999.0, 0.0)  # the first point left when it started: room for one
    assert rc == 0 and st.PntBufUsageSpace == 50
    run_out(rack)
    assert pos(0) == 9999.0 and bit(do_word(rack), 5) == 1  # the DO went with the accepted point


# -- dwell and instructions ------------------------------------------------------------------------

def test_dwell_holds_for_the_time_rounded_up_to_whole_cycles_with_ptb_on(rack: Any) -> None:
    """Spec §2.21: 10.4 ms is 11 cycles; PTB stays 1, MDN 0 and no ACC/VM/DEC bit meanwhile."""
    enable()
    assert line(1000.0, 0.0)[0] == 0
    rc, st = dwell(10.4)
    assert rc == 0 and st.PntBufUsageSpace == 2
    assert line(2000.0, 0.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 111)  # the line ends at 110 ms; the dwell to 121 ms
    assert pos(0) == 1000.0 and status().RunningCnt == 2
    word = msts(0)
    assert bit(word, aps.MTS_PTB) and not bit(word, aps.MTS_MDN)
    assert not (bit(word, aps.MTS_ACC) or bit(word, aps.MTS_VM) or bit(word, aps.MTS_DEC))
    step_ms(rack, 9)  # 120 ms: the dwell's last whole cycle
    assert pos(0) == 1000.0 and status().RunningCnt == 2
    step_ms(rack, 2)  # the next line started at 121 ms
    assert pos(0) > 1000.0 and status().RunningCnt == 3


def test_do_instruction_switches_when_its_point_starts(rack: Any) -> None:
    """M §4.9.6.1 b: the instruction is executed with the next pushed point, at its start (spec
    §2.21 ASSUMPTION); OnOff 1 = on (Q14)."""
    enable()
    assert aps.APS_pt_ext_set_do_ch(B, PT, 3, 1) == 0
    assert aps.APS_pt_ext_set_do_ch(B, PT, 9, 1) == 0  # a TTL output, the same point
    assert line(1000.0, 0.0)[0] == 0
    assert do_word(rack) == 0  # pushed, not started
    assert aps.APS_pt_ext_set_do_ch(B, PT, 3, 0) == 0
    assert line(2000.0, 0.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    assert do_word(rack) == (1 << 3) | (1 << 9)
    step_ms(rack, 109)
    assert do_word(rack) == (1 << 3) | (1 << 9)
    step_ms(rack, 2)  # the second line starts at 110 ms
    assert do_word(rack) == 1 << 9


def test_vao_table_instruction_is_recorded_when_its_point_starts(rack: Any) -> None:
    enable()
    assert aps.APS_pt_ext_set_table_no(B, PT, 1, 7) == 0
    assert aps.APS_pt_ext_set_table_no(B, PT, 2, 0) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_ext_set_table_no(B, PT, 0, 8) == aps.ERR_ParametersInvalid
    assert line(100.0, 0.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    run_out(rack)
    assert status().RunningCnt == 1


# -- transitions [M §4.7.3] ------------------------------------------------------------------------

def corner(rack: Any, trans: Any, *args: float) -> tuple[int, bool]:
    """(0, 0) -> (1000, 0) -> (1000, 1000) with the second point's transition: when axis 1 starts
    (ms) and whether BLD was seen."""
    enable()
    assert line(1000.0, 0.0)[0] == 0
    assert trans(B, PT, *args) == 0
    assert line(1000.0, 1000.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    started, bld = 0, False
    for ms in range(1, 400):
        step_ms(rack, 1)
        bld |= bool(bit(msts(1), aps.MTS_BLD))
        if not started and pos(1) > 0.1:  # 0.5 units in the first ms from rest
            started = ms
        if not status().BitSts & aps.PTSTS_WORKING:
            break
    assert (pos(0), pos(1)) == (1000.0, 1000.0)
    return started, bld


def test_buffered_transition_starts_the_next_point_when_the_previous_ends(rack: Any) -> None:
    assert corner(rack, aps.APS_pt_set_trans_buffered) == (111, False)


def test_blend_dec_starts_the_next_point_when_the_previous_decelerates(rack: Any) -> None:
    """Method 5: the second line starts at 100 ms (the first's deceleration), BLD while both run."""
    assert corner(rack, aps.APS_pt_set_trans_blend_dec, 0.0) == (101, True)


@pytest.mark.parametrize("setter, bp", [(aps.APS_pt_set_trans_blend_dist, 550.0),
                                        (aps.APS_pt_set_trans_blend_pcnt, 55.0),
                                        (aps.APS_pt_set_trans_blend_pcmt, 55.0)])
def test_blend_at_residual_distance_or_percent(rack: Any, setter: Any, bp: float) -> None:
    """Methods 6 and 7: 550 units (55 %) left of 1000 is at 50 ms (50 units of ramp + 400 at Vm)."""
    assert corner(rack, setter, bp) == (51, True)


def test_trans_inp_waits_for_in_position(rack: Any) -> None:
    """APS_pt_set_trans_inp: the next point waits for INP of the table's axes (spec §2.21)."""
    enable()
    assert line(1000.0, 0.0)[0] == 0
    assert aps.APS_pt_set_trans_inp(B, PT) == 0
    assert line(2000.0, 0.0)[0] == 0
    rack.card("amp0").control("set_inp", axis=1, active=False)
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 150)
    assert pos(0) == 1000.0 and status().BitSts & aps.PTSTS_WORKING and status().RunningCnt == 1
    assert bit(msts(0), aps.MTS_PTB) and not bit(msts(0), aps.MTS_MDN)
    rack.card("amp0").control("set_inp", axis=1, active=None)
    step_ms(rack, 3)
    assert pos(0) > 1000.0 and status().RunningCnt == 2
    run_out(rack)
    assert pos(0) == 2000.0


# -- stops and status bits -------------------------------------------------------------------------

def test_ptb_on_every_table_axis_while_running_and_mdn_astp_off(rack: Any) -> None:
    """M §4.9.4 Note 2 bit 11; spec §2.21: PTB 1, MDN = ASTP = 0 on every table axis."""
    enable((2, 0, 1))
    assert line(100.0, 200.0, 300.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 5)
    for a in (0, 1, 2):
        w = msts(a)
        assert bit(w, aps.MTS_PTB) and not bit(w, aps.MTS_MDN) and not bit(w, aps.MTS_ASTP)
        assert not bit(w, aps.MTS_CSTP)
    assert not bit(msts(3), aps.MTS_PTB)
    assert aps.APS_ptp(0, aps.OPT_RELATIVE, 10.0) == aps.ERR_CommandInProcess  # owned
    run_out(rack)
    for a, p in ((2, 100.0), (0, 200.0), (1, 300.0)):
        w = msts(a)
        assert not bit(w, aps.MTS_PTB) and bit(w, aps.MTS_MDN) and pos(a) == p
        assert aps.APS_get_stop_code(a, byref(aps.I32())) == 0


def test_pt_stop_decelerates_at_sd_dec_of_the_first_axis_and_clears_the_buffer(rack: Any) -> None:
    """Spec §2.21 ASSUMPTION: SD_DEC 1e5 from Vm 1e4 stops in 100 ms over 500 units; code 9."""
    assert aps.APS_set_axis_param_f(0, aps.PRA_SD_DEC, 1e5) == 0
    assert aps.APS_set_axis_param(0, aps.PRA_PT_STOP_ENDO, 0b1100) == 0
    assert aps.APS_set_axis_param(0, aps.PRA_PT_STOP_DO, 0b0100) == 0
    enable()
    assert aps.APS_pt_ext_set_do_ch(B, PT, 3, 1) == 0
    assert line(3000.0, 4000.0)[0] == 0
    assert line(0.0, 0.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 50)
    assert do_word(rack) == 1 << 3
    x, y = pos(0), pos(1)
    assert aps.APS_pt_stop(B, PT) == 0
    assert do_word(rack) == 1 << 2  # PRA_PT_STOP_ENDO's channels take PRA_PT_STOP_DO's values
    st = status()
    assert st.PntBufUsageSpace == 0 and st.BitSts & aps.PTSTS_WORKING
    assert run_out(rack) == pytest.approx(100, abs=1)
    assert pos(0) == pytest.approx(x + 300.0, abs=1e-6) and pos(1) == pytest.approx(y + 400.0, abs=1e-6)
    code = aps.I32()
    assert aps.APS_get_stop_code(0, byref(code)) == 0 and code.value == aps.STOP_USER
    assert not bit(msts(0), aps.MTS_ASTP) and bit(msts(0), aps.MTS_MDN)
    assert aps.APS_pt_roll_back(B, PT, 1e4) == 0  # back to where the line began
    run_out(rack)
    assert (pos(0), pos(1)) == (0.0, 0.0) and status().RunningCnt == 1


def test_emg_stops_the_table_at_once_with_astp_and_the_error(rack: Any) -> None:
    enable()
    assert line(1000.0, 1000.0)[0] == 0
    assert line(0.0, 0.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 30)
    rack.card("amp0").control("set_estop", active=True)
    step_ms(rack, 1)
    x = pos(0)
    step_ms(rack, 10)
    assert pos(0) == x and not status().BitSts & aps.PTSTS_WORKING
    assert status().PntBufUsageSpace == 0
    for a in (0, 1):
        assert bit(msts(a), aps.MTS_ASTP) and bit(msts(a), aps.MTS_MDN) and not bit(msts(a), aps.MTS_PTB)
    err = aps.I32()
    assert aps.APS_pt_get_error(B, PT, byref(err)) == 0 and err.value == aps.STOP_EMG


# -- geometry ---------------------------------------------------------------------------------------

def test_relative_arcs_and_spiral_on_columns_picked_by_index(rack: Any) -> None:
    """Index[] picks the table's columns (spec §2.21 ASSUMPTION); relative centres and ends are
    from the point's start; the column the arc does not use stays put."""
    enable((0, 1, 2))
    assert aps.APS_pt_set_relative(B, PT) == 0
    assert line(100.0, 0.0, 0.0)[0] == 0
    ce, st = aps.PTA2CE(), aps.PTSTS()
    ce.Index[0], ce.Index[1] = 2, 1  # the plane of axes 2 and 1
    ce.Center[0], ce.Center[1] = 50.0, 0.0
    ce.End[0], ce.End[1] = 100.0, 0.0  # a half circle
    assert aps.APS_pt_arc2_ce(B, PT, byref(ce), byref(st)) == 0
    hx = aps.PTHCA()
    hx.Index[0], hx.Index[1], hx.Index[2] = 0, 1, 2
    hx.Center[0], hx.Center[1], hx.Center[2] = -100.0, 0.0, 0.0
    hx.Normal[0], hx.Normal[1], hx.Normal[2] = 0.0, 0.0, 1.0
    hx.Angle, hx.DeltaH, hx.FinalR = 2 * math.pi, 50.0, 100.0
    assert aps.APS_pt_sprial_ca(B, PT, byref(hx), byref(st)) == 0 and st.PntBufUsageSpace == 3
    a3 = aps.PTA3CE()
    a3.Index[0], a3.Index[1], a3.Index[2] = 0, 1, 2
    a3.Center[0], a3.Center[1], a3.Center[2] = 0.0, 10.0, 0.0
    a3.End[0], a3.End[1], a3.End[2] = 10.0, 10.0, 0.0
    assert aps.APS_pt_arc3_ce(B, PT, byref(a3), byref(st)) == 0
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 15)
    assert pos(0) < 100.0 and pos(2) == 0.0  # the line takes 20 ms
    step_ms(rack, 20)
    assert pos(0) == 100.0 and 0.0 < pos(2) < 100.0  # the arc in axes 2/1: axis 0 stands still
    run_out(rack)
    assert pos(0) == pytest.approx(110.0, abs=1e-6)
    assert pos(1) == pytest.approx(10.0, abs=1e-6)
    assert pos(2) == pytest.approx(150.0, abs=1e-6)


def test_modal_values_read_back_and_persist_until_changed(rack: Any) -> None:
    enable()
    vs = aps.F64()
    assert aps.APS_pt_set_vs(B, PT, 123.0) == 0
    assert aps.APS_pt_get_vs(B, PT, byref(vs)) == 0 and vs.value == 123.0
    assert aps.APS_pt_set_vs(B, PT, -1.0) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_get_vs(B, PT, byref(vs)) == 0 and vs.value == 123.0
    assert aps.APS_pt_set_s(B, PT, 1.5) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_set_trans_blend_pcnt(B, PT, 101.0) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_set_trans_blend_dist(B, PT, -1.0) == aps.ERR_ParametersInvalid


# -- refused arguments -------------------------------------------------------------------------------

def test_bad_inputs_are_minus_10_and_change_nothing(rack: Any) -> None:
    two = (aps.I32 * 2)(0, 1)
    for ptb in (2, -1):
        assert aps.APS_pt_enable(B, ptb, 2, two) == aps.ERR_ParametersInvalid
        assert aps.APS_get_pt_status(B, ptb, byref(aps.PTSTS())) == aps.ERR_ParametersInvalid
        assert aps.APS_pt_start(B, ptb) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_enable(B, PT, 1, (aps.I32 * 1)(0)) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_enable(B, PT, 7, (aps.I32 * 7)(*range(7))) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_enable(B, PT, 2, (aps.I32 * 2)(0, 8)) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_enable(B, PT, 2, (aps.I32 * 2)(1, 1)) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_enable(B, 5, 2, two) == aps.ERR_ParametersInvalid
    info = aps.PTINFO()
    assert aps.APS_get_pt_info(B, PT, byref(info)) == 0 and info.Dimension == 0
    assert line(1.0, 2.0)[0] == aps.ERR_FunctionNotEnable  # not enabled
    enable()
    assert line(100.0, 100.0)[0] == 0
    assert line(math.nan, 0.0)[0] == aps.ERR_ParametersInvalid
    assert line(1.0, 2.0, 3.0)[0] == aps.ERR_ParametersInvalid  # Dim 3 for a 2-axis table
    assert aps.APS_pt_set_vm(B, PT, math.nan) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_set_acc(B, PT, 0.0) == aps.ERR_ParametersInvalid
    arc, st = aps.PTA2CA(), aps.PTSTS()
    arc.Index[0], arc.Index[1] = 0, 2  # column 2 of a 2-axis table
    arc.Center[0], arc.Center[1], arc.Angle = 0.0, 0.0, 1.0
    assert aps.APS_pt_arc2_ca(B, PT, byref(arc), byref(st)) == aps.ERR_ParametersInvalid
    arc.Index[1] = 1
    arc.Center[0], arc.Center[1] = 100.0, 100.0  # the centre is the start point
    assert aps.APS_pt_arc2_ca(B, PT, byref(arc), byref(st)) == aps.ERR_ParametersInvalid
    assert st.PntBufUsageSpace == 1
    assert dwell(-1.0)[0] == aps.ERR_ParametersInvalid
    assert aps.APS_pt_ext_set_do_ch(B, PT, 24, 1) == aps.ERR_ParametersInvalid
    assert aps.APS_pt_ext_set_do_ch(B, PT, 0, 2) == aps.ERR_ParametersInvalid
    st = status()
    assert st.PntBufUsageSpace == 1 and st.RunningCnt == 0
    assert aps.APS_pt_start(B, PT) == 0
    assert aps.APS_pt_disable(B, PT) == aps.ERR_CommandInProcess
    run_out(rack)
    assert (pos(0), pos(1)) == (100.0, 100.0)
    assert aps.APS_pt_disable(B, PT) == 0


def test_stop_move_on_a_table_axis_stops_the_whole_table_along_the_path(rack: Any) -> None:
    """The kernel's stop of one axis (APS_stop_move, SD_DEC) stops its table with it (spec §2.10:
    the group's axes together); the path is kept, the buffer cleared."""
    assert aps.APS_set_axis_param_f(0, aps.PRA_SD_DEC, 1e5) == 0
    enable()
    assert line(3000.0, 4000.0)[0] == 0
    assert line(0.0, 0.0)[0] == 0
    assert aps.APS_pt_start(B, PT) == 0
    step_ms(rack, 50)
    x, y = pos(0), pos(1)
    assert aps.APS_stop_move(1) == 0
    assert run_out(rack) == pytest.approx(100, abs=1)
    assert pos(0) == pytest.approx(x + 300.0, abs=1e-6) and pos(1) == pytest.approx(y + 400.0, abs=1e-6)
    assert status().PntBufUsageSpace == 0
    for a in (0, 1):
        code = aps.I32()
        assert aps.APS_get_stop_code(a, byref(code)) == 0 and code.value == aps.STOP_USER
        assert bit(msts(a), aps.MTS_MDN) and not bit(msts(a), aps.MTS_ASTP)
