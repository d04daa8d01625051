"""Simple-motion RTCs [Ch5 "Simple Motion"; spec §4.3, §5.3]: the AXMOVE family, DDAC, STOP and
VELMODE, on the shared motion core. Units: the RTC's raw words converted once here (acc 1.15
counts/sample^2, velocity 16.16 counts/sample, positions counts, times in samples).

Conflicts (Ch7 Table 7-1): an AXMOVE/REL_AXMOVE/VELMODE naming an axis that contours, or a START
naming one in AXMOVE/VELMODE motion, is discarded whole with "conflicting commands" (000h b6,
007h); one naming an axis halting under STOP or *ESTOP is discarded with "RTC ignored" (000h b7,
008h) [Ch5 STOP Note]. The _S and _T variants are treated as AXMOVE/REL_AXMOVE (spec §4.3).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import acc_from_raw, vel_from_raw

from vdevd.devices.octavia.state import CONTOURING, Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

Groups = list[tuple[int, dict[str, Any]]]
TS = 200e-6
_MOVE = int(Mode.MOVE)
VMAX = 0xFFFFFF / 65536.0  # counts/sample: "maximum unsigned velocity 00FFFFFFh" [Ch5 AXMOVE]


def move_time_velocity(acc: float, dist: float, samples: float) -> float:
    """The slew velocity of a trapezoid covering `dist` counts in `samples` at `acc`
    (counts/sample^2): V = (A*T - sqrt((A*T)^2 - 4*A*D)) / 2 [Ch5 AXMOVE_T; spec §5.3]; when no
    trapezoid fits (the manual's own AXMOVE_T example), the triangle at `acc`, which takes
    longer (spec Q-19)."""
    at = acc * samples
    disc = at * at - 4 * acc * dist
    if disc < 0 or samples <= 0:
        return math.sqrt(acc * dist)
    return (at - math.sqrt(disc)) / 2


def axmove(relative: str, shape: str, fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """AXMOVE, AXMOVE_S, AXMOVE_T and their REL_ forms: per axis acc, position (absolute, or
    relative to the present command position), and the slew velocity (or the move time)
    [Ch5 AXMOVE ... REL_AXMOVE_T]. The axes start together; each ends on its own. A move of an
    axis already moving re-targets from its present state (Example 3). Zero acceleration, or a
    zero slew velocity, leaves that axis where it is."""
    todo, axes, n = [], [], fw.n  # `axes_of` and its axes, in one loop (every AXMOVE)
    for a, g in groups:
        if a <= n:
            todo.append((a - 1, g))
            axes.append(a - 1)
    if not todo or fw.discarded(axes, CONTOURING):
        return
    core = fw.core
    cmd_pos, mode, prev = core.axes.cmd_pos, fw.mode, fw._prev_flags
    for a, g in todo:
        acc = acc_from_raw(g["acc"])
        if relative == "rel" or shape == "timed":  # (an AXMOVE needs no present position)
            here = _rint(float(cmd_pos[a]))
            target = here + g["pos"] if relative == "rel" else float(g["pos"])
        else:
            target = float(g["pos"])
        if shape == "timed":
            vel = min(move_time_velocity(acc, abs(target - here), float(g["tm"])), VMAX)
        else:
            vel = abs(vel_from_raw(g["vel"]))
        if acc <= 0 or vel <= 0:
            continue
        if fw.any_open:
            fw.close_loop([a])
        a_s, v_s = acc / (TS * TS), vel / TS
        if shape == "s_curve":  # triangular acceleration pulses peaking at 2*acc [Ch5 AXMOVE_S]
            core.move_one(a, target, v_s, 2 * a_s, 2 * a_s, 4 * a_s * a_s / v_s, commit=False)
        else:
            core.move_one(a, target, v_s, a_s, a_s, commit=False)
        mode[a] = _MOVE
        prev[a] = 0
    core.profile.commit()


def _rint(x: float) -> float:
    """`float(np.rint(x))` of a float, without numpy's scalar machinery: `round` rounds half to
    even too (and is exact: a float beyond 2^52 is already whole)."""
    return float(round(x)) if math.isfinite(x) else x


def ddac(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Open loop: the DAC outputs `val` (int16, 7FFFh = +10 V) [Ch5 DDAC]; the command position
    follows the actual one (the core's servo off), so AXMOVE or VELMODE closes the loop again
    without a jump (README assumption). TRQ_LIMIT still applies (spec §5.2)."""
    for a, g in fw.axes_of(groups):
        if fw.mode[a] != Mode.OPEN:
            fw.core.servo_off(a)
        limit = int(fw.params.trq_limit[a])
        low = -0x8000 if limit >= 0x7FFF else -limit  # 8000h = -10 V at full swing
        fw.open_dac[a] = float(min(max(int(g["val"]), low), limit))
        fw.mode[a] = Mode.OPEN
    fw.any_open = bool((fw.mode == Mode.OPEN).any())


def stop(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Decelerate the axes at MAXACC and abort their command [Ch5 STOP]: ignored for an axis
    whose MAXACC is 0 (Note 2). A contouring axis leaves the ring as it is (the host clears
    it); completion is "motion complete"."""
    axes = [a for a in fw.mask(head["n"]) if fw.params.maxacc[a] > 0]
    if axes:
        halt(fw, np.array(axes), estop=False)


def halt(fw: Firmware, axes: np.ndarray, estop: bool) -> None:
    """Bring `axes` to rest: at MAXACC (STOP), or at ESTOP_ACC (*ESTOP, EN_ERRHLT), falling back
    to MAXACC, then at once (spec §5.3 ESTOP). Open-loop axes are left alone."""
    p, core = fw.params, fw.core
    axes = np.asarray(axes, dtype=np.int64)
    if fw.nurbs_axes and set(axes.tolist()) & set(fw.nurbs_axes):
        keep = [a for a in fw.nurbs_axes if a not in set(axes.tolist())]
        fw.nurbs.stop()  # the curve ends here: the axes stopped decelerate below, the others hold
        fw.nurbs_axes = []
        if keep:
            core.hold(keep)
            fw.mode[keep] = Mode.HOLD
    for a in axes.tolist():
        if fw.mode[a] == Mode.OPEN:
            continue
        raw = p.estop_acc[a] if estop and p.estop_acc[a] else p.maxacc[a]
        moving = bool(core.profile.moving[a])
        if raw > 0 and moving:
            core.stop(a, acc_from_raw(int(raw)) / (TS * TS))
            fw.mode[a] = Mode.ESTOP if estop else Mode.STOP
            fw._prev_flags[a] = 0
        else:
            core.abort(a)
            fw.mode[a] = Mode.HOLD


def velmode(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Run at a signed velocity (16.16), ramping at MAXACC, the position loop closed [Ch5
    VELMODE]; ignored while MAXACC is 0 (Note); velocity 0 ends the mode (motion complete when
    the axis stops, spec §5.3)."""
    todo = [(a, g) for a, g in fw.axes_of(groups) if fw.params.maxacc[a] > 0]
    if not todo or fw.discarded([a for a, _ in todo], CONTOURING):
        return
    core = fw.core
    for a, g in todo:
        vel = vel_from_raw(g["vel"])
        acc = acc_from_raw(int(fw.params.maxacc[a])) / (TS * TS)
        fw.close_loop([a])
        core.jog(a, vel / TS, acc, acc)
        fw.mode[a] = Mode.VELMODE
        fw._prev_flags[a] = 0
