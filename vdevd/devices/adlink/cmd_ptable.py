"""The point-table commands of the kernel [M §4.9.6; spec adlink.md §2.21, §4.11]: enable, modal
settings, instructions, the pushes (geometry from `path.py`), start/stop, the buffer. Each
handler checks its arguments and changes nothing when it refuses: -10 for a bad table number,
dimension, axis, index or value, -15 for a full buffer (spec §4.11 ASSUMPTION) or a running table,
-23 `ERR_FunctionNotEnable` for a table not enabled (vdevd's choice, README). The run itself is
`ptable.PointTables`."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
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
    PT_BUFFER_POINTS,
    STOP_ALM,
    STOP_EMG,
    ERR_FunctionNotEnable,
)

from vdevd.devices.adlink import path as geo
from vdevd.devices.adlink.errors import ApsError, busy, invalid
from vdevd.devices.adlink.group import Transition
from vdevd.devices.adlink.modes import IDLE
from vdevd.devices.adlink.profile import VM_MAX_PPS
from vdevd.devices.adlink.ptable import TRANS_INP, Embedded, Modal, Point, PointTables, Table, dwell_time

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

VAO_CONTROLLERS, VAO_TABLES = 2, 8  # [M §4.9.3.1] (spec §2.17)
_TRANSITIONS = {ITP_OPT_BUFFERED: Transition.BUFFERED, ITP_OPT_BLEND_DEC_EVENT: Transition.BLEND_DEC_EVENT,
                ITP_OPT_BLEND_RES_DIST: Transition.BLEND_RES_DIST,
                ITP_OPT_BLEND_RES_DIST_PERCENT: Transition.BLEND_RES_DIST_PERCENT}
#: the profile items of pt_set_profile: (lowest, strictly above it, highest)
_PROFILE = {PRA_VS: ("vs", 0.0, False, math.inf), PRA_VM: ("vm", 0.0, True, math.inf),
            PRA_VE: ("ve", 0.0, False, math.inf), PRA_ACC: ("acc", 0.0, True, math.inf),
            PRA_DEC: ("dec", 0.0, True, math.inf), PRA_SF: ("sf", 0.0, False, 1.0)}
Status = list[int]


def _unit(k: Kernel) -> PointTables:
    return next(u for u in k.units if isinstance(u, PointTables))


def _table(k: Kernel, ptb: int, enabled: bool = True) -> tuple[PointTables, Table]:
    unit = _unit(k)
    if isinstance(ptb, bool) or not 0 <= ptb < len(unit.tables):
        raise invalid(f"point table {ptb}")
    tb = unit.tables[ptb]
    if enabled and not tb.enabled:
        raise ApsError(ERR_FunctionNotEnable, f"point table {ptb} is not enabled")
    return unit, tb


def _finite(*values: float) -> None:
    if not all(math.isfinite(v) for v in values):
        raise invalid("not finite")


# -- enable, info, start, stop ---------------------------------------------------------------------

def pt_enable(k: Kernel, ptb: int, axes: list[int]) -> None:
    """APS_pt_enable [M §4.9.6.2]: bind the table to 2-6 axes (AxisArr[0] first); the modal
    settings start absolute, buffered, with the first axis's profile parameters."""
    _, tb = _table(k, ptb, enabled=False)
    if not 2 <= len(axes) <= MAX_PT_DIM or len(set(axes)) != len(axes):
        raise invalid(f"axes {axes}")
    for a in axes:
        k.check_axis(a)
    if tb.running:
        raise busy(f"point table {ptb} is running")
    a0 = axes[0]
    tb.clear()
    tb.enabled = True
    tb.axes = tuple(axes)
    tb.modal = Modal(vs=float(k.p(PRA_VS)[a0]), vm=float(k.p(PRA_VM)[a0]), ve=float(k.p(PRA_VE)[a0]),
                     acc=float(k.p(PRA_ACC)[a0]), dec=float(k.p(PRA_DEC)[a0]), sf=float(k.p(PRA_SF)[a0]))


def pt_disable(k: Kernel, ptb: int) -> None:
    """APS_pt_disable: the table forgets its axes and points (-15 while it runs)."""
    _, tb = _table(k, ptb, enabled=False)
    if tb.running:
        raise busy(f"point table {ptb} is running")
    tb.clear()


