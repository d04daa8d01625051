"""APS point tables [M §4.9.6; spec adlink.md §2.21, §4.11]: enable, modal settings, instructions,
the pushes (type_def.h structures PTLINE, PTA2CA ... PTDWL), start/stop and the status.

A push answers the table's PTSTS in its last argument (also when it is refused, e.g. -15 for a
full table: the status read from the status block). APS_get_pt_status is one read of the status
block. The manual's spellings `APS_pt_sprial_*` and `APS_pt_set_trans_blend_pcmt` are aliases.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from vdevmaps.adlink import PT_TABLES, Bar
from vdevmaps.aps_defs import (
    ITP_OPT_BLEND_DEC_EVENT,
    ITP_OPT_BLEND_RES_DIST,
    ITP_OPT_BLEND_RES_DIST_PERCENT,
    ITP_OPT_BUFFERED,
    MAX_PT_DIM,
    PRA_ACC,
    PRA_DEC,
    PRA_SF,
    PRA_VE,
    PRA_VM,
    PRA_VS,
    ERR_ParametersInvalid,
)

from vdevclient._aps_bus import Board
from vdevclient._aps_session import (
    ApsArgError,
    as_float,
    as_int,
    axis,
    board,
    guarded,
    ints,
    put,
)
from vdevclient._cargs import target

_PTSTS = struct.Struct("<HHHHI")  # BitSts, free, usage, pad, RunningCnt (vdevmaps.adlink Bar.PT_STATUS)
_STRIDE = 16


def _ptb(value: Any) -> int:
    ptb = as_int(value)
    if not 0 <= ptb < PT_TABLES:
        raise ApsArgError(ERR_ParametersInvalid)
    return ptb


def _struct(param: Any) -> Any:
    """The structure a pointer argument points to; NULL is -10."""
    obj = target(param)
    if obj is None:
        raise ApsArgError(ERR_ParametersInvalid)
    return obj


def _status(b: Board, ptb: int) -> tuple[int, int, int, int]:
    bits, free, usage, _, count = _PTSTS.unpack(b.bar.read(Bar.PT_STATUS + ptb * _STRIDE, _PTSTS.size))
    return bits, free, usage, count


def _put_status(param: Any, values: tuple[int, ...] | list[int]) -> None:
    st = _struct(param)
    st.BitSts, st.PntBufFreeSpace, st.PntBufUsageSpace, st.RunningCnt = values


def _push(Board_ID: Any, PtbId: Any, Status: Any, name: str, *args: Any) -> int:
    b, ptb = board(Board_ID), _ptb(PtbId)
    _struct(Status)
    rc, out = b.post(name, ptb, *args)
    _put_status(Status, out if rc == 0 else _status(b, ptb))
    return rc


def _post(Board_ID: Any, PtbId: Any, name: str, *args: Any) -> int:
    return board(Board_ID).post(name, as_int(PtbId), *args)[0]


# -- enable, info, status, start, stop --------------------------------------------------------------

@guarded
def APS_pt_enable(Board_ID: int, PtbId: int, Dimension: int, AxisArr: Any) -> int:
    """Bind table PtbId (0-1) to Dimension (2-6) axes of this board, AxisArr[0] first [M §4.9.6.2]."""
    b = board(Board_ID)
    n = as_int(Dimension)
    if not 0 < n <= MAX_PT_DIM + 1:
        raise ApsArgError(ERR_ParametersInvalid)
    local = []
    for axis_id in ints(AxisArr, n):
        ab, a = axis(axis_id)
        if ab is not b:
            raise ApsArgError(ERR_ParametersInvalid)
        local.append(a)
    return b.post("pt_enable", as_int(PtbId), local)[0]


@guarded
def APS_pt_disable(Board_ID: int, PtbId: int) -> int:
    return _post(Board_ID, PtbId, "pt_disable")


@guarded
def APS_get_pt_info(Board_ID: int, PtbId: int, Info: Any) -> int:
    """PTINFO: Dimension and AxisArr (global axis IDs); Dimension 0 while disabled [X1]."""
    b = board(Board_ID)
    info = _struct(Info)
    rc, out = b.post("pt_get_info", as_int(PtbId))
    if rc == 0:
        dim, axes = out
        info.Dimension = dim
        for i in range(MAX_PT_DIM):
            info.AxisArr[i] = b.first_axis + axes[i] if i < dim else 0
    return rc


@guarded
def APS_get_pt_status(Board_ID: int, PtbId: int, Status: Any) -> int:
    """PTSTS: BitSts (bit 0 working, 1 full, 2 empty), free and used points, RunningCnt."""
    b, ptb = board(Board_ID), _ptb(PtbId)
    _put_status(Status, _status(b, ptb))
    return 0


@guarded
def APS_pt_start(Board_ID: int, PtbId: int, _Manual: Any = None) -> int:
    """Run the table's points [M §4.9.6.2]. The manual's example passes a third argument, [X1] has
    two (spec §2.21 CONFLICT): a third is accepted and ignored."""
    return _post(Board_ID, PtbId, "pt_start")


@guarded
def APS_pt_stop(Board_ID: int, PtbId: int) -> int:
    """Decelerate along the path (SD_DEC of the first axis), the buffer cleared."""
    return _post(Board_ID, PtbId, "pt_stop")


@guarded
def APS_reset_pt_buffer(Board_ID: int, PtbId: int) -> int:
    return _post(Board_ID, PtbId, "reset_pt_buffer")


@guarded
def APS_pt_roll_back(Board_ID: int, PtbId: int, Max_Speed: float) -> int:
    return _post(Board_ID, PtbId, "pt_roll_back", as_float(Max_Speed))


@guarded
def APS_pt_get_error(Board_ID: int, PtbId: int, ErrCode: Any) -> int:
    rc, out = board(Board_ID).post("pt_get_error", as_int(PtbId))
    if rc == 0:
        put(ErrCode, out[0])
    return rc


# -- modal settings [M §4.9.6.1 a] -------------------------------------------------------------------

@guarded
def APS_pt_set_absolute(Board_ID: int, PtbId: int) -> int:
    return _post(Board_ID, PtbId, "pt_set_relative", 0)


@guarded
def APS_pt_set_relative(Board_ID: int, PtbId: int) -> int:
    return _post(Board_ID, PtbId, "pt_set_relative", 1)


def _setter(item: int) -> Callable[..., int]:
    @guarded
    def fn(Board_ID: int, PtbId: int, Value: float) -> int:
        return _post(Board_ID, PtbId, "pt_set_profile", item, as_float(Value))
    return fn


APS_pt_set_vs = _setter(PRA_VS)
APS_pt_set_vm = _setter(PRA_VM)
APS_pt_set_ve = _setter(PRA_VE)
APS_pt_set_acc = _setter(PRA_ACC)
APS_pt_set_dec = _setter(PRA_DEC)
APS_pt_set_s = _setter(PRA_SF)


@guarded
def APS_pt_set_acc_dec(Board_ID: int, PtbId: int, AccDec: float) -> int:
    return _post(Board_ID, PtbId, "pt_set_acc_dec", as_float(AccDec))


@guarded
def APS_pt_get_vs(Board_ID: int, PtbId: int, Vs: Any) -> int:
    rc, out = board(Board_ID).post("pt_get_profile", as_int(PtbId), PRA_VS)
    if rc == 0:
        put(Vs, out[0])
    return rc


@guarded
def APS_pt_set_trans_buffered(Board_ID: int, PtbId: int) -> int:
    return _post(Board_ID, PtbId, "pt_set_trans", ITP_OPT_BUFFERED, 0.0)


@guarded
def APS_pt_set_trans_inp(Board_ID: int, PtbId: int) -> int:
    return _post(Board_ID, PtbId, "pt_set_trans_inp")


@guarded
def APS_pt_set_trans_blend_dec(Board_ID: int, PtbId: int, Bp: float) -> int:
    """Blend when the previous point starts decelerating [M §4.7.3 method 5]; Bp ignored."""
    return _post(Board_ID, PtbId, "pt_set_trans", ITP_OPT_BLEND_DEC_EVENT, as_float(Bp))


@guarded
def APS_pt_set_trans_blend_dist(Board_ID: int, PtbId: int, Bp: float) -> int:
    """Blend at residual distance Bp of the previous point [M §4.7.3 method 6]."""
    return _post(Board_ID, PtbId, "pt_set_trans", ITP_OPT_BLEND_RES_DIST, as_float(Bp))


@guarded
def APS_pt_set_trans_blend_pcnt(Board_ID: int, PtbId: int, Bp: float) -> int:
    """Blend at residual distance Bp % (0-100) of the previous point [M §4.7.3 method 7]."""
    return _post(Board_ID, PtbId, "pt_set_trans", ITP_OPT_BLEND_RES_DIST_PERCENT, as_float(Bp))


APS_pt_set_trans_blend_pcmt = APS_pt_set_trans_blend_pcnt  # the manual's spelling [M §4.9.6.1]


# -- instructions [M §4.9.6.1 b] ---------------------------------------------------------------------

@guarded
def APS_pt_ext_set_do_ch(Board_ID: int, PtbId: int, Channel: int, OnOff: int) -> int:
    """DO Channel on (1) or off (0) when the next pushed point starts (Q14)."""
    return _post(Board_ID, PtbId, "pt_ext_set_do_ch", as_int(Channel), as_int(OnOff))


@guarded
def APS_pt_ext_set_table_no(Board_ID: int, PtbId: int, CtrlNo: int, TableNo: int) -> int:
    """VAO controller CtrlNo switches to table TableNo when the next pushed point starts."""
    return _post(Board_ID, PtbId, "pt_ext_set_table_no", as_int(CtrlNo), as_int(TableNo))


# -- pushes [M §4.9.6.1 c] ----------------------------------------------------------------------------

def _floats(*arrays: Any) -> list[float]:
    return [float(v) for arr in arrays for v in arr]


def _index(prof: Any) -> list[int]:
    return [int(i) for i in prof.Index]


@guarded
def APS_pt_line(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTLINE {Dim; Pos[6]}: Dim is the table's dimension."""
    p = _struct(Prof)
    dim = as_int(p.Dim)
    pos = _floats(list(p.Pos)[:max(0, min(dim, MAX_PT_DIM))])
    return _push(Board_ID, PtbId, Status, "pt_line", dim, pos)


