"""The motors of one Turbo PMAC card over the shared motion core [spec pmac.md §2.6, §2.7, §1.5].

Units. The core works in encoder counts and seconds; the I-variables are in counts/ms (Ixx16,
Ixx22, Ixx23), counts/ms^2 (Ixx15, Ixx19), ms (Ixx20, Ixx21) and 1/16 count (Ixx11, Ixx12, Ixx26,
Ixx28), converted here. The core's position is the raw (unwrapped) encoder count since power-up;
the *motor* position is that minus the home origin, which the home search (homing.py) sets to the
captured trigger + Ixx26/16 (EncoderPos = MotorPos + HomeCapture + Ixx26/16 [A L900-914]), so
homing never renumbers the encoder.

Servo loop [§2.7, PMAC1-UM p.108]: with K = Ixx30 * 2^-19 (16-bit DAC units),
    DAC = K * (Ixx08 * (FE + (Ixx32*CV + Ixx35*CA)/128 + Ixx33*IE/2^23) - Ixx09*Ixx31*AV/128)
(CV, CA, AV per servo cycle). The derivative acts on the actual velocity AV = CV - (FE - FE_prev),
so it maps onto the core's PID (derivative on the error) as kd = K*Ixx09*Ixx31/128 and a velocity
feed-forward reduced by kd. Output clamped to Ixx69, integrator held while the output saturates
or (Ixx34 = 1) while the commanded velocity is not zero (the core's `Pid.set_hold`).

Plant (servo): a torque-mode amplifier and an almost frictionless motor (`PLANT_AMP_GAIN`,
`PLANT_VISCOUS`), chosen so the factory gains (Ixx30 2000, Ixx31 = Ixx32 1280, Ixx33 0) close the
loop at about 50 Hz, well damped; a 32 counts/ms jog then follows within a few counts. "ideal":
the actual position is the commanded one.
"""

from __future__ import annotations

import math

import numpy as np

from vdevd.devices.pmac.homing import Found, HomeAction, HomeSearch, Jog, TriggerAction
from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.jog_profile import jog_accel, jog_speed
from vdevd.devices.pmac.motor_reports import DAC_FULL_SCALE, IXX24_LIMITS_OFF, MotorReports
from vdevd.rt import AxisFlag, MotionCore, PlantKind
from vdevd.rt.axes import MOTION_STICKY

#: servo plant: counts/s^2 per DAC unit (full scale ~ 8.9e9 counts/s^2) and viscous damping 1/s
PLANT_AMP_GAIN = 2.7e5
PLANT_VISCOUS = 10.0

# Ixx24 flag-mode bits [A L1811-1877] (bit 17, limits off: motor_reports.py)
IXX24_AMP_FAULT_OFF = 1 << 20
IXX24_ACTION_SHIFT = 21

ERR_PHASE_CLOCK = 18  # ERR018: enabling refused with the phase-clock error bit set [A L3320]

_FE_TRIP = int(AxisFlag.FE_TRIP)
_STOPPED = int(AxisFlag.STOPPED_BY_LIMIT)


class MotorError(Exception):
    """A command refused with a PMAC error number (`code`, e.g. 18 = ERR018)."""

    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(f"ERR{code:03d}" + (f": {message}" if message else ""))
        self.code = code