def pt_get_info(k: Kernel, ptb: int) -> tuple[int, list[int]]:
    """APS_get_pt_info: dimension and axes (0 and none while disabled)."""
    _, tb = _table(k, ptb, enabled=False)
    return len(tb.axes), list(tb.axes)


def pt_start(k: Kernel, ptb: int) -> None:
    """APS_pt_start [M §4.9.6.2]: run the points in order; nothing while it runs already or the
    table is empty; -15 when an axis is busy; EMG or ALM: ignored, the stop code and ASTP set (Q15)."""
    unit, tb = _table(k, ptb)
    if tb.running or not tb.buffer:
        return
    axes = list(tb.axes)
    if ((k.mode[axes] != IDLE).any() or k.owned[axes].any() or k.moving()[axes].any()
            or k.wait[axes].any()):
        raise busy(f"an axis of point table {ptb} is busy")
    code = STOP_EMG if k.emg else STOP_ALM if k.alm[axes].any() else None
    if code is not None:
        k.stop_code[axes] = code
        k.astp[axes] = True
        return
    unit.start(tb)


def pt_stop(k: Kernel, ptb: int) -> None:
    """APS_pt_stop: decelerate along the path at the first axis's SD_DEC, the buffer cleared."""
    unit, tb = _table(k, ptb)
    unit.stop(tb)


def reset_pt_buffer(k: Kernel, ptb: int) -> None:
    """APS_reset_pt_buffer [X1]: the points and pending instructions dropped (-15 while it runs)."""
    _, tb = _table(k, ptb)
    if tb.running:
        raise busy(f"point table {ptb} is running")
    tb.buffer.clear()
    tb.actions.clear()
    tb.error = 0


def pt_roll_back(k: Kernel, ptb: int, speed: float) -> None:
    """APS_pt_roll_back [X1] (vdevd's reading): back to the start of the last started point."""
    unit, tb = _table(k, ptb)
    _finite(speed)
    if speed <= 0:
        raise invalid("Max_Speed must be positive")
    if tb.running:
        raise busy(f"point table {ptb} is running")
    axes = list(tb.axes)
    if (k.mode[axes] != IDLE).any() or k.owned[axes].any() or k.moving()[axes].any():
        raise busy(f"an axis of point table {ptb} is busy")
    unit.roll_back(tb, speed)


def pt_get_error(k: Kernel, ptb: int) -> int:
    """APS_pt_get_error [X1]: the last error of the run (a refused point's code, or the stop code
    of an abnormal stop), 0 for none."""
    _, tb = _table(k, ptb)
    return tb.error


# -- modal settings [M §4.9.6.1 a] ----------------------------------------------------------------

def pt_set_relative(k: Kernel, ptb: int, relative: int) -> None:
    """APS_pt_set_absolute (0) / APS_pt_set_relative (1)."""
    _, tb = _table(k, ptb)
    if relative not in (0, 1):
        raise invalid("relative is 0 or 1")
    tb.modal.relative = bool(relative)


def pt_set_profile(k: Kernel, ptb: int, item: int, value: float) -> None:
    """APS_pt_set_vs/_vm/_ve/_acc/_dec/_s: item is the axis parameter's number (PRA_VS ...)."""
    _, tb = _table(k, ptb)
    spec = _PROFILE.get(item)
    if spec is None:
        raise invalid(f"profile item {item:#x}")
    name, low, strict, high = spec
    _finite(value)
    if value < low or (strict and value <= low) or value > high:
        raise invalid(f"{name} {value}")
    setattr(tb.modal, name, float(value))


def pt_set_acc_dec(k: Kernel, ptb: int, value: float) -> None:
    """APS_pt_set_acc_dec: Acc and Dec together."""
    _, tb = _table(k, ptb)
    _finite(value)
    if value <= 0:
        raise invalid("acc/dec must be positive")
    tb.modal.acc = tb.modal.dec = float(value)


def pt_get_profile(k: Kernel, ptb: int, item: int) -> float:
    """APS_pt_get_vs (and the other items of pt_set_profile)."""
    _, tb = _table(k, ptb)
    spec = _PROFILE.get(item)
    if spec is None:
        raise invalid(f"profile item {item:#x}")
    return float(getattr(tb.modal, spec[0]))


