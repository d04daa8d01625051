"""Control law and initialization RTCs [Ch5 "Control Law and Initialization"; spec §4.3]: each
handler takes (firmware, head fields, per-axis groups) as vdevmaps.octavia decodes them."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import RESET_ARGS

from vdevd.devices.octavia.state import Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

Groups = list[tuple[int, dict[str, Any]]]


def _per_axis(fw: Firmware, groups: Groups, field: str, target: np.ndarray,
              lo: int = 0, hi: int = 0xFFFF) -> list[int]:
    """Store one field per axis into `target`, values clamped to lo..hi; the axes set."""
    axes = []
    for a, g in fw.axes_of(groups):
        target[a] = min(max(int(g[field]), lo), hi)
        axes.append(a)
    return axes


def ctrl(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Ki, Kp, Kf, Kd per axis (16-bit, positive) [Ch5 CTRL]."""
    p = fw.params
    for a, g in fw.axes_of(groups):
        p.ki[a], p.kp[a], p.kf[a], p.kd[a] = g["ki"], g["kp"], g["kf"], g["kd"]
    fw.apply_gains()


def ctrl_ka(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The acceleration feed-forward gain [Ch5 CTRL_KA]."""
    _per_axis(fw, groups, "ka", fw.params.ka)
    fw.apply_gains()


def kilimit(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The integral channel's limit, 10 V / 2^val, val 0..14 [Ch5 KILIMIT]: a larger value is
    taken as 14."""
    _per_axis(fw, groups, "val", fw.params.kilimit, 0, 14)
    fw.apply_gains()


def outgain(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The output loop gain 2^m, m 0..4 [Ch5 OUTGAIN]: a larger m is taken as 4."""
    _per_axis(fw, groups, "m", fw.params.outgain, 0, 4)
    fw.apply_gains()


def trq_limit(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The output (torque) limit, 0..7FFFh = 0..+-10 V [Ch5 TRQ_LIMIT]: larger is 7FFFh."""
    _per_axis(fw, groups, "val", fw.params.trq_limit, 0, 0x7FFF)
    fw.apply_gains()


def maxacc(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The acceleration of STOP, VELMODE, cam/gear slaves and *_OFF_ACC [Ch5 MAXACC]; "MAXACC
    will be ignored if the specified argument is zero" (per axis)."""
    for a, g in fw.axes_of(groups):
        if g["acc"]:
            fw.params.maxacc[a] = g["acc"]


def estop_acc(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The deceleration of *ESTOP and EN_ERRHLT halts [Ch5 ESTOP_ACC]; ignored when zero."""
    for a, g in fw.axes_of(groups):
        if g["acc"]:
            fw.params.estop_acc[a] = g["acc"]


def pos_preset(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Define the present position of the axes: command = actual = pset, following error 0;
    disables their position breakpoint [Ch5 POS_PRESET; spec Q-33]."""
    for a, g in fw.axes_of(groups):
        fw.core.set_position(a, int(g["pset"]))
        fw.params.posbrk_on[a] = False
        if fw.mode[a] != Mode.OPEN:  # an open loop stays open (DDAC)
            fw.mode[a] = Mode.HOLD


def pos_shift(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Add psft to the axes' position counters, command and actual alike, "without losing
    position integrity" (the following error is kept); disables their position breakpoint
    [Ch5 POS_SHIFT]."""
    for a, g in fw.axes_of(groups):
        fw.core.shift_position(a, int(g["psft"]))
        fw.contour.redefined(a, int(g["psft"]))  # a contouring axis's path moves with it
        fw.cubic.redefined(a, int(g["psft"]))
        fw.params.posbrk_on[a] = False


def reset(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """RESET, with the two signature bytes AAh AAh; other bytes: ignored (spec §2.5.2)."""
    if bytes((head["sig1"], head["sig2"])) == RESET_ARGS:
        fw.reset()
    else:
        fw.buf[0x3C2] = 0


def sync(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Master (0) or slave (not 0) of the J5 sync chain [Ch5 SYNC]."""
    fw.params.slave = head["m"] != 0


def override(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The feed-rate override 16.16, 0.125..10.0 [Ch5 OVERRIDE]: stored (it scales DSPL's
    interpolated moves, which vdevd does not run); out of range: clamped."""
    fw.params.override = min(max(int(head["val"]), 0x2000), 0xA0000)


def stepper_on(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The axes driven by the Stp4 stepper add-on [Ch5 STEPPER_ON]: stored (the option is not
    emulated, README)."""
    fw.params.stepper_on = head["n"] & 0xFF
