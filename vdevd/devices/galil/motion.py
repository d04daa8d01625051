"""Independent-axis motion of the DMC-13X8 over the shared motion core (manual ch. 3 and 6).

`GalilMotion` keeps the per-axis parameters (KP ... DC, spec §1.3), maps the digital filter of
spec §5.1 onto the core's PID with the 16-bit DAC scaling, starts and stops profiles the Galil way
(PR/PA/JG/FE/FI/HM then BG; ST; AB; MO/SH), runs the homing phases of ch. 3 "Home Switch Input",
and derives what the card reports: stop codes (SC), the axis status word and switch byte of the
data record (ch. 4 "Explanation of Status Information"), TV, TT, TD. The tick path is vectorised;
per-axis Python runs only at commands and at the tick an axis changes phase.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
from vdevmaps.galil import AxisStatus, AxisSwitch

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.params import COUNTS_PER_VOLT, DAC_FULL_SCALE, PARAMS
from vdevd.rt import AxisFlag, MotionCore, PlantKind
from vdevd.rt.axes import ProfileMode
from vdevd.rt.plants import StepperPlant

HOME_CREEP = 256.0  # counts/s: phases 2 and 3 of HM [M Ch3 §Home Switch Input]
TV_SECONDS = 0.25  # TV averages over about a quarter second (spec §1.2)
#: a TV below this reads 0 in TV (rint) and in the data record (rint of 64 x TV): every 64
#: samples it is made 0, so that a motor at rest settles and the card can rest (decision 0008)
TV_FLUSH = 1 / 256
_MOVING = int(AxisFlag.MOVING)


class Mode(enum.IntEnum):
    """What BG starts on an axis: the last mode command given."""

    PR = 0
    PA = 1
    JG = 2
    FE = 3
    FI = 4
    HM = 5


class Phase(enum.IntEnum):
    """Where an FE, FI or HM search is (ch. 3 "Home Switch Input")."""

    NONE = 0
    EDGE = 1  # slewing at SP toward the home input's transition (FE, HM phase 1)
    EDGE_STOP = 2  # found it: decelerating with DC
    BACK = 3  # HM phase 2: creeping back at 256 counts/s until the input changes again
    INDEX = 4  # FI, HM phase 3: until the index pulse
    INDEX_STOP = 5  # found the index (now position 0): decelerating


class StopCode(enum.IntEnum):
    """SC codes (spec §4.4)."""

    RUNNING = 0
    AT_POSITION = 1
    FORWARD_LIMIT = 2
    REVERSE_LIMIT = 3
    STOP_COMMAND = 4
    ABORT_INPUT = 6
    ABORT_COMMAND = 7
    OFF_ON_ERROR = 8
    FIND_EDGE = 9
    HOMED = 10
    MC_TIMEOUT = 99


_PLANTS = {"servo": PlantKind.SERVO, "stepper": PlantKind.STEPPER, "ideal": PlantKind.IDEAL}


class SmoothedStepper(StepperPlant):
    """Step pulses through the KS smoothing filter (ch. 6 "Monitoring Generated Pulses"): the
    step count follows the reference through a single pole of time constant 3*KS samples (KS 2 =
    6 samples, the manual's one data point); `gen` is the filter state, whole steps go out."""

    def __init__(self, n: int, dt: float) -> None:
        super().__init__(n, dt)
        self.gain = np.ones(n)

    def set_ks(self, ks: np.ndarray) -> None:
        self.gain[:] = 1.0 - np.exp(-1.0 / (3.0 * ks))

    def step(self, cmd_pos: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        gen, tgt = self.gen, self._tgt
        np.subtract(cmd_pos, gen, out=tgt)
        tgt *= self.gain
        gen += tgt
        np.rint(gen, out=tgt)
        np.subtract(tgt, pos, out=vel)
        vel *= self._inv_dt
        pos[...] = tgt


class GalilMotion:
    """The motion firmware of one card: n axes X, Y, Z, W."""

    def __init__(self, n: int, period_ns: int, plant: str = "servo") -> None:
        self.n = n
        self.dt = period_ns / 1e9
        self.plant_kind = _PLANTS[plant]
        self.core = MotionCore(n, period_ns, self.plant_kind)
        self.stepper = SmoothedStepper(n, self.dt)
        self.core.stepper = self.stepper
        self.values: dict[str, np.ndarray] = {k: np.full(n, float(p.default)) for k, p in PARAMS.items()}
        if self.plant_kind == PlantKind.STEPPER:
            self.values["MT"][:] = 2.0  # SM jumpers installed: the card is set up for steppers
        self.stepper.set_ks(self.values["KS"])
        self.lowpass = np.zeros(n)  # PL output filter state (DAC counts)
        self._pl = False
        self.mode = np.zeros(n, dtype=np.int64)
        self.phase = np.zeros(n, dtype=np.int64)
        self.search_dir = np.ones(n)  # direction of the FE/HM phase-1 search
        self.home_level0 = np.zeros(n, dtype=bool)  # the home input when a phase began
        self.stop_code = np.full(n, int(StopCode.AT_POSITION), dtype=np.int64)
        self.move_start = np.zeros(n)  # the reference at the last BG (AD measures from it)
        self.stop_reason = np.zeros(n, dtype=np.int64)  # why a stopping profile stops (0: none)
        self.pa_target = np.zeros(n)
        self.oe_tripped = np.zeros(n, dtype=bool)
        self.error_over = np.zeros(n, dtype=bool)  # |TE| > ER (TS bit 6, ERROR output)
        # inputs: limits "active" (switch tripped), home input logic level, abort input; the
        # card's axis world drives them through `sense`, called after the motion of every sample
        self.forward_limit = np.zeros(n, dtype=bool)
        self.reverse_limit = np.zeros(n, dtype=bool)
        self.home_input = np.ones(n, dtype=bool)
        self.sense: Callable[[], None] | None = None
        #: gearing, ECAM and contour (follow.py): their work before each sample while they have
        #: some; `engaged` while an axis follows (the card is then not at rest)
        self.before_tick: Callable[[], None] | None = None
        self.engaged = False
        #: +1, or -1 where MT -1 reverses the servo polarity or CE 2/3 reverses the main encoder:
        #: the sign of the DAC output per count of error (`apply_filter`) [M Ch6 §Using the CE]
        self.loop_sign = np.ones(n)
        #: -1 where CE 2/3 reverses the main encoder: the core's output is the DAC seen in the
        #: reversed count direction (`torque`)
        self.dac_sign = np.ones(n)
        # index pulses at phase + k * period in physical counts (period 0: none)
        self.index_period = np.full(n, 4096.0)
        self.index_phase = np.zeros(n)
        self._phys_prev = np.zeros(n)  # the physical encoder reading of the last search sample
        self.abort_input = False
        self.aux = np.zeros(n)  # TD for servo axes (no auxiliary encoder model): what DE set
        self.enc_offset = np.zeros(n)  # stepper axes: TP = encoder + offset (DE, DP)
        self.latch_armed = np.zeros(n, dtype=bool)
        self.latch_occurred = np.zeros(n, dtype=bool)
        self.latched = np.zeros(n)
        #: TV (row 0) beside this sample's encoder change (row 1): one multiply by `_tv_coef`
        #: (rows: keep, gain) scales both (`tick`)
        self._tv_pair = np.zeros((2, n))
        self.tv = self._tv_pair[0]
        self._delta = self._tv_pair[1]
        self._enc_prev = np.zeros(n)
        self._tv_alpha = min(1.0, self.dt / TV_SECONDS)
        self._moving_prev = np.zeros(n, dtype=bool)
        self._searching = False
        self._tmp = np.zeros(n)
        self._done = np.zeros(n, dtype=bool)
        self._over = np.zeros(n, dtype=bool)
        self._new = np.zeros(n, dtype=bool)
        self._er = np.zeros(n)
        self._tv_gain = self._tv_alpha / self.dt
        self._tv_keep = 1.0 - self._tv_alpha
        self._tv_coef = np.array([np.full(n, self._tv_keep), np.full(n, self._tv_gain)])
        self.apply_filter()
        self.apply_limits()
        self.core.servo_on(slice(None))

    # -- parameters --------------------------------------------------------------------------------
    def apply_filter(self, axes: Any = slice(None)) -> None:
        """Map KP KD KI IL TL OF FV FA onto the core's PID in DAC counts (spec §5.1):
        u = 4*KP*e + 4*KD*(e - e[k-1]) + (KI/2)*sum(e), the integral term clamped to IL volts,
        the output offset by OF and clamped to TL volts and to the 16-bit DAC."""
        v = self.values
        sign = self.loop_sign[axes]
        kp, kd, ki = 4 * v["KP"][axes] * sign, 4 * v["KD"][axes] * sign, v["KI"][axes] / 2
        il_counts = np.abs(v["IL"][axes]) * COUNTS_PER_VOLT
        il = np.where(ki > 0, il_counts / np.where(ki > 0, ki, 1.0), np.inf)
        ki = ki * sign
        self.out_limit = np.minimum(v["TL"] * COUNTS_PER_VOLT, DAC_FULL_SCALE)
        self.offset = v["OF"] * COUNTS_PER_VOLT
        self._pl = bool(v["PL"].any())
        if self._pl:  # PL filters the PID sum; OF and TL then act after it (spec §5.1)
            offset, limit = np.zeros(self.n), np.full(self.n, np.inf)
        else:
            offset, limit = self.offset, self.out_limit
        self.core.pid.set(slice(None), offset=offset, out_limit=limit)
        self.core.pid.set(axes, kp=kp, kd=kd, ki=ki, il=il, vff=v["FV"][axes] * 1e-4 * sign,
                          aff=v["FA"][axes] * 1e-6 * sign)

    def apply_limits(self) -> None:
        """ER (-1 disables) is checked by the card each tick; FL/BL are the core's soft limits;
        a limit switch stops with DC [M Ch3 §Limit Switch Input]."""
        v = self.values
        self.core.set_soft_limits(slice(None), v["BL"], v["FL"])
        self.core.limits.limit_dec[:] = v["DC"]
        self._er[:] = np.where(v["ER"] > 0, v["ER"], np.inf)

    def set_param(self, name: str, axes: Iterable[int], values: Iterable[float]) -> None:
        """Store values already checked by `Param.coerce`, with the side effects the card has."""
        idx = list(axes)
        arr = self.values[name]
        arr[idx] = list(values)
        if name in ("KP", "KD", "KI", "IL", "TL", "OF", "FA", "FV", "PL"):
            self.apply_filter()
        elif name in ("MT", "CE"):
            reversed_servo = self.values["MT"] == -1
            reversed_encoder = (self.values["CE"].astype(np.int64) & 3) >= 2
            self.loop_sign[:] = np.where(reversed_servo != reversed_encoder, -1.0, 1.0)
            self.dac_sign[:] = np.where(reversed_encoder, -1.0, 1.0)
            self.apply_filter()
        elif name == "KS":
            self.stepper.set_ks(self.values["KS"])
        elif name in ("FL", "BL", "DC", "ER"):
            self.apply_limits()
        elif name == "PR":
            self.mode[idx] = Mode.PR
        elif name == "PA":
            self.mode[idx] = Mode.PA
        elif name == "JG":
            self.mode[idx] = Mode.JG
            self._jog_on_the_fly(idx)
        if name in ("SP", "AC"):
            self._replan(idx)

    def _jerk(self, a: int) -> float:
        """IT smoothing as an S-curve: a moving average of L = 1/IT samples over the velocity
        profile is a jerk-limited profile with jerk = acceleration / (L * TM) (spec §5.3)."""
        it = float(self.values["IT"][a])
        samples = round(1.0 / it) if it > 0 else 1
        return 0.0 if samples <= 1 else float(self.values["AC"][a]) / (samples * self.dt)

    def _replan(self, idx: list[int]) -> None:
        """SP and AC may change during a PR/PA move [M Ch6 §Independent Axis Positioning]."""
        core, v = self.core, self.values
        for a in idx:
            if self.moving(a) and self.mode[a] in (Mode.PR, Mode.PA) and not self.stop_reason[a]:
                core.move_absolute(a, float(core.target[a]), max(v["SP"][a], 1.0), v["AC"][a],
                                   v["DC"][a], self._jerk(a))

    def _jog_on_the_fly(self, idx: list[int]) -> None:
        """JG during a jog changes speed and direction with AC/DC [M Ch6 §Independent Jogging]."""
        v = self.values
        for a in idx:
            if self.moving(a) and not self.stop_reason[a] and self.phase[a] == Phase.NONE:
                self.core.jog(a, v["JG"][a], v["AC"][a], v["DC"][a], self._jerk(a))

    def moving(self, a: int) -> bool:
        return bool(self.core.profile.moving[a])

    def tracking(self, axes: Any) -> None:
        """Axes whose commanded position a follower mode (contour) now sets every sample: in
        motion, and the end of it is a motion complete like a move's (`tick`, `_finish`)."""
        self._moving_prev[axes] = True
        self.stop_reason[axes] = 0

    # -- commands ----------------------------------------------------------------------------------
    def begin(self, axes: list[int]) -> None:
        """BG: check every axis first (TC 20 motor off, 21 running, 22 limit), then start all."""
        core, v = self.core, self.values
        for a in axes:
            if not core.servo_on_mask[a]:
                raise GalilError(TC.BEGIN_WITH_MOTOR_OFF)
            if self.moving(a):
                raise GalilError(TC.BEGIN_WHILE_RUNNING)
            if self._blocked(a):
                raise GalilError(TC.BEGIN_LIMIT_SWITCH)
        for a in axes:
            mode = Mode(int(self.mode[a]))
            sp, ac, dc, jerk = max(v["SP"][a], 1.0), v["AC"][a], v["DC"][a], self._jerk(a)
            self.stop_reason[a] = 0
            self.stop_code[a] = StopCode.RUNNING
            here = float(np.rint(core.axes.cmd_pos[a]))
            self.move_start[a] = here
            if mode == Mode.PR:
                core.move_absolute(a, here + v["PR"][a], sp, ac, dc, jerk)
            elif mode == Mode.PA:
                core.move_absolute(a, v["PA"][a], sp, ac, dc, jerk)
            elif mode == Mode.JG:
                core.jog(a, v["JG"][a], ac, dc, jerk)
            else:
                self._start_search(a, mode)
            if not self.moving(a) and self.phase[a] == Phase.NONE:
                self.stop_code[a] = StopCode.AT_POSITION
        self._moving_prev[axes] = core.profile.moving[axes]

    def _blocked(self, a: int) -> bool:
        """Motion toward an active limit switch is refused [M Ch3 §Limit Switch Input]."""
        mode, v = self.mode[a], self.values
        here = float(self.core.axes.cmd_pos[a])
        if mode == Mode.PR:
            direction = v["PR"][a]
        elif mode == Mode.PA:
            direction = v["PA"][a] - here
        elif mode == Mode.JG:
            direction = v["JG"][a]
        elif mode == Mode.FI:
            direction = math.copysign(1.0, v["JG"][a])
        else:
            direction = 1.0 if self.home_input[a] else -1.0
        return bool((direction > 0 and self.forward_limit[a])
                    or (direction < 0 and self.reverse_limit[a]))

    def _start_search(self, a: int, mode: Mode) -> None:
        """FE/HM: toward the home input's transition, forward when the input is high; FI: at SP
        in the direction of JG, until the index [M Ch3 §Home Switch Input]."""
        v = self.values
        if mode == Mode.FI:
            self.phase[a] = Phase.INDEX
            speed = math.copysign(max(v["SP"][a], 1.0), v["JG"][a])
        else:
            self.phase[a] = Phase.EDGE
            self.search_dir[a] = 1.0 if self.home_input[a] else -1.0
            self.home_level0[a] = self.home_input[a]
            speed = self.search_dir[a] * max(v["SP"][a], 1.0)
        self._searching = True
        self._phys_prev[a] = self.core.axes.fb[a] - self.core.zero[a]
        self.core.jog(a, speed, v["AC"][a], v["DC"][a])

    def stop(self, axes: list[int], reason: StopCode = StopCode.STOP_COMMAND) -> None:
        """ST: decelerate with DC; a search ends where it stops [M Ch6]."""
        for a in axes:
            if self.moving(a):
                self.stop_reason[a] = reason
                self.phase[a] = Phase.NONE
                self.core.stop(a, self.values["DC"][a])

    def abort(self, axes: list[int], reason: StopCode) -> None:
        """AB / abort input: motion generation stops at once; with OE1 the motor turns off
        [M Ch3 §Abort Input]."""
        idx = np.asarray(axes, dtype=np.int64)
        moving = idx[self.core.profile.moving[idx]]
        self.phase[idx] = Phase.NONE
        self.core.abort(idx)
        self.stop_code[moving] = reason
        self.stop_reason[moving] = 0
        self._moving_prev[idx] = False
        if reason == StopCode.ABORT_INPUT:
            off = idx[self.values["OE"][idx] > 0]
            if len(off):
                self.motor_off(off.tolist())

    def motor_off(self, axes: list[int]) -> None:
        """MO: amplifier disabled, DAC 0, the motor coasts."""
        self.phase[axes] = Phase.NONE
        self.core.servo_off(np.asarray(axes, dtype=np.int64))
        self._moving_prev[axes] = False

    def servo_here(self, axes: list[int]) -> None:
        """SH: servo on at the present position; clears an off-on-error trip."""
        self.core.servo_on(np.asarray(axes, dtype=np.int64))
        self.oe_tripped[axes] = False

    def define_position(self, axes: list[int], values: list[float]) -> None:
        """DP: the present position becomes `values`: reference and encoder on a servo axis
        [M Ch2 Ex6], reference and step count on a stepper axis, whose encoder keeps its reading
        [M Ch6 §Stepper]."""
        tp = self.position()[axes]
        self.core.set_position(np.asarray(axes, dtype=np.int64), values)
        self._enc_prev[axes] = self.core.axes.fb[axes]
        if self.plant_kind == PlantKind.STEPPER:
            self.enc_offset[axes] = tp - self.core.axes.encoder[axes]
        self.values["PA"][axes] = values

    def define_aux(self, axes: list[int], values: list[float]) -> None:
        """DE: the auxiliary encoder reads `values`; on a stepper axis the main encoder (TP)
        [M Ch6 §Stepper: "DE defines the encoder position"]."""
        if self.plant_kind == PlantKind.STEPPER:
            self.enc_offset[axes] = np.asarray(values) - self.core.axes.encoder[axes]
        else:
            self.aux[axes] = values

    def increment(self, axes: list[int], values: list[float]) -> None:
        """IP: on the fly a new target further along the move; in a jog the position moves by
        the increment at once; idle: PR and BG [M Ch6 §Independent Axis Positioning, §Jogging]."""
        v = self.values
        for a, d in zip(axes, values, strict=True):
            if not self.moving(a):
                v["PR"][a] = d
                self.mode[a] = Mode.PR
                self.begin([a])
            elif self.mode[a] in (Mode.PR, Mode.PA) and not self.stop_reason[a]:
                if d * (float(self.core.target[a]) - float(self.core.axes.cmd_pos[a])) < 0:
                    raise GalilError(TC.IP_INCORRECT_SIGN)
                self.core.move_absolute(a, float(self.core.target[a]) + d, max(v["SP"][a], 1.0),
                                        v["AC"][a], v["DC"][a], self._jerk(a))
            elif self.mode[a] == Mode.JG and not self.stop_reason[a] and self.phase[a] == Phase.NONE:
                # jogging: the commanded position moves by d at once, the jog goes on from there
                self.core.axes.cmd_pos[a] += d
                self.core.jog(a, v["JG"][a], v["AC"][a], v["DC"][a], self._jerk(a))
            else:
                raise GalilError(TC.IP_INCORRECT_SIGN)

    # -- inputs ------------------------------------------------------------------------------------
    def set_limits(self, forward: np.ndarray, reverse: np.ndarray) -> np.ndarray:
        """New limit switch states (True = tripped); a moving axis heading into a newly tripped
        switch stops with DC. Returns the axes whose switch became active."""
        rising = (forward & ~self.forward_limit) | (reverse & ~self.reverse_limit)
        heading_f = forward & ~self.forward_limit & self.core.profile.moving & (self.core.axes.cmd_vel > 0)
        heading_r = reverse & ~self.reverse_limit & self.core.profile.moving & (self.core.axes.cmd_vel < 0)
        self.forward_limit[:], self.reverse_limit[:] = forward, reverse
        for a in np.flatnonzero(heading_f | heading_r).tolist():
            self.phase[a] = Phase.NONE
            self.stop_reason[a] = StopCode.FORWARD_LIMIT if heading_f[a] else StopCode.REVERSE_LIMIT
        self.core.set_inputs(hard_limit_pos=forward, hard_limit_neg=reverse)
        return rising

    # -- the tick ----------------------------------------------------------------------------------
    def tick(self) -> np.ndarray | None:
        """One servo sample; the mask of axes whose motion completed at it (None: none did)."""
        core = self.core
        if self.before_tick is not None:
            self.before_tick()
        core.tick()
        if self.sense is not None:  # the switches where the stage now is
            self.sense()
        if self._pl:
            self._low_pass(core.axes.out)
        enc, tv, delta = core.axes.fb, self.tv, self._delta
        # TV: a first-order average of the velocity, tv = keep * tv + gain * (enc - enc_prev)
        np.subtract(enc, self._enc_prev, delta)
        np.multiply(self._tv_pair, self._tv_coef, self._tv_pair)
        np.add(tv, delta, tv)
        if not core.profile.ticks & 63:
            np.copyto(tv, 0.0, where=np.abs(tv) < TV_FLUSH)
        if self._searching:
            self._search_step(enc)
        self._enc_prev[...] = enc
        moving, prev = core.profile.moving, self._moving_prev
        if moving.tobytes() == prev.tobytes():  # no axis stopped since the last sample
            return None
        done = self._done
        np.greater(prev, moving, done)
        if not np.count_nonzero(done):
            return None
        self._moving_prev[...] = moving
        self._finish(np.flatnonzero(done))
        return done

    def rest_state(self) -> bytes | None:
        """What a sample may change (the core's and the filters', averages and latches of this
        firmware), as bytes; None during a home search (MotionCore.rest_state)."""
        core = self.core.rest_state()
        if core is None or self._searching or self.engaged:
            return None
        return b"".join((core, self.tv.tobytes(), self.lowpass.tobytes(),
                         self._enc_prev.tobytes(), self.error_over.tobytes(),
                         self._moving_prev.tobytes(), self.phase.tobytes(),
                         self.stop_code.tobytes(), self.oe_tripped.tobytes(),
                         self.latch_occurred.tobytes(), self.latched.tobytes()))

    def _low_pass(self, out: np.ndarray) -> None:
        """L(z) = (1 - B)/(z - B), B = PL, then OF and the TL clamp (spec §5.1); axes that are
        off (or not servo axes) output 0 and their filter forgets."""
        b, y = self.values["PL"], self.lowpass
        y *= b
        y += (1.0 - b) * out
        on = self.core.pid.enabled
        y *= on
        np.add(y, self.offset, out=out)
        np.clip(out, -self.out_limit, self.out_limit, out=out)
        out *= on

    def _search_step(self, enc: np.ndarray) -> None:
        """Home input transitions and index pulses of the axes in an FE/FI/HM search."""
        phase = self.phase
        if not phase.any():
            self._searching = False
            return
        level = self.home_input
        edge = ((phase == Phase.EDGE) | (phase == Phase.BACK)) & (level != self.home_level0)
        # index pulses are marks on the stage: count them in physical encoder counts
        phys = enc - self.core.zero
        period = np.where(self.index_period > 0, self.index_period, np.inf)
        k_now = np.floor((phys - self.index_phase) / period)
        k_prev = np.floor((self._phys_prev - self.index_phase) / period)
        np.copyto(self._phys_prev, phys)
        index = (phase == Phase.INDEX) & (k_now != k_prev)
        v = self.values
        for a in np.flatnonzero(edge).tolist():
            self.home_level0[a] = level[a]
            if phase[a] == Phase.EDGE:
                phase[a] = Phase.EDGE_STOP
                self.core.stop(a, v["DC"][a])
            else:  # HM phase 2 complete: forward to the index
                phase[a] = Phase.INDEX
                self.core.jog(a, HOME_CREEP, v["AC"][a], v["DC"][a])
        for a in np.flatnonzero(index).tolist():  # the index becomes position 0, then DC
            boundary = max(k_now[a], k_prev[a]) * period[a] + self.index_phase[a]
            self.core.redefine_and_stop(a, float(phys[a] - boundary), float(v["DC"][a]))
            phase[a] = Phase.INDEX_STOP

    def _finish(self, idx: np.ndarray) -> None:
        """Profiles that ended: the next homing phase, or the stop code of the move."""
        done_flags = self.core.axes.flags
        for a in idx.tolist():
            ph, mode = self.phase[a], self.mode[a]
            if ph == Phase.EDGE_STOP and mode == Mode.HM:
                self.phase[a] = Phase.BACK  # phase 1 complete: back at 256 counts/s
                self.core.jog(a, -self.search_dir[a] * HOME_CREEP, self.values["AC"][a],
                              self.values["DC"][a])
                self._moving_prev[a] = True
                continue
            if ph == Phase.EDGE_STOP:
                self.stop_code[a] = StopCode.FIND_EDGE
            elif ph == Phase.INDEX_STOP:
                self.stop_code[a] = StopCode.HOMED
            elif self.stop_reason[a]:
                self.stop_code[a] = self.stop_reason[a]
            elif done_flags[a] & AxisFlag.STOPPED_BY_LIMIT:
                self.stop_code[a] = (StopCode.FORWARD_LIMIT if self.core.axes.cmd_vel[a] >= 0
                                     and self.forward_limit[a] else StopCode.REVERSE_LIMIT)
            else:
                self.stop_code[a] = StopCode.AT_POSITION
            self.phase[a] = Phase.NONE
            self.stop_reason[a] = 0

    def error_changed(self) -> bool:
        """Whether |TE| > ER now differs from the last check on an axis (`check_error` acts)."""
        np.abs(self.core.axes.ferr, self._tmp)
        np.greater(self._tmp, self._er, self._over)
        return self._over.tobytes() != self.error_over.tobytes()

    def check_error(self) -> np.ndarray | None:
        """|TE| > ER (ER -1 disables): the ERROR output; with OE1 the motor turns off (SC 8).
        Returns the mask of axes that newly exceeded the limit, None if none [M Ch2 Step 7a]."""
        if not self.error_changed():  # no axis crossed ER either way
            return None
        over, new = self._over, self._new
        np.greater(over, self.error_over, new)
        self.error_over[...] = over
        if not np.count_nonzero(new):
            return None
        trip = new & (self.values["OE"] > 0)
        if trip.any():
            axes = np.flatnonzero(trip).tolist()
            self.motor_off(axes)
            self.oe_tripped[axes] = True
            self.stop_code[axes] = StopCode.OFF_ON_ERROR
        return new

    # -- what the card reports ---------------------------------------------------------------------
    def reference(self) -> np.ndarray:
        """RP: the profiler's commanded position, whole counts."""
        return np.rint(self.core.axes.cmd_pos)

    def position(self) -> np.ndarray:
        """TP: the main encoder (on a stepper card its own counter, which DE defines)."""
        return self.core.axes.encoder + self.enc_offset

    def error(self) -> np.ndarray:
        """TE = commanded - actual [M Ch2 Ex5]."""
        return self.reference() - self.position()

    def auxiliary(self) -> np.ndarray:
        """TD: the auxiliary encoder (what DE set: no encoder is modelled there); on a stepper
        axis the step count [M Ch6 §Stepper]."""
        if self.plant_kind == PlantKind.STEPPER:
            return np.rint(self.core.axes.pos)
        return self.aux.copy()

    def torque(self) -> np.ndarray:
        """TT: the DAC output in volts."""
        out = np.clip(np.rint(self.core.axes.out), -DAC_FULL_SCALE, DAC_FULL_SCALE)
        return out * self.dac_sign / COUNTS_PER_VOLT

    def destination(self) -> np.ndarray:
        """_PA: the destination while moving, else the commanded position [M Ch6]."""
        moving = self.core.profile.moving & self.core.target_valid
        return np.where(moving, self.core.target.astype(float), self.reference())

    def status_word(self) -> np.ndarray:
        """The axis status word of the data record, per axis (vectorised)."""
        core, ax = self.core, self.core.axes
        moving = core.profile.moving
        mode, phase = self.mode, self.phase
        pm = core.profile.mode
        s = np.zeros(self.n, dtype=np.int64)
        s |= moving * int(AxisStatus.MOVING)
        s |= (moving & ((mode == Mode.PR) | (mode == Mode.PA))) * int(AxisStatus.PA_OR_PR)
        s |= (moving & (mode == Mode.PA)) * int(AxisStatus.PA_ONLY)
        s |= ((phase != Phase.NONE) & (mode == Mode.FE)) * int(AxisStatus.FIND_EDGE)
        hm = (phase != Phase.NONE) & (mode == Mode.HM)
        s |= hm * int(AxisStatus.HOMING)
        s |= (hm & (phase >= Phase.BACK)) * int(AxisStatus.HM_PHASE1)
        s |= ((hm & (phase >= Phase.INDEX)) | ((mode == Mode.FI) & (phase != Phase.NONE))) * int(
            AxisStatus.HM_PHASE2_OR_FI)
        s |= (moving & (ax.cmd_vel < 0)) * int(AxisStatus.NEGATIVE)
        s |= (moving & (ax.cmd_acc == 0) & (ax.cmd_vel != 0)) * int(AxisStatus.SLEWING)
        stopping = moving & ((self.stop_reason > 0) | (pm == ProfileMode.STOPPING))
        s |= stopping * int(AxisStatus.STOPPING)
        s |= (moving & ~stopping & (ax.cmd_acc * ax.cmd_vel < 0)) * int(AxisStatus.FINAL_DECEL)
        s |= self.latch_armed * int(AxisStatus.LATCH_ARMED)
        s |= self.oe_tripped * int(AxisStatus.OFF_ON_ERROR)
        s |= ~core.servo_on_mask * int(AxisStatus.MOTOR_OFF)
        return s

    def switches(self, latch_inputs: np.ndarray) -> np.ndarray:
        """The axis switch byte; limit bits are logic levels (1 = switch not tripped), as
        `_LFx`/`_LRx` and TS read them [M Ch3 §Limit Switch Input]."""
        s = np.zeros(self.n, dtype=np.int64)
        if self.plant_kind == PlantKind.STEPPER:
            s |= int(AxisSwitch.SM_JUMPER)
        s |= self.home_input * int(AxisSwitch.HOME)
        s |= ~self.reverse_limit * int(AxisSwitch.REVERSE_LIMIT)
        s |= ~self.forward_limit * int(AxisSwitch.FORWARD_LIMIT)
        s |= latch_inputs * int(AxisSwitch.LATCH_INPUT)
        s |= self.latch_occurred * int(AxisSwitch.LATCH_OCCURRED)
        return s

    def tell_switches(self) -> np.ndarray:
        """TS: bit 7 in motion, 6 error limit exceeded, 5 motor off, 3/2 forward/reverse limit
        inactive, 1 home input, 0 latch not armed (spec §4.4)."""
        s = np.zeros(self.n, dtype=np.int64)
        s |= self.core.profile.moving * 0x80
        s |= self.error_over * 0x40
        s |= ~self.core.servo_on_mask * 0x20
        s |= ~self.forward_limit * 0x08
        s |= ~self.reverse_limit * 0x04
        s |= self.home_input * 0x02
        s |= ~self.latch_armed * 0x01
        return s
