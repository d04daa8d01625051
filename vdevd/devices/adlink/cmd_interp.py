"""Kernel commands of interpolation: lines, arcs, helices [M §4.7.1-4.7.3, §4.9.5; spec adlink.md
§2.10-2.13, §4.4]. Each builds the command's absolute path from where the group's motion will
be when it starts (OPT_RELATIVE: end points and centres are offsets from that start point, spec
§2.10) and hands it to the interpolation unit (interp.py) with the vector profile of the
reference axis (NaN on the wire: its parameter) and the transition of Option bits 12-15."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import OPT_RELATIVE, OPT_WAIT, ERR_ParametersInvalid

from vdevd.devices.adlink import motion
from vdevd.devices.adlink import path as geo
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.group import Transition
from vdevd.devices.adlink.interp import Command, Interpolation, Vector

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

Build = Callable[[np.ndarray, bool], geo.Path]
"""`build(start, relative)`: the command's absolute path from `start` (user units)."""

_I16 = (-(2**15), 2**15 - 1)


def _unit(k: Kernel) -> Interpolation:
    return next(u for u in k.units if isinstance(u, Interpolation))


def _transition(option: int, trans_para: float) -> tuple[Transition, float]:
    """Option bits 12-15 [M §4.7.3]; TransPara is the residue (method 6, >= 0) or its percent
    (method 7, 0-100) and is ignored by the others (spec §2.13 ASSUMPTION)."""
    try:
        transition = Transition.from_option(option)
    except ValueError:
        raise ApsError(ERR_ParametersInvalid, f"transition {option >> 12 & 0xF}") from None
    if transition is Transition.BLEND_RES_DIST:
        if not trans_para >= 0 or not math.isfinite(trans_para):
            raise ApsError(ERR_ParametersInvalid, "residual distance")
        return transition, trans_para
    if transition is Transition.BLEND_RES_DIST_PERCENT:
        if not 0 <= trans_para <= 100:
            raise ApsError(ERR_ParametersInvalid, "residual percent")
        return transition, trans_para
    return transition, 0.0


def _interpolate(k: Kernel, axes: Sequence[int], dims: tuple[int, ...], option: int,
                 trans_para: float, profile6: Sequence[float], build: Build) -> None:
    """The common part of every interpolation command (spec §2.10, §2.13)."""
    if len(axes) not in dims:
        raise ApsError(ERR_ParametersInvalid, f"{len(axes)} axes for this interpolation")
    transition, para = _transition(option, trans_para)
    unit = _unit(k)
    entry = unit.entry_for(tuple(axes), transition)
    vector = Vector(*motion.profile_values(k, axes[0], *profile6))
    start = unit.start_point(entry, transition)
    try:
        path = build(start, bool(option & OPT_RELATIVE))
    except geo.PathError as exc:
        raise ApsError(exc.code, str(exc)) from None
    unit.submit(entry, Command(path, vector, transition, para), bool(option & OPT_WAIT))


def _point(name: str, values: Sequence[float], dims: int) -> np.ndarray:
    if len(values) != dims:
        raise ApsError(ERR_ParametersInvalid, f"{name}: {len(values)} values, {dims} expected")
    return np.array(values, dtype=float)


def _dir(direction: int) -> int:
    if not _I16[0] <= direction <= _I16[1]:
        raise ApsError(ERR_ParametersInvalid, "Dir is an I16")
    return direction


def _at(start: np.ndarray, point: np.ndarray, relative: bool) -> np.ndarray:
    return start + point if relative else point


def line(k: Kernel, dimension: int, axes: list[int], option: int, positions: list[float],
         trans_para: float, *profile6: float) -> None:
    """APS_line(_v/_all) [M §4.7.1]: 2-6 axes; the vector profile on sqrt(sum dXi^2)."""
    if dimension != len(axes):
        raise ApsError(ERR_ParametersInvalid, "Dimension and the axis array differ")
    end = _point("PositionArray", positions, len(axes))
    _interpolate(k, axes, (2, 3, 4, 5, 6), option, trans_para, profile6,
                 lambda s, rel: geo.line(s, _at(s, end, rel)))


