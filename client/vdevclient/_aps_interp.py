"""APS interpolation: lines, 2-D/3-D arcs and helices, and their continuous transitions
[M §4.7, §4.9.5; spec adlink.md §4.4]. The plain functions take the reference axis's profile
parameters (NaN on the wire), `_v` a vector Vm, `_all` every vector value. Angles are radians
[X5]; `F64 *TransPara` is the blend parameter of ITP_OPT_BLEND_RES_DIST(_PERCENT) and may be
NULL (None). The manual's spellings `APS_sprial_*` are aliases of the DLL's `APS_spiral_*`."""

from __future__ import annotations

from typing import Any

from vdevmaps.aps_defs import ERR_ParametersInvalid

from vdevclient._aps_session import (
    ApsArgError,
    as_float,
    as_int,
    asyncall,
    axes_of,
    floats,
    guarded,
    ints,
)
from vdevclient._cargs import target

NAN = float("nan")
_PARAMS = (NAN,) * 6


def _trans(trans_para: Any) -> float:
    """`F64 *TransPara`: NULL reads as 0."""
    if trans_para is None or target(trans_para) is None:
        return 0.0
    return floats(trans_para, 1)[0]


def _v(vm: Any) -> tuple[float, ...]:
    return (NAN, as_float(vm), NAN, NAN, NAN, NAN)


def _all(*values: Any) -> tuple[float, ...]:
    return tuple(as_float(v) for v in values)


def _group(count: int, axis_ids: Any) -> tuple[Any, list[int]]:
    return axes_of(count, axis_ids)


def _i16(value: Any) -> int:
    v = as_int(value)
    if not -(2**15) <= v < 2**15:
        raise ApsArgError(ERR_ParametersInvalid)
    return v


# -- lines [M §4.7.1] ------------------------------------------------------------------------------

