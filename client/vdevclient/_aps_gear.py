"""APS electronic gearing and gantry [M §4.9.1; spec adlink.md §2.15, §4.5]. The slave's
PRA_GEAR_MASTER, PRA_GEAR_ENGAGE_RATE, PRA_GEAR_RATIO and PRA_GANTRY_PROTECT_1/2 are axis
parameters; `APS_get_gear_status` reads the status block (_aps_system)."""

from __future__ import annotations

from vdevclient._aps_session import as_int, axis, guarded


@guarded
def APS_start_gear(Axis_ID: int, Mode: int) -> int:
    """Gear the slave `Axis_ID` to its PRA_GEAR_MASTER: Mode 0 release, 1 standard (ramped
    in at PRA_GEAR_ENGAGE_RATE), 2 gantry (1:1) [M §4.9.1; X5]."""
    b, a = axis(Axis_ID)
    return b.post("start_gear", a, as_int(Mode))[0]


__all__ = [n for n in dir() if n.startswith("APS_")]
