"""APS initialisation, system, parameters, positions, status and servo [M §4.1, §4.2, §4.8;
spec adlink.md §4.1-4.2]."""

from __future__ import annotations

import math
from typing import Any

from vdevmaps.adlink import Axis, Bar
from vdevmaps.aps_defs import (
    DEVICE_INFO_DRIVER,
    DEVICE_INFO_DSP_KERNEL,
    DEVICE_INFO_FPGA,
    DEVICE_INFO_PCB,
    DEVICE_NAME_AMP_82548,
    INIT_MANUAL_ID,
    INIT_PARALLEL_FIXED,
    INIT_PARAM_LOAD_DEFAULT,
    INIT_PARAM_LOAD_FLASH,
    ERR_CardIdDuplicate,
    ERR_DeviceAlreadyInitialed,
    ERR_NoDeviceFound,
    ERR_NoError,
    ERR_ParametersInvalid,
)

from vdevclient._aps_bus import Board, Links, Session, find_cards
from vdevclient._aps_session import (
    ApsArgError,
    as_float,
    as_int,
    axis,
    board,
    close_session,
    guarded,
    open_session,
    put,
    session,
)
from vdevclient.core import connect

#: the library's version numbers (vdevd's own, spec §4.1)
VERSION = 0x20260001
DRIVER_VERSION = 0x00010000
#: APS_get_device_info numbers -> the versions the virtual card reports
DEVICE_INFO = {DEVICE_INFO_DRIVER: DRIVER_VERSION, DEVICE_INFO_FPGA: 0x0200,
               DEVICE_INFO_PCB: 0x0002, DEVICE_INFO_DSP_KERNEL: 0x0200}
MAX_AXES_PER_BOARD = 8


@guarded
def APS_initial(BoardID_InBits: Any, Mode: int, *, endpoint: str | None = None) -> int:
    """Find the rack's AMP cards at $VDEVD_ENDPOINT: bit n of *BoardID_InBits for board ID n.
    Mode bit 0 (INIT_MANUAL_ID): IDs from the DIP switch, else 0, 1, ... in configuration
    order; bit 1 (INIT_PARALLEL_FIXED): axis IDs board x 8 + axis, else consecutive by board ID;
    bits 4-5: parameters from the defaults or from flash [spec §3.7, §4.1]."""
    mode = as_int(Mode)
    try:
        session()
        return ERR_DeviceAlreadyInitialed
    except ApsArgError:
        pass
    rack = connect(endpoint)
    try:
        cards = find_cards(rack)
        if not cards:
            rack.close()
            return ERR_NoDeviceFound
        ids = [c[1] for c in cards] if mode & INIT_MANUAL_ID else list(range(len(cards)))
        if len(set(ids)) != len(ids):
            rack.close()
            return ERR_CardIdDuplicate
        links = Links(rack)
        boards: dict[int, Board] = {}
        axes: list[tuple[Board, int]] = []
        first = 0
        for (name, card_id, n, model), bid in sorted(zip(cards, ids, strict=True),
                                                     key=lambda x: x[1]):
            if mode & INIT_PARALLEL_FIXED:
                first = bid * MAX_AXES_PER_BOARD
            b = Board(links, name, bid, first, n, card_id, model)
            boards[bid] = b
            while len(axes) < first:
                axes.append(None)  # type: ignore[arg-type]
            axes.extend((b, a) for a in range(n))
            first += n
        open_session(Session(links, boards, axes))
        for b in boards.values():
            if mode & 0x30 == INIT_PARAM_LOAD_DEFAULT:
                b.post("load_parameter_from_default")
            elif mode & 0x30 == INIT_PARAM_LOAD_FLASH:
                b.post("load_parameter_from_flash")
        put(BoardID_InBits, sum(1 << bid for bid in boards))
        return ERR_NoError
    except BaseException:
        if close_session() is None:
            rack.close()
        raise