class Motors:
    """The motors of one card: closed/open loop, jog, home, limits, following error; what they
    report (positions, registers, status words) is the read-only view `reports` (motor_reports.py).

    Motor index m is 0-based. Commands plan at command time; `tick()` is vectorised over motors
    (per-motor Python only at the servo cycle a trigger or fault happens).
    """

    def __init__(self, ivars: IVars, period_ns: float, plant: str = "servo") -> None:
        if plant not in ("servo", "ideal"):
            raise ValueError(f"plant must be 'servo' or 'ideal', not {plant!r}")
        self.ivars = ivars
        self.n = n = ivars.motors
        self.period_ms = period_ns / 1e6
        kind = PlantKind.SERVO if plant == "servo" else PlantKind.IDEAL
        self.core = MotionCore(n, period_ns, kind)
        self.pid = self.core.pid
        self.pid.set_hold(saturated=True)  # [§2.7]: never integrates while saturated at Ixx69
        self.core.plant.set(slice(None), amp_gain=PLANT_AMP_GAIN, viscous=PLANT_VISCOUS)
        self._ix = 100 * np.arange(1, n + 1)  # I-variable number of Ixx00 per motor
        #: Mxx72 variable jog position/distance, counts (J=* J:* J^*)
        self.jog_register = np.zeros(n)
        #: coordinate system (1-16, 0 none) and axis definition code, set by the card [§2.6]
        self.cs = np.zeros(n, dtype=np.int64)
        self.axis_code = np.zeros(n, dtype=np.int64)
        # raw flag inputs (1 = the input reads 1): limits read 0 when clear [A L1847]
        self.plim = np.zeros(n, dtype=bool)
        self.mlim = np.zeros(n, dtype=bool)
        self.hmfl = np.zeros(n, dtype=bool)
        self.amp_fault_in = np.zeros(n, dtype=bool)  # the amplifier reports a fault (logical)
        self.user = np.zeros(n, dtype=bool)  # USERn: the registration probe (card.py)
        self.phase_clock_error = False
        self.homing = HomeSearch(self)  # HM, HMZ, the capture registers and index pulses
        self.reports = MotorReports(self)  # P, V, F, ?, the registers: read-only
        self._alloc_state()
        self._apply()
        self.reset()

    def _alloc_state(self) -> None:
        n = self.n
        self.origin = np.zeros(n)  # core counts of motor position 0
        self.amp_enabled = np.zeros(n, dtype=bool)
        self.open_out = np.zeros(n)  # O{c}: DAC output of open-loop enabled motors
        self.homing.clear()
        self.timed = np.zeros(n, dtype=bool)  # a move with a defined end (move timer)
        self.abort_decel = np.zeros(n, dtype=bool)
        self.dwell = np.zeros(n, dtype=bool)  # word 1 bit 15: its C.S. program dwells
        self.fatal_error = np.zeros(n, dtype=bool)
        self.amp_error = np.zeros(n, dtype=bool)
        self.prejog = np.zeros(n)  # motor position before the last jog (J=)
        self.limit_bits = np.zeros(n, dtype=np.int64)  # word-1 bits 21/22 frozen while killed
        self._soft_hi_hit = np.zeros(n, dtype=bool)
        self._soft_lo_hit = np.zeros(n, dtype=bool)
        self.inpos_scans = np.zeros(n, dtype=np.int64)
        #: I60's velocity buffer: the feedback at each of the last 17 sample times (the newest at
        #: `_vslot`, the one 16 samples before it next to it); `filtered_velocity` is their
        #: difference, computed when read
        self._vbuf = np.zeros((17, n))
        self._vdiv = 16.0
        self._vslot = 0
        self._vcount = 0
        self._any_open = False

    # -- I-variables -------------------------------------------------------------------------------
    def _iv(self, yy: int) -> np.ndarray:
        return self.ivars.values[self._ix + yy]

    def on_ivar(self, n: int) -> None:
        """An I-variable changed: refresh what is derived from it (motor Ixx, I13, I60, I7mnx)."""
        if n in (13, 60) or 100 <= n < 100 * (self.n + 1) or 7000 <= n < 8000:
            self._apply()

    def _apply(self) -> None:
        """Gains, limits, flags and modes from the I-variables [§2.2, §2.7, §1.5]."""
        core = self.core
        k = self._iv(30) * 2.0**-19  # gains per servo cycle, 16-bit DAC units
        i08, i09 = self._iv(8), self._iv(9)
        kp = k * i08
        kd = k * i09 * self._iv(31) / 128
        vff = k * i08 * self._iv(32) / 128
        aff = k * i08 * self._iv(35) / 128
        ki = k * i08 * self._iv(33) / 2**23
        dt = core.dt
        # Ixx63 limits the integrator register IPOS = Ixx33*Ixx08*32*2^-23 * sum(FE) [UM p.179]
        scale = self._iv(33) * i08 * 32 / 2**23
        il = np.divide(np.abs(self._iv(63)), np.abs(scale), out=np.full(self.n, np.inf),
                       where=scale != 0)
        self.out_limit = np.minimum(self._iv(69), DAC_FULL_SCALE)
        self.pid.set(slice(None), kp=kp, kd=kd, ki=ki, il=il, vff=(vff - kd) * dt,
                     aff=aff * dt * dt, offset=self._iv(29), out_limit=self.out_limit)
        self.pid.set_hold(moving=self._iv(34) == 1)
        self.friction = self._iv(68)
        self._any_friction = bool(self.friction.any())
        core.set_fe_limit(slice(None), self._iv(11) / 16)
        ix15 = self._iv(15) * 1e6
        core.limits.limit_dec[:] = np.where(ix15 > 0, ix15, np.inf)
        self.flag_mode = self._iv(24).astype(np.int64)
        self.active = self._iv(0) == 1
        self.count_inpos = bool((self._iv(88) > 0).any())
        i60 = int(self.ivars.values[60])
        self._vperiod = i60 + 1 if i60 >= 0 else 1
        self.homing.map_channels()
        for m in np.flatnonzero(~self.active & self.amp_enabled).tolist():
            self._kill(np.array([m]))
        self._push_inputs()

    # -- power-up --------------------------------------------------------------------------------------
    def reset(self) -> None:
        """$$$ / power-up: counters and positions zero, home complete cleared, every motor killed
        except those with Ixx80 bit 0 = 1, which close their loop at position 0 [SRM Ixx80 p.136]."""
        core = self.core
        everyone = np.arange(self.n)
        core.servo_off(everyone)
        core.axes.vel[:] = 0.0
        core.set_position(everyone, 0.0)
        core.axes.flags &= ~int(MOTION_STICKY)
        self._alloc_state()
        self._push_inputs()
        up = np.flatnonzero(self.active & ((self._iv(80).astype(np.int64) & 1) == 1))
        if len(up) and not self.phase_clock_error:
            self._enable(up)

    # -- enabling and killing ----------------------------------------------------------------------
    def _closed(self) -> np.ndarray:
        return self.core.servo_on_mask

    def _enable(self, idx: np.ndarray) -> np.ndarray:
        """Close the loop of the motors of `idx` that are not closed, at their present actual
        position; returns those now closed. ERR018 while the phase clock error is set."""
        idx = idx[self.active[idx]]
        todo = idx[~self._closed()[idx]]
        if len(todo) and self.phase_clock_error:
            raise MotorError(ERR_PHASE_CLOCK, "phase clock error")
        if len(todo):
            self._stop_open(todo)
            self.core.servo_on(todo)
            on = todo[self._closed()[todo]]  # refused while the amplifier faults
            self.amp_enabled[on] = True
            self.fatal_error[on] = False
            self.amp_error[on] = False
        return idx[self._closed()[idx]]

    def _stop_open(self, idx: np.ndarray) -> None:
        self.open_out[idx] = 0.0
        self._any_open = bool(self.open_out.any())

    def _kill(self, idx: np.ndarray) -> None:
        """Open loop, output 0, amplifier disabled [§2.7]; the limit bits freeze [SRM p.189]."""
        self.limit_bits[idx] = self.reports.limit_bits_now()[idx]
        self._stop_open(idx)
        self.core.servo_off(idx)
        self.amp_enabled[idx] = False
        self.homing.end(idx)
        self.timed[idx] = False
        self.abort_decel[idx] = False

    def kill(self, m: int) -> None:
        """K: kill motor m."""
        self._kill(np.array([m]))

    def kill_all(self) -> None:
        """^K: kill every motor."""
        self._kill(np.arange(self.n))

    def _fault_kill(self, offenders: np.ndarray) -> None:
        """Kill per Ixx24 bits 21-22 of each offender: 00 all motors, 01 the motors of its
        coordinate system (itself when in none), 10 itself; 11 (reserved) as 00 [A L1863-1871]."""
        victims = np.zeros(self.n, dtype=bool)
        for m in offenders.tolist():
            action = (int(self.flag_mode[m]) >> IXX24_ACTION_SHIFT) & 3
            if action == 2:
                victims[m] = True
            elif action == 1:
                victims |= (self.cs == self.cs[m]) if self.cs[m] else np.arange(self.n) == m
            else:
                victims[:] = True
        self._kill(np.flatnonzero(victims & (self.amp_enabled | self._closed())))

    def set_phase_clock_error(self, on: bool) -> None:
        """X:$000006 bit 3: while set, enabling any motor is refused with ERR018 [A L3320]."""
        self.phase_clock_error = bool(on)

    def open_loop(self, m: int, percent: float) -> None:
        """O{c}: open loop with the amplifier enabled, output c % of Ixx69 (c clipped to +-100)."""
        if not self.active[m]:
            return
        if not self.amp_enabled[m] and self.phase_clock_error:
            raise MotorError(ERR_PHASE_CLOCK, "phase clock error")
        if self.core.amp_fault[m]:
            return
        a = np.array([m])
        self.homing.end(m)
        self.timed[m] = self.abort_decel[m] = False
        if self._closed()[m]:
            self.core.servo_off(a)
        self.amp_enabled[m] = True
        self.open_out[m] = float(np.clip(percent, -100.0, 100.0)) / 100 * float(self.out_limit[m])
        self._any_open = True
        self.core.axes.out[m] = self.open_out[m]

    # -- jogs and moves (their profile: jog_profile.py) ---------------------------------------------
    def _start(self, m: int) -> bool:
        """Before a jog or home: the motor must be active; a killed motor closes its loop."""
        if not self.active[m]:
            return False
        self.homing.end(m)
        self.homing.new_move(m)
        self.abort_decel[m] = False
        return bool(len(self._enable(np.array([m]))))

    def _jog_at(self, m: int, velocity: float) -> None:
        """Run at `velocity` counts/ms with the jog accelerations."""
        now = float(self.core.axes.cmd_vel[m]) / 1000
        reverse = now * velocity < 0
        dv = max(abs(now), abs(velocity)) if reverse else abs(velocity - now)
        acc, jerk = jog_accel(self.ivars.values, m, dv)
        self.core.jog(m, velocity * 1000, acc, acc, jerk)

    def _note_prejog(self, m: int) -> None:
        self.prejog[m] = float(self.core.axes.cmd_pos[m] - self.origin[m])

    def jog(self, m: int, direction: int) -> None:
        """J+ / J-: jog indefinitely at Ixx22 in `direction` (+1/-1) [SRM Ixx22]; a killed motor
        closes its loop first."""
        if not self._start(m):
            return
        self._note_prejog(m)
        self.timed[m] = False
        self._jog_at(m, math.copysign(jog_speed(self.ivars.values, m), direction))
        self._after_command(m)

    def _halt(self, m: int) -> bool:
        """What J/ and A share: an inactive motor is left alone and a killed or open-loop one
        closes its loop at its present position (False: nothing more to do); otherwise the
        home search and move timer end and the caller stops the motion (True)."""
        if not self.active[m]:
            return False
        if not self._closed()[m]:
            self._start(m)
            return False
        self.homing.end(m)
        self.timed[m] = False
        return True

    def jog_stop(self, m: int) -> None:
        """J/: stop a jog with the jog deceleration; a killed or open-loop motor closes its loop
        and holds its present position."""
        if not self._halt(m):
            return
        if self.core.profile.moving[m]:
            acc, jerk = jog_accel(self.ivars.values, m, abs(float(self.core.axes.cmd_vel[m])) / 1000)
            self.core.last_jerk[m] = jerk
            self.core.stop(m, acc)

    def _move_to(self, m: int, motor_counts: float) -> None:
        """A jog-to-position move (move timer active) to a motor position."""
        speed = jog_speed(self.ivars.values, m, to_position=True)
        if speed <= 0:
            return
        acc, jerk = jog_accel(self.ivars.values, m, speed)
        self.timed[m] = True
        self.core.move_absolute(m, float(self.origin[m]) + motor_counts, speed * 1000, acc, acc, jerk)
        self._after_command(m)

    def jog_to(self, m: int, counts: float | None) -> None:
        """J= (counts None: back to the pre-jog position) / J={counts} (motor position)."""
        if not self._start(m):
            return
        if counts is None:
            target = float(self.prejog[m])
        else:
            self._note_prejog(m)
            target = float(counts)
        self._move_to(m, target)

    def jog_relative(self, m: int, counts: float, from_actual: bool) -> None:
        """J:{counts} from the present commanded position / J^{counts} from the actual one."""
        if not self._start(m):
            return
        self._note_prejog(m)
        base = self.reports.position()[m] if from_actual else self.reports.commanded()[m]
        self._move_to(m, float(base) + counts)

    def jog_variable(self, m: int, kind: str) -> None:
        """J=* (to Mxx72), J:* (Mxx72 from commanded), J^* (Mxx72 from actual); `kind` is "=",
        ":" or "^"."""
        value = float(self.jog_register[m])
        if kind == "=":
            self.jog_to(m, value)
        elif kind in (":", "^"):
            self.jog_relative(m, value, from_actual=kind == "^")
        else:
            raise ValueError(f"jog kind must be '=', ':' or '^', not {kind!r}")

    def jog_trigger(self, m: int, kind: str, counts: float | None, distance: float,
                    variable: bool = False) -> None:
        """Jog-until-trigger: the definite jog J= (counts None: the pre-jog position), J={c},
        J:{c} or J^{c} (`kind` "=", ":", "^"; `variable`: Mxx72 for c, J=* J:* J^*), ended at
        trigger + `distance` counts if the trigger of a home search (I7mn2/I7mn3 on Ixx25, or
        Ixx97) comes first; the zero position stays [UM "Jog-until-trigger", PMAC1-SRM p.241]."""
        if variable:
            counts = float(self.jog_register[m])
        if kind == "=":
            self.jog_to(m, counts)
        else:
            self.jog_relative(m, float(counts or 0.0), from_actual=kind == "^")
        if not self.closed_loop(m):
            return
        self.homing.start_trigger(m, distance)
        self._home_found(self.homing.check(initial=True))

    def closed_loop(self, m: int) -> bool:
        """Whether motor m's servo loop is closed."""
        return bool(self._closed()[m])

    def abort(self, m: int) -> None:
        """A / ^A: decelerate at Ixx15 and hold in closed loop; a killed motor closes its loop
        at its present position."""
        if not self._halt(m):
            return
        moving = bool(self.core.profile.moving[m])
        ix15 = float(self.ivars.values[100 * (m + 1) + 15]) * 1e6
        self.core.abort(m, ix15 if ix15 > 0 else None)
        self.abort_decel[m] = moving and ix15 > 0

    def round_commanded(self, m: int) -> None:
        """J!: the commanded position of a closed-loop motor at rest to the nearest whole count
        (motor position), whatever the following error [A L3251]."""
        core = self.core
        if not self._closed()[m] or core.profile.moving[m]:
            return
        target = float(np.rint(core.axes.cmd_pos[m] - self.origin[m]) + self.origin[m])
        core.profile.hold(m, target)
        core.profile.commit()

    # -- homing (homing.py) -----------------------------------------------------------------------------
    def home(self, m: int) -> None:
        """HM: home search at Ixx23 to the I7mn2/I7mn3 capture trigger (`HomeSearch.start`); a
        killed motor closes its loop first."""
        if not self._start(m):
            return
        self.timed[m] = False
        self._home_action(m, self.homing.start(m))

    def home_zero(self, m: int) -> None:
        """HMZ: the present commanded position becomes motor position 0 (`HomeSearch.zero`)."""
        self._home_action(m, self.homing.zero(m))

    def _home_action(self, m: int, action: HomeAction) -> None:
        """Do what a home search answered for motor m [§2.7]."""
        if isinstance(action, Jog):
            self._push_inputs()  # software limits off while searching
            self._jog_at(m, action.velocity)
            self._after_command(m)
            self._home_found(self.homing.check(initial=True))
        else:
            self._home_found([(m, action)])

    def _home_found(self, found: list[tuple[int, TriggerAction]]) -> int:
        """Each motor's home origin set and, after a trigger, the timed move to it at |Ixx23|;
        AxisFlag.HOMED if a trigger moved a motor."""
        if not found:
            return 0
        events = 0
        for m, home in found:
            if not isinstance(home, Found):  # a jog-until-trigger: to trigger + c, jog speed
                self._move_to(m, home.position - float(self.origin[m]))
                continue
            self.origin[m] = home.origin
            if home.speed is not None:
                acc, jerk = jog_accel(self.ivars.values, m, home.speed)
                self.timed[m] = True
                self.abort_decel[m] = False
                self.core.move_absolute(m, home.origin, home.speed * 1000, acc, acc, jerk)
                events |= int(AxisFlag.HOMED)
        self._push_inputs()
        return events

    # -- inputs ----------------------------------------------------------------------------------------
    def apply_inputs(self, plim: np.ndarray, mlim: np.ndarray, hmfl: np.ndarray,
                     amp_fault: np.ndarray, user: np.ndarray | None = None,
                     edges: np.ndarray | None = None) -> None:
        """The axis world's levels on every motor's flag inputs at once (the card's
        `apply_world`): plim/mlim, the PMAC2 PLIMn/MLIMn inputs read 1 (switch open = at the
        limit; PLIM stops positive motion); hmfl, HMFLn reads 1; amp_fault, the amplifier
        reports a fault; user, USERn (the registration probe). `edges` (4 x motors, encoder
        counts, NaN: none): where the HMFL, PLIM, MLIM and USER levels changed during this servo
        cycle, which a home search triggered by that change captures (the hardware latches the
        counter at the edge, not at the next servo cycle)."""
        flags = [(self.plim, plim), (self.mlim, mlim), (self.hmfl, hmfl),
                 (self.amp_fault_in, amp_fault)]
        if user is not None:
            flags.append((self.user, user))
        changed = False
        for mine, level in flags:
            if not np.array_equal(mine, level):
                np.copyto(mine, level)
                changed = True
        if not changed:
            return
        self._push_inputs()
        if self.homing.any_searching:
            self._home_found(self.homing.check(initial=True, edges=edges))

    def set_encoder_losses(self, lost: np.ndarray) -> None:
        """The encoders of the motors where `lost` is True stop counting; the others count."""
        if not np.array_equal(self.core.encoder_loss, lost):
            self.core.set_inputs(encoder_loss=np.array(lost, dtype=bool))

    def _amp_faults(self) -> np.ndarray:
        """The amplifier faults the motors act on: not with Ixx24 bit 20 (input unused)."""
        return self.amp_fault_in & ((self.flag_mode & IXX24_AMP_FAULT_OFF) == 0) & self.active

    def _push_inputs(self) -> None:
        """Feed limits (hardware unless Ixx24 bit 17, software Ixx13/Ixx14 hit by the actual
        position, off during a home search) and amplifier faults to the core; a new fault
        kills per Ixx24 [A L1863-1875]."""
        core = self.core
        use = (self.flag_mode & IXX24_LIMITS_OFF) == 0
        searching = self.homing.searching & ~self.homing.jog_trigger
        pos = (self.plim & use) | (self._soft_hi_hit & ~searching)
        neg = (self.mlim & use) | (self._soft_lo_hit & ~searching)
        fault = self._amp_faults()
        rising = np.flatnonzero(fault & ~core.amp_fault)
        lim = core.limits
        if not (np.array_equal(lim.hard_pos, pos) and np.array_equal(lim.hard_neg, neg)):
            core.last_jerk[:] = 0.0  # a limit stop is a plain Ixx15 deceleration, no S-curve
            core.set_inputs(hard_limit_pos=pos, hard_limit_neg=neg)
            stopped = (core.axes.flags & _STOPPED) != 0
            self.abort_decel |= stopped & core.profile.moving  # a limit stop at Ixx15
            self.homing.stopped(core.profile.moving)
        if not np.array_equal(fault, core.amp_fault):
            core.set_inputs(amp_fault=fault)
        if len(rising):
            self.amp_error[rising[self.amp_enabled[rising]]] = True
            self._fault_kill(rising)
        self._update_soft_limits()

    def _update_soft_limits(self) -> None:
        """Software limits in core counts: origin + Ixx13 / origin + Ixx14 (0 disables)."""
        hi, lo = self._iv(13), self._iv(14)
        self.soft_hi = np.where(hi != 0, self.origin + hi, np.inf)
        self.soft_lo = np.where(lo != 0, self.origin + lo, -np.inf)
        self._soft_on = bool(np.isfinite(self.soft_hi).any() or np.isfinite(self.soft_lo).any())

    def _check_soft_limits(self) -> None:
        fb = self.core.axes.fb
        hi = np.greater(fb, self.soft_hi)
        lo = np.less(fb, self.soft_lo)
        if not (np.array_equal(hi, self._soft_hi_hit) and np.array_equal(lo, self._soft_lo_hit)):
            self._soft_hi_hit, self._soft_lo_hit = hi, lo
            self._push_inputs()

    def _after_command(self, m: int) -> None:
        """A motion command refused or stopped at once by a limit is not an abort deceleration."""
        self.abort_decel[m] = False

    def skip(self, k: int) -> None:
        """k cycles at rest: the profile clock, I60's slot counters (every slot already holds
        the reading) and the in-position scan counts move, as k ticks would move them."""
        self.core.skip(k)
        total = self._vcount + k
        self._vslot = (self._vslot + total // self._vperiod) % 17
        self._vcount = total % self._vperiod
        if self.count_inpos:
            self.inpos_scans[self.inpos_scans > 0] += k

    def counting_to_inpos(self) -> bool:
        """Whether a motor's in-position scan count is under way to Ixx88 (in position but not
        yet for Ixx88 + 1 scans): its in-position bit, and the interrupt on its edge, are still
        to come at a cycle of their own."""
        if not self.count_inpos:
            return False
        scans = self.inpos_scans
        return bool(np.count_nonzero((scans > 0) & (scans <= self._iv(88))))

    @property
    def filtered_velocity(self) -> np.ndarray:
        """The actual velocity over the last 16 samples of I60's buffer, counts per servo cycle
        (a fresh array) [SRM I60]."""
        slot = self._vslot
        return (self._vbuf[slot] - self._vbuf[(slot + 1) % 17]) / self._vdiv

    # -- the tick ------------------------------------------------------------------------------------------
    def tick(self) -> int:
        """One servo cycle; the AxisFlag bits of what happened (FE_TRIP on a fatal following
        error, HOMED at a home trigger, the core's DONE/limit/amp-fault events)."""
        core = self.core
        events = core.tick()
        if self._any_open:
            np.copyto(core.axes.out, self.open_out, where=self.open_out != 0)
        if self._any_friction:
            out = core.axes.out
            out += self.friction * np.sign(core.axes.cmd_vel) * core.servo_on_mask
            np.clip(out, -self.out_limit, self.out_limit, out=out)
        if self._soft_on and core.profile.active:
            self._check_soft_limits()
        if self.homing.any_searching:
            events |= self._home_found(self.homing.check())
        if events & _FE_TRIP:
            trip = ((core.axes.flags & _FE_TRIP) != 0) & self._closed()
            if trip.any():
                offenders = np.flatnonzero(trip)
                self.fatal_error[offenders] = True
                self._fault_kill(offenders)
        self._vcount += 1
        if self._vcount >= self._vperiod:  # I60: 16-slot velocity buffer [SRM I60]
            self._vcount = 0
            self._vslot = slot = (self._vslot + 1) % 17
            self._vbuf[slot] = core.axes.fb
            self._vdiv = 16 * self._vperiod
        if self.count_inpos:
            ok = self.reports.in_position_now()
            self.inpos_scans = np.where(ok, self.inpos_scans + 1, 0)
        return events