def _line(dimension: Any, axis_ids: Any, option: Any, positions: Any, trans_para: Any,
          profile: tuple[float, ...], wait: Any) -> int:
    n = as_int(dimension)
    b, axes = _group(n, axis_ids)
    rc = b.post("line", n, axes, as_int(option), floats(positions, n), _trans(trans_para),
                *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_line(Dimension: int, Axis_ID_Array: Any, Option: int, PositionArray: Any,
             TransPara: Any, Wait: Any = None) -> int:
    """Linear interpolation of 2-6 axes [M §4.7.1]; the first axis is the reference axis."""
    return _line(Dimension, Axis_ID_Array, Option, PositionArray, TransPara, _PARAMS, Wait)


@guarded
def APS_line_v(Dimension: int, Axis_ID_Array: Any, Option: int, PositionArray: Any,
               TransPara: Any, Vm: float, Wait: Any = None) -> int:
    return _line(Dimension, Axis_ID_Array, Option, PositionArray, TransPara, _v(Vm), Wait)


@guarded
def APS_line_all(Dimension: int, Axis_ID_Array: Any, Option: int, PositionArray: Any,
                 TransPara: Any, Vs: float, Vm: float, Ve: float, Acc: float, Dec: float,
                 SFac: float, Wait: Any = None) -> int:
    return _line(Dimension, Axis_ID_Array, Option, PositionArray, TransPara,
                 _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


def _linear_counts(dimension: Any, axis_ids: Any, values: Any, speed: Any, relative: int) -> int:
    n = as_int(dimension)
    b, axes = _group(n, axis_ids)
    return b.post("linear_counts", n, axes, relative, ints(values, n),
                  float(as_int(speed)))[0]


@guarded
def APS_absolute_linear_move(Dimension: int, Axis_ID_Array: Any, Position_Array: Any,
                             Max_Linear_Speed: int) -> int:
    """I32 linear move to pulses, the vector speed in pulses/s [M §4.7.1]."""
    return _linear_counts(Dimension, Axis_ID_Array, Position_Array, Max_Linear_Speed, 0)


@guarded
def APS_relative_linear_move(Dimension: int, Axis_ID_Array: Any, Distance_Array: Any,
                             Max_Linear_Speed: int) -> int:
    return _linear_counts(Dimension, Axis_ID_Array, Distance_Array, Max_Linear_Speed, 1)


# -- 2-D arcs [M §4.7.2.2] -----------------------------------------------------------------------------

def _arc2_ca(axis_ids: Any, option: Any, centre: Any, angle: Any, trans_para: Any,
             profile: tuple[float, ...], wait: Any) -> int:
    b, axes = _group(2, axis_ids)
    rc = b.post("arc2_ca", axes, as_int(option), floats(centre, 2), as_float(angle),
                _trans(trans_para), *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_arc2_ca(Axis_ID_Array: Any, Option: int, CenterArray: Any, Angle: float,
                TransPara: Any, Wait: Any = None) -> int:
    """2-D arc by centre and angle (radians, + counter-clockwise from axis 0 to axis 1)."""
    return _arc2_ca(Axis_ID_Array, Option, CenterArray, Angle, TransPara, _PARAMS, Wait)


@guarded
def APS_arc2_ca_v(Axis_ID_Array: Any, Option: int, CenterArray: Any, Angle: float,
                  TransPara: Any, Vm: float, Wait: Any = None) -> int:
    return _arc2_ca(Axis_ID_Array, Option, CenterArray, Angle, TransPara, _v(Vm), Wait)


@guarded
def APS_arc2_ca_all(Axis_ID_Array: Any, Option: int, CenterArray: Any, Angle: float,
                    TransPara: Any, Vs: float, Vm: float, Ve: float, Acc: float, Dec: float,
                    SFac: float, Wait: Any = None) -> int:
    return _arc2_ca(Axis_ID_Array, Option, CenterArray, Angle, TransPara,
                    _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


def _arc_ce(name: str, dims: int, axis_ids: Any, option: Any, centre: Any, end: Any,
            direction: Any, trans_para: Any, profile: tuple[float, ...], wait: Any) -> int:
    b, axes = _group(dims, axis_ids)
    rc = b.post(name, axes, as_int(option), floats(centre, dims), floats(end, dims),
                _i16(direction), _trans(trans_para), *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_arc2_ce(Axis_ID_Array: Any, Option: int, CenterArray: Any, EndArray: Any, Dir: int,
                TransPara: Any, Wait: Any = None) -> int:
    """2-D arc by centre and end; Dir >= 0 counter-clockwise, laps Angle = theta + Dir 2 pi."""
    return _arc_ce("arc2_ce", 2, Axis_ID_Array, Option, CenterArray, EndArray, Dir, TransPara,
                   _PARAMS, Wait)


@guarded
def APS_arc2_ce_v(Axis_ID_Array: Any, Option: int, CenterArray: Any, EndArray: Any, Dir: int,
                  TransPara: Any, Vm: float, Wait: Any = None) -> int:
    return _arc_ce("arc2_ce", 2, Axis_ID_Array, Option, CenterArray, EndArray, Dir, TransPara,
                   _v(Vm), Wait)


@guarded
def APS_arc2_ce_all(Axis_ID_Array: Any, Option: int, CenterArray: Any, EndArray: Any,
                    Dir: int, TransPara: Any, Vs: float, Vm: float, Ve: float, Acc: float,
                    Dec: float, SFac: float, Wait: Any = None) -> int:
    return _arc_ce("arc2_ce", 2, Axis_ID_Array, Option, CenterArray, EndArray, Dir, TransPara,
                   _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


# -- 3-D arcs [M §4.7.2.1] -----------------------------------------------------------------------------

def _arc3_ca(axis_ids: Any, option: Any, centre: Any, normal: Any, angle: Any, trans_para: Any,
             profile: tuple[float, ...], wait: Any) -> int:
    b, axes = _group(3, axis_ids)
    rc = b.post("arc3_ca", axes, as_int(option), floats(centre, 3), floats(normal, 3),
                as_float(angle), _trans(trans_para), *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_arc3_ca(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                Angle: float, TransPara: Any, Wait: Any = None) -> int:
    """3-D arc by centre, normal and angle (right-hand rule; beyond 2 pi: laps)."""
    return _arc3_ca(Axis_ID_Array, Option, CenterArray, NormalArray, Angle, TransPara, _PARAMS,
                    Wait)


@guarded
def APS_arc3_ca_v(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                  Angle: float, TransPara: Any, Vm: float, Wait: Any = None) -> int:
    return _arc3_ca(Axis_ID_Array, Option, CenterArray, NormalArray, Angle, TransPara, _v(Vm),
                    Wait)


@guarded
def APS_arc3_ca_all(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                    Angle: float, TransPara: Any, Vs: float, Vm: float, Ve: float, Acc: float,
                    Dec: float, SFac: float, Wait: Any = None) -> int:
    return _arc3_ca(Axis_ID_Array, Option, CenterArray, NormalArray, Angle, TransPara,
                    _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


@guarded
def APS_arc3_ce(Axis_ID_Array: Any, Option: int, CenterArray: Any, EndArray: Any, Dir: int,
                TransPara: Any, Wait: Any = None) -> int:
    """3-D arc by centre and end (no 180 degrees), normal (S - C) x (E - C), Dir laps."""
    return _arc_ce("arc3_ce", 3, Axis_ID_Array, Option, CenterArray, EndArray, Dir, TransPara,
                   _PARAMS, Wait)


@guarded
def APS_arc3_ce_v(Axis_ID_Array: Any, Option: int, CenterArray: Any, EndArray: Any, Dir: int,
                  TransPara: Any, Vm: float, Wait: Any = None) -> int:
    return _arc_ce("arc3_ce", 3, Axis_ID_Array, Option, CenterArray, EndArray, Dir, TransPara,
                   _v(Vm), Wait)


@guarded
def APS_arc3_ce_all(Axis_ID_Array: Any, Option: int, CenterArray: Any, EndArray: Any,
                    Dir: int, TransPara: Any, Vs: float, Vm: float, Ve: float, Acc: float,
                    Dec: float, SFac: float, Wait: Any = None) -> int:
    return _arc_ce("arc3_ce", 3, Axis_ID_Array, Option, CenterArray, EndArray, Dir, TransPara,
                   _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


# -- helices [M §4.7.2.3] ------------------------------------------------------------------------------

def _spiral_ca(axis_ids: Any, option: Any, centre: Any, normal: Any, angle: Any, delta_h: Any,
               final_r: Any, trans_para: Any, profile: tuple[float, ...], wait: Any) -> int:
    b, axes = _group(3, axis_ids)
    rc = b.post("spiral_ca", axes, as_int(option), floats(centre, 3), floats(normal, 3),
                as_float(angle), as_float(delta_h), as_float(final_r), _trans(trans_para),
                *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_spiral_ca(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                  Angle: float, DeltaH: float, FinalR: float, TransPara: Any,
                  Wait: Any = None) -> int:
    """Helix/spiral by centre, normal, angle, height DeltaH and final radius FinalR."""
    return _spiral_ca(Axis_ID_Array, Option, CenterArray, NormalArray, Angle, DeltaH, FinalR,
                      TransPara, _PARAMS, Wait)


@guarded
def APS_spiral_ca_v(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                    Angle: float, DeltaH: float, FinalR: float, TransPara: Any, Vm: float,
                    Wait: Any = None) -> int:
    return _spiral_ca(Axis_ID_Array, Option, CenterArray, NormalArray, Angle, DeltaH, FinalR,
                      TransPara, _v(Vm), Wait)


@guarded
def APS_spiral_ca_all(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                      Angle: float, DeltaH: float, FinalR: float, TransPara: Any, Vs: float,
                      Vm: float, Ve: float, Acc: float, Dec: float, SFac: float,
                      Wait: Any = None) -> int:
    return _spiral_ca(Axis_ID_Array, Option, CenterArray, NormalArray, Angle, DeltaH, FinalR,
                      TransPara, _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


def _spiral_ce(axis_ids: Any, option: Any, centre: Any, normal: Any, end: Any, direction: Any,
               trans_para: Any, profile: tuple[float, ...], wait: Any) -> int:
    b, axes = _group(3, axis_ids)
    rc = b.post("spiral_ce", axes, as_int(option), floats(centre, 3), floats(normal, 3),
                floats(end, 3), _i16(direction), _trans(trans_para), *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_spiral_ce(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                  EndArray: Any, Dir: int, TransPara: Any, Wait: Any = None) -> int:
    """Helix/spiral by centre, normal, the cone's end point and Dir laps."""
    return _spiral_ce(Axis_ID_Array, Option, CenterArray, NormalArray, EndArray, Dir, TransPara,
                      _PARAMS, Wait)


@guarded
def APS_spiral_ce_v(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                    EndArray: Any, Dir: int, TransPara: Any, Vm: float,
                    Wait: Any = None) -> int:
    return _spiral_ce(Axis_ID_Array, Option, CenterArray, NormalArray, EndArray, Dir, TransPara,
                      _v(Vm), Wait)


@guarded
def APS_spiral_ce_all(Axis_ID_Array: Any, Option: int, CenterArray: Any, NormalArray: Any,
                      EndArray: Any, Dir: int, TransPara: Any, Vs: float, Vm: float, Ve: float,
                      Acc: float, Dec: float, SFac: float, Wait: Any = None) -> int:
    return _spiral_ce(Axis_ID_Array, Option, CenterArray, NormalArray, EndArray, Dir, TransPara,
                      _all(Vs, Vm, Ve, Acc, Dec, SFac), Wait)


# the manual's spellings [M §4.7.2.3]
APS_sprial_ca = APS_spiral_ca
APS_sprial_ca_v = APS_spiral_ca_v
APS_sprial_ca_all = APS_spiral_ca_all
APS_sprial_ce = APS_spiral_ce
APS_sprial_ce_v = APS_spiral_ce_v
APS_sprial_ce_all = APS_spiral_ce_all


__all__ = [n for n in dir() if n.startswith("APS_")]