@guarded
def APS_close() -> int:
    """Release the cards (motion in progress goes on, spec §4.1)."""
    s = close_session()
    if s is not None:
        s.close()
    return ERR_NoError


def APS_version() -> int:
    return VERSION


@guarded
def APS_device_driver_version(Board_ID: int) -> int:
    board(Board_ID)
    return DRIVER_VERSION


@guarded
def APS_get_device_info(Board_ID: int, Info_No: int, Info: Any) -> int:
    board(Board_ID)
    value = DEVICE_INFO.get(as_int(Info_No))
    if value is None:
        return ERR_ParametersInvalid
    put(Info, value)
    return ERR_NoError


@guarded
def APS_get_card_name(Board_ID: int, CardName: Any) -> int:
    """DEVICE_NAME_AMP_82548 (14) for both models (spec Q16)."""
    board(Board_ID)
    put(CardName, DEVICE_NAME_AMP_82548)
    return ERR_NoError


@guarded
def APS_get_first_axisId(Board_ID: int, StartAxisID: Any, TotalAxisNum: Any) -> int:
    b = board(Board_ID)
    put(StartAxisID, b.first_axis)
    put(TotalAxisNum, b.axes)
    return ERR_NoError


@guarded
def APS_get_axis_info(Axis_ID: int, Board_ID: Any, Axis_No: Any, Port_ID: Any,
                      Module_ID: Any) -> int:
    b, a = axis(Axis_ID)
    put(Board_ID, b.board_id)
    put(Axis_No, a)
    put(Port_ID, 0)
    put(Module_ID, 0)
    return ERR_NoError


@guarded
def APS_get_eep_curr_drv_ctrl_mode(Board_ID: int, ModeInBit: Any) -> int:
    """Every axis in pulse mode (bit n = 0) [M §4.1.1.1]."""
    board(Board_ID)
    put(ModeInBit, 0)
    return ERR_NoError


# -- parameters [spec §3] -------------------------------------------------------------------------

@guarded
def APS_set_board_param(Board_ID: int, BOD_Param_No: int, BOD_Param: int) -> int:
    return board(Board_ID).post("set_board_param", as_int(BOD_Param_No), as_int(BOD_Param))[0]


@guarded
def APS_get_board_param(Board_ID: int, BOD_Param_No: int, BOD_Param: Any) -> int:
    rc, out = board(Board_ID).post("get_board_param", as_int(BOD_Param_No))
    if rc == 0:
        put(BOD_Param, out[0])
    return rc


@guarded
def APS_set_axis_param(Axis_ID: int, AXS_Param_No: int, AXS_Param: int) -> int:
    b, a = axis(Axis_ID)
    return b.post("set_axis_param", a, as_int(AXS_Param_No), as_int(AXS_Param))[0]


@guarded
def APS_get_axis_param(Axis_ID: int, AXS_Param_No: int, AXS_Param: Any) -> int:
    b, a = axis(Axis_ID)
    rc, out = b.post("get_axis_param", a, as_int(AXS_Param_No))
    if rc == 0:
        put(AXS_Param, out[0])
    return rc


@guarded
def APS_set_axis_param_f(Axis_ID: int, AXS_Param_No: int, AXS_Param: float) -> int:
    b, a = axis(Axis_ID)
    value = as_float(AXS_Param)
    return b.post("set_axis_param_f", a, as_int(AXS_Param_No), value)[0]


@guarded
def APS_get_axis_param_f(Axis_ID: int, AXS_Param_No: int, AXS_Param: Any) -> int:
    b, a = axis(Axis_ID)
    rc, out = b.post("get_axis_param_f", a, as_int(AXS_Param_No))
    if rc == 0:
        put(AXS_Param, out[0])
    return rc


@guarded
def APS_save_parameter_to_flash(Board_ID: int) -> int:
    return board(Board_ID).post("save_parameter_to_flash")[0]


@guarded
def APS_load_parameter_from_flash(Board_ID: int) -> int:
    return board(Board_ID).post("load_parameter_from_flash")[0]


