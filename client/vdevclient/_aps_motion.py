"""APS single-axis motion: PTP, velocity, stops, synchronous start, home and jog [M §4.3-4.6,
§4.9.5; spec adlink.md §4.3]. Profile values not given come from the axis parameters (NaN on
the wire)."""

from __future__ import annotations

from typing import Any

from vdevclient._aps_session import (
    as_float,
    as_int,
    asyncall,
    axes_of,
    axis,
    guarded,
)

NAN = float("nan")


def _ptp(axis_id: int, option: int, pos: float, profile: tuple[float, ...], wait: Any) -> int:
    b, a = axis(axis_id)
    rc = b.post("ptp", a, as_int(option), as_float(pos), *profile)[0]
    return asyncall(wait, rc)


@guarded
def APS_ptp(Axis_ID: int, Option: int, Position: float, Wait: Any = None) -> int:
    """PTP with the axis's profile parameters [M §4.6.1]; Option: OPT_RELATIVE, OPT_WAIT,
    PTP_OPT_* [spec §3.6]."""
    return _ptp(Axis_ID, Option, Position, (NAN,) * 6, Wait)


@guarded
def APS_ptp_v(Axis_ID: int, Option: int, Position: float, Vm: float, Wait: Any = None) -> int:
    return _ptp(Axis_ID, Option, Position, (NAN, as_float(Vm), NAN, NAN, NAN, NAN), Wait)


@guarded
def APS_ptp_all(Axis_ID: int, Option: int, Position: float, Vs: float, Vm: float, Ve: float,
                Acc: float, Dec: float, SFac: float, Wait: Any = None) -> int:
    values = tuple(as_float(v) for v in (Vs, Vm, Ve, Acc, Dec, SFac))
    return _ptp(Axis_ID, Option, Position, values, Wait)


@guarded
def APS_relative_move(Axis_ID: int, Distance: int, Max_Speed: int) -> int:
    """I32 relative PTP: pulses and pulses/s (spec §2.9)."""
    b, a = axis(Axis_ID)
    return b.post("ptp_counts", a, 1, float(as_int(Distance)), float(as_int(Max_Speed)))[0]


@guarded
def APS_absolute_move(Axis_ID: int, Position: int, Max_Speed: int) -> int:
    b, a = axis(Axis_ID)
    return b.post("ptp_counts", a, 0, float(as_int(Position)), float(as_int(Max_Speed)))[0]


@guarded
def APS_vel(Axis_ID: int, Option: int, Vm: float, Wait: Any = None) -> int:
    """Velocity move at Vm, its sign the direction (spec Q26) [M §4.4]."""
    b, a = axis(Axis_ID)
    rc = b.post("vel", a, as_int(Option), as_float(Vm), NAN, NAN, NAN, NAN, NAN)[0]
    return asyncall(Wait, rc)


@guarded
def APS_vel_all(Axis_ID: int, Option: int, Vs: float, Vm: float, Ve: float, Acc: float,
                Dec: float, SFac: float, Wait: Any = None) -> int:
    b, a = axis(Axis_ID)
    vs, vm, ve, acc, dec, sf = (as_float(v) for v in (Vs, Vm, Ve, Acc, Dec, SFac))
    rc = b.post("vel", a, as_int(Option), vm, vs, ve, acc, dec, sf)[0]
    return asyncall(Wait, rc)


@guarded
def APS_velocity_move(Axis_ID: int, Max_Speed: int) -> int:
    """I32 velocity move, pulses/s [X1]."""
    b, a = axis(Axis_ID)
    return b.post("velocity_counts", a, float(as_int(Max_Speed)))[0]


@guarded
def APS_stop_move(Axis_ID: int) -> int:
    """Decelerate to a stop at PRA_SD_DEC [M §4.4]."""
    b, a = axis(Axis_ID)
    return b.post("stop_move", [a])[0]


@guarded
def APS_emg_stop(Axis_ID: int) -> int:
    """Stop at once [M §4.4]."""
    b, a = axis(Axis_ID)
    return b.post("emg_stop", [a])[0]


@guarded
def APS_stop_move_multi(Dimension: int, Axis_ID_Array: Any) -> int:
    b, axes = axes_of(Dimension, Axis_ID_Array)
    return b.post("stop_move", axes)[0]


@guarded
def APS_emg_stop_multi(Dimension: int, Axis_ID_Array: Any) -> int:
    b, axes = axes_of(Dimension, Axis_ID_Array)
    return b.post("emg_stop", axes)[0]


@guarded
def APS_move_trigger(Dimension: int, Axis_ID_Array: Any) -> int:
    """Start the listed axes waiting with OPT_WAIT, in one cycle [M §4.9.5.1]."""
    b, axes = axes_of(Dimension, Axis_ID_Array)
    return b.post("move_trigger", axes)[0]


@guarded
def APS_home_move(Axis_ID: int) -> int:
    """Start homing with PRA_HOME_* [M §4.3]."""
    b, a = axis(Axis_ID)
    return b.post("home_move", a)[0]


@guarded
def APS_jog_start(Axis_ID: int, STA_On: int) -> int:
    """The software JOG-ON signal: 0 -> 1 starts, 1 -> 0 stops [M §4.5]."""
    b, a = axis(Axis_ID)
    return b.post("jog_start", a, as_int(STA_On))[0]


APS_jog_on = APS_jog_start  # the manual's name [M §4.5]


__all__ = [n for n in dir() if n.startswith("APS_")]
