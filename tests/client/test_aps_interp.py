"""APS interpolation through the client against a lockstep daemon [M §4.7, §4.8.1, §4.9.5;
spec adlink.md §2.10-2.14, §2.20, §4.4]: lines, arcs, helices, the seven transitions, the
synchronous start, group stops and the refusals.

The vector profile in most tests: Vm 1000, Acc = Dec 10000, T-curve (SF 0): 0.1 s and 50 units
to speed, so a line of length L takes L/1000 + 0.1 s."""

from __future__ import annotations

import math
from collections.abc import Iterator
from ctypes import c_double, c_int32
from typing import Any

import numpy as np
import pytest
from vdevclient import aps

from tests.client.aps_rack import aps_session, f64, i32, step_ms

VM, ACC = 1000.0, 10000.0
PROFILE = (0.0, VM, 0.0, ACC, ACC, 0.0)  # Vs, Vm, Ve, Acc, Dec, SFac
X, Y, Z = 0, 1, 2


@pytest.fixture
def rack() -> Iterator[Any]:
    with aps_session() as (_, r):
        for a in range(8):
            assert aps.APS_set_servo_on(a, 1) == 0
        yield r


def pos(*axes: int) -> np.ndarray:
    return np.array([f64(aps.APS_get_command_f, a) for a in axes])


def vel(*axes: int) -> np.ndarray:
    return np.array([f64(aps.APS_get_command_velocity_f, a) for a in axes])


def sts(a: int) -> int:
    return int(aps.APS_motion_status(a))


def bit(a: int, b: int) -> bool:
    return bool(sts(a) >> b & 1)


def done(*axes: int) -> bool:
    return all(bit(a, aps.MTS_MDN) and bit(a, aps.MTS_CSTP) for a in axes)


def line(axes: list[int], end: list[float], option: int = 0, para: float | None = None,
         vm: float = VM) -> int:
    trans = None if para is None else c_double(para)
    return int(aps.APS_line_all(len(axes), axes, option, end, trans, 0.0, vm, 0.0, ACC, ACC,
                                0.0))


