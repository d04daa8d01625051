"""Electronic gearing and gantry pairs of the kernel [M §4.9.1; spec adlink.md §2.15].

Each cycle a geared slave's command moves by `r(t) x (the master's command move)`, both in the
user units of their own axes (spec §2.15 ASSUMPTION); r(t) ramps toward PRA_GEAR_RATIO at
PRA_GEAR_ENGAGE_RATE per second, on engagement and on every ratio change (Fig 4-52:
engage time = ratio / rate). A gantry pair is 1:1 with no ramp.

How the slave moves: the slave keeps its own profile in the motion core (its own PTP or
velocity move, or rest) and the gear's share is added to it by shifting that profile
(`ProfileGenerator.shift`) before the core's tick, so the drive follows the sum in the same
tick and a standard slave's own motion is superposed for free (spec Q13). The master's command
at the end of the coming tick is read from its phases (`master_at`), so master and slave are
commanded in the same cycle (a gantry's feedbacks do not drift apart by a cycle of motion).
The gear's share of the slave's velocity is `Kernel.gear_vel`, which the status words, the
limit checks and the velocity readback add to the profile's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import (
    GEAR_DISABLE,
    GEAR_GANTRY,
    GEAR_STANDARD,
    PRA_GANTRY_PROTECT_1,
    PRA_GANTRY_PROTECT_2,
    PRA_GEAR_ENGAGE_RATE,
    PRA_GEAR_MASTER,
    PRA_GEAR_RATIO,
    STOP_GAN_L1,
    STOP_GAN_L2,
    STOP_SVNO,
    STOP_USER,
    STOP_USER_EMG,
    ERR_CommandInProcess,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink import motion
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.modes import HOME, JOG, STOPPING, UNIT
from vdevd.rt.profiles import INF, Phase

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

_EPS = 1e-9  # counts/s: a gear velocity change below this is "constant" (the VM bit)


class GearUnit:
    """The gear and gantry relations of one card, by slave axis."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.master = np.full(k.n, -1, dtype=np.intp)  # the engaged master of each slave
        self.ratio = np.zeros(k.n)  # r(t), the effective ratio now
        self.speed = np.zeros(k.n)  # |gear velocity| of the last cycle (counts/s): its phase

    def reset(self) -> None:
        """Power-up: nothing engaged (the kernel's arrays are new)."""
        self.master[:] = -1
        self.ratio[:] = 0.0
        self.speed[:] = 0.0
        self.k.gear_status[:] = GEAR_DISABLE
        self.k.ger[:] = False
        self.k.gear_vel[:] = 0.0

    def busy(self) -> bool:
        return bool(self.k.gear_status.any())

    # -- engagement ---------------------------------------------------------------------------
    def engage(self, s: int, mode: int) -> None:
        """APS_start_gear(slave, 1 or 2): the master from PRA_GEAR_MASTER of the slave."""
        k = self.k
        m = int(k.p(PRA_GEAR_MASTER)[s])
        if not 0 <= m < k.n or m == s:
            raise ApsError(ERR_ParametersInvalid, f"PRA_GEAR_MASTER {m} of slave {s}")
        engaged = k.gear_status != GEAR_DISABLE
        if engaged[m] or (engaged & (self.master == s)).any():
            # no chains: the master is a slave, or the slave is somebody's master
            raise ApsError(ERR_ParametersInvalid, f"axis {m} or {s} is in a gear already")
        if k.gear_status[s]:
            if k.gear_status[s] == mode and self.master[s] == m:
                return  # engaged already: nothing to do
            raise ApsError(ERR_CommandInProcess, f"slave {s} is geared: release it first")
        if k.mode[s] in (HOME, JOG, UNIT) or k.owned[s]:
            raise ApsError(ERR_CommandInProcess, f"slave {s} is busy")
        if mode == GEAR_GANTRY and k.moving()[s]:
            raise ApsError(ERR_CommandInProcess, f"slave {s} moves: a gantry slave is only led")
        if motion.refused(k, s, 0.0):  # EMG or ALM of the slave [M §4.10]
            return
        self.master[s] = m
        self.ratio[s] = 1.0 if mode == GEAR_GANTRY else 0.0
        self.speed[s] = 0.0
        k.gear_status[s] = mode
        k.ger[s] = True
        if mode == GEAR_GANTRY:
            k.owned[s] = True  # its own commands are -15 (spec §2.15 ASSUMPTION)

    def release(self, s: int, handover: bool = False) -> None:
        """The slave stops following. `handover`: it keeps the gear's velocity as a profile of
        its own, for the stop that follows to bring it to rest (a deceleration stop)."""
        k = self.k
        if not k.gear_status[s]:
            return
        if handover and k.gear_vel[s] != 0:
            prof = k.core.profile
            v = float(k.core.axes.cmd_vel[s] + k.gear_vel[s])
            prof.load(s, [Phase(prof.t, INF, float(k.core.axes.cmd_pos[s]), v, 0.0, 0.0)],
                      endless=True)
            prof.commit()
            k.mdn[s] = False
        if k.gear_status[s] == GEAR_GANTRY:
            k.owned[s] = False
        k.gear_status[s] = GEAR_DISABLE
        k.ger[s] = False
        k.gear_vel[s] = 0.0
        k.unit_moving[s] = False
        k.phase[s] = 0
        self.master[s] = -1
        self.ratio[s] = 0.0
        self.speed[s] = 0.0

    # -- the kernel's hooks -------------------------------------------------------------------
    def stop_axis(self, a: int, code: int, immediate: bool) -> None:
        """A stop of axis a [M §4.9.1]: a standard slave is released (it then stops from the
        gear's velocity, at once or at its PRA_SD_DEC); a stop of a gantry slave stops its
        master too, with the same code (the pair stays engaged)."""
        k = self.k
        status = k.gear_status[a]
        if status == GEAR_STANDARD:
            self.release(a, handover=True)
        elif status == GEAR_GANTRY:
            m = int(self.master[a])
            if not k.moving()[m] or (k.mode[m] == STOPPING and not immediate):
                return
            astp = code not in (STOP_USER, STOP_USER_EMG)
            k.stop_axes(np.array([m]), code, immediate=immediate, astp=astp)

    def servo_off(self, idx: np.ndarray) -> None:
        """APS_set_servo_on(slave, 0) releases a standard slave and stops a gantry pair
        [M §4.9.1], moving or not."""
        k = self.k
        for a in idx.tolist():
            if k.gear_status[a] and not k.moving()[a]:
                self.stop_axis(a, STOP_SVNO, immediate=True)

    # -- the cycle ----------------------------------------------------------------------------
    def before_motion(self, t: float) -> None:
        k = self.k
        slaves = np.flatnonzero(k.gear_status)
        if not len(slaves):
            return
        core = k.core
        prof = core.profile
        f = k.axis_params.row(0x86)
        for s in slaves.tolist():
            standard = k.gear_status[s] == GEAR_STANDARD
            if standard and (k.emg or k.alm[s]):  # released by EMG/ALM of the slave [M §4.9.1.1]
                self.release(s)
                continue
            m = int(self.master[s])
            if standard:
                target = float(k.p(PRA_GEAR_RATIO)[s])
                step = float(k.p(PRA_GEAR_ENGAGE_RATE)[s]) * k.dt
                r = self.ratio[s]
                self.ratio[s] = r + min(max(target - r, -step), step)
            dm = master_at(k, m, t) - float(core.axes.cmd_pos[m])
            d = float(self.ratio[s]) * dm / float(f[m]) * float(f[s])
            if d:
                prof.shift(s, d)
            v = d / k.dt
            self.phase(s, v)
            k.gear_vel[s] = v
        self.protect()

    def phase(self, s: int, v: float) -> None:
        """CSTP/ACC/VM/DEC of a slave the gear moves: the gear's speed rising, steady or
        falling (when it has a motion of its own too, the kernel derives them)."""
        k = self.k
        speed, before = abs(v), self.speed[s]
        self.speed[s] = speed
        k.unit_moving[s] = speed > 0
        if speed == 0 or k.core.profile.moving[s]:
            k.phase[s] = 0
        elif speed > before + _EPS:
            k.phase[s] = 1
        elif speed < before - _EPS:
            k.phase[s] = 3
        else:
            k.phase[s] = 2

    def protect(self) -> None:
        """Gantry protection on |fbk_master - fbk_slave| (user units) [M §4.9.1.2; X5]: above
        PRA_GANTRY_PROTECT_2 both servos off (code 11); above PRA_GANTRY_PROTECT_1 both stop
        at their PRA_SD_DEC (code 10). 0 turns a level off."""
        k = self.k
        gantry = np.flatnonzero(k.gear_status == GEAR_GANTRY)
        if not len(gantry):
            return
        fbk = k.user_fbk()
        l1, l2 = k.p(PRA_GANTRY_PROTECT_1), k.p(PRA_GANTRY_PROTECT_2)
        for s in gantry.tolist():
            m = int(self.master[s])
            err = abs(float(fbk[m] - fbk[s]))
            pair = np.array([m, s])
            if 0 < l2[s] < err and k.svon[pair].any():
                k.abnormal(pair, STOP_GAN_L2, immediate=True)
                k.svon[pair] = False
                k.follow_drive()
            elif 0 < l1[s] < err and k.moving()[m] and k.mode[m] != STOPPING:
                k.abnormal(pair, STOP_GAN_L1, immediate=False)

    def after_motion(self, t: float) -> None:
        pass