def linear_counts(k: Kernel, dimension: int, axes: list[int], relative: int,
                  counts: list[int], speed: float) -> None:
    """APS_absolute_linear_move / APS_relative_linear_move (I32): pulses, and the vector speed
    in pulses/s of the reference axis, with the reference axis's Acc/Dec/SF (the ASSUMPTION of
    the I32 PTP functions, spec §2.9, carried over)."""
    if dimension != len(axes) or len(counts) != dimension:
        raise ApsError(ERR_ParametersInvalid, "Dimension and the arrays differ")
    if not speed > 0:
        raise ApsError(ERR_ParametersInvalid, "Max_Linear_Speed must be positive")
    for a in axes:
        k.check_axis(a)
    pos = [c / k.factor(a) + (0.0 if relative else float(k.cmd_off[a]))
           for a, c in zip(axes, counts, strict=True)]
    nan = math.nan
    line(k, dimension, axes, OPT_RELATIVE if relative else 0, pos, 0.0,
         nan, speed / k.factor(axes[0]), nan, nan, nan, nan)


def arc2_ca(k: Kernel, axes: list[int], option: int, centre: list[float], angle: float,
            trans_para: float, *profile6: float) -> None:
    """APS_arc2_ca(_v/_all) [M §4.7.2.2]: centre and angle (rad, + counter-clockwise)."""
    c = _point("CenterArray", centre, 2)
    _interpolate(k, axes, (2,), option, trans_para, profile6,
                 lambda s, rel: geo.arc2_ca(s, _at(s, c, rel), angle))


def arc2_ce(k: Kernel, axes: list[int], option: int, centre: list[float], end: list[float],
            direction: int, trans_para: float, *profile6: float) -> None:
    """APS_arc2_ce(_v/_all) [M §4.7.2.2]: centre, end and Dir (laps)."""
    c, e, d = _point("CenterArray", centre, 2), _point("EndArray", end, 2), _dir(direction)
    _interpolate(k, axes, (2,), option, trans_para, profile6,
                 lambda s, rel: geo.arc2_ce(s, _at(s, c, rel), _at(s, e, rel), d))


def arc3_ca(k: Kernel, axes: list[int], option: int, centre: list[float], normal: list[float],
            angle: float, trans_para: float, *profile6: float) -> None:
    """APS_arc3_ca(_v/_all) [M §4.7.2.1]: centre, normal (Gram-Schmidt corrected), angle."""
    c, n = _point("CenterArray", centre, 3), _point("NormalArray", normal, 3)
    _interpolate(k, axes, (3,), option, trans_para, profile6,
                 lambda s, rel: geo.arc3_ca(s, _at(s, c, rel), n, angle))


def arc3_ce(k: Kernel, axes: list[int], option: int, centre: list[float], end: list[float],
            direction: int, trans_para: float, *profile6: float) -> None:
    """APS_arc3_ce(_v/_all) [M §4.7.2.1]: centre, end, Dir; no 0 or 180 degrees (spec §2.12)."""
    c, e, d = _point("CenterArray", centre, 3), _point("EndArray", end, 3), _dir(direction)
    _interpolate(k, axes, (3,), option, trans_para, profile6,
                 lambda s, rel: geo.arc3_ce(s, _at(s, c, rel), _at(s, e, rel), d))


def spiral_ca(k: Kernel, axes: list[int], option: int, centre: list[float], normal: list[float],
              angle: float, delta_h: float, final_r: float, trans_para: float,
              *profile6: float) -> None:
    """APS_spiral_ca(_v/_all) [M §4.7.2.3]: centre, normal, angle, height DeltaH, FinalR."""
    c, n = _point("CenterArray", centre, 3), _point("NormalArray", normal, 3)
    _interpolate(k, axes, (3,), option, trans_para, profile6,
                 lambda s, rel: geo.spiral_ca(s, _at(s, c, rel), n, angle, delta_h, final_r))


def spiral_ce(k: Kernel, axes: list[int], option: int, centre: list[float], normal: list[float],
              end: list[float], direction: int, trans_para: float, *profile6: float) -> None:
    """APS_spiral_ce(_v/_all) [M §4.7.2.3]: centre, normal, the cone's end point, Dir."""
    c, n = _point("CenterArray", centre, 3), _point("NormalArray", normal, 3)
    e, d = _point("EndArray", end, 3), _dir(direction)
    _interpolate(k, axes, (3,), option, trans_para, profile6,
                 lambda s, rel: geo.spiral_ce(s, _at(s, c, rel), n, _at(s, e, rel), d))