@guarded
def APS_pt_arc2_ca(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTA2CA {Index[2]; Center[2]; Angle (radians)}."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_arc2_ca", _index(p), _floats(p.Center, [p.Angle]))


@guarded
def APS_pt_arc2_ce(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTA2CE {Index[2]; Center[2]; End[2]; Dir}."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_arc2_ce", _index(p), _floats(p.Center, p.End),
                 as_int(p.Dir))


@guarded
def APS_pt_arc3_ca(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTA3CA {Index[3]; Center[3]; Normal[3]; Angle}."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_arc3_ca", _index(p),
                 _floats(p.Center, p.Normal, [p.Angle]))


@guarded
def APS_pt_arc3_ce(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTA3CE {Index[3]; Center[3]; End[3]; Dir}."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_arc3_ce", _index(p), _floats(p.Center, p.End),
                 as_int(p.Dir))


@guarded
def APS_pt_spiral_ca(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTHCA {Index[3]; Center[3]; Normal[3]; Angle; DeltaH; FinalR}."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_spiral_ca", _index(p),
                 _floats(p.Center, p.Normal, [p.Angle, p.DeltaH, p.FinalR]))


@guarded
def APS_pt_spiral_ce(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTHCE {Index[3]; Center[3]; Normal[3]; End[3]; Dir}."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_spiral_ce", _index(p),
                 _floats(p.Center, p.Normal, p.End), as_int(p.Dir))


APS_pt_sprial_ca = APS_pt_spiral_ca  # the manual's spelling [M §4.9.6.1]
APS_pt_sprial_ce = APS_pt_spiral_ce


@guarded
def APS_pt_dwell(Board_ID: int, PtbId: int, Prof: Any, Status: Any) -> int:
    """PTDWL {DwTime (ms)}: hold, rounded up to whole motion cycles."""
    p = _struct(Prof)
    return _push(Board_ID, PtbId, Status, "pt_dwell", float(p.DwTime))


__all__ = [n for n in dir() if n.startswith("APS_")]
