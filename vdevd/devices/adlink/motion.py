"""Single-axis motion of the kernel: PTP with its 10-command buffer and speed connections,
velocity moves, stops, synchronous start [M §4.4, §4.6, §4.9.5; spec adlink.md §2.7, §2.9,
§2.20].

Commands take user units; the motion core runs in pulses (user units x the unit factor,
PRA_POS_UNIT_FACTOR [M §4.2.2]). A profile is planned by `profile.py` and loaded into the core's
phase table, which evaluates it every cycle, vectorised. A segment that ends at a non-zero Ve
(a buffered PTP) hands over at its end time to the next queued one (`next_segment`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import (
    OPT_FORCE_ABORT,
    OPT_RELATIVE,
    OPT_WAIT,
    PTP_OPT_ABORTING,
    PTP_OPT_BLEND_HIGH,
    PTP_OPT_BLEND_LOW,
    PTP_OPT_BLEND_NEXT,
    PTP_OPT_BLEND_PREVIOUS,
    PTP_OPT_BUFFERED,
    STOP_ALM,
    STOP_EMG,
    STOP_MEL,
    STOP_PEL,
    STOP_SMEL,
    STOP_SPEL,
    STOP_USER,
    STOP_USER_EMG,
    ERR_CommandInProcess,
    ERR_DistantNotEnough,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink import profile
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.modes import HOME, IDLE, JOG, PTP, STOPPING, UNIT, VEL

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

QUEUE = 10  # commands in an axis's motion buffer [M §4.6.4]
_MODE_MASK = 0xF000
_FLAGS = OPT_RELATIVE | OPT_WAIT | OPT_FORCE_ABORT  # the option bits besides the mode [spec §3.6]
#: the longest move in pulses: the 32-bit position command range [M §1.1]
MAX_PULSES = 2**31 - 1
# axis parameters [spec §3.2]
SD_DEC, SF, ACC, DEC, VS, VM, VE = 0x07, 0x20, 0x21, 0x22, 0x23, 0x24, 0x25
PRE_DIST, POST_DIST, UNIT_FACTOR, MDM_CONDI, MDN_DELAY = 0x2A, 0x2B, 0x86, 0x03, 0x50


@dataclass(slots=True)
class Segment:
    """One PTP command: absolute target (user units), its profile (user units), its mode."""

    target: float
    vs: float
    vm: float
    ve: float
    acc: float
    dec: float
    sf: float
    mode: int


def profile_values(k: Kernel, a: int, vs: float, vm: float, ve: float, acc: float, dec: float,
                   sf: float) -> tuple[float, float, float, float, float, float]:
    """The command's profile: NaN takes the axis parameter; values out of range are -10."""
    out = []
    for value, no, lo, strict in ((vs, VS, 0.0, False), (vm, VM, 0.0, True), (ve, VE, 0.0, False),
                                  (acc, ACC, 0.0, True), (dec, DEC, 0.0, True),
                                  (sf, SF, 0.0, False)):
        v = float(k.p(no)[a]) if math.isnan(value) else float(value)
        if not math.isfinite(v) or v < lo or (strict and v <= lo) or (no == SF and v > 1):
            raise ApsError(ERR_ParametersInvalid, f"profile value {v} of parameter {no:#x}")
        out.append(v)
    vs_, vm_, ve_, acc_, dec_, sf_ = out
    vm_ = min(vm_, profile.VM_MAX_PPS / k.factor(a))  # 6.5 Mpps at most [M §3.1], Q7
    return vs_, vm_, ve_, acc_, dec_, sf_


def refused(k: Kernel, a: int, direction: float) -> bool:
    """EMG, ALM or a limit in the direction of travel: the command is ignored, the stop code
    and ASTP set, and the call returns 0 [M §4.10; spec Q15] (or the card's `refused_rc`).
    Motion away from an active limit, and a zero direction with a limit, are not refused."""
    code = None
    if k.emg:
        code = STOP_EMG
    elif k.alm[a]:
        code = STOP_ALM
    elif direction > 0 and k.pel[a]:
        code = STOP_PEL
    elif direction < 0 and k.mel[a]:
        code = STOP_MEL
    elif direction > 0 and k.spel[a]:
        code = STOP_SPEL
    elif direction < 0 and k.smel[a]:
        code = STOP_SMEL
    if code is None:
        return False
    k.stop_code[a] = code
    k.astp[a] = True
    k.mdn[a] = not k.moving()[a]
    k.refusal = True
    return True