def pt_set_trans(k: Kernel, ptb: int, option: int, bp: float) -> None:
    """APS_pt_set_trans_buffered / _blend_dec / _blend_dist / _blend_pcnt: the ITP_OPT_* value
    of the §4.7.3 method and Bp (residual distance, or percent 0-100; ignored by blend_dec)."""
    _, tb = _table(k, ptb)
    mode = _TRANSITIONS.get(option)
    _finite(bp)
    if mode is None:
        raise invalid(f"transition {option:#x}")
    if mode is Transition.BLEND_RES_DIST and bp < 0:
        raise invalid("negative residual distance")
    if mode is Transition.BLEND_RES_DIST_PERCENT and not 0 <= bp <= 100:
        raise invalid("percent outside 0-100")
    tb.modal.trans = int(mode)
    tb.modal.bp = float(bp) if mode in (Transition.BLEND_RES_DIST, Transition.BLEND_RES_DIST_PERCENT) else 0.0


def pt_set_trans_inp(k: Kernel, ptb: int) -> None:
    """APS_pt_set_trans_inp ("buffered in-place"): the next point waits for INP of every table axis
    (spec §2.21 ASSUMPTION)."""
    _, tb = _table(k, ptb)
    tb.modal.trans = TRANS_INP
    tb.modal.bp = 0.0


# -- instructions [M §4.9.6.1 b] -------------------------------------------------------------------

def pt_ext_set_do_ch(k: Kernel, ptb: int, channel: int, on: int) -> None:
    """APS_pt_ext_set_do_ch: DO channel (0-23: EDO 0-7, TDO 8-23) on (1) or off (0) when the next
    pushed point starts (spec §2.21 ASSUMPTION, Q14: OnOff 1 = DO on)."""
    _, tb = _table(k, ptb)
    mask = 0xFFFF0F if k.n == 4 else 0xFFFFFF  # the 204C has EDO 0-3 (spec §2.18)
    if not 0 <= channel < 24 or not mask >> channel & 1 or on not in (0, 1):
        raise invalid(f"DO channel {channel}, OnOff {on}")
    tb.actions.append(("do", channel, on))


def pt_ext_set_table_no(k: Kernel, ptb: int, ctrl: int, table: int) -> None:
    """APS_pt_ext_set_table_no: VAO controller 0-1 switches to table 0-7 when the next pushed point
    starts."""
    _, tb = _table(k, ptb)
    if not 0 <= ctrl < VAO_CONTROLLERS or not 0 <= table < VAO_TABLES:
        raise invalid(f"VAO controller {ctrl}, table {table}")
    tb.actions.append(("vao", ctrl, table))


# -- pushes [M §4.9.6.1 c] --------------------------------------------------------------------------

Build = Callable[[np.ndarray, bool], "geo.Path | Embedded"]


def _push(k: Kernel, ptb: int, build: Build, dwell: float | None = None) -> Status:
    """A point at the end of the table with the modal profile and the pending instructions; the
    table's PTSTS after it. Full (50 points): -15, nothing changed."""
    unit, tb = _table(k, ptb)
    if len(tb.buffer) >= PT_BUFFER_POINTS:
        raise busy(f"point table {ptb} is full")
    start = unit.tail(tb)
    try:
        path = build(start, tb.modal.relative)
    except geo.PathError as exc:
        raise invalid(str(exc)) from None
    m = tb.modal
    vm = min(m.vm, VM_MAX_PPS / k.factor(tb.axes[0]))  # 6.5 Mpps at most [M §3.1]
    point = Point(path, min(m.vs, vm), vm, m.ve, m.acc, m.dec, m.sf, m.trans, m.bp, dwell,
                  tb.actions)
    tb.actions = []
    tb.buffer.append(point)
    return list(tb.status())


def _columns(k: Kernel, ptb: int, index: list[int], count: int) -> list[int]:
    """Index[]: which columns of the table's axis array an arc uses (spec §2.21 ASSUMPTION)."""
    _, tb = _table(k, ptb)
    if len(index) != count or len(set(index)) != count or not all(0 <= i < len(tb.axes) for i in index):
        raise invalid(f"Index {index} for a table of {len(tb.axes)} axes")
    return index


