"""Two AMP cards in one rack, an AMP-204C (board 0, axes 0-3) and an AMP-208C (board 1, axes
4-11) [spec adlink.md §3.7 "APS_initial", §2.23 Int_No = board x 352 + item x 32 + factor]:
every command reaches its own card, the interrupts and their waits are per board."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from ctypes import byref, c_double, c_int32

import pytest
import vdevclient
from vdevclient import aps
from vdevmaps.adlink import Axis, axis_offset

from tests.client.aps_rack import amp, aps_session, step_ms

MS = 1_000_000
PER_BOARD = aps.INT_NO_PER_BOARD


@pytest.fixture
def rack() -> Iterator[vdevclient.Rack]:
    with aps_session(amp("small", model="AMP-204C"), amp("big", model="AMP-208C")) as (_, r):
        for a in range(12):
            assert aps.APS_set_servo_on(a, 1) == 0
        yield r


def cmd(axis: int) -> float:
    v = c_double()
    assert aps.APS_get_command_f(axis, byref(v)) == 0
    return v.value


def card_cmd(rack: vdevclient.Rack, card: str, axis: int) -> float:
    """The command position in the card's own status block (its local axis number)."""
    raw = rack.card(card).region("bar0").read(axis_offset(axis, Axis.CMD_POS), 8)
    return float(struct.unpack("<d", raw)[0])


def test_axis_ids_run_on_from_the_204c_to_the_208c(rack: vdevclient.Rack) -> None:
    start, total = c_int32(), c_int32()
    assert aps.APS_get_first_axisId(0, byref(start), byref(total)) == 0
    assert (start.value, total.value) == (0, 4)
    assert aps.APS_get_first_axisId(1, byref(start), byref(total)) == 0
    assert (start.value, total.value) == (4, 8)
    board, no, port, module = c_int32(), c_int32(), c_int32(), c_int32()
    assert aps.APS_get_axis_info(11, byref(board), byref(no), byref(port), byref(module)) == 0
    assert (board.value, no.value) == (1, 7)
    assert aps.APS_motion_status(12) == aps.ERR_ParametersInvalid
    assert aps.APS_get_first_axisId(2, byref(start), byref(total)) == aps.ERR_ParametersInvalid


def test_each_move_and_parameter_reaches_its_own_card(rack: vdevclient.Rack) -> None:
    assert aps.APS_set_axis_param_f(5, aps.PRA_VM, 5000.0) == 0
    v = c_double()
    assert aps.APS_get_axis_param_f(1, aps.PRA_VM, byref(v)) == 0 and v.value == 1e5
    assert aps.APS_ptp(1, 0, 1000.0, None) == 0  # board 0's axis 1
    assert aps.APS_ptp(5, 0, -2000.0, None) == 0  # board 1's axis 1
    step_ms(rack, 1000)
    assert cmd(1) == 1000.0 and cmd(5) == -2000.0
    assert [cmd(a) for a in (0, 2, 3, 4, 6, 7, 8, 9, 10, 11)] == [0.0] * 10
    assert (card_cmd(rack, "small", 1), card_cmd(rack, "big", 1)) == (1000.0, -2000.0)
    assert card_cmd(rack, "small", 0) == card_cmd(rack, "big", 5) == 0.0
    assert aps.APS_write_d_output(1, 0, 0x3) == 0
    assert rack.card("big").control("get_outputs")["do"] & 0x3 == 0x3
    assert rack.card("small").control("get_outputs")["do"] == 0


def test_an_alarm_on_one_card_stops_only_its_axis(rack: vdevclient.Rack) -> None:
    assert aps.APS_vel(1, 0, 5000.0, None) == 0
    assert aps.APS_vel(5, 0, 5000.0, None) == 0
    step_ms(rack, 50)
    rack.card("big").control("set_alarm", axis=1)
    step_ms(rack, 50)
    assert aps.APS_motion_io_status(5) & 1 << aps.MIO_ALM
    assert not aps.APS_motion_io_status(1) & 1 << aps.MIO_ALM
    assert aps.APS_motion_status(5) & aps.MTS_ASTP_V
    assert not aps.APS_motion_status(1) & aps.MTS_MDN_V  # still moving
    assert aps.APS_stop_move(1) == 0


def test_interrupts_are_numbered_and_waited_on_per_board(rack: vdevclient.Rack) -> None:
    small = aps.APS_set_int_factor(0, 1, aps.IMDN, 1)
    big = aps.APS_set_int_factor(1, 1, aps.IMDN, 1)
    big3 = aps.APS_set_int_factor(1, 3, aps.IMDN, 1)
    assert (small, big, big3) == (32 + aps.IMDN, PER_BOARD + 32 + aps.IMDN,
                                  PER_BOARD + 96 + aps.IMDN)
    assert aps.APS_set_int_factor(0, 4, aps.IMDN, 1) == aps.ERR_ParametersInvalid  # a 204C
    assert aps.APS_int_enable(0, 1) == 0
    # board 1's main switch is off: its waits are -8, board 0's work
    assert aps.APS_wait_single_int(big, 10) == aps.ERR_InterruptNotEnable
    assert aps.APS_int_enable(1, 1) == 0
    assert aps.APS_ptp(5, 0, 20_000.0, None) == 0  # 300 ms at the defaults (board 1)
    assert aps.APS_ptp(1, 0, 5_000.0, None) == 0  # board 0: ~120 ms
    t0 = rack.sim.now_ns()
    assert aps.APS_wait_single_int(big, 5000) == 0
    assert 300 * MS <= rack.sim.now_ns() - t0 <= 301 * MS
    assert aps.APS_wait_single_int(small, 0) == 0  # long signaled
    assert aps.APS_wait_single_int(big3, 0) == aps.ERR_TimeOut
    assert aps.APS_reset_int(big) == 0
    assert aps.APS_wait_single_int(big, 0) == aps.ERR_TimeOut
    assert aps.APS_wait_single_int(small, 0) == 0  # board 0's flag untouched
    # across items of one board: the first of the array signaled, or all of them
    assert aps.APS_ptp(7, 0, 1_000.0, None) == 0
    assert aps.APS_wait_multiple_int(2, [big, big3], 0, 5000) == 1
    assert aps.APS_wait_multiple_int(2, [big, big3], 1, 20) == aps.ERR_TimeOut
    assert aps.APS_ptp(5, 0, 0.0, None) == 0
    assert aps.APS_wait_multiple_int(2, [big, big3], 1, 5000) == 0
    # across boards: vdevd's waits are of one board (spec §2.23 ASSUMPTION)
    assert aps.APS_wait_multiple_int(2, [small, big], 0, 10) == aps.ERR_ParametersInvalid
    assert aps.APS_set_int(PER_BOARD + 8 * 32 + 0) == aps.ERR_InterruptNotEnable
    assert aps.APS_wait_single_int(2 * PER_BOARD + 32, 10) == aps.ERR_ParametersInvalid
