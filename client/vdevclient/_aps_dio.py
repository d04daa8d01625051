"""APS digital I/O [spec adlink.md §2.18, §4.6]: the DI and DO words of group 0 (bits 0-7 EDI/EDO,
8-23 TDI/TDO) and single DO channels. The AMP has no analog I/O: those functions return -13."""

from __future__ import annotations

from typing import Any

from vdevmaps.aps_defs import ERR_FunctionNotAvailable

from vdevclient._aps_session import as_int, board, get_one, guarded


@guarded
def APS_read_d_input(Board_ID: int, DI_Group: int, DI_Data: Any) -> int:
    """The DI word after PRB_DI_LOGIC."""
    return get_one(Board_ID, "read_d_input", (DI_Group,), DI_Data)


@guarded
def APS_write_d_output(Board_ID: int, DO_Group: int, DO_Data: int) -> int:
    return board(Board_ID).post("write_d_output", as_int(DO_Group), as_int(DO_Data))[0]


@guarded
def APS_read_d_output(Board_ID: int, DO_Group: int, DO_Data: Any) -> int:
    """The DO word as written (PRB_DO_LOGIC inverts it at the connector)."""
    return get_one(Board_ID, "read_d_output", (DO_Group,), DO_Data)


@guarded
def APS_write_d_channel_output(Board_ID: int, DO_Group: int, Ch_No: int, DO_Data: int) -> int:
    return board(Board_ID).post("write_d_channel_output", as_int(DO_Group), as_int(Ch_No),
                                as_int(DO_Data))[0]


@guarded
def APS_read_d_channel_output(Board_ID: int, DO_Group: int, Ch_No: int, DO_Data: Any) -> int:
    return get_one(Board_ID, "read_d_channel_output", (DO_Group, Ch_No), DO_Data)


def _no_analog(board_id: Any) -> int:
    board(board_id)
    return ERR_FunctionNotAvailable


@guarded
def APS_read_a_input_value(Board_ID: int, Channel_No: int, Convert_Data: Any) -> int:
    """The AMP has no analog inputs (spec §4.6): -13."""
    return _no_analog(Board_ID)


@guarded
def APS_read_a_input_data(Board_ID: int, Channel_No: int, Raw_Data: Any) -> int:
    return _no_analog(Board_ID)


@guarded
def APS_write_a_output_value(Board_ID: int, Channel_No: int, Convert_Data: float) -> int:
    return _no_analog(Board_ID)


@guarded
def APS_write_a_output_data(Board_ID: int, Channel_No: int, Raw_Data: int) -> int:
    return _no_analog(Board_ID)


@guarded
def APS_read_a_output_value(Board_ID: int, Channel_No: int, Convert_Data: Any) -> int:
    return _no_analog(Board_ID)


__all__ = [n for n in dir() if n.startswith("APS_")]