def check_free(k: Kernel, a: int) -> None:
    """A jogging, homing or unit-driven axis takes no other motion command (-15) [M §4.5 NOTE]."""
    if k.mode[a] in (HOME, JOG, UNIT) or k.owned[a]:
        raise ApsError(ERR_CommandInProcess, f"axis {a} is busy")


# -- PTP ----------------------------------------------------------------------------------------

def ptp(k: Kernel, a: int, option: int, pos: float, vs: float, vm: float, ve: float, acc: float,
        dec: float, sf: float) -> None:
    """APS_ptp / _v / _all [M §4.6.1]: NaN profile values come from the axis parameters."""
    k.check_axis(a)
    if not math.isfinite(pos):
        raise ApsError(ERR_ParametersInvalid, "position must be finite")
    mode = option & _MODE_MASK
    if mode > PTP_OPT_BLEND_HIGH or option & ~(_MODE_MASK | _FLAGS):
        raise ApsError(ERR_ParametersInvalid, f"option {option:#x}")
    check_free(k, a)
    values = profile_values(k, a, vs, vm, ve, acc, dec, sf)
    busy = k.mode[a] in (PTP, VEL, STOPPING) and k.core.profile.moving[a]
    queued = busy and mode != PTP_OPT_ABORTING and k.mode[a] == PTP
    here = base = k.user_cmd_of(a)  # aborting: relative to the command position now
    if queued:  # buffered: to the end of the last queued segment
        base = k.queue[a][-1].target if k.queue[a] else float(k.target[a])
    target = base + pos if option & OPT_RELATIVE else pos
    if abs(k.to_counts(a, target) - k.to_counts(a, base)) > MAX_PULSES:
        raise ApsError(ERR_ParametersInvalid, "beyond the 32-bit position command [M §1.1]")
    seg = Segment(target, *values, mode)
    if queued:
        if len(k.queue[a]) + 1 >= QUEUE:
            raise ApsError(ERR_CommandInProcess, "the motion buffer is full")
        connect(k, a, seg)
        k.queue[a].append(seg)
        k.mq_usage[a] = len(k.queue[a]) + 1
        return
    if refused(k, a, target - here):
        return
    if option & OPT_WAIT:
        k.queue[a][:] = [seg]
        k.wait[a], k.mdn[a], k.astp[a] = True, False, False
        k.pending_start[a] = PTP
        return
    start_ptp(k, a, seg)


def connect(k: Kernel, a: int, seg: Segment) -> None:
    """A blended PTP joins the one before it at a junction speed [M §4.6.4; spec §2.9 table]:
    the previous segment's Ve becomes that speed (0 where the direction reverses)."""
    if seg.mode == PTP_OPT_BUFFERED:
        return
    prev = k.queue[a][-1] if k.queue[a] else None
    prev_target = prev.target if prev is not None else float(k.target[a])
    prev_vm = prev.vm if prev is not None else k.seg_vm[a]
    before = prev.target - (k.queue[a][-2].target if len(k.queue[a]) > 1 else float(k.target[a])) \
        if prev is not None else float(k.target[a]) - k.seg_from[a]
    after = seg.target - prev_target
    if before * after <= 0:
        speed = 0.0
    elif seg.mode == PTP_OPT_BLEND_LOW:
        speed = min(prev_vm, seg.vm)
    elif seg.mode == PTP_OPT_BLEND_PREVIOUS:
        speed = prev_vm
    elif seg.mode == PTP_OPT_BLEND_NEXT:
        speed = seg.vm
    else:
        speed = max(prev_vm, seg.vm)
    seg.vs = speed
    if prev is not None:
        prev.ve = speed
    else:  # the running segment: re-planned from where it is to the same target
        k.seg_ve[a] = speed
        replan_running(k, a)


