"""APS_save_parameter_to_flash across a daemon restart: the trigger parameters and the VAO
tables come back with the board and axis parameters (spec adlink.md §4.1 ASSUMPTION, card
README "Parameters and flash"); a corrupt image in the state directory does not stop the card."""

from __future__ import annotations

from ctypes import byref, c_int32
from pathlib import Path

from vdevclient import aps

from tests.client.aps_rack import aps_session, step_ms


def test_trigger_parameters_and_vao_tables_survive_a_daemon_restart(tmp_path: Path) -> None:
    data = (aps.I32 * 3)(100, 200, 300)
    with aps_session(state_dir=str(tmp_path)):
        assert aps.APS_set_trigger_param(0, aps.TGR_TRG0_PWD, 99) == 0
        assert aps.APS_set_trigger_param(0, aps.TIMR_ITV, 2500) == 0
        assert aps.APS_set_trigger_param(0, aps.TIMR_EN, 1) == 0
        assert aps.APS_set_vao_table(0, 2, 1000, 500, 3, data) == 0
        assert aps.APS_set_board_param(0, aps.PRB_DO_LOGIC, 1) == 0
        assert aps.APS_save_parameter_to_flash(0) == 0
    with aps_session(state_dir=str(tmp_path)) as (_, rack):
        v = c_int32()
        assert aps.APS_get_trigger_param(0, aps.TGR_TRG0_PWD, byref(v)) == 0 and v.value == 99
        assert aps.APS_get_trigger_param(0, aps.TIMR_ITV, byref(v)) == 0 and v.value == 2500
        assert aps.APS_get_trigger_param(0, aps.TIMR_EN, byref(v)) == 0 and v.value == 0
        step_ms(rack, 10)
        assert aps.APS_get_timer_counter(0, 0, byref(v)) == 0 and v.value == 0  # stopped
        assert aps.APS_check_vao_param(0, 2, byref(v)) == 0 and v.value == 0  # has its data
        assert aps.APS_get_board_param(0, aps.PRB_DO_LOGIC, byref(v)) == 0 and v.value == 1


def test_load_from_flash_keeps_the_motion_cycle_the_card_runs(tmp_path: Path) -> None:
    """The cycle is the card's option at power-up, so a flash image's never changes it; loading
    the image must not make PRB 8000h read a cycle the card does not run."""
    with aps_session(state_dir=str(tmp_path)) as (_, rack):
        assert aps.APS_save_parameter_to_flash(0) == 0  # at 1000 us
        assert aps.APS_set_board_param(0, aps.PRB_VDEVD_MOTION_CYCLE, 500) == 0
        assert aps.APS_load_parameter_from_flash(0) == 0
        v, before, after = c_int32(), c_int32(), c_int32()
        assert aps.APS_get_board_param(0, aps.PRB_VDEVD_MOTION_CYCLE, byref(v)) == 0
        assert aps.APS_get_board_cycle_count(0, byref(before)) == 0
        step_ms(rack, 10)
        assert aps.APS_get_board_cycle_count(0, byref(after)) == 0
        assert after.value - before.value == 20 and v.value == 500


def test_a_corrupt_flash_image_starts_the_card_from_its_defaults(tmp_path: Path) -> None:
    (tmp_path / "amp0.nvram").write_bytes(b"\x93\x01")  # a truncated msgpack array
    with aps_session(state_dir=str(tmp_path)):
        v = c_int32()
        assert aps.APS_get_trigger_param(0, aps.TIMR_ITV, byref(v)) == 0 and v.value == 10_000
        assert aps.APS_ptp(0, 0, 100.0, None) == 0
    assert (tmp_path / "amp0.nvram.corrupt").exists()