def trace(rack: Any, ms: int, *axes: int, every: int = 1) -> np.ndarray:
    """Command positions sampled every `every` ms for `ms` ms (rows: time)."""
    out = []
    for _ in range(ms // every):
        step_ms(rack, every)
        out.append(pos(*axes))
    return np.array(out)


# -- lines [M §4.7.1] ------------------------------------------------------------------------------

def test_line_2_axes_path_length_time_and_axis_speeds_vi_dxi_over_dp_v_m_4_7_1(rack: Any) -> None:
    assert line([X, Y], [3000.0, 4000.0]) == 0  # dP = 5000: 5.1 s
    assert bit(X, aps.MTS_ACC) and bit(Y, aps.MTS_ACC) and not bit(X, aps.MTS_MDN)
    step_ms(rack, 1000)
    np.testing.assert_allclose(pos(X, Y), [0.6 * 950, 0.8 * 950], atol=1e-6)
    np.testing.assert_allclose(vel(X, Y), [600.0, 800.0], rtol=1e-9)  # Vi = dXi/dP * V
    assert bit(X, aps.MTS_VM) and bit(Y, aps.MTS_VM)
    step_ms(rack, 4050)
    assert bit(X, aps.MTS_DEC) and bit(Y, aps.MTS_DEC) and not done(X, Y)
    step_ms(rack, 48)  # 5.098 s
    assert not done(X, Y)
    step_ms(rack, 4)
    assert done(X, Y)
    np.testing.assert_array_equal(pos(X, Y), [3000.0, 4000.0])
    assert i32(aps.APS_get_stop_code, X) == aps.STOP_NORMAL
    assert i32(aps.APS_get_command, Y) == 4000


def test_line_3_axes_shares_phase_bits_and_each_axis_keeps_its_dir(rack: Any) -> None:
    assert line([X, Y, Z], [2000.0, -3000.0, 6000.0]) == 0  # dP = 7000: 7.1 s
    step_ms(rack, 3000)
    np.testing.assert_allclose(vel(X, Y, Z), np.array([2, -3, 6]) / 7 * VM, rtol=1e-9)
    masks = [sts(a) & ~aps.MTS_DIR_V for a in (X, Y, Z)]
    assert masks[0] == masks[1] == masks[2]
    assert [bit(a, aps.MTS_DIR) for a in (X, Y, Z)] == [True, False, True]
    step_ms(rack, 4098)
    assert not done(X, Y, Z)
    step_ms(rack, 4)
    assert done(X, Y, Z)
    np.testing.assert_array_equal(pos(X, Y, Z), [2000.0, -3000.0, 6000.0])
    assert not bit(Y, aps.MTS_DIR)  # the last direction holds [M §4.8.1 bit 4]


def test_relative_line_and_the_i32_linear_moves(rack: Any) -> None:
    assert line([X, Y], [100.0, 100.0]) == 0
    step_ms(rack, 1000)
    assert line([X, Y], [300.0, -400.0], option=aps.OPT_RELATIVE) == 0
    step_ms(rack, 1000)
    np.testing.assert_allclose(pos(X, Y), [400.0, -300.0])
    assert aps.APS_relative_linear_move(2, [X, Y], [-400, 300], 1000) == 0
    step_ms(rack, 1000)
    np.testing.assert_allclose(pos(X, Y), [0.0, 0.0])
    assert aps.APS_absolute_linear_move(2, [X, Y], [600, 800], 2000) == 0
    step_ms(rack, 200)
    np.testing.assert_allclose(vel(X, Y), [1200.0, 1600.0], rtol=1e-9)  # 2000 pulses/s on dP
    step_ms(rack, 1000)
    assert i32(aps.APS_get_command, X) == 600 and i32(aps.APS_get_command, Y) == 800


def test_plain_line_takes_the_reference_axis_parameters_and_line_v_its_vm(rack: Any) -> None:
    for a, vm in ((X, 500.0), (Y, 9000.0)):  # the second axis's parameters are ignored
        assert aps.APS_set_axis_param_f(a, aps.PRA_VM, vm) == 0
        assert aps.APS_set_axis_param_f(a, aps.PRA_ACC, ACC) == 0
        assert aps.APS_set_axis_param_f(a, aps.PRA_DEC, ACC) == 0
    assert aps.APS_line(2, [X, Y], 0, [300.0, 400.0], None) == 0
    step_ms(rack, 500)
    assert np.hypot(*vel(X, Y)) == pytest.approx(500.0)
    step_ms(rack, 1000)
    assert aps.APS_line_v(2, [X, Y], 0, [0.0, 0.0], None, 250.0) == 0
    step_ms(rack, 500)
    assert np.hypot(*vel(X, Y)) == pytest.approx(250.0)


# -- arcs and the helix [M §4.7.2] ---------------------------------------------------------------------

def test_quarter_arc_2d_length_time_radius_and_exact_end_m_4_7_2_2(rack: Any) -> None:
    assert aps.APS_set_command_f(X, 1000.0) == 0
    r = 1000.0
    assert aps.APS_arc2_ca_all([X, Y], 0, [0.0, 0.0], math.pi / 2, None, *PROFILE) == 0
    length = r * math.pi / 2  # 1570.8: 1.6708 s
    pts = trace(rack, 1000, X, Y, every=10)
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), r, rtol=1e-6)
    assert (np.diff(np.arctan2(pts[:, 1], pts[:, 0])) >= 0).all()  # counter-clockwise
    t_end = length / VM + VM / ACC
    step_ms(rack, int(t_end * 1000) - 1000 - 2)
    assert not done(X, Y)
    step_ms(rack, 4)
    assert done(X, Y)
    np.testing.assert_allclose(pos(X, Y), [0.0, r], atol=1e-9)