def master_at(k: Kernel, a: int, t: float) -> float:
    """Axis a's commanded position (counts) at time t from its profile's phases: where the
    coming tick will put it."""
    prof = k.core.profile
    if t < prof.t_end[a]:
        tau = t - float(prof.t0[a])
        p0, v0, a0, j = (float(x[a]) for x in (prof.p0, prof.v0, prof.a0, prof.j))
    else:
        c = int(prof.k[a]) + 1
        while prof.pend[a, c] <= t:
            c += 1
        tau = t - float(prof.pt0[a, c])
        p0, v0, a0, j = (float(x[a, c]) for x in (prof.pp0, prof.pv0, prof.pa0, prof.pj))
    return p0 + tau * (v0 + tau * (a0 / 2 + tau * j / 6))


def start_gear(k: Kernel, s: int, mode: int) -> None:
    """APS_start_gear(Axis_ID /*slave*/, Mode) [M §4.9.1; X1, X5]: 0 release, 1 standard,
    2 gantry."""
    k.check_axis(s)
    unit = next(u for u in k.units if isinstance(u, GearUnit))
    if mode == GEAR_DISABLE:
        unit.release(s)
    elif mode in (GEAR_STANDARD, GEAR_GANTRY):
        unit.engage(s, mode)
    else:
        raise ApsError(ERR_ParametersInvalid, f"gear mode {mode}")