@guarded
def APS_load_parameter_from_default(Board_ID: int) -> int:
    return board(Board_ID).post("load_parameter_from_default")[0]


# -- CPU load [M §4.1.2; spec Q1]: the manual's names with the APS_ prefix -------------------------

def _timing(board_id: int, which: int, out: Any) -> int:
    rc, vals = board(board_id).post("get_timing", which)
    if rc == 0:
        put(out, vals[0])
    return rc


@guarded
def APS_get_motion_control_timing(Board_ID: int, Loading: Any) -> int:
    """The motion cycle's load now, 0.01 % units (LPSTS.MotionLoopLoading)."""
    return _timing(Board_ID, 0, Loading)


@guarded
def APS_get_host_control_timing(Board_ID: int, Loading: Any) -> int:
    return _timing(Board_ID, 1, Loading)


@guarded
def APS_get_max_motion_control_timing(Board_ID: int, Loading: Any) -> int:
    return _timing(Board_ID, 2, Loading)


@guarded
def APS_get_max_host_control_timing(Board_ID: int, Loading: Any) -> int:
    return _timing(Board_ID, 3, Loading)


@guarded
def APS_reset_max_motion_control_timing(Board_ID: int) -> int:
    return board(Board_ID).post("reset_timing", 2)[0]


@guarded
def APS_reset_max_host_control_timing(Board_ID: int) -> int:
    return board(Board_ID).post("reset_timing", 3)[0]


@guarded
def APS_get_over_cycle_count(Board_ID: int, Count: Any) -> int:
    return _timing(Board_ID, 4, Count)


@guarded
def APS_get_over_cycle_event(Board_ID: int, Event: Any) -> int:
    """1 when a cycle overran since the count was reset."""
    rc, vals = board(Board_ID).post("get_timing", 4)
    if rc == 0:
        put(Event, int(vals[0] > 0))
    return rc


@guarded
def APS_reset_over_cycle_count(Board_ID: int) -> int:
    return board(Board_ID).post("reset_timing", 4)[0]


# -- servo, positions and status [M §4.1.1.4, §4.2.1, §4.8] --------------------------------------

@guarded
def APS_set_servo_on(Axis_ID: int, Servo_On: int) -> int:
    b, a = axis(Axis_ID)
    return b.post("set_servo_on", a, as_int(Servo_On))[0]


@guarded
def APS_motion_status(Axis_ID: int) -> int:
    """The motion status word [M §4.8.1] (one register read)."""
    b, a = axis(Axis_ID)
    return b.read_i32(a, Axis.MSTS)


@guarded
def APS_motion_io_status(Axis_ID: int) -> int:
    """The motion I/O word [M §4.1.1.4]."""
    b, a = axis(Axis_ID)
    return b.read_i32(a, Axis.MIO)


def _get_i32(axis_id: int, fld: Axis, out: Any) -> int:
    b, a = axis(axis_id)
    put(out, b.read_i32(a, fld))
    return ERR_NoError


def _get_f64(axis_id: int, fld: Axis, out: Any) -> int:
    b, a = axis(axis_id)
    put(out, b.read_f64(a, fld))
    return ERR_NoError


def _get_rounded(axis_id: int, fld: Axis, out: Any) -> int:
    b, a = axis(axis_id)
    v = b.read_f64(a, fld)
    put(out, max(min(int(math.floor(v + 0.5)), 2**31 - 1), -(2**31)))
    return ERR_NoError


@guarded
def APS_get_stop_code(Axis_ID: int, Code: Any) -> int:
    return _get_i32(Axis_ID, Axis.STOP_CODE, Code)


@guarded
def APS_get_command_f(Axis_ID: int, Command: Any) -> int:
    return _get_f64(Axis_ID, Axis.CMD_POS, Command)


@guarded
def APS_get_position_f(Axis_ID: int, Position: Any) -> int:
    return _get_f64(Axis_ID, Axis.FBK_POS, Position)


