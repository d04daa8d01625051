"""Helpers to drive the generic-servo card's registers (vdevd/devices/generic/README.md)."""

from __future__ import annotations

from typing import Any

from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg, Command

BAR = {"card": "servo0", "region": "bar0"}


def axis_reg(axis: int, reg: AxisReg) -> int:
    return R.AXIS_BASE + R.AXIS_STRIDE * axis + reg


def u32(value: int) -> bytes:
    return (value & 0xFFFFFFFF).to_bytes(4, "little")


def move_ops(axis: int, target: int, vmax: int = 50_000, acc: int = 500_000,
             command: Command = Command.MOVE_ABS) -> list[dict[str, Any]]:
    """Batch ops that set up and start a move of one axis."""
    return [
        {"op": "write", **BAR, "offset": axis_reg(axis, AxisReg.TARGET), "data": u32(target)},
        {"op": "write", **BAR, "offset": axis_reg(axis, AxisReg.VMAX), "data": u32(vmax)},
        {"op": "write", **BAR, "offset": axis_reg(axis, AxisReg.ACC), "data": u32(acc)},
        {"op": "write", **BAR, "offset": axis_reg(axis, AxisReg.DEC), "data": u32(acc)},
        {"op": "write", **BAR, "offset": axis_reg(axis, AxisReg.COMMAND), "data": u32(command)},
    ]