def start_ptp(k: Kernel, a: int, seg: Segment) -> int:
    """Plan and load a PTP segment from the axis's commanded state now (on the fly when it
    moves [M §4.6.3]); 0 or -22 when Ve cannot be reached."""
    core = k.core
    f = k.factor(a)
    p, v, _ = core.profile.state(a)
    goal = k.to_counts(a, seg.target)
    dist = goal - p
    sign = 1.0 if dist > 0 or (dist == 0 and v >= 0) else -1.0
    moving = bool(core.profile.moving[a]) and v != 0
    if moving:
        plan = profile.plan_from(v * sign, abs(dist), seg.vm * f, seg.ve * f, seg.acc * f,
                                 seg.dec * f, seg.sf)
    else:
        plan = profile.plan_ptp(abs(dist), seg.vs * f, seg.vm * f, seg.ve * f, seg.acc * f,
                                seg.dec * f, seg.sf)
    t0 = core.profile.t
    hold = goal if seg.ve == 0 else None
    k.load(a, plan, p, sign, hold)
    core.profile.commit()
    begin(k, a, PTP, seg.target)
    k.seg_end[a] = t0 + plan.duration() if seg.ve > 0 else math.inf
    k.seg_vm[a], k.seg_ve[a], k.seg_from[a] = seg.vm, seg.ve, k.user_cmd_of(a)
    k.seg_plan[a] = seg
    events(k, a, plan, t0, f)
    k.mq_usage[a] = len(k.queue[a]) + 1
    return 0 if getattr(plan, "ve_reached", True) else ERR_DistantNotEnough


def replan_running(k: Kernel, a: int) -> None:
    """The running segment with a new Ve (a blend queued behind it)."""
    seg = k.seg_plan[a]
    if seg is None:
        return
    seg.ve = k.seg_ve[a]
    start_ptp(k, a, seg)


def events(k: Kernel, a: int, plan: profile.Plan, t0: float, f: float) -> None:
    """The pre- and post-distance events of a move [M §4.8.1 bits 18-19]."""
    pre, post = float(k.p(PRE_DIST)[a]) * f, float(k.p(POST_DIST)[a]) * f
    d = abs(plan.distance)
    k.pred[a] = k.postd[a] = False
    k.pred_at[a] = t0 + plan.time_at(pre) if 0 < pre <= d else math.inf
    k.postd_at[a] = t0 + plan.time_at(d - post) if 0 < post <= d else math.inf


def begin(k: Kernel, a: int, mode: int, target: float) -> None:
    """A motion starts: MDN, ASTP and WAIT cleared [M §4.8.1 bits 5, 10, 16]."""
    k.mode[a] = mode
    k.mdn[a] = False
    k.astp[a] = False
    k.wait[a] = False
    k.target[a] = target


def next_segment(k: Kernel, a: int) -> None:
    """The running segment reached its end (at its Ve): the next queued one takes over."""
    k.seg_end[a] = math.inf
    if not k.queue[a] or k.mode[a] != PTP:
        return
    seg = k.queue[a].pop(0)
    k.target[a] = seg.target
    start_ptp(k, a, seg)


def profile_ended(k: Kernel, a: int) -> None:
    """The core's profile of axis a ended (at rest)."""
    mode = int(k.mode[a])
    if mode == PTP and k.queue[a]:
        next_segment(k, a)
        return
    if mode in (HOME, JOG):
        step = k.sequences.get(a)
        if step is not None and step():
            return
    if k.p(MDM_CONDI)[a] and not k.inp[a] and mode != STOPPING:
        return  # MDN waits for INP (PRA_MDM_CONDI, spec §2.14 Q10)
    delay = int(k.p(MDN_DELAY)[a])
    if delay and mode != STOPPING:  # and PRA_MDN_DELAY cycles after the profile's end
        due = k.mdn_due.setdefault(a, k.cycles + delay)
        if k.cycles < due:
            return
    k.mdn_due.pop(a, None)
    k.mq_usage[a] = 0
    k.seg_plan[a] = None
    k.finish(a)


# -- velocity ------------------------------------------------------------------------------------

def vel(k: Kernel, a: int, option: int, vm: float, vs: float, ve: float, acc: float,
        dec: float, sf: float) -> None:
    """APS_vel / _vel_all [M §4.4]: run at Vm (its sign the direction, spec Q26) until a stop;
    a new Vm changes speed on the fly, through zero on reversal."""
    k.check_axis(a)
    if not math.isfinite(vm):
        raise ApsError(ERR_ParametersInvalid, "Vm must be finite")
    if option & ~_FLAGS:  # no buffer mode for a velocity move [M §4.9.5.1]
        raise ApsError(ERR_ParametersInvalid, f"option {option:#x}")
    check_free(k, a)
    vs_, _, _, acc_, dec_, sf_ = profile_values(k, a, vs, abs(vm) or math.nan, ve, acc, dec, sf)
    if refused(k, a, vm):
        return
    if option & OPT_WAIT:
        k.vel_pending[a] = (vm, vs_, acc_, dec_, sf_)
        k.queue[a].clear()
        k.wait[a], k.mdn[a], k.astp[a] = True, False, False
        k.pending_start[a] = VEL
        return
    start_vel(k, a, vm, vs_, acc_, dec_, sf_)