@guarded
def APS_get_command(Axis_ID: int, Command: Any) -> int:
    return _get_rounded(Axis_ID, Axis.CMD_POS, Command)


@guarded
def APS_get_position(Axis_ID: int, Position: Any) -> int:
    return _get_rounded(Axis_ID, Axis.FBK_POS, Position)


@guarded
def APS_set_command_f(Axis_ID: int, Command: float) -> int:
    b, a = axis(Axis_ID)
    return b.post("set_command_f", a, as_float(Command))[0]


@guarded
def APS_set_position_f(Axis_ID: int, Position: float) -> int:
    b, a = axis(Axis_ID)
    return b.post("set_position_f", a, as_float(Position))[0]


@guarded
def APS_set_command(Axis_ID: int, Command: int) -> int:
    b, a = axis(Axis_ID)
    return b.post("set_command_f", a, float(as_int(Command)))[0]


@guarded
def APS_set_position(Axis_ID: int, Position: int) -> int:
    b, a = axis(Axis_ID)
    return b.post("set_position_f", a, float(as_int(Position)))[0]


@guarded
def APS_get_encoder(Axis_ID: int, Encoder: Any) -> int:
    return _get_i32(Axis_ID, Axis.ENCODER, Encoder)


@guarded
def APS_get_command_counter(Axis_ID: int, Counter: Any) -> int:
    return _get_i32(Axis_ID, Axis.CMD_COUNTER, Counter)


@guarded
def APS_get_target_position_f(Axis_ID: int, Targ_Pos: Any) -> int:
    return _get_f64(Axis_ID, Axis.TARGET, Targ_Pos)


@guarded
def APS_get_target_position(Axis_ID: int, Targ_Pos: Any) -> int:
    return _get_rounded(Axis_ID, Axis.TARGET, Targ_Pos)


@guarded
def APS_get_error_position_f(Axis_ID: int, Err_Pos: Any) -> int:
    return _get_f64(Axis_ID, Axis.ERR_POS, Err_Pos)


@guarded
def APS_get_error_position(Axis_ID: int, Err_Pos: Any) -> int:
    return _get_rounded(Axis_ID, Axis.ERR_POS, Err_Pos)


@guarded
def APS_get_command_velocity_f(Axis_ID: int, Velocity: Any) -> int:
    return _get_f64(Axis_ID, Axis.CMD_VEL, Velocity)


@guarded
def APS_get_command_velocity(Axis_ID: int, Velocity: Any) -> int:
    return _get_rounded(Axis_ID, Axis.CMD_VEL, Velocity)


@guarded
def APS_get_feedback_velocity_f(Axis_ID: int, Velocity: Any) -> int:
    return _get_f64(Axis_ID, Axis.FBK_VEL, Velocity)


@guarded
def APS_get_feedback_velocity(Axis_ID: int, Velocity: Any) -> int:
    return _get_rounded(Axis_ID, Axis.FBK_VEL, Velocity)


@guarded
def APS_get_mq_usage(Axis_ID: int, Usage: Any) -> int:
    return _get_i32(Axis_ID, Axis.MQ_USAGE, Usage)


@guarded
def APS_get_mq_free_space(Axis_ID: int, Space: Any) -> int:
    b, a = axis(Axis_ID)
    put(Space, 10 - b.read_i32(a, Axis.MQ_USAGE))
    return ERR_NoError


@guarded
def APS_get_gear_status(Axis_ID: int, Status: Any) -> int:
    return _get_i32(Axis_ID, Axis.GEAR, Status)


@guarded
def APS_get_board_cycle_count(Board_ID: int, Count: Any) -> int:
    """vdevd: the motion cycles since power-up (Bar.CYCLE_COUNT)."""
    put(Count, board(Board_ID).read_u32(Bar.CYCLE_COUNT))
    return ERR_NoError


__all__ = [n for n in dir() if n.startswith("APS_")]