def _values(values: list[float], count: int) -> list[float]:
    if len(values) != count:
        raise invalid(f"{len(values)} values, {count} expected")
    _finite(*values)
    return values


def pt_line(k: Kernel, ptb: int, dim: int, pos: list[float]) -> Status:
    """APS_pt_line(PTLINE): Dim must be the table's dimension; Pos[0..Dim-1] absolute or relative."""
    _, tb = _table(k, ptb)
    if dim != len(tb.axes) or len(pos) < dim:
        raise invalid(f"PTLINE.Dim {dim} for a table of {len(tb.axes)} axes")
    end = np.array(_values(pos[:dim], dim))
    return _push(k, ptb, lambda s, rel: geo.line(s, s + end if rel else end))


def _arc(k: Kernel, ptb: int, index: list[int], count: int,
         make: Callable[[np.ndarray, bool], geo.Path]) -> Status:
    cols = _columns(k, ptb, index, count)
    return _push(k, ptb, lambda s, rel: Embedded(make(s[cols], rel), tuple(cols), s))


def _at(rel: bool, start: np.ndarray, p: list[float]) -> np.ndarray:
    return start + np.array(p) if rel else np.array(p)


def pt_arc2_ca(k: Kernel, ptb: int, index: list[int], v: list[float]) -> Status:
    """APS_pt_arc2_ca(PTA2CA): Center[2], Angle (radians) [M §4.7.2.2]."""
    c0, c1, angle = _values(v, 3)
    return _arc(k, ptb, index, 2, lambda s, rel: geo.arc2_ca(s, _at(rel, s, [c0, c1]), angle))


def pt_arc2_ce(k: Kernel, ptb: int, index: list[int], v: list[float], direction: int) -> Status:
    """APS_pt_arc2_ce(PTA2CE): Center[2], End[2], Dir."""
    c0, c1, e0, e1 = _values(v, 4)
    return _arc(k, ptb, index, 2,
                lambda s, rel: geo.arc2_ce(s, _at(rel, s, [c0, c1]), _at(rel, s, [e0, e1]), direction))


def pt_arc3_ca(k: Kernel, ptb: int, index: list[int], v: list[float]) -> Status:
    """APS_pt_arc3_ca(PTA3CA): Center[3], Normal[3], Angle [M §4.7.2.1]."""
    vals = _values(v, 7)
    return _arc(k, ptb, index, 3, lambda s, rel: geo.arc3_ca(s, _at(rel, s, vals[0:3]), vals[3:6], vals[6]))


def pt_arc3_ce(k: Kernel, ptb: int, index: list[int], v: list[float], direction: int) -> Status:
    """APS_pt_arc3_ce(PTA3CE): Center[3], End[3], Dir."""
    vals = _values(v, 6)
    return _arc(k, ptb, index, 3,
                lambda s, rel: geo.arc3_ce(s, _at(rel, s, vals[0:3]), _at(rel, s, vals[3:6]), direction))


def pt_spiral_ca(k: Kernel, ptb: int, index: list[int], v: list[float]) -> Status:
    """APS_pt_spiral_ca(PTHCA): Center[3], Normal[3], Angle, DeltaH, FinalR [M §4.7.2.3]."""
    vals = _values(v, 9)
    return _arc(k, ptb, index, 3, lambda s, rel: geo.spiral_ca(
        s, _at(rel, s, vals[0:3]), vals[3:6], vals[6], vals[7], vals[8]))


def pt_spiral_ce(k: Kernel, ptb: int, index: list[int], v: list[float], direction: int) -> Status:
    """APS_pt_spiral_ce(PTHCE): Center[3], Normal[3], End[3], Dir."""
    vals = _values(v, 9)
    return _arc(k, ptb, index, 3, lambda s, rel: geo.spiral_ce(
        s, _at(rel, s, vals[0:3]), vals[3:6], _at(rel, s, vals[6:9]), direction))


def pt_dwell(k: Kernel, ptb: int, ms: float) -> Status:
    """APS_pt_dwell(PTDWL): hold DwTime ms, rounded up to whole cycles (spec §2.21)."""
    _table(k, ptb)
    _finite(ms)
    if ms < 0:
        raise invalid("negative dwell time")
    return _push(k, ptb, lambda s, rel: geo.line(s, s), dwell_time(ms, k.cycle_us))