def start_vel(k: Kernel, a: int, vm: float, vs: float, acc: float, dec: float, sf: float) -> None:
    core, f = k.core, k.factor(a)
    p, v, _ = core.profile.state(a)
    moving = bool(core.profile.moving[a])
    v0 = v if moving else math.copysign(min(vs, abs(vm)), vm) * f
    plan = profile.plan_velocity(v0, vm * f, acc * f, dec * f, sf)
    k.load(a, plan, p, 1.0, None, endless=True)
    core.profile.commit()
    k.queue[a].clear()
    k.seg_end[a] = math.inf
    begin(k, a, VEL, k.user_cmd_of(a))
    k.pred_at[a] = k.postd_at[a] = math.inf
    k.mq_usage[a] = 1


def velocity_counts(k: Kernel, a: int, speed: float) -> None:
    """APS_velocity_move(Axis, Max_Speed): pulses/s, the axis's Acc/Dec/SF."""
    k.check_axis(a)
    vel(k, a, 0, speed / k.factor(a), math.nan, math.nan, math.nan, math.nan, math.nan)


def ptp_counts(k: Kernel, a: int, relative: int, counts: float, speed: float) -> None:
    """APS_relative_move / APS_absolute_move (I32: pulses and pulses/s, spec §2.9)."""
    k.check_axis(a)
    if not speed > 0:
        raise ApsError(ERR_ParametersInvalid, "Max_Speed must be positive")
    f = k.factor(a)
    pos = counts / f + (0.0 if relative else float(k.cmd_off[a]))
    ptp(k, a, OPT_RELATIVE if relative else 0, pos, math.nan, speed / f, math.nan, math.nan,
        math.nan, math.nan)


# -- stops and synchronous start ---------------------------------------------------------------

def _axes(k: Kernel, axes: list[int]) -> np.ndarray:
    if not axes or len(axes) > k.n:
        raise ApsError(ERR_ParametersInvalid, "no axes")
    for a in axes:
        k.check_axis(a)
    return np.array(sorted(set(axes)), dtype=np.intp)


def stop_move(k: Kernel, axes: list[int]) -> None:
    """APS_stop_move(_multi) [M §4.4, §4.6.1]: decelerate at PRA_SD_DEC (with the axis's
    S-factor), the queue cleared; ASTP 0 and stop code 9 (spec Q9). A waiting axis's command is
    cancelled."""
    idx = _axes(k, axes)
    k.stop_axes(idx, STOP_USER, immediate=False, astp=False)
    for a in idx.tolist():
        k.pending_start[a] = IDLE
        k.mq_usage[a] = 0


def emg_stop(k: Kernel, axes: list[int]) -> None:
    """APS_emg_stop(_multi): immediate stop, code 8 (spec Q9)."""
    idx = _axes(k, axes)
    k.stop_axes(idx, STOP_USER_EMG, immediate=True, astp=False)
    for a in idx.tolist():
        k.pending_start[a] = IDLE
        k.mq_usage[a] = 0


def move_trigger(k: Kernel, axes: list[int]) -> None:
    """APS_move_trigger [M §4.9.5.1]: the waiting axes among `axes` start in this cycle; the
    others are left alone."""
    idx = _axes(k, axes)
    for a in idx.tolist():
        if not k.wait[a]:
            continue
        kind = k.pending_start[a]
        k.wait[a] = False
        k.pending_start[a] = IDLE
        if kind == PTP and k.queue[a]:
            seg = k.queue[a].pop(0)
            if refused(k, a, seg.target - k.user_cmd_of(a)):
                continue
            start_ptp(k, a, seg)
        elif kind == VEL and k.vel_pending[a] is not None:
            vm, vs, acc, dec, sf = k.vel_pending[a]
            k.vel_pending[a] = None
            if not refused(k, a, vm):
                start_vel(k, a, vm, vs, acc, dec, sf)
        else:
            start = k.unit_starts.pop(a, None)  # a unit's command (interpolation) waiting
            if start is not None:
                start()
        if not k.moving()[a] and k.mode[a] == IDLE:
            k.mdn[a] = True
