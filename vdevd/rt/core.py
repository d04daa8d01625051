"""The motion core of one card: profiles -> PID -> plant -> encoder -> limits, every tick.

Vectorised over the card's axes: the tick path has no Python loop over axes (loops run only at
command time and on the rare ticks where a profile ends or a limit trips). Events (a profile
ended, a limit or following-error trip) are returned as AxisFlag bits so firmware can react at
the exact tick; `run(n)` stops at such a tick.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from vdevd.rt.axes import MOTION_STICKY, Axes, AxisFlag, PlantKind
from vdevd.rt.filters import Pid
from vdevd.rt.limits import Limits
from vdevd.rt.plants import ServoPlant, default_gains
from vdevd.rt.profiles import ProfileGenerator

Selector = int | slice | Sequence[int] | np.ndarray


class MotionCore:
    """Axes, profile generator, PID, plants and limits of one card."""

    def __init__(self, n: int, dt_ns: int, plant: PlantKind | Sequence[PlantKind] = PlantKind.SERVO
                 ) -> None:
        if n < 1 or dt_ns <= 0:
            raise ValueError("need at least one axis and a positive period")
        self.n, self.dt_ns, self.dt = n, dt_ns, dt_ns / 1e9
        self.pid = Pid(n)
        self.pid.set(slice(None), **default_gains(self.dt))
        self.axes = Axes(n, cmd_vel=self.pid.cmd_vel, cmd_acc=self.pid.cmd_acc)
        self.profile = ProfileGenerator(self.axes, self.dt)
        self.plant = ServoPlant(n, self.dt)
        self.limits = Limits(n)
        kinds = [PlantKind(plant)] * n if isinstance(plant, (int, PlantKind)) else list(plant)
        if len(kinds) != n:
            raise ValueError(f"{len(kinds)} plant kinds for {n} axes")
        self.kinds = np.array([int(k) for k in kinds])
        self._servo_idx = np.flatnonzero(self.kinds == PlantKind.SERVO)
        self._ideal_idx = np.flatnonzero(self.kinds == PlantKind.IDEAL)
        self._step_idx = np.flatnonzero(self.kinds == PlantKind.STEPPER)
        self._all_one = len(set(self.kinds.tolist())) == 1
        self.servo_on_mask = np.zeros(n, dtype=bool)
        self._any_off = True
        self.amp_fault = np.zeros(n, dtype=bool)
        self.encoder_loss = np.zeros(n, dtype=bool)
        self._any_loss = False
        self.target = np.zeros(n, dtype=np.int64)
        self.last_dec = np.full(n, np.inf)
        self.last_jerk = np.zeros(n)
        self._pending = 0
        self._enc = np.zeros(n)  # the encoder as floats, for the float arithmetic of the tick
        self._tmp = np.zeros(n)

    # -- the tick ----------------------------------------------------------------------------------
    def tick(self) -> int:
        """One servo tick; the AxisFlag bits of what happened (0 when nothing did)."""
        ax, prof, lim = self.axes, self.profile, self.limits
        events, self._pending = self._pending, 0
        finished = prof.advance()
        if finished:
            events |= self._finish(finished)
        if lim.soft_enabled and prof.active:
            crossed = lim.soft_crossed(ax.cmd_pos, prof.moving)
            if len(crossed):
                events |= self._soft_stop(crossed)
        self._plant_step()
        if lim.fe_enabled:
            tripped = lim.fe_exceeded(ax.ferr)
            if len(tripped):
                events |= self._fe_trip(tripped)
        return events

    def run(self, n: int) -> tuple[int, int]:
        """Up to n ticks; stops right after the first tick with events. (ticks done, events)."""
        tick = self.tick
        for i in range(n):
            events = tick()
            if events:
                self.update_in_position()
                return i + 1, events
        self.update_in_position()
        return n, 0

    def _plant_step(self) -> None:
        ax = self.axes
        if len(self._servo_idx):
            np.subtract(ax.cmd_pos, self._enc, out=self.pid.e)
            self.pid.update(ax.out)
            if self._any_off:
                ax.out *= self.servo_on_mask
            self.plant.step(ax.out, ax.pos, ax.vel)
        if len(self._ideal_idx):
            self._follow(self._ideal_idx, rounded=False)
        if len(self._step_idx):
            self._follow(self._step_idx, rounded=True)
        enc = self._enc
        if self._any_loss:
            np.floor(ax.pos, out=self._tmp)
            np.copyto(enc, self._tmp, where=~self.encoder_loss)
        else:
            np.floor(ax.pos, out=enc)
        ax.encoder[:] = enc
        if self._any_off:  # servo off: the command follows the actual position
            np.copyto(ax.cmd_pos, ax.pos, where=~self.servo_on_mask)
        np.subtract(ax.cmd_pos, enc, out=ax.ferr)

    def _follow(self, idx: np.ndarray, rounded: bool) -> None:
        """Ideal and stepper axes: the actual position is the command (in whole steps)."""
        ax = self.axes
        if self._all_one and not self._any_off:
            if rounded:
                np.rint(ax.cmd_pos, out=ax.pos)
            else:
                ax.pos[:] = ax.cmd_pos
            ax.vel[:] = ax.cmd_vel
            return
        on = idx[self.servo_on_mask[idx]]
        ax.pos[on] = np.rint(ax.cmd_pos[on]) if rounded else ax.cmd_pos[on]
        ax.vel[on] = ax.cmd_vel[on]
        ax.vel[idx[~self.servo_on_mask[idx]]] = 0.0

    def update_in_position(self) -> None:
        """IN_POSITION: no profile running and |ferr| within the in-position band."""
        flags = self.axes.flags
        np.abs(self.axes.ferr, out=self._tmp)
        ok = (self._tmp <= self.limits.in_position) & ~self.profile.moving
        flags &= ~int(AxisFlag.IN_POSITION)
        flags |= ok * int(AxisFlag.IN_POSITION)

    # -- events ----------------------------------------------------------------------------------
    def _finish(self, axes: list[int]) -> int:
        flags = self.axes.flags
        for a in axes:
            flags[a] = (flags[a] & ~AxisFlag.MOVING) | AxisFlag.DONE
        return int(AxisFlag.DONE)

    def _soft_stop(self, crossed: np.ndarray) -> int:
        ax, events = self.axes, 0
        for a in crossed.tolist():
            above = ax.cmd_pos[a] >= self.limits.soft_hi[a]
            bit = AxisFlag.SOFT_LIMIT_POS if above else AxisFlag.SOFT_LIMIT_NEG
            heading = ax.cmd_vel[a]
            toward = heading > 0 if bit == AxisFlag.SOFT_LIMIT_POS else heading < 0
            if ax.flags[a] & bit or not toward:
                continue
            ax.flags[a] |= bit | AxisFlag.STOPPED_BY_LIMIT
            self._limit_stop(a)
            events |= int(bit | AxisFlag.STOPPED_BY_LIMIT)
        return events

    def _limit_stop(self, a: int) -> None:
        dec = float(self.limits.limit_dec[a])
        if math.isinf(dec):
            dec = float(self.last_dec[a])
        if math.isinf(dec) or dec <= 0:
            self.profile.hold(a, float(self.axes.cmd_pos[a]))
            self._finish([a])
        else:
            self.profile.stop(a, dec, float(self.last_jerk[a]))
            self._after_plan(a)

    def _fe_trip(self, tripped: np.ndarray) -> int:
        flags, events = self.axes.flags, 0
        for a in tripped.tolist():
            if not flags[a] & AxisFlag.FE_TRIP:
                flags[a] |= AxisFlag.FE_TRIP
                events = int(AxisFlag.FE_TRIP)
        return events

    def _after_plan(self, a: int) -> None:
        """Set MOVING after a plan; a plan that is already complete is DONE at once."""
        flags = self.axes.flags
        if self.profile.moving[a]:
            flags[a] |= AxisFlag.MOVING
        else:
            flags[a] = (flags[a] & ~AxisFlag.MOVING) | AxisFlag.DONE
            self._pending |= int(AxisFlag.DONE)

    # -- commands --------------------------------------------------------------------------------
    def _select(self, axes: Selector) -> list[int]:
        idx = np.arange(self.n)[axes]
        return [int(i) for i in np.atleast_1d(idx)]

    @staticmethod
    def _per_axis(value: Any, count: int) -> list[float]:
        arr = np.broadcast_to(np.asarray(value, dtype=float), (count,))
        return [float(v) for v in arr]

    def _start(self, a: int, direction: float) -> bool:
        """Common checks before a motion command; False (and a limit stop) when blocked."""
        flags = self.axes.flags
        flags[a] &= ~int(MOTION_STICKY)
        if direction and self.limits.blocked(a, direction):
            flags[a] = (flags[a] & ~AxisFlag.MOVING) | AxisFlag.STOPPED_BY_LIMIT | AxisFlag.DONE
            self._pending |= int(AxisFlag.DONE | AxisFlag.STOPPED_BY_LIMIT)
            if self.profile.moving[a]:
                self._limit_stop(a)
            return False
        return True

    def move_absolute(self, axes: Selector, target_counts: Any, vmax: Any, acc: Any, dec: Any,
                      jerk: Any = 0.0) -> None:
        """Point-to-point move to integer targets: trapezoid (jerk 0) or S-curve; replans from
        the current commanded state when the axis is already moving."""
        sel = self._select(axes)
        k = len(sel)
        targets = [int(round(t)) for t in self._per_axis(target_counts, k)]
        vs, accs = self._per_axis(vmax, k), self._per_axis(acc, k)
        decs, jerks = self._per_axis(dec, k), self._per_axis(jerk, k)
        if min(vs + accs + decs) <= 0 or min(jerks) < 0:
            raise ValueError("vmax, acc and dec must be positive and jerk >= 0")
        for a, t, v, ac, de, j in zip(sel, targets, vs, accs, decs, jerks, strict=True):
            if not self._start(a, t - float(self.axes.cmd_pos[a])):
                continue
            self.target[a], self.last_dec[a], self.last_jerk[a] = t, de, j
            self.profile.move(a, t, v, ac, de, j)
            self._after_plan(a)

    def move_relative(self, axes: Selector, distance: Any, vmax: Any, acc: Any, dec: Any,
                      jerk: Any = 0.0) -> None:
        """A move by `distance` counts from the last target (a card's PR semantics)."""
        sel = self._select(axes)
        dists = self._per_axis(distance, len(sel))
        targets = [int(self.target[a]) + int(round(d)) for a, d in zip(sel, dists, strict=True)]
        self.move_absolute(sel, targets, vmax, acc, dec, jerk)

    def jog(self, axes: Selector, velocity: Any, acc: Any, dec: Any, jerk: Any = 0.0) -> None:
        """Run at a signed velocity; a new velocity ramps on the fly (through zero on reversal)."""
        sel = self._select(axes)
        k = len(sel)
        vels, accs = self._per_axis(velocity, k), self._per_axis(acc, k)
        decs, jerks = self._per_axis(dec, k), self._per_axis(jerk, k)
        for a, v, ac, de, j in zip(sel, vels, accs, decs, jerks, strict=True):
            if ac <= 0 or de <= 0 or j < 0:
                raise ValueError("acc and dec must be positive and jerk >= 0")
            if not self._start(a, v):
                continue
            self.last_dec[a], self.last_jerk[a] = de, j
            self.profile.jog(a, v, ac, de, j)
            self._after_plan(a)

    def stop(self, axes: Selector, dec: Any = None) -> None:
        """Decelerate to standstill with `dec` (default: the last command's deceleration)."""
        sel = self._select(axes)
        decs = self._per_axis(self.last_dec[sel] if dec is None else dec, len(sel))
        for a, de in zip(sel, decs, strict=True):
            if not self.profile.moving[a]:
                continue
            if math.isinf(de) or de <= 0:
                self.abort(a)
                continue
            self.profile.stop(a, de, float(self.last_jerk[a]))
            self._after_plan(a)

    def abort(self, axes: Selector, dec: Any = None) -> None:
        """Abort: the profile stops at once (or decelerates with `dec`); sets ABORTED."""
        sel = self._select(axes)
        flags = self.axes.flags
        for a in sel:
            moving = bool(self.profile.moving[a])
            flags[a] |= AxisFlag.ABORTED
            if dec is not None and moving:
                self.profile.stop(a, float(dec), 0.0)
                self._after_plan(a)
                continue
            self.profile.hold(a, float(self.axes.cmd_pos[a]))
            if moving:
                flags[a] = (flags[a] & ~AxisFlag.MOVING) | AxisFlag.DONE
                self._pending |= int(AxisFlag.DONE | AxisFlag.ABORTED)

    def servo_on(self, axes: Selector) -> None:
        """Close the loop holding the present position; clears FE_TRIP."""
        sel = self._select(axes)
        ax = self.axes
        for a in sel:
            if self.amp_fault[a]:
                continue
            self.servo_on_mask[a] = True
            ax.flags[a] = (ax.flags[a] | AxisFlag.SERVO_ON) & ~AxisFlag.FE_TRIP
            self.profile.hold(a, float(ax.encoder[a]) if self.kinds[a] == PlantKind.SERVO
                              else float(ax.pos[a]))
            self.pid.reset(a)
        self._any_off = not bool(self.servo_on_mask.all())

    def servo_off(self, axes: Selector) -> None:
        """Open the loop: output 0, the plant coasts, the command follows the actual position."""
        sel = self._select(axes)
        for a in sel:
            if self.profile.moving[a]:
                self.abort(a)
            self.servo_on_mask[a] = False
            self.axes.flags[a] &= ~AxisFlag.SERVO_ON
            self.axes.out[a] = 0.0
        self._any_off = not bool(self.servo_on_mask.all())

    def set_position(self, axes: Selector, counts: Any) -> None:
        """Define the present position as `counts` without motion (commanded and actual)."""
        sel = self._select(axes)
        ax = self.axes
        for a, c in zip(sel, self._per_axis(counts, len(sel)), strict=True):
            shift = c - float(ax.encoder[a])
            ax.pos[a] += shift
            ax.encoder[a] = int(round(c))
            self._enc[a] = float(ax.encoder[a])
            ax.cmd_pos[a] = float(ax.cmd_pos[a]) + shift
            self.target[a] = int(round(c))
            self.profile.hold(a, float(round(c)) if not self.profile.moving[a] else c)
            ax.ferr[a] = ax.cmd_pos[a] - ax.encoder[a]
            self.pid.reset(a)

    def set_inputs(self, hard_limit_pos: Any = None, hard_limit_neg: Any = None,
                   amp_fault: Any = None, encoder_loss: Any = None) -> None:
        """Backdoor inputs, one bool per axis. A limit that becomes active stops an axis moving
        toward it; an amplifier fault turns the servo off and aborts."""
        ax, lim = self.axes, self.limits
        flags = ax.flags
        if encoder_loss is not None:
            self.encoder_loss[:] = np.asarray(encoder_loss, dtype=bool)
            self._any_loss = bool(self.encoder_loss.any())
            self._set_bit(AxisFlag.ENCODER_LOSS, self.encoder_loss)
        if amp_fault is not None:
            new = np.asarray(amp_fault, dtype=bool)
            rising = np.flatnonzero(new & ~self.amp_fault)
            self.amp_fault[:] = new
            self._set_bit(AxisFlag.AMP_FAULT, new)
            for a in rising.tolist():
                self.abort(a)
                self.servo_off(a)
                self._pending |= int(AxisFlag.AMP_FAULT)
        for value, store, bit, sign in (
            (hard_limit_pos, lim.hard_pos, AxisFlag.HARD_LIMIT_POS, 1.0),
            (hard_limit_neg, lim.hard_neg, AxisFlag.HARD_LIMIT_NEG, -1.0),
        ):
            if value is None:
                continue
            new = np.asarray(value, dtype=bool)
            rising = np.flatnonzero(new & ~store)
            store[:] = new
            self._set_bit(bit, new)
            for a in rising.tolist():
                if self.profile.moving[a] and ax.cmd_vel[a] * sign > 0:
                    flags[a] |= AxisFlag.STOPPED_BY_LIMIT
                    self._limit_stop(a)
                    self._pending |= int(bit | AxisFlag.STOPPED_BY_LIMIT)

    def _set_bit(self, bit: AxisFlag, on: np.ndarray) -> None:
        flags = self.axes.flags
        flags &= ~int(bit)
        flags |= on.astype(np.int64) * int(bit)

    def set_soft_limits(self, axes: Selector, lo: Any, hi: Any) -> None:
        """Soft limits on the commanded position (-inf/inf disable)."""
        sel = self._select(axes)
        self.limits.soft_lo[sel] = self._per_axis(lo, len(sel))
        self.limits.soft_hi[sel] = self._per_axis(hi, len(sel))
        self.limits.update_enabled()

    def set_fe_limit(self, axes: Selector, limit: Any) -> None:
        """Following-error limit in counts (inf or 0 disables)."""
        sel = self._select(axes)
        values = [v if v > 0 else np.inf for v in self._per_axis(limit, len(sel))]
        self.limits.fe_limit[sel] = values
        self.limits.update_enabled()