def test_arc2_ce_relative_centre_and_dir_laps(rack: Any) -> None:
    # from (0, 0), centre (+100, 0) relative, end (200, 0): theta = 180 deg, accepted in 2-D (G20)
    assert aps.APS_arc2_ce_all([X, Y], aps.OPT_RELATIVE, [100.0, 0.0], [200.0, 0.0], 1, None,
                               *PROFILE) == 0
    pts = trace(rack, 400, X, Y, every=10)  # 180 + 360 degrees
    assert pts[10, 1] < 0  # counter-clockwise from (0, 0) about (100, 0) goes down first
    step_ms(rack, int((3 * math.pi * 100 / VM + 0.1) * 1000))
    assert done(X, Y)
    np.testing.assert_allclose(pos(X, Y), [200.0, 0.0], atol=1e-9)


def test_arc3_ca_two_laps_returns_to_start_after_4_pi_r(rack: Any) -> None:
    assert aps.APS_set_command_f(X, 100.0) == 0
    assert aps.APS_arc3_ca_all([X, Y, Z], 0, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 4 * math.pi,
                               None, *PROFILE) == 0
    t_end = 4 * math.pi * 100 / VM + 0.1  # 1.3566 s
    pts = trace(rack, 300, X, Y, Z, every=10)
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), 100.0, rtol=1e-6)
    np.testing.assert_allclose(pts[:, 2], 0.0, atol=1e-9)
    step_ms(rack, int(t_end * 1000) - 300 - 2)
    assert not done(X, Y, Z)
    step_ms(rack, 4)
    assert done(X, Y, Z)
    np.testing.assert_allclose(pos(X, Y, Z), [100.0, 0.0, 0.0], atol=1e-6)


@pytest.mark.parametrize(("direction", "angle"), [(0, 90), (1, 450), (-1, -270)])
def test_arc3_ce_dir_sets_the_laps_m_4_7_2_1(rack: Any, direction: int, angle: float) -> None:
    assert aps.APS_set_command_f(X, 100.0) == 0
    assert aps.APS_arc3_ce_all([X, Y, Z], 0, [0.0, 0.0, 0.0], [0.0, 100.0, 0.0], direction,
                               None, *PROFILE) == 0
    step_ms(rack, 150)  # past 50 units of path
    y = pos(Y)[0]
    assert (y > 0) == (angle > 0)  # the normal (S - C) x (E - C) = +Z; Dir -1 the other way
    t_end = abs(math.radians(angle)) * 100 / VM + 0.1
    step_ms(rack, int(t_end * 1000) - 150 - 2)
    assert not done(X, Y, Z)
    step_ms(rack, 4)
    assert done(X, Y, Z)
    np.testing.assert_allclose(pos(X, Y, Z), [0.0, 100.0, 0.0], atol=1e-9)


def test_helix_spiral_ca_one_turn_rising_500_and_spiral_ce_back(rack: Any) -> None:
    assert aps.APS_set_command_f(X, 1000.0) == 0
    assert aps.APS_spiral_ca_all([X, Y, Z], 0, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 2 * math.pi,
                                 500.0, 1000.0, None, *PROFILE) == 0
    length = math.hypot(2 * math.pi * 1000.0, 500.0)  # the unrolled helix
    pts = trace(rack, 500, X, Y, Z, every=10)
    np.testing.assert_allclose(np.hypot(pts[:, 0], pts[:, 1]), 1000.0, rtol=1e-6)
    phi = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    np.testing.assert_allclose(pts[:, 2], 500.0 * phi / (2 * math.pi), atol=1e-6)
    t_end = length / VM + 0.1
    step_ms(rack, int(t_end * 1000) - 500 - 2)
    assert not done(X, Y, Z)
    step_ms(rack, 4)
    assert done(X, Y, Z)
    np.testing.assert_allclose(pos(X, Y, Z), [1000.0, 0.0, 500.0], atol=1e-6)
    # the manual's spelling, centre-end: a cone down to radius 500 at z 0, half a turn
    assert aps.APS_sprial_ce_all([X, Y, Z], 0, [0.0, 0.0, 500.0], [0.0, 0.0, 1.0],
                                 [-500.0, 0.0, 0.0], 0, None, *PROFILE) == 0
    step_ms(rack, 3000)
    assert done(X, Y, Z)
    np.testing.assert_allclose(pos(X, Y, Z), [-500.0, 0.0, 0.0], atol=1e-9)


