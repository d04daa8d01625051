"""vdevclient.aps initialisation and parameters against a lockstep daemon: APS_initial's card
and axis IDs, board and axis parameters with their ranges, flash across a daemon restart, the
parameter file [spec adlink.md §3, §4.1]."""

from __future__ import annotations

from ctypes import byref, c_double, c_int32
from pathlib import Path

import pytest
from vdevclient import aps

from tests.client.aps_rack import amp, aps_session, f64, step_ms


def test_initial_finds_the_cards_with_their_dip_switch_ids() -> None:
    """INIT_MANUAL_ID: the DIP switch [M §2.6.1]; axis IDs run on by board ID."""
    with aps_session(amp("a", card_id=3), amp("b", card_id=1, model="AMP-204C"),
                     mode=aps.INIT_MANUAL_ID):
        start, total = c_int32(), c_int32()
        assert aps.APS_get_first_axisId(1, byref(start), byref(total)) == 0
        assert (start.value, total.value) == (0, 4)
        assert aps.APS_get_first_axisId(3, byref(start), byref(total)) == 0
        assert (start.value, total.value) == (4, 8)
        board, axis_no = c_int32(), c_int32()
        port, module = c_int32(), c_int32()
        assert aps.APS_get_axis_info(5, byref(board), byref(axis_no), byref(port),
                                     byref(module)) == 0
        assert (board.value, axis_no.value) == (3, 1)
        assert aps.APS_get_first_axisId(0, byref(start), byref(total)) == aps.ERR_ParametersInvalid
        assert aps.APS_motion_status(12) == aps.ERR_ParametersInvalid


def test_initial_assigns_ids_in_order_and_reports_the_bits() -> None:
    with aps_session(amp("a"), amp("b")):
        bits = c_int32()
        assert aps.APS_initial(byref(bits), 0) == aps.ERR_DeviceAlreadyInitialed
        name = c_int32()
        assert aps.APS_get_card_name(1, byref(name)) == 0
        assert name.value == aps.DEVICE_NAME_AMP_82548


def test_duplicate_card_ids_are_refused() -> None:
    with pytest.raises(AssertionError), aps_session(amp("a"), amp("b"), mode=aps.INIT_MANUAL_ID):
        pass
    assert aps.APS_close() == 0


def test_parallel_fixed_axis_ids() -> None:
    with aps_session(amp("a", card_id=1, model="AMP-204C"), amp("b", card_id=0, model="AMP-204C"),
                     mode=aps.INIT_MANUAL_ID | aps.INIT_PARALLEL_FIXED):
        start, total = c_int32(), c_int32()
        assert aps.APS_get_first_axisId(1, byref(start), byref(total)) == 0
        assert start.value == 8
        assert aps.APS_motion_status(5) == aps.ERR_ParametersInvalid  # a gap
        assert aps.APS_motion_status(9) >= 0


def test_axis_parameters_round_trip_with_their_ranges() -> None:
    with aps_session():
        v, i = c_double(), c_int32()
        assert aps.APS_get_axis_param_f(0, aps.PRA_VM, byref(v)) == 0 and v.value == 1e5
        assert aps.APS_set_axis_param_f(0, aps.PRA_VM, 2500.5) == 0
        assert aps.APS_get_axis_param_f(0, aps.PRA_VM, byref(v)) == 0 and v.value == 2500.5
        assert aps.APS_get_axis_param(0, aps.PRA_VM, byref(i)) == 0 and i.value == 2500
        assert aps.APS_set_axis_param(0, aps.PRA_HOME_MODE, 2) == 0
        for no, bad in ((aps.PRA_SF, 1.5), (aps.PRA_ACC, 0.0), (aps.PRA_HOME_MODE, 3.0),
                        (aps.PRA_EL_LOGIC, 0.5), (0x7777, 1.0), (aps.PRA_JG_DELAY, 2e7)):
            assert aps.APS_set_axis_param_f(0, no, bad) == aps.ERR_ParametersInvalid, hex(no)
        assert aps.APS_get_axis_param_f(0, aps.PRA_SF, byref(v)) == 0 and v.value == 0.0
        assert aps.APS_get_axis_param(0, 0x7777, byref(i)) == aps.ERR_ParametersInvalid
        assert aps.APS_set_axis_param_f(0, aps.PRA_KP_GAIN, 3.0) == 0  # kept, no effect (§3.2)


def test_board_parameters() -> None:
    with aps_session():
        v = c_int32()
        assert aps.APS_get_board_param(0, aps.PRB_EMG_LOGIC, byref(v)) == 0 and v.value == 0
        assert aps.APS_get_board_param(0, aps.PRB_PWM0_MAP_DO, byref(v)) == 0 and v.value == -1
        assert aps.APS_set_board_param(0, aps.PRB_EMG_LOGIC, 2) == aps.ERR_ParametersInvalid
        assert aps.APS_set_board_param(0, 0x7777, 0) == aps.ERR_ParametersInvalid
        assert aps.APS_set_board_param(9, aps.PRB_EMG_LOGIC, 0) == aps.ERR_ParametersInvalid


