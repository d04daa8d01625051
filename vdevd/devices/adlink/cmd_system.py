"""Kernel commands of the system, parameters, positions and servo [M §4.1, §4.2.1, §4.1.1.4;
spec adlink.md §2.1-2.4, §3]."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import ERR_CommandInProcess, ERR_ParametersInvalid

from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.modes import IDLE
from vdevd.devices.adlink.params import BOARD_CYCLE

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

#: the largest user position a coordinate may be set to: beyond 2^53 an F64 no longer holds
#: whole pulses (the counters are 32-bit [M §1.1], user positions F64: spec Q20)
MAX_USER = 2.0**53

#: get_timing / reset_timing selectors: the LPSTS fields [M §4.1.2; spec Q1]
TIMING_MOTION, TIMING_HOST, TIMING_MOTION_MAX, TIMING_HOST_MAX, TIMING_OVER_COUNT = range(5)


def reset(k: Kernel) -> None:
    """The kernel's power-up state (parameters kept)."""
    k.power_up()


def set_board_param(k: Kernel, no: int, value: int) -> None:
    """APS_set_board_param [M §4.9.3.6; spec §3.1]."""
    if not k.board_params.check(no, float(value)):
        raise ApsError(ERR_ParametersInvalid, f"board parameter {no:#x} = {value}")
    if no == BOARD_CYCLE and value != k.cycle_us:
        if k.moving().any():
            raise ApsError(ERR_CommandInProcess, "the cycle changes only while no axis moves")
        k.new_cycle_us = int(value)
    k.board_params.values[no] = float(value)
    k.params_changed = True


def get_board_param(k: Kernel, no: int) -> int:
    if no not in k.board_params.values:
        raise ApsError(ERR_ParametersInvalid, f"board parameter {no:#x}")
    return int(k.board_params.values[no])


def _axis_param(k: Kernel, a: int, no: int, value: float) -> None:
    k.check_axis(a)
    if not k.axis_params.check(no, value):
        raise ApsError(ERR_ParametersInvalid, f"axis parameter {no:#x} = {value}")
    if no == 0x86 and k.moving()[a]:
        raise ApsError(ERR_CommandInProcess, "the unit factor changes only at rest")
    if no == 0x86:  # the user coordinate stays where it is (the offsets absorb the new factor)
        ax, old = k.core.axes, k.factor(a)
        k.cmd_off[a] += float(ax.cmd_pos[a]) * (1 / old - 1 / value)
        k.fb_off[a] += float(ax.fb[a]) * (1 / old - 1 / value)
    k.axis_params.set(a, no, value)
    k.params_changed = True


def set_axis_param(k: Kernel, a: int, no: int, value: int) -> None:
    """APS_set_axis_param [M §4.1.1.3]."""
    _axis_param(k, a, no, float(value))


def set_axis_param_f(k: Kernel, a: int, no: int, value: float) -> None:
    """APS_set_axis_param_f [M §4.4 example]."""
    _axis_param(k, a, no, float(value))


def _get(k: Kernel, a: int, no: int) -> float:
    k.check_axis(a)
    if not k.axis_params.known(no):
        raise ApsError(ERR_ParametersInvalid, f"axis parameter {no:#x}")
    return k.axis_params.get(a, no)


def get_axis_param(k: Kernel, a: int, no: int) -> int:
    v = _get(k, a, no)
    return int(max(min(v, 2**31 - 1), -(2**31))) if math.isfinite(v) else 2**31 - 1


def get_axis_param_f(k: Kernel, a: int, no: int) -> float:
    return _get(k, a, no)


def get_axis_param_table(k: Kernel, a: int) -> list[list[float] | list[int]]:
    """Every axis parameter of axis a: (numbers, values), for APS_save_param_to_file."""
    k.check_axis(a)
    p = k.axis_params
    return [list(p.numbers), p.values[:, a].tolist()]


def get_board_param_table(k: Kernel) -> list[list[float] | list[int]]:
    values = k.board_params.values
    return [list(values), list(values.values())]


def save_parameter_to_flash(k: Kernel) -> None:
    """APS_save_parameter_to_flash: the card writes the image atomically (card.py)."""
    k.flash = k.parameter_image()
    k.flash_dirty = True


def load_parameter_from_flash(k: Kernel) -> None:
    if k.moving().any():
        raise ApsError(ERR_CommandInProcess, "parameters load only while no axis moves")
    if k.flash is not None:
        k.restore_parameters(k.flash)
        k.board_params.values[BOARD_CYCLE] = float(k.cycle_us)  # the cycle the card runs


def load_parameter_from_default(k: Kernel) -> None:
    if k.moving().any():
        raise ApsError(ERR_CommandInProcess, "parameters load only while no axis moves")
    k.axis_params.defaults()
    k.board_params.defaults()
    k.board_params.values[BOARD_CYCLE] = float(k.cycle_us)


def get_timing(k: Kernel, which: int) -> int:
    """The CPU-load figures of M §4.1.2 (0.01 % of the cycle) and the over-cycle count."""
    if not 0 <= which <= TIMING_OVER_COUNT:
        raise ApsError(ERR_ParametersInvalid, f"timing selector {which}")
    return int(k.timing[which])


def reset_timing(k: Kernel, which: int) -> None:
    """Reset the maximum (2, 3) or the over-cycle count (4)."""
    if which not in (TIMING_MOTION_MAX, TIMING_HOST_MAX, TIMING_OVER_COUNT):
        raise ApsError(ERR_ParametersInvalid, f"timing selector {which}")
    k.timing[which] = 0


def set_servo_on(k: Kernel, a: int, on: int) -> None:
    """APS_set_servo_on [M §4.1.1.4]: SVON; off stops a moving axis at once (code 3)."""
    k.check_axis(a)
    if on not in (0, 1):
        raise ApsError(ERR_ParametersInvalid, f"Servo_On {on}")
    k.servo(np.array([a]), bool(on))


def _idle(k: Kernel, a: int) -> None:
    k.check_axis(a)
    if k.mode[a] != IDLE or k.moving()[a]:
        raise ApsError(ERR_CommandInProcess, f"axis {a} moves (spec Q29)")


def set_command_f(k: Kernel, a: int, value: float) -> None:
    """APS_set_command_f [M §4.2.1]: the command position redefined, no motion, the raw
    counters untouched (spec §2.3); only at rest (spec Q29)."""
    if not math.isfinite(value) or abs(value) > MAX_USER:
        raise ApsError(ERR_ParametersInvalid, "position must be finite")
    _idle(k, a)
    k.cmd_off[a] = value - float(k.core.axes.cmd_pos[a]) / k.factor(a)
    k.target[a] = value


def set_position_f(k: Kernel, a: int, value: float) -> None:
    """APS_set_position_f [M §4.2.1]: the feedback position redefined."""
    if not math.isfinite(value) or abs(value) > MAX_USER:
        raise ApsError(ERR_ParametersInvalid, "position must be finite")
    k.check_axis(a)
    k.fb_off[a] = value - float(k.core.axes.fb[a]) / k.factor(a)
