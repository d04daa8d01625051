"""The motion core of one card: servo plant -> profile -> ideal/stepper plants -> encoder ->
following error -> PID, every tick (the order of a card's servo interrupt, see MotionCore).

Vectorised over the card's axes: the tick path has no Python loop over axes (only over the at most
three plant kinds), and costs about 20 numpy calls for servo axes in motion with every feature on.
Unused features (servo off, ideal or stepper axes, encoder loss, slip or scale, following-error limit,
PID limits, peak torque, friction) cost nothing, and the profile step is skipped while no axis
profiles. Commands plan at command time (a loop over the commanded axes is fine there). Events (a
profile ended, a limit or following-error trip, an amplifier fault) are returned as AxisFlag bits
so firmware can react at the exact tick; `run(n)` stops right after such a tick.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from vdevd.rt import kernel as kn
from vdevd.rt.axes import MOTION_STICKY, Axes, AxisFlag, PlantKind, ProfileMode
from vdevd.rt.filters import Pid
from vdevd.rt.limits import Limits
from vdevd.rt.plants import ServoPlant, StepperPlant, default_gains
from vdevd.rt.profiles import Phase, ProfileGenerator

Selector = int | slice | Sequence[int] | np.ndarray
#: plan(t, p, v, goal) -> the phases from time t and commanded state (p, v) to rest at goal
Planner = Callable[[float, float, float, float], list[Phase]]

_MOVING, _DONE = int(AxisFlag.MOVING), int(AxisFlag.DONE)
_STOPPED, _ABORTED = int(AxisFlag.STOPPED_BY_LIMIT), int(AxisFlag.ABORTED)
_NOT_STICKY = ~int(MOTION_STICKY)
_FE_TRIP, _SERVO_ON = int(AxisFlag.FE_TRIP), int(AxisFlag.SERVO_ON)
_HOMED = int(AxisFlag.HOMED)


class MotionCore:
    """Axes, profile generator, PID, plants and limits of one card.

    `plant` holds the servo parameters (ServoPlant), `stepper` the pulse-rate limits
    (StepperPlant); `encoder_scale` (set_encoder_scale) is encoder counts per count of position.

    One tick, in the order of a card's servo interrupt: the servo plant runs one period with the
    output computed at the previous tick (zero-order hold); the profile advances to the new
    command; ideal and stepper axes follow it; the encoder is sampled; ferr = cmd_pos - encoder
    is the PID's error; the following-error limit is checked; the PID computes the new output.
    """

    def __init__(self, n: int, dt_ns: float, plant: PlantKind | Sequence[PlantKind] = PlantKind.SERVO,
                 compiled: bool | None = None) -> None:
        """`compiled`: tick with the compiled kernel (vdevd.rt.kernel) and plan trapezoids with
        the compiled planner (vdevd.rt.profile_kernel); None: when they are available (numba
        installed, VDEVD_JIT not 0), False: the numpy and Python paths."""
        if n < 1 or dt_ns <= 0:
            raise ValueError("need at least one axis and a positive period")
        self.n, self.dt_ns, self.dt = n, dt_ns, dt_ns / 1e9
        kinds = [PlantKind(plant)] * n if isinstance(plant, int) else [PlantKind(k) for k in plant]
        if len(kinds) != n:
            raise ValueError(f"{len(kinds)} plant kinds for {n} axes")
        self.kinds = np.array([int(k) for k in kinds], dtype=np.int64)
        self.axes = Axes(n)
        #: the per-axis coefficients the tick reads, one block (rows: vdevd.rt.kernel); the
        #: parts below own their rows as views and write them in place
        self.coef = c = np.zeros((kn.ROWS, n))
        self.pid = Pid(n, self.axes.pid_terms, c[kn.PID_GAINS:kn.PID_HOLD_SAT + 1])
        self.pid.set(slice(None), **default_gains(self.dt))
        self.profile = ProfileGenerator(self.axes, self.dt, c[kn.JSTEP:kn.JSTEP + 3],
                                        compiled)
        self.plant = ServoPlant(n, self.dt, c[kn.GAIN_DT:kn.COUL_DT + 1])
        self._stepper = StepperPlant(n, self.dt, c[kn.STEP_GEN:kn.STEP_LIM + 1])
        self._own_stepper = True
        self.limits = Limits(n, c[kn.FE_OVER])
        self._kernel = kn.compiled() if compiled is None or compiled else None
        if compiled and self._kernel is None:
            raise RuntimeError("the compiled motion core is not available (numba)")
        self._ax_flags = np.zeros(n, dtype=np.int64)  # kernel.AX_* of each axis
        #: the axes `track` set tracking (their key and indices) and the profile's plans then
        self._track_key: Any = None
        self._track_idx = np.zeros(0, dtype=np.intp)
        self._track_plans = -1
        self._kmode = 0
        #: a scope's stage block and what empties it (`stage_into`)
        self._stage_block: np.ndarray | None = None
        self._on_stage_full: Callable[[], None] | None = None
        self.servo_on_mask = np.zeros(n, dtype=bool)
        self.amp_fault = np.zeros(n, dtype=bool)
        self.encoder_loss = np.zeros(n, dtype=bool)
        self.encoder_slip = c[kn.SLIP]  # counts the encoder has lost (slip_encoder)
        self.home_switch = np.zeros(n, dtype=bool)
        self._scale = c[kn.SCALE]
        self._scale[:] = 1.0
        self._inv_scale = c[kn.INV_SCALE]
        self.encoder_scale = self._scale.view()  # read-only: set_encoder_scale
        self.encoder_scale.flags.writeable = False
        self.target = np.zeros(n, dtype=np.int64)  # last move target (move_relative's origin)
        self.target_valid = np.ones(n, dtype=bool)  # False after a jog, stop or abort
        self.last_dec = np.full(n, np.inf)
        self.last_jerk = np.zeros(n)
        self.done_bits = np.zeros(n, dtype=np.int64)  # bits latched with DONE (a soft-limit stop)
        self._pending = 0
        self._enc = c[kn.ENC]  # the encoder as floats, in encoder counts
        self._tmp = np.zeros(n)
        self._pv2 = np.zeros((2, n))
        #: the actual position minus the stage's physical position: what redefinitions of zero
        #: (set_position, a home found, redefine_and_stop) have shifted (`physical`)
        self.zero = np.zeros(n)
        #: the motor is blocked (backdoor `jam`): the stage stays at `_jam_pos`
        self.jammed = np.zeros(n, dtype=bool)
        self._jam_pos = c[kn.JAM_POS]
        self._has_servo = bool((self.kinds == PlantKind.SERVO).any())
        self._configure()

    def _configure(self) -> None:
        """Derive the tick's switches and masks from plant kinds, servo state and inputs."""
        kinds, on = self.kinds, self.servo_on_mask
        servo = kinds == PlantKind.SERVO
        self.pid.enable(servo & on)
        self.plant.enable(servo)
        self._any_off = not bool(on.all())
        self._off = ~on
        ideal_on = (kinds == PlantKind.IDEAL) & on
        step_on = (kinds == PlantKind.STEPPER) & on
        self._ideal_on2 = np.array([ideal_on, ideal_on])  # a (2, n) mask: no broadcasting per tick
        self._step_on2 = np.array([step_on, step_on])
        self._all_ideal = bool(ideal_on.all())
        self._all_step = bool(step_on.all())
        self._any_ideal = bool(ideal_on.any())
        self._any_step = bool(step_on.any())
        self._enc_ok = ~self.encoder_loss
        self._any_loss = bool(self.encoder_loss.any())
        self._any_slip = bool(self.encoder_slip.any())
        self._scaled = bool((self.encoder_scale != 1.0).any())
        np.divide(1.0, self.encoder_scale, out=self._inv_scale)
        self._plain_encoder = not (self._scaled or self._any_loss or self._any_slip)
        self._any_jam = bool(self.jammed.any())
        self._enc[:] = self.axes.encoder  # where a lost encoder freezes
        self._ax_flags[...] = (ideal_on * kn.AX_IDEAL + step_on * kn.AX_STEP + self._off * kn.AX_OFF
                               + self.jammed * kn.AX_JAM + self._enc_ok * kn.AX_ENC_OK)
        self._kmode = ((kn.PLANT | kn.PID if self._has_servo else 0) | kn.FOLLOW
                       | (kn.PLAIN_ENCODER if self._plain_encoder else 0)
                       | (kn.STEPPERS if self._any_step else 0)
                       | (self._kmode & kn.RECORD))

    @property
    def stepper(self) -> StepperPlant:
        """The stepper plant; a card may put its own in (a StepperPlant whose `step` it
        overrides): while one of its axes is on, the core then ticks its numpy path."""
        return self._stepper

    @stepper.setter
    def stepper(self, plant: StepperPlant) -> None:
        self._stepper = plant
        self._own_stepper = plant.gen.base is self.coef and type(plant).step is StepperPlant.step

    # -- the tick ----------------------------------------------------------------------------------
    def tick(self) -> int:
        """One servo tick; the AxisFlag bits of what happened (0 when nothing did)."""
        kernel = self._kernel
        if kernel is None or (self._any_step and not self._own_stepper):
            if self._kmode & kn.RECORD:
                return self._tick_numpy_staged()
            return self.tick_numpy()
        events = self._pending
        if events:
            self._pending = 0
        prof, ax = self.profile, self.axes
        prof.ticks += 1
        prof.t = t = prof._t_base + (prof.ticks - prof._ticks_base) * prof.dt
        mode = self._kmode
        if self.stepper._limited:
            mode |= kn.STEP_LIMITED
        if self.plant._friction:
            mode |= kn.FRICTION
        if t < prof.next_t:
            if prof.active:
                mode |= kn.PROFILE
            over = kernel(mode, ax.state, ax.encoder, self.coef, self._ax_flags, prof._m3, self.dt)
        else:
            kernel(mode & ~(kn.FOLLOW | kn.PID | kn.RECORD), ax.state, ax.encoder, self.coef,
                   self._ax_flags, prof._m3, self.dt)
            finished = prof.boundary(t)
            if len(finished):
                events |= self._finish(finished)
            mode = self._kmode | (mode & (kn.STEP_LIMITED | kn.FRICTION))
            over = kernel(mode & ~kn.PLANT, ax.state, ax.encoder, self.coef, self._ax_flags,
                          prof._m3, self.dt)
        if over:
            if over == 1:
                hit = self.limits.fe_exceeded(ax.ferr)
                if hit is not None:
                    events |= self._fe_trip(hit)
                over = kernel(self._kmode & (kn.PID | kn.RECORD), ax.state, ax.encoder,
                              self.coef, self._ax_flags, prof._m3, self.dt)
            if over:  # 2: the stage is full (`stage_into`)
                self._stage_full()
        return events

    # -- staging (a scope recording, issue 23 §1) ------------------------------------------------
    def stage_into(self, block: np.ndarray, on_full: Callable[[], None]) -> None:
        """From the next tick, stage a sample of the state after each whole tick into `block`
        (a stage block, vdevd.rt.kernel "Staging": counters set by the caller), the compiled
        kernel's copy (no Python per tick); `on_full()` once a tick staged LIMIT samples (it
        takes them: STAGED 0). The numpy path stages the same samples."""
        prof = self.profile
        block[:3, :3] = prof._m3
        prof._m3 = block  # the kernel's step comes from its top-left corner
        self._stage_block = block
        self._on_stage_full = on_full
        self._kmode |= kn.RECORD

    def stop_staging(self) -> None:
        """No more samples staged: the tick as before `stage_into`."""
        block = self._stage_block
        if block is None:
            return
        self._kmode &= ~kn.RECORD
        self.profile._m3 = np.ascontiguousarray(block[:3, :3])
        self._stage_block = None
        self._on_stage_full = None

    @property
    def staging(self) -> np.ndarray | None:
        """The stage block samples go into (`stage_into`), or None."""
        return self._stage_block

    def _stage_full(self) -> None:
        if self._on_stage_full is not None:
            self._on_stage_full()

    def _tick_numpy_staged(self) -> int:
        """`tick_numpy`, then its sample staged as the kernel stages it."""
        events = self.tick_numpy()
        b = self._stage_block
        assert b is not None
        h = b[:, 0]
        c = h[kn.COUNTDOWN] - 1.0
        if c > 0.0:
            h[kn.COUNTDOWN] = c
            return events
        h[kn.COUNTDOWN] = h[kn.EVERY]
        m, row = int(h[kn.NCOLS]), kn.STAGE_HEAD + int(h[kn.SLOT])
        at = b[kn.CELL_ROWS:kn.CELL_AXES + 1, :m].astype(np.intp)
        b[row, :m] = self.axes.state[at[0], at[1]]
        h[kn.SLOT] = 0 if row + 1 == len(b) else row + 1 - kn.STAGE_HEAD
        h[kn.STAGED] += 1
        if h[kn.STAGED] >= h[kn.LIMIT]:
            self._stage_full()
        return events

    def tick_numpy(self) -> int:
        """`tick` with numpy calls (the reference the compiled kernel follows; the path
        without numba)."""
        events = self._pending
        if events:
            self._pending = 0
        ax = self.axes
        servo = self._has_servo
        if servo:
            self.plant.step(ax.out, ax.pos, ax.vel)
        finished = self.profile.advance()
        if finished is not None and len(finished):
            events |= self._finish(finished)
        if self._any_ideal:
            if self._all_ideal:
                ax.pv[...] = ax.cmd_pv
            else:
                np.copyto(ax.pv, ax.cmd_pv, where=self._ideal_on2)
        if self._any_step:
            self._step()
        if self._any_jam:  # a blocked motor: the stage does not move, the error grows
            np.copyto(ax.pos, self._jam_pos, where=self.jammed)
            ax.vel[self.jammed] = 0.0
        if self._any_off:  # servo off: the command follows the actual position
            np.copyto(ax.cmd_pos, ax.pos, where=self._off)
        fb = ax.fb
        if self._plain_encoder:
            np.floor(ax.pos, fb)
            ax.encoder[...] = fb
        else:
            self._encode()
        np.subtract(ax.cmd_pos, fb, ax.ferr)
        limits = self.limits
        if limits.fe_enabled:
            over = limits.fe_exceeded(ax.ferr)
            if over is not None:
                events |= self._fe_trip(over)
        if servo:
            self.pid.update(ax.out)
        return events

    def _step(self) -> None:
        """Stepper axes (servo on) follow the command in whole steps."""
        ax = self.axes
        if self._all_step:
            self.stepper.step(ax.cmd_pos, ax.pos, ax.vel)
            return
        pv2 = self._pv2
        pv2[...] = ax.pv
        self.stepper.step(ax.cmd_pos, pv2[0], pv2[1])
        np.copyto(ax.pv, pv2, where=self._step_on2)

    def _encode(self) -> None:
        """Encoder with a scale, with slipped counts or with lost encoders (frozen while lost)."""
        ax, tmp = self.axes, self._tmp
        if self._scaled:
            np.multiply(ax.pos, self.encoder_scale, out=tmp)
            np.floor(tmp, out=tmp)
        else:
            np.floor(ax.pos, out=tmp)
        if self._any_slip:
            tmp -= self.encoder_slip
        np.copyto(self._enc, tmp, where=self._enc_ok)
        ax.encoder[:] = self._enc
        np.multiply(self._enc, self._inv_scale, out=ax.fb)

    def run(self, n: int) -> tuple[int, int]:
        """Up to n ticks; stops right after the first tick with events. (ticks done, events).
        Refreshes IN_POSITION before returning."""
        tick = self.tick
        for i in range(n):
            events = tick()
            if events:
                self.update_in_position()
                return i + 1, events
        self.update_in_position()
        return n, 0

    # -- rest (DESIGN.md "Time that costs nothing") ------------------------------------------------
    def rest_state(self) -> bytes | None:
        """Everything a tick may change, as bytes, except the profile clock (`skip` advances it);
        None while a profile runs or a phase boundary or an event is due. Equal results around
        one tick prove the core at a fixed point: the next ticks change nothing until a command
        or an input does (the card compares: Card.rest_state)."""
        prof = self.profile
        if self._pending or prof.active or prof.next_t != math.inf:
            return None
        ax = self.axes
        return b"".join((ax.state.tobytes(), ax.encoder.tobytes(), ax.flags.tobytes(),
                         self.stepper.gen.tobytes(), self._enc.tobytes()))

    def skip(self, k: int) -> None:
        """k ticks at rest in closed form: only the profile clock moves (see rest_state)."""
        self.profile.skip(k)

    def update_in_position(self) -> None:
        """IN_POSITION: no profile running and |ferr| within the in-position band. Not done
        every tick (it is a status, not an event): `run` refreshes it at its end."""
        flags = self.axes.flags
        np.abs(self.axes.ferr, out=self._tmp)
        ok = (self._tmp <= self.limits.in_position) & ~self.profile.moving
        flags &= ~int(AxisFlag.IN_POSITION)
        flags |= ok * int(AxisFlag.IN_POSITION)

    # -- events ----------------------------------------------------------------------------------
    def _finish(self, idx: np.ndarray) -> int:
        """Profiles of axes `idx` ended: DONE (with any latched limit bits), MOVING cleared."""
        flags, bits = self.axes.flags, self.done_bits[idx]
        flags[idx] = (flags[idx] & ~_MOVING) | _DONE | bits
        return _DONE | int(np.bitwise_or.reduce(bits))

    def _fe_trip(self, over: np.ndarray) -> int:
        flags = self.axes.flags
        new = over & ((flags & _FE_TRIP) == 0)
        if not new.any():
            return 0
        flags[new] |= _FE_TRIP
        return _FE_TRIP

    def _after_plan(self, a: int) -> None:
        """Set MOVING after a plan; a plan that is already complete is DONE at once (the event
        is reported by the next tick)."""
        flags = self.axes.flags
        if self.profile.moving[a]:
            flags[a] |= _MOVING
        else:
            bits = int(self.done_bits[a])
            flags[a] = (flags[a] & ~_MOVING) | _DONE | bits
            self._pending |= _DONE | bits

    def _refuse(self, a: int, bits: int) -> None:
        """A command toward an active limit: not executed; an axis moving stops (limit decel)."""
        self.axes.flags[a] |= _STOPPED | bits
        self._pending |= _STOPPED | bits
        if self.profile.moving[a]:
            self._limit_stop(a, bits)
        else:
            self.done_bits[a] = _STOPPED | bits
            self._after_plan(a)

    def _limit_stop(self, a: int, bits: int) -> None:
        """Decelerate axis a with the limit deceleration (or its command's); DONE carries `bits`."""
        dec = float(self.limits.limit_dec[a])
        if math.isinf(dec):
            dec = float(self.last_dec[a])
        self.done_bits[a] = _STOPPED | bits
        self.target_valid[a] = False
        if math.isinf(dec) or dec <= 0:
            self.profile.hold(a, float(self.axes.cmd_pos[a]))
        else:
            self.profile.stop(a, dec, float(self.last_jerk[a]))
        self._after_plan(a)

    # -- commands --------------------------------------------------------------------------------
    def _select(self, axes: Selector) -> np.ndarray:
        return np.atleast_1d(np.arange(self.n)[axes])

    @staticmethod
    def _per_axis(value: Any, count: int) -> np.ndarray:
        return np.broadcast_to(np.asarray(value, dtype=float), (count,))

    def _begin(self, idx: np.ndarray) -> None:
        """A motion command clears DONE, ABORTED and the limit-stop bits of its axes."""
        self.axes.flags[idx] &= ~int(MOTION_STICKY)
        self.done_bits[idx] = 0

    @staticmethod
    def _check(positive: Sequence[np.ndarray], jerk: np.ndarray) -> None:
        for arr in positive:
            if not (np.isfinite(arr).all() and (arr > 0).all()):
                raise ValueError("vmax, acc and dec must be positive and finite")
        if not (np.isfinite(jerk).all() and (jerk >= 0).all()):
            raise ValueError("jerk must be >= 0 and finite")

    def move_absolute(self, axes: Selector, target_counts: Any, vmax: Any, acc: Any, dec: Any,
                      jerk: Any = 0.0) -> None:
        """Point-to-point move to integer targets: trapezoid (jerk 0) or S-curve; replans from
        the current commanded state when the axis is already moving (on-the-fly retarget)."""
        idx = self._select(axes)
        k = len(idx)
        targets = np.rint(self._per_axis(target_counts, k))
        vs, accs, decs = self._per_axis(vmax, k), self._per_axis(acc, k), self._per_axis(dec, k)
        jerks = self._per_axis(jerk, k)
        self._check((vs, accs, decs), jerks)
        if not np.isfinite(targets).all():
            raise ValueError("targets must be finite")
        self._begin(idx)
        for a, t, v, ac, de, j in zip(idx.tolist(), targets.tolist(), vs.tolist(), accs.tolist(),
                                      decs.tolist(), jerks.tolist(), strict=True):
            self._move_to(a, t, v, ac, de, j)
        self.profile.commit()

    def move_one(self, axis: int, target: float, vmax: float, acc: float, dec: float,
                 jerk: float = 0.0, commit: bool = True) -> None:
        """`move_absolute` of one axis with plain numbers (a card's per-axis command, without
        the broadcasting); `commit=False` leaves `profile.commit()` to the caller, who plans
        several axes in a row."""
        isfinite = math.isfinite  # (no generator: a card's command runs this for every axis)
        if not (isfinite(vmax) and vmax > 0 and isfinite(acc) and acc > 0 and isfinite(dec)
                and dec > 0):
            raise ValueError("vmax, acc and dec must be positive and finite")
        if not (isfinite(jerk) and jerk >= 0):
            raise ValueError("jerk must be >= 0 and finite")
        if not isfinite(target):
            raise ValueError("targets must be finite")
        a = int(axis)
        self.axes.flags[a] &= _NOT_STICKY
        self.done_bits[a] = 0
        self._move_to(a, float(round(target)), vmax, acc, dec, jerk)
        if commit:
            self.profile.commit()

    def _move_to(self, a: int, t: float, vmax: float, acc: float, dec: float,
                 jerk: float) -> None:
        """Plan axis a's move to the whole count t within its limits (or refuse it)."""
        here = float(self.axes.cmd_pos[a])
        if self.limits.blocked(a, t - here):
            self._refuse(a, 0)
            return
        goal, bits = self.limits.soft_target(a, here, t)
        if bits and goal == here:
            self._refuse(a, bits)
            return
        self._move(a, goal, bits, vmax, acc, dec, jerk)

    def _move(self, a: int, goal: float, bits: int, vmax: float, acc: float, dec: float,
              jerk: float) -> None:
        self.target[a], self.target_valid[a] = int(goal), True
        self.last_dec[a], self.last_jerk[a] = dec, jerk
        self.done_bits[a] = _STOPPED | bits if bits else 0
        self.profile.move(a, int(goal), vmax, acc, dec, jerk)
        self._after_plan(a)

    def move_planned(self, axis: int, target: float, plan: Planner, dec: float) -> None:
        """A point-to-point move of one axis along phases its caller plans (a card's own profile
        shape, e.g. one that starts at a base velocity): `plan(t, p, v, goal)` returns the phases
        from now and the commanded state to rest at the integer `goal`, the last one a hold
        there. Limits, flags and the target as `move_absolute`; `dec` is the deceleration a
        limit stop uses."""
        a = int(axis)
        if not (math.isfinite(target) and dec > 0):
            raise ValueError("target must be finite and dec positive")
        self._begin(np.array([a]))
        here, t = float(self.axes.cmd_pos[a]), float(np.rint(target))
        goal, bits = self.limits.soft_target(a, here, t)
        if self.limits.blocked(a, t - here):
            self._refuse(a, 0)
        elif bits and goal == here:
            self._refuse(a, bits)
        else:
            self.target[a], self.target_valid[a] = int(goal), True
            self.last_dec[a], self.last_jerk[a] = dec, 0.0
            self.done_bits[a] = _STOPPED | bits if bits else 0
            p, v, _ = self.profile.state(a)
            self.profile.load(a, plan(self.profile.t, p, v, goal), mode=ProfileMode.TRAPEZOID)
            self._after_plan(a)
        self.profile.commit()

    def move_relative(self, axes: Selector, distance: Any, vmax: Any, acc: Any, dec: Any,
                      jerk: Any = 0.0) -> None:
        """A move by `distance` counts from the last target (from the rounded commanded position
        after a jog, stop or abort)."""
        idx = self._select(axes)
        base = np.where(self.target_valid[idx], self.target[idx], np.rint(self.axes.cmd_pos[idx]))
        targets = base + np.rint(self._per_axis(distance, len(idx)))
        self.move_absolute(idx, targets, vmax, acc, dec, jerk)

    def jog(self, axes: Selector, velocity: Any, acc: Any, dec: Any, jerk: Any = 0.0) -> None:
        """Run at a signed velocity; a new velocity ramps on the fly (through zero on reversal,
        decelerating with dec then accelerating with acc). A jog toward a soft limit is planned
        to stop exactly at it."""
        idx = self._select(axes)
        k = len(idx)
        vels, accs, decs = self._per_axis(velocity, k), self._per_axis(acc, k), self._per_axis(dec, k)
        jerks = self._per_axis(jerk, k)
        self._check((accs, decs), jerks)
        if not np.isfinite(vels).all():
            raise ValueError("velocity must be finite")
        self._begin(idx)
        for a, v, ac, de, j in zip(idx.tolist(), vels.tolist(), accs.tolist(), decs.tolist(),
                                   jerks.tolist(), strict=True):
            here = float(self.axes.cmd_pos[a])
            if self.limits.blocked(a, v):
                self._refuse(a, 0)
                continue
            goal, bits = self.limits.soft_target(a, here, math.copysign(math.inf, v) if v else here)
            if bits:
                if goal == here:
                    self._refuse(a, bits)
                else:
                    self._move(a, goal, bits, abs(v), ac, de, j)
                    self.target_valid[a] = False
                continue
            self.last_dec[a], self.last_jerk[a] = de, j
            self.target_valid[a] = False
            self.profile.jog(a, v, ac, de, j)
            self._after_plan(a)
        self.profile.commit()

    def home(self, axes: Selector, velocity: Any, acc: Any, dec: Any, jerk: Any = 0.0) -> None:
        """Home search: a jog at the signed `velocity` until the home switch becomes active;
        there the encoder reading becomes position 0, HOMED is set and the axis stops with `dec`
        (DONE). An axis already on its switch is homed where it is. Otherwise as `jog`: a search
        toward an active hard limit is refused, one toward a soft limit ends there unhomed."""
        idx = self._select(axes)
        self.jog(idx, velocity, acc, dec, jerk)
        self.axes.flags[idx] &= ~_HOMED
        mode = self.profile.mode
        search = idx[mode[idx] == ProfileMode.JOG]
        mode[search] = ProfileMode.HOMING
        self._home_found(search[self.home_switch[search]])

    def _home_found(self, idx: np.ndarray) -> None:
        """Searching axes `idx` found their home switch: the encoder there becomes position 0,
        HOMED is set, and the axis stops with its search's deceleration."""
        if not len(idx):
            return
        for a in idx.tolist():
            self.axes.flags[a] |= _HOMED
            self.redefine_and_stop(a, 0, float(self.last_dec[a]))

    def redefine_and_stop(self, axis: int, counts: float, dec: float) -> None:
        """A reference mark found at speed: the encoder reading of `axis` becomes `counts`
        (whole counts) without motion (the actual and commanded positions shift with it, so the
        following error is unchanged), and the axis decelerates to a stop with `dec` from there."""
        a, ax, whole = axis, self.axes, float(np.rint(counts))
        if self.encoder_slip[a]:
            self._clear_slip(np.array([a]))
        shift = whole - float(ax.fb[a])
        ax.pos[a] += shift
        self.zero[a] += shift
        self._jam_pos[a] += shift
        ax.cmd_pos[a] += shift  # the stop below plans from the shifted command
        self.stepper.gen[a] += shift
        enc = math.floor(whole * float(self._scale[a]) + 1e-9)
        self._enc[a], ax.encoder[a] = enc, enc
        ax.fb[a] = enc * float(self._inv_scale[a])
        self.done_bits[a] = 0
        self.target_valid[a] = False
        self.profile.stop(a, dec, float(self.last_jerk[a]))
        self._after_plan(a)
        self.profile.commit()

    def stop(self, axes: Selector, dec: Any = None) -> None:
        """Decelerate to standstill with `dec` (default: the last command's deceleration); axes
        not moving are left alone."""
        idx = self._select(axes)
        decs = self.last_dec[idx] if dec is None else self._per_axis(dec, len(idx))
        for a, de in zip(idx.tolist(), decs.tolist(), strict=True):
            if not self.profile.moving[a]:
                continue
            self.done_bits[a] = 0
            self.target_valid[a] = False
            if math.isinf(de) or de <= 0:
                self.profile.hold(a, float(self.axes.cmd_pos[a]))
            else:
                self.profile.stop(a, de, float(self.last_jerk[a]))
            self._after_plan(a)
        self.profile.commit()

    def abort(self, axes: Selector, dec: Any = None) -> None:
        """Abort: the profile stops at once (or decelerates with `dec`); sets ABORTED."""
        idx = self._select(axes)
        flags = self.axes.flags
        decs = None if dec is None else self._per_axis(dec, len(idx)).tolist()
        for i, a in enumerate(idx.tolist()):
            flags[a] |= _ABORTED
            if not self.profile.moving[a]:
                continue
            self.done_bits[a] = _ABORTED
            self.target_valid[a] = False
            if decs is not None and decs[i] > 0 and math.isfinite(decs[i]):
                self.profile.stop(a, decs[i], 0.0, ProfileMode.ABORTING)
            else:
                self.profile.hold(a, float(self.axes.cmd_pos[a]))
            self._after_plan(a)
        self.profile.commit()

    def servo_on(self, axes: Selector) -> None:
        """Close the loop holding the present position; clears FE_TRIP. Refused (left off)
        while the axis has an amplifier fault."""
        idx = self._select(axes)
        idx = idx[~self.amp_fault[idx]]
        ax = self.axes
        self.servo_on_mask[idx] = True
        ax.flags[idx] = (ax.flags[idx] | _SERVO_ON) & ~_FE_TRIP
        self.stepper.gen[idx] = ax.pos[idx]
        self.pid.reset(idx)
        self.target_valid[idx] = False
        servo = (self.kinds == PlantKind.SERVO).tolist()
        for a in idx.tolist():
            self.profile.hold(a, float(ax.fb[a] if servo[a] else ax.pos[a]))
        self.profile.commit()
        self._configure()

    def servo_off(self, axes: Selector) -> None:
        """Open the loop: output 0, the plant coasts, the command follows the actual position.
        A profile running is aborted."""
        idx = self._select(axes)
        self.abort(idx[self.profile.moving[idx]])
        self.servo_on_mask[idx] = False
        ax = self.axes
        ax.flags[idx] &= ~_SERVO_ON
        ax.out[idx] = 0.0
        ax.vel[idx[self.kinds[idx] != PlantKind.SERVO]] = 0.0  # ideal and stepper axes halt
        self._configure()

    def set_position(self, axes: Selector, counts: Any) -> None:
        """Define the present position as `counts` without motion: the actual position shifts by
        the same amount, so the encoder reads `counts` (integers) and the following error is 0.
        A profile running stops at once."""
        idx = self._select(axes)
        c = np.rint(self._per_axis(counts, len(idx)))
        ax = self.axes
        if self._any_slip:
            self._clear_slip(idx)
        shift = c - ax.fb[idx]
        ax.pos[idx] += shift
        self.zero[idx] += shift
        self._jam_pos[idx] += shift
        self.stepper.gen[idx] += shift
        enc = np.floor(c * self.encoder_scale[idx])
        self._enc[idx] = enc
        ax.encoder[idx] = enc
        ax.fb[idx] = enc * self._inv_scale[idx]
        ax.ferr[idx] = c - ax.fb[idx]
        self.target[idx], self.target_valid[idx] = c, True
        self.pid.reset(idx)
        flags = ax.flags
        for a, p in zip(idx.tolist(), c.tolist(), strict=True):
            if self.profile.moving[a]:
                flags[a] = (flags[a] & ~_MOVING) | _ABORTED | _DONE
                self._pending |= _DONE | _ABORTED
            self.profile.hold(a, p)
        self.profile.commit()

    def shift_position(self, axes: Selector, counts: Any) -> None:
        """Add whole `counts` to the position counters of `axes`, command and actual alike: the
        following error, the motion under way and the integrator are kept (a reference shift,
        e.g. the Octavia's POS_SHIFT)."""
        idx = self._select(axes)
        d = np.rint(self._per_axis(counts, len(idx)))
        ax = self.axes
        ax.pos[idx] += d
        self.zero[idx] += d
        self._jam_pos[idx] += d
        self.stepper.gen[idx] += d
        enc = np.floor(ax.pos[idx] * self.encoder_scale[idx]) - self.encoder_slip[idx]
        enc = np.where(self.encoder_loss[idx], self._enc[idx] + d, enc)
        self._enc[idx] = enc
        ax.encoder[idx] = enc
        ax.fb[idx] = enc * self._inv_scale[idx]
        self.target[idx] += d.astype(np.int64)
        for a, dist in zip(idx.tolist(), d.tolist(), strict=True):
            self.profile.shift(a, dist)
        self.profile.commit()

    def push(self, axes: Selector, counts: Any) -> None:
        """The mechanics of `axes` moved by hand by whole `counts` (backdoor `push`): the stage
        moves, the command does not, and the encoder reads the stage at once (its scale and slip
        as the tick's; a lost encoder stays frozen). Servo and ideal axes: the actual position
        moves, so the following error changes; servo off, the axis stays there (the next tick's
        command follows it); servo on, the loop pulls it back as the plant allows (an ideal axis
        at the next tick); a jammed stage stays where pushed. Stepper axes: the step count (their
        actual position) does not change; the stage moves away from it (`zero`) and their
        encoder slips by as much (`encoder_slip`), so the following error is the lost steps."""
        idx = self._select(axes)
        d = np.rint(self._per_axis(counts, len(idx)))
        if not np.isfinite(d).all():
            raise ValueError("counts must be finite")
        ax = self.axes
        step = self.kinds[idx] == PlantKind.STEPPER
        moved, dm = idx[~step], d[~step]
        ax.pos[moved] += dm
        self._jam_pos[moved] += dm
        steps, ds = idx[step], d[step]
        self.zero[steps] -= ds
        self.encoder_slip[steps] -= np.rint(ds * self.encoder_scale[steps])
        enc = np.floor(ax.pos[idx] * self.encoder_scale[idx]) - self.encoder_slip[idx]
        self._enc[idx] = np.where(self.encoder_loss[idx], self._enc[idx], enc)
        ax.encoder[idx] = self._enc[idx]
        ax.fb[idx] = self._enc[idx] * self._inv_scale[idx]
        ax.ferr[idx] = ax.cmd_pos[idx] - ax.fb[idx]
        if len(steps):
            self._configure()

    def track(self, axes: Selector, positions: Any) -> None:
        """The commanded positions of `axes` at the next tick, given by the caller every tick
        (a path sampled once a tick: contouring, cam and gear followers): each axis runs in a
        straight line to its position, MOVING, and on at that velocity until the next call;
        end with `hold` (or stop, abort). No limit checks: the caller plans the path.

        The same axes again with nothing re-planned in between (the path's every tick) take a
        cheap step (`ProfileGenerator.retrack`): only their phase's start moves."""
        prof = self.profile
        key = (axes.tobytes() if isinstance(axes, np.ndarray)
               else tuple(axes) if isinstance(axes, list | tuple) else None)
        if key is not None and key == self._track_key and prof.plans == self._track_plans:
            idx = self._track_idx
            pos = np.asarray(positions, dtype=float)
            if pos.shape != idx.shape:
                pos = self._per_axis(pos, len(idx))
            if not np.isfinite(pos).all():
                raise ValueError("positions must be finite")
            prof.retrack(idx, pos)
            return
        idx = self._select(axes)
        if not len(idx):
            return
        pos = self._per_axis(positions, len(idx))
        if not np.isfinite(pos).all():
            raise ValueError("positions must be finite")
        self._begin(idx)
        self.target_valid[idx] = False
        prof.reach_many(idx, np.asarray(pos, dtype=float))
        self.axes.flags[idx] |= _MOVING
        prof.commit()
        self._track_key, self._track_idx, self._track_plans = key, idx, prof.plans

    def hold(self, axes: Selector, positions: Any = None) -> None:
        """End a tracked path: the axes hold their commanded position now, or `positions`
        (where the path ends exactly, free of the rounding of its last straight piece) (DONE)."""
        idx = self._select(axes)
        at = (self.axes.cmd_pos[idx] if positions is None
              else self._per_axis(positions, len(idx)))
        if not np.isfinite(at).all():
            raise ValueError("positions must be finite")
        for a, p in zip(idx.tolist(), at.tolist(), strict=True):
            self.profile.hold(a, p)
            self.done_bits[a] = 0
            self._after_plan(a)
        self.profile.commit()

    def slip_encoder(self, axes: Selector, counts: Any) -> None:
        """The encoder slips: from the next tick it reads `counts` fewer (more if negative) than
        the position gives, until set_position or redefine_and_stop define its reading again.
        A servo's loop sees it (the motor moves on by that much); a stepper's does not."""
        idx = self._select(axes)
        values = self._per_axis(counts, len(idx))
        if not np.isfinite(values).all():
            raise ValueError("counts must be finite")
        self.encoder_slip[idx] += np.rint(values)
        self._configure()

    @property
    def any_slip(self) -> bool:
        """Whether any encoder has slipped (`encoder_slip` not all 0)."""
        return self._any_slip

    def _clear_slip(self, idx: np.ndarray) -> None:
        """Forget the slip of axes `idx`: `fb` becomes their reading without it (the redefinition
        that follows shifts the position by what the encoder then reads)."""
        self.axes.fb[idx] += self.encoder_slip[idx] * self._inv_scale[idx]
        self.encoder_slip[idx] = 0.0
        self._configure()

    def set_inputs(self, hard_limit_pos: Any = None, hard_limit_neg: Any = None,
                   amp_fault: Any = None, encoder_loss: Any = None, home: Any = None) -> None:
        """Backdoor inputs, one bool per axis (None: unchanged). A limit that becomes active
        stops an axis moving toward it; an amplifier fault aborts and turns the servo off; a home
        switch that becomes active ends a home search (`home`)."""
        ax, lim = self.axes, self.limits
        if encoder_loss is not None:
            self.encoder_loss[:] = np.asarray(encoder_loss, dtype=bool)
            self._set_bit(AxisFlag.ENCODER_LOSS, self.encoder_loss)
        if amp_fault is not None:
            new = np.asarray(amp_fault, dtype=bool)
            rising = np.flatnonzero(new & ~self.amp_fault)
            self.amp_fault[:] = new
            self._set_bit(AxisFlag.AMP_FAULT, new)
            if len(rising):
                self.abort(rising)
                self.servo_off(rising)
                self._pending |= int(AxisFlag.AMP_FAULT)
        for value, store, bit, sign in (
            (hard_limit_pos, lim.hard_pos, int(AxisFlag.HARD_LIMIT_POS), 1.0),
            (hard_limit_neg, lim.hard_neg, int(AxisFlag.HARD_LIMIT_NEG), -1.0),
        ):
            if value is None:
                continue
            new = np.asarray(value, dtype=bool)
            rising = np.flatnonzero(new & ~store)
            store[:] = new
            self._set_bit(AxisFlag(bit), new)
            heading = rising[self.profile.moving[rising] & (ax.cmd_vel[rising] * sign > 0)]
            for a in heading.tolist():
                ax.flags[a] |= _STOPPED
                self._pending |= bit | _STOPPED
                self._limit_stop(a, 0)
            if len(heading):
                self.profile.commit()
        if home is not None:
            new = np.asarray(home, dtype=bool)
            rising = np.flatnonzero(new & ~self.home_switch)
            self.home_switch[:] = new
            self._set_bit(AxisFlag.HOME_SWITCH, new)
            self._home_found(rising[self.profile.mode[rising] == ProfileMode.HOMING])
        self._configure()

    def set_period(self, dt_ns: float) -> None:
        """A new servo period from the next tick on (a card whose update rate changes): the
        profiles go on at their planned times; the PID gains, per sample, stay as they are."""
        if not dt_ns > 0:
            raise ValueError("the period must be positive")
        self.dt_ns, self.dt = dt_ns, dt_ns / 1e9
        self.profile.set_dt(self.dt)
        block, on_full = self._stage_block, self._on_stage_full
        if block is not None and on_full is not None:  # the new step into the stage block
            self.stage_into(block, on_full)
        self.plant.set_dt(self.dt)
        self.stepper.set_dt(self.dt)

    def physical(self) -> np.ndarray:
        """The stage's physical positions in counts: the actual positions less every
        redefinition of zero (a fresh array)."""
        return self.axes.pos - self.zero

    def set_jammed(self, axes: Selector, active: bool) -> None:
        """Block (or free) the motors of `axes`: the stage stays where it is while the command
        goes on, so the following error grows (backdoor `jam`)."""
        idx = self._select(axes)
        self.jammed[idx] = bool(active)
        self._jam_pos[idx] = self.axes.pos[idx]
        self.axes.vel[idx[self.jammed[idx]]] = 0.0
        self._configure()

    def follow_jams(self, jammed: np.ndarray) -> None:
        """Make the blocked motors those of `jammed` (one bool per axis), each newly blocked
        one where its stage is now (a card applying its axis world's `jam`)."""
        changed = np.flatnonzero(self.jammed != jammed)
        if len(changed):
            on = jammed[changed].astype(bool)
            self.set_jammed(changed[on], True)
            self.set_jammed(changed[~on], False)

    def _set_bit(self, bit: AxisFlag, on: np.ndarray) -> None:
        flags = self.axes.flags
        flags &= ~int(bit)
        flags |= on.astype(np.int64) * int(bit)

    def set_soft_limits(self, axes: Selector, lo: Any, hi: Any) -> None:
        """Soft limits on the commanded position (-inf/inf disable); they apply from the next
        motion command."""
        idx = self._select(axes)
        self.limits.soft_lo[idx] = self._per_axis(lo, len(idx))
        self.limits.soft_hi[idx] = self._per_axis(hi, len(idx))

    def set_fe_limit(self, axes: Selector, limit: Any) -> None:
        """Following-error limit in counts (0 or inf disables)."""
        idx = self._select(axes)
        self.limits.set_fe_limit(idx, self._per_axis(limit, len(idx)))

    def set_kind(self, axes: Selector, kind: PlantKind) -> None:
        """Change what axes drive (a card's motor-type command); a profile running is aborted,
        the axes hold where they are."""
        idx = self._select(axes)
        self.abort(idx[self.profile.moving[idx]])
        self.kinds[idx] = int(kind)
        self._has_servo = bool((self.kinds == PlantKind.SERVO).any())
        ax = self.axes
        ax.vel[idx] = 0.0
        ax.out[idx] = 0.0
        self.stepper.gen[idx] = ax.pos[idx]
        self.pid.reset(idx)
        for a in idx.tolist():
            self.profile.hold(a, float(ax.pos[a]))
        self.profile.commit()
        self._configure()

    def set_encoder_scale(self, axes: Selector, scale: Any) -> None:
        """Encoder counts per count of position (default 1): encoder = floor(pos * scale) and
        the loop compares the command with encoder / scale."""
        idx = self._select(axes)
        values = self._per_axis(scale, len(idx))
        if not (np.isfinite(values).all() and (values > 0).all()):
            raise ValueError("scale must be positive")
        self._scale[idx] = values
        self._configure()