def test_the_motion_cycle_board_parameter_changes_the_cycle() -> None:
    """vdevd's PRB_VDEVD_MOTION_CYCLE (spec Q1): 500 us cycles."""
    with aps_session() as (_, rack):
        assert aps.APS_set_board_param(0, aps.PRB_VDEVD_MOTION_CYCLE, 700) == \
            aps.ERR_ParametersInvalid
        assert aps.APS_set_board_param(0, aps.PRB_VDEVD_MOTION_CYCLE, 500) == 0
        count, after = c_int32(), c_int32()
        assert aps.APS_get_board_cycle_count(0, byref(count)) == 0
        step_ms(rack, 10)
        assert aps.APS_get_board_cycle_count(0, byref(after)) == 0
        assert after.value - count.value == 20


def test_flash_keeps_parameters_across_a_daemon_restart(tmp_path: Path) -> None:
    with aps_session(state_dir=str(tmp_path)):
        assert aps.APS_set_axis_param_f(2, aps.PRA_ACC, 12345.0) == 0
        assert aps.APS_save_parameter_to_flash(0) == 0
        assert aps.APS_set_axis_param_f(2, aps.PRA_ACC, 1.0) == 0
    with aps_session(state_dir=str(tmp_path)):  # flash is loaded at power-up
        v = c_double()
        assert aps.APS_get_axis_param_f(2, aps.PRA_ACC, byref(v)) == 0 and v.value == 12345.0
        assert aps.APS_set_axis_param_f(2, aps.PRA_ACC, 5.0) == 0
        assert aps.APS_load_parameter_from_flash(0) == 0
        assert aps.APS_get_axis_param_f(2, aps.PRA_ACC, byref(v)) == 0 and v.value == 12345.0
        assert aps.APS_load_parameter_from_default(0) == 0
        assert aps.APS_get_axis_param_f(2, aps.PRA_ACC, byref(v)) == 0 and v.value == 1e6


def test_initial_can_load_the_defaults() -> None:
    with aps_session():
        assert aps.APS_set_axis_param_f(0, aps.PRA_VM, 7.0) == 0
        assert aps.APS_close() == 0
        bits = c_int32()
        from tests.client.aps_rack import _last_endpoint  # noqa: PLC0415
        assert aps.APS_initial(byref(bits), aps.INIT_PARAM_LOAD_DEFAULT,
                               endpoint=_last_endpoint()) == 0
        v = c_double()
        assert aps.APS_get_axis_param_f(0, aps.PRA_VM, byref(v)) == 0 and v.value == 1e5


def test_parameter_file_round_trip(tmp_path: Path) -> None:
    path = str(tmp_path / "amp.xml")
    with aps_session():
        assert aps.APS_set_axis_param_f(3, aps.PRA_DEC, 4321.5) == 0
        assert aps.APS_set_board_param(0, aps.PRB_DO_LOGIC, 1) == 0
        assert aps.APS_save_param_to_file(0, path) == 0
        assert "PRA_DEC" in Path(path).read_text()
        assert aps.APS_load_parameter_from_default(0) == 0
        assert aps.APS_load_param_from_file(path.encode()) == 0
        v, i = c_double(), c_int32()
        assert aps.APS_get_axis_param_f(3, aps.PRA_DEC, byref(v)) == 0 and v.value == 4321.5
        assert aps.APS_get_board_param(0, aps.PRB_DO_LOGIC, byref(i)) == 0 and i.value == 1


@pytest.mark.parametrize("content", [
    "not xml", "<MotionCreatorPro><Board ID='7'/></MotionCreatorPro>",
    "<MotionCreatorPro><Board ID='0'><Axis ID='9'/></Board></MotionCreatorPro>",
    "<MotionCreatorPro><Board ID='0'><Axis ID='0'><Param Name='PRA_NOPE' Value='1'/>"
    "</Axis></Board></MotionCreatorPro>",
    "<MotionCreatorPro><Board ID='0'><Axis ID='0'><Param No='0x21' Value='x'/>"
    "</Axis></Board></MotionCreatorPro>"])
def test_a_bad_parameter_file_changes_nothing(tmp_path: Path, content: str) -> None:
    path = tmp_path / "bad.xml"
    path.write_text(content)
    with aps_session():
        assert aps.APS_load_param_from_file(str(path)) == aps.ERR_FILE_FORMAT
        assert aps.APS_load_param_from_file(str(tmp_path / "missing.xml")) == aps.ERR_FILE_FORMAT
        assert f64(aps.APS_get_command_f, 0) == 0.0


def test_versions_and_device_info() -> None:
    with aps_session():
        assert aps.APS_version() > 0 and aps.APS_device_driver_version(0) > 0
        info = c_int32()
        assert aps.APS_get_device_info(0, aps.DEVICE_INFO_DSP_KERNEL, byref(info)) == 0
        assert aps.APS_get_device_info(0, 0x99, byref(info)) == aps.ERR_ParametersInvalid
        mode = c_int32(-1)
        assert aps.APS_get_eep_curr_drv_ctrl_mode(0, byref(mode)) == 0 and mode.value == 0
