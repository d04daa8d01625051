"""The single-axis moves the home and jog sequences are made of (spec adlink.md §2.6, §2.8):
a sequence starts, runs at a speed, goes to a position, decelerates or stops at once. Values
are in user units (the axis's unit factor turns them into the motion core's pulses) unless a
name says counts; every plan starts from the axis's commanded state now."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from vdevd.devices.adlink import motion, profile

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel


def begin(k: Kernel, a: int, mode: int) -> None:
    """A sequence takes the axis: MDN, ASTP, WAIT and the distance events cleared [M §4.8.1]."""
    motion.begin(k, a, mode, float(k.user_cmd()[a]))
    k.queue[a].clear()
    k.seg_end[a] = math.inf
    k.pred[a] = k.postd[a] = False
    k.pred_at[a] = k.postd_at[a] = math.inf
    k.mq_usage[a] = 1


def run_at(k: Kernel, a: int, v: float, vs: float, acc: float, dec: float, sf: float) -> None:
    """Run at the signed speed v (from rest: jump to vs first) until told otherwise."""
    core, f = k.core, k.factor(a)
    p, v0, _ = core.profile.state(a)
    if not core.profile.moving[a]:
        v0 = math.copysign(min(vs, abs(v)), v) * f
    plan = profile.plan_velocity(v0, v * f, acc * f, dec * f, sf)
    core.profile.load(a, profile.to_core_phases(plan, core.profile.t, p, 1.0, None), endless=True)
    core.profile.commit()


def go_to(k: Kernel, a: int, goal: float, vs: float, vm: float, acc: float, dec: float,
          sf: float) -> None:
    """Go to `goal` (counts, command coordinates) and stop there exactly; from a moving state
    on the fly [M §4.6.3]."""
    core, f = k.core, k.factor(a)
    p, v, _ = core.profile.state(a)
    dist = goal - p
    sign = 1.0 if dist > 0 or (dist == 0 and v >= 0) else -1.0
    if core.profile.moving[a] and v != 0:
        plan = profile.plan_from(v * sign, abs(dist), vm * f, 0.0, acc * f, dec * f, sf)
    else:
        plan = profile.plan_ptp(abs(dist), vs * f, vm * f, 0.0, acc * f, dec * f, sf)
    core.profile.load(a, profile.to_core_phases(plan, core.profile.t, p, sign, goal))
    core.profile.commit()


def stop_distance(k: Kernel, a: int, dec: float, sf: float) -> float:
    """How far (counts, >= 0) a deceleration with `dec` from the speed now runs on."""
    v = float(k.core.axes.cmd_vel[a])
    return abs(profile.plan_stop(abs(v), dec * k.factor(a), sf).distance)


def decelerate(k: Kernel, a: int, dec: float, sf: float) -> None:
    """Decelerate to rest with `dec` and S-factor sf."""
    k.stop_profile(a, dec, sf)
    k.core.profile.commit()


def halt(k: Kernel, a: int, d: int, counts: float | None = None) -> None:
    """Stop at once (a pulse card's output simply ends) and hold `counts` (command
    coordinates), or the whole pulse the command has reached moving in direction d."""
    core = k.core
    if counts is None:
        here = float(core.axes.cmd_pos[a])
        counts = math.ceil(here - 1e-9) if d > 0 else math.floor(here + 1e-9)
    core.profile.hold(a, counts)
    core.profile.commit()