# -- continuous interpolation: the seven transitions [M §4.7.3] ------------------------------------------

def corner(rack: Any, option: int, para: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Line (0,0)-(1000,0) (1.1 s), then (1000,0)-(1000,1000) queued with `option`; positions
    and BLD of axis 1 every ms for 2.3 s."""
    assert line([X, Y], [1000.0, 0.0]) == 0
    assert line([X, Y], [1000.0, 1000.0], option=option, para=para) == 0
    assert i32(aps.APS_get_mq_usage, X) == 2
    pts, bld = [], []
    for _ in range(2300):
        step_ms(rack, 1)
        pts.append(pos(X, Y))
        bld.append(bit(Y, aps.MTS_BLD))
    return np.array(pts), np.array(bld)


def first_ms(mask: np.ndarray) -> int:
    return int(np.argmax(mask)) + 1  # sample i is at (i + 1) ms


def test_buffered_corner_is_exact_and_the_second_starts_after_the_first_ends(rack: Any) -> None:
    pts, bld = corner(rack, aps.ITP_OPT_BUFFERED)
    assert first_ms(pts[:, 1] > 0) == 1101
    assert (pts[pts[:, 1] > 0, 0] == 1000.0).all()  # the corner is passed exactly
    assert not bld.any()
    assert first_ms(pts[:, 1] == 1000.0) == 2200
    assert done(X, Y)


def test_blend_at_deceleration_event_starts_when_the_first_decelerates(rack: Any) -> None:
    pts, bld = corner(rack, aps.ITP_OPT_BLEND_DEC_EVENT)
    assert first_ms(pts[:, 1] > 0) == 1001  # its deceleration starts at 1.0 s
    # BLD from the blend's start (1.0 s) until the first ends (1.1 s) [M §4.8.1 bit 17]
    assert first_ms(bld) == 1000 and bld.sum() == 100
    assert first_ms(pts[:, 1] == 1000.0) == 2100
    np.testing.assert_allclose(pts[-1], [1000.0, 1000.0])


def test_blend_at_residual_distance_200_starts_at_800(rack: Any) -> None:
    pts, bld = corner(rack, aps.ITP_OPT_BLEND_RES_DIST, 200.0)
    start = first_ms(pts[:, 1] > 0)  # 800 of 1000 travelled at 0.85 s
    assert start == 851 and pts[start - 2, 0] == pytest.approx(800.0)
    assert first_ms(bld) == 850 and first_ms(pts[:, 1] == 1000.0) == 1950


def test_blend_at_residual_percent_10_starts_at_90_percent(rack: Any) -> None:
    pts, bld = corner(rack, aps.ITP_OPT_BLEND_RES_DIST_PERCENT, 10.0)
    start = first_ms(pts[:, 1] > 0)  # "10 % of 1000: the blend starts at 900" (Fig 4-41)
    assert start in (950, 951) and pts[start - 2, 0] == pytest.approx(900.0, abs=1.0)
    assert first_ms(bld) == 950 and bld.sum() == 150
    assert first_ms(pts[:, 1] == 1000.0) == 2050


def midway(rack: Any, option: int, end: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """At 0.5 s into (0,0)-(1000,0) at full speed (x = 450), with a command buffered behind
    it, a new line with `option`; where the command was received and the positions every ms
    for 1.5 s."""
    assert line([X, Y], [1000.0, 0.0]) == 0
    assert line([X, Y], [0.0, 0.0], option=aps.ITP_OPT_BUFFERED) == 0
    step_ms(rack, 500)
    here = pos(X, Y)
    assert line([X, Y], end, option=option) == 0
    # the buffer is cleared: the new command runs (abort-stop: after the stop) [M §4.7.3]
    usage = 2 if option & 0xF000 == aps.ITP_OPT_ABORT_STOP else 1
    assert i32(aps.APS_get_mq_usage, X) == usage
    return here, trace(rack, 1500, X, Y)


def test_abort_blend_turns_at_once_while_the_old_motion_decelerates(rack: Any) -> None:
    here, pts = midway(rack, aps.ITP_OPT_ABORT_BLEND, [450.0, 1000.0])
    assert pts[0, 1] > 0 and pts[0, 0] > here[0]  # no slow-down first: both move in the blend
    assert here[0] < pts[:, 0].max() < 500.0  # the old motion's stop (50 at its Dec) superposed
    assert pts[:100, 1].min() > 0 and bit(X, aps.MTS_MDN)
    assert done(X, Y)
    np.testing.assert_allclose(pts[-1], [450.0, 1000.0])


def test_abort_force_switches_path_at_once_keeping_the_speed(rack: Any) -> None:
    here, pts = midway(rack, aps.ITP_OPT_ABORT_FORCE, [450.0, 1000.0])
    assert pts[0, 0] == pytest.approx(here[0]) and pts[0, 1] == pytest.approx(1.0)  # 1000/s
    np.testing.assert_allclose(pts[:, 0], here[0])  # exactly on the new path
    assert first_ms(pts[:, 1] == 1000.0) == 1050  # 1000 on at 1000/s, 0.05 s to stop
    assert done(X, Y)


def test_abort_stop_stops_then_goes_relative_to_the_receiving_point_m_4_7_3(rack: Any) -> None:
    here, pts = midway(rack, aps.ITP_OPT_ABORT_STOP | aps.OPT_RELATIVE, [0.0, 500.0])
    assert (pts[:100, 1] == 0).all() and pts[99, 0] == pytest.approx(500.0)  # stop: 50 on
    assert pts[110, 1] > 0
    assert done(X, Y)
    np.testing.assert_allclose(pts[-1], [here[0], 500.0])  # E1' + (0, 500), not S2 + ...


def test_queue_holds_ten_commands_the_next_is_minus_15(rack: Any) -> None:
    assert line([X, Y], [100.0, 0.0]) == 0
    for i in range(9):
        assert line([X, Y], [100.0, 10.0 * (i + 1)], option=aps.ITP_OPT_BUFFERED) == 0
    assert i32(aps.APS_get_mq_usage, Y) == 10
    assert i32(aps.APS_get_mq_free_space, Y) == 0
    assert line([X, Y], [0.0, 0.0], option=aps.ITP_OPT_BUFFERED) == aps.ERR_CommandInProcess
    step_ms(rack, 3000)
    assert done(X, Y)
    np.testing.assert_allclose(pos(X, Y), [100.0, 90.0])


# -- synchronous start [M §4.9.5] --------------------------------------------------------------------------

def test_opt_wait_holds_the_group_until_move_trigger_names_any_member(rack: Any) -> None:
    assert line([X, Y], [300.0, 400.0], option=aps.OPT_WAIT) == 0
    assert line([X, Y], [0.0, 400.0], option=aps.ITP_OPT_BUFFERED) == 0  # behind it
    for a in (X, Y):
        s = sts(a)
        assert s & aps.MTS_WAIT_V and s & aps.MTS_CSTP_V and not s & aps.MTS_MDN_V
    step_ms(rack, 100)
    np.testing.assert_array_equal(pos(X, Y), [0.0, 0.0])
    assert aps.APS_move_trigger(1, [Y]) == 0
    assert not bit(X, aps.MTS_WAIT) and bit(X, aps.MTS_ACC)
    step_ms(rack, 100)
    assert pos(X)[0] > 0
    step_ms(rack, 1000)
    assert done(X, Y)
    np.testing.assert_allclose(pos(X, Y), [0.0, 400.0])


def test_stop_move_cancels_a_waiting_group(rack: Any) -> None:
    assert line([X, Y], [300.0, 400.0], option=aps.OPT_WAIT) == 0
    assert aps.APS_stop_move(X) == 0
    assert done(X, Y) and not bit(Y, aps.MTS_WAIT)
    assert aps.APS_move_trigger(2, [X, Y]) == 0
    step_ms(rack, 100)
    np.testing.assert_array_equal(pos(X, Y), [0.0, 0.0])


# -- stops of a group (spec Q13) ----------------------------------------------------------------------

def test_a_limit_on_one_member_stops_the_whole_group_with_astp_and_code(rack: Any) -> None:
    assert line([X, Y], [1000.0, 1000.0]) == 0
    step_ms(rack, 300)
    rack.card("amp0").control("set_limit", axis=Y, side="positive", active=True)
    step_ms(rack, 2)
    held = pos(X, Y)
    step_ms(rack, 100)
    np.testing.assert_array_equal(pos(X, Y), held)
    for a in (X, Y):
        assert done(a) and bit(a, aps.MTS_ASTP)
        assert i32(aps.APS_get_stop_code, a) == aps.STOP_PEL
    # away from the limit it moves again; ASTP clears
    assert line([X, Y], [0.0, 0.0]) == 0
    assert not bit(X, aps.MTS_ASTP)


def test_stop_move_on_one_member_decelerates_the_group_along_its_path(rack: Any) -> None:
    assert aps.APS_set_axis_param_f(X, aps.PRA_SD_DEC, 2000.0) == 0  # the reference axis's
    assert line([X, Y], [3000.0, 4000.0]) == 0
    step_ms(rack, 500)
    at = pos(X, Y)
    assert aps.APS_stop_move(Y) == 0
    pts = trace(rack, 600, X, Y, every=10)
    np.testing.assert_allclose(pts[:, 1] / pts[:, 0], 4 / 3)  # on the line
    travelled = np.hypot(*(pts[-1] - at))
    assert travelled == pytest.approx(250.0, abs=2.0)  # 1000^2 / (2 * 2000)
    for a in (X, Y):
        assert done(a) and not bit(a, aps.MTS_ASTP)
        assert i32(aps.APS_get_stop_code, a) == aps.STOP_USER


def test_emg_stop_on_one_member_stops_the_group_at_once(rack: Any) -> None:
    assert line([X, Y, Z], [1000.0, 1000.0, 1000.0]) == 0
    step_ms(rack, 300)
    assert aps.APS_emg_stop(Z) == 0
    held = pos(X, Y, Z)
    step_ms(rack, 10)
    np.testing.assert_array_equal(pos(X, Y, Z), held)
    assert all(i32(aps.APS_get_stop_code, a) == aps.STOP_USER_EMG for a in (X, Y, Z))
    assert done(X, Y, Z)


# -- refusals ----------------------------------------------------------------------------------------------

def test_bad_geometry_is_minus_10_and_changes_nothing(rack: Any) -> None:
    before = [sts(a) for a in range(3)]
    bad = aps.ERR_ParametersInvalid
    assert aps.APS_arc2_ce([X, Y], 0, [100.0, 0.0], [150.0, 0.0], 0, None) == bad  # radius
    assert aps.APS_arc3_ce([X, Y, Z], 0, [100.0, 0.0, 0.0], [200.0, 0.0, 0.0], 0, None) == bad
    assert aps.APS_arc3_ca([X, Y, Z], 0, [100.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1.0, None) == bad
    assert aps.APS_arc2_ca([X, Y], 0, [0.0, 0.0], 1.0, None) == bad  # centre = start
    assert aps.APS_spiral_ca([X, Y, Z], 0, [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], 1.0, 0.0, 1.0,
                             None) == bad  # zero normal
    assert aps.APS_line(7, list(range(7)), 0, [1.0] * 7, None) == bad  # 2-6 axes
    assert aps.APS_line(1, [X], 0, [1.0], None) == bad
    assert aps.APS_line(2, [X, X], 0, [1.0, 2.0], None) == bad  # an axis twice
    assert aps.APS_arc3_ca([X, Y], 0, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0, None) == bad
    assert line([X, Y], [10.0, 10.0], option=0x7000) == bad  # no transition 7
    assert line([X, Y], [10.0, 10.0], option=aps.ITP_OPT_BLEND_RES_DIST_PERCENT,
                para=150.0) == bad
    assert aps.APS_line_v(2, [X, Y], 0, [10.0, 10.0], None, -5.0) == bad  # Vm
    step_ms(rack, 10)
    assert [sts(a) for a in range(3)] == before
    np.testing.assert_array_equal(pos(X, Y, Z), [0.0, 0.0, 0.0])


def test_busy_axes_and_mismatched_groups(rack: Any) -> None:
    assert aps.APS_ptp(Z, 0, 1000.0) == 0
    assert line([X, Z], [10.0, 10.0]) == aps.ERR_CommandInProcess  # Z runs a PTP
    assert line([X, Y], [1000.0, 0.0]) == 0
    assert aps.APS_ptp(Y, 0, 10.0) == aps.ERR_CommandInProcess  # Y is in a group
    assert line([Y, X], [0.0, 0.0]) == aps.ERR_CommandInProcess  # another reference axis
    assert line([X, Y, 3], [0.0, 0.0, 0.0], option=aps.ITP_OPT_BUFFERED) == \
        aps.ERR_ParametersInvalid  # a continuation of another dimension [M §4.7.3]
    assert aps.APS_arc3_ce([X, Y, 3], aps.ITP_OPT_BUFFERED, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0],
                           0, None) == aps.ERR_ParametersInvalid
    step_ms(rack, 2000)
    assert done(X, Y)
    np.testing.assert_allclose(pos(X, Y), [1000.0, 0.0])


def test_a_command_into_an_active_limit_is_ignored_with_the_code_on_every_member(rack: Any
                                                                               ) -> None:
    rack.card("amp0").control("set_limit", axis=Y, side="negative", active=True)
    step_ms(rack, 1)
    assert line([X, Y], [100.0, -100.0]) == 0  # refused: the call returns 0 (spec Q15)
    step_ms(rack, 100)
    np.testing.assert_array_equal(pos(X, Y), [0.0, 0.0])
    for a in (X, Y):
        assert bit(a, aps.MTS_ASTP) and i32(aps.APS_get_stop_code, a) == aps.STOP_MEL
    assert line([X, Y], [100.0, 100.0]) == 0  # away from it: moves
    step_ms(rack, 500)
    np.testing.assert_allclose(pos(X, Y), [100.0, 100.0])


def test_pre_and_post_distance_events_on_every_member(rack: Any) -> None:
    assert aps.APS_set_axis_param_f(X, aps.PRA_PRE_EVENT_DIST, 100.0) == 0
    assert aps.APS_set_axis_param_f(X, aps.PRA_POST_EVENT_DIST, 100.0) == 0
    assert line([X, Y], [600.0, 800.0]) == 0  # 1000 long
    step_ms(rack, 100)  # 50 travelled
    assert not bit(Y, aps.MTS_PRED)
    step_ms(rack, 100)  # 150
    assert bit(X, aps.MTS_PRED) and bit(Y, aps.MTS_PRED) and not bit(Y, aps.MTS_POSTD)
    step_ms(rack, 800)  # 950 travelled
    assert bit(X, aps.MTS_POSTD) and bit(Y, aps.MTS_POSTD)
    step_ms(rack, 200)
    assert done(X, Y) and bit(Y, aps.MTS_PRED) and bit(Y, aps.MTS_POSTD)


def test_transpara_may_be_null_and_ctypes_arrays_are_taken(rack: Any) -> None:
    axes = (c_int32 * 2)(X, Y)
    ends = (c_double * 2)(30.0, 40.0)
    assert aps.APS_line(2, axes, 0, ends, None) == 0
    step_ms(rack, 1000)
    np.testing.assert_allclose(pos(X, Y), [30.0, 40.0])
