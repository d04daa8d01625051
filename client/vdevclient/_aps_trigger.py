"""APS compare trigger and timer [M §4.9.2; spec adlink.md §2.16, §4.8]: trigger parameters,
manual, linear and table compare, trigger counts, the FIFO access of the table comparators and
timer 0. A table of any size is streamed to the card in parts, as the library does
[M §4.9.2.2.2]."""

from __future__ import annotations

from typing import Any

from vdevmaps.adlink import Bar
from vdevmaps.aps_defs import ERR_NoError, ERR_ParametersInvalid

from vdevclient._aps_bus import Board
from vdevclient._aps_session import ApsArgError, as_int, board, get_one, guarded, ints, put

#: compare points per mailbox post (an I32 array of a post stays under ARGS_MAX)
TABLE_PART = 800
_FIRST, _LAST = 1, 2


def _i32(v: int) -> int:
    return (v + 2**31) % 2**32 - 2**31


def _trg_channel(b: Board, ch: Any) -> int:
    """A TRG channel: 0-1 on the AMP-204C, 0-3 on the AMP-208C (spec Q25); -10 else."""
    c = as_int(ch)
    if not 0 <= c < (2 if b.axes == 4 else 4):
        raise ApsArgError(ERR_ParametersInvalid)
    return c


@guarded
def APS_set_trigger_param(Board_ID: int, Param_No: int, Param_Val: int) -> int:
    """A trigger parameter TGR_* / TIMR_* [M §4.9.2; spec §2.16 table]."""
    return board(Board_ID).post("set_trigger_param", as_int(Param_No), as_int(Param_Val))[0]


@guarded
def APS_get_trigger_param(Board_ID: int, Param_No: int, Param_Val: Any) -> int:
    return get_one(Board_ID, "get_trigger_param", (Param_No,), Param_Val)


@guarded
def APS_set_trigger_manual(Board_ID: int, TrgCh: int) -> int:
    """One pulse on TRG TrgCh when its source has the manual bit [M §4.9.2.1]."""
    b = board(Board_ID)
    return b.post("set_trigger_manual", 1 << _trg_channel(b, TrgCh))[0]


@guarded
def APS_set_trigger_manual_s(Board_ID: int, TrgChInBit: int) -> int:
    """APS_set_trigger_manual on several channels at once (bit n = TRGn)."""
    return board(Board_ID).post("set_trigger_manual", as_int(TrgChInBit))[0]


@guarded
def APS_set_trigger_linear(Board_ID: int, LCmpCh: int, StartPoint: int, RepeatTimes: int,
                           Interval: int) -> int:
    """Arm linear comparator LCmpCh: RepeatTimes points from StartPoint, Interval apart (its
    sign is the compare direction) [M §4.9.2.2.1]."""
    return board(Board_ID).post("set_trigger_linear", as_int(LCmpCh), as_int(StartPoint),
                                as_int(RepeatTimes), as_int(Interval))[0]


@guarded
def APS_set_trigger_table(Board_ID: int, TCmpCh: int, DataArr: Any, ArraySize: int) -> int:
    """Load and arm table comparator TCmpCh with ArraySize points of any number; the card's
    FIFOs refill from it every cycle [M §4.9.2.2.2]. Sent in parts of TABLE_PART points."""
    b = board(Board_ID)
    ch, size = as_int(TCmpCh), as_int(ArraySize)
    if size < 1:
        return ERR_ParametersInvalid
    points = [_i32(v) for v in ints(DataArr, size)]
    for at in range(0, size, TABLE_PART):
        flags = (_FIRST if at == 0 else 0) | (_LAST if at + TABLE_PART >= size else 0)
        rc = b.post("set_trigger_table", ch, flags, points[at:at + TABLE_PART])[0]
        if rc != ERR_NoError:
            return rc
    return ERR_NoError


@guarded
def APS_get_trigger_linear_cmp(Board_ID: int, LCmpCh: int, CmpVal: Any) -> int:
    """The next compare value of a linear comparator (the last one when it has finished)."""
    return get_one(Board_ID, "get_trigger_linear_cmp", (LCmpCh,), CmpVal)


@guarded
def APS_get_trigger_table_cmp(Board_ID: int, TCmpCh: int, CmpVal: Any) -> int:
    return get_one(Board_ID, "get_trigger_table_cmp", (TCmpCh,), CmpVal)


@guarded
def APS_get_trigger_count(Board_ID: int, TrgCh: int, TrgCnt: Any) -> int:
    """Pulses output on TRG TrgCh (the status block: one register read)."""
    b = board(Board_ID)
    ch = _trg_channel(b, TrgCh)
    put(TrgCnt, _i32(b.read_u32(Bar.TRG_COUNT + 4 * ch)))
    return ERR_NoError


@guarded
def APS_reset_trigger_count(Board_ID: int, TrgCh: int) -> int:
    return board(Board_ID).post("reset_trigger_count", as_int(TrgCh))[0]


@guarded
def APS_enable_trigger_fifo_cmp(Board_ID: int, FCmpCh: int, Enable: int) -> int:
    """Start (1) or pause (0) the FIFO (table) comparator FCmpCh, its points kept."""
    return board(Board_ID).post("enable_trigger_fifo_cmp", as_int(FCmpCh), as_int(Enable))[0]


@guarded
def APS_get_trigger_fifo_cmp(Board_ID: int, FCmpCh: int, CmpVal: Any) -> int:
    """The FIFO's next compare value (= APS_get_trigger_table_cmp)."""
    return get_one(Board_ID, "get_trigger_table_cmp", (FCmpCh,), CmpVal)


@guarded
def APS_get_trigger_fifo_status(Board_ID: int, FCmpCh: int, FifoSts: Any) -> int:
    """Bit 0 empty, bit 1 hardware FIFO full, bit 2 enabled, bits 16-23 the hardware FIFO's
    usage (vdevd's encoding)."""
    return get_one(Board_ID, "get_trigger_fifo_status", (FCmpCh,), FifoSts)


@guarded
def APS_set_trigger_fifo_data(Board_ID: int, FCmpCh: int, DataArr: Any, ArraySize: int,
                              ShiftFlag: int) -> int:
    """Queue ArraySize points (at most 255 + 999 pending) on FIFO comparator FCmpCh; ShiftFlag
    1 empties it first (vdevd's reading)."""
    size = as_int(ArraySize)
    if size < 1:
        return ERR_ParametersInvalid
    points = [_i32(v) for v in ints(DataArr, size)]
    return board(Board_ID).post("set_trigger_fifo_data", as_int(FCmpCh), as_int(ShiftFlag),
                                points)[0]


@guarded
def APS_start_timer(Board_ID: int, TrgCh: int, Start: int) -> int:
    """Timer 0 runs (1) or stops (0): TIMR_EN."""
    return board(Board_ID).post("start_timer", as_int(TrgCh), as_int(Start))[0]


@guarded
def APS_get_timer_counter(Board_ID: int, TmrCh: int, Cnt: Any) -> int:
    return get_one(Board_ID, "get_timer_counter", (TmrCh,), Cnt)


@guarded
def APS_set_timer_counter(Board_ID: int, TmrCh: int, Cnt: int) -> int:
    return board(Board_ID).post("set_timer_counter", as_int(TmrCh), as_int(Cnt))[0]


__all__ = [n for n in dir() if n.startswith("APS_")]
