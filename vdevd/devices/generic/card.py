"""The generic servo card (type `generic-servo`): the platform's reference card.

Not a vendor product: a small, documented register map (README.md, regions.py) over the shared
motion core, used to exercise regions, hooks, interrupts, the clock and the backdoor end to end.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction
from typing import Any, ClassVar

import numpy as np

from vdevd import nvcheck
from vdevd.devices.base import Card, CardContext, Option, control
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg, CardStatus, Command, CommandError
from vdevd.pci import Bar, PciIdentity
from vdevd.region import Region
from vdevd.rt import AxisFlag, MotionCore, PlantKind

_PLANTS = {"servo": PlantKind.SERVO, "stepper": PlantKind.STEPPER, "ideal": PlantKind.IDEAL}
_FAULTS = int(AxisFlag.AMP_FAULT | AxisFlag.ENCODER_LOSS)
_STOPS = int(AxisFlag.STOPPED_BY_LIMIT | AxisFlag.FE_TRIP | AxisFlag.AMP_FAULT)
_DONE = int(AxisFlag.DONE)
_MOTION = (Command.MOVE_ABS, Command.MOVE_REL, Command.JOG, Command.HOME)
#: the motion parameters `save` keeps in flash
_SAVED = ("vmax", "acc", "dec", "jerk")
#: the configuration header (README.md "PCI configuration space"): not a vendor product, so the
#: vendor ID is 1234 (the unassigned ID emulators use) and the class 1180 (other data
#: acquisition and signal processing controller)
PCI_IDENTITY = PciIdentity(vendor=0x1234, device=0x5644, revision=0x01, class_code=0x118000,
                           subsystem_vendor=0x1234, subsystem=0x0001, bars=(Bar(R.BAR_SIZE),))


class GenericServoCard(Card):
    type_name: ClassVar[str] = "generic-servo"
    options: ClassVar[Mapping[str, Option]] = {
        "axes": Option(int, 4, min=1, max=R.MAX_AXES, help="number of axes"),
        "plant": Option(str, "servo", choices=tuple(_PLANTS), help="servo, stepper or ideal"),
    }

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        self.n = self.opts.axes
        self.core = MotionCore(self.n, float(self.period), _PLANTS[self.opts.plant])
        self.make_world(self.n)
        # passive (decision 0010): the outputs and the axes' parameters, the registers with no
        # hook (the card reads the parameters when a command is written)
        params = [(R.AXIS_BASE + R.AXIS_STRIDE * axis + AxisReg.TARGET,
                   R.AXIS_BASE + R.AXIS_STRIDE * axis + AxisReg.STATUS) for axis in range(self.n)]
        self.bar = self.add_region(
            Region("bar0", R.BAR_SIZE, widths=(1, 2, 4), endian="little",
                   description="registers (README.md)",
                   passive=[(R.OUTPUTS, R.OUTPUTS + 4), *params], memory=ctx.memory)
        )
        self.inta = self.add_irq("inta")
        self.pci = self.add_config_space(PCI_IDENTITY, self.inta)
        end = R.AXIS_BASE + R.AXIS_STRIDE * self.n
        self.axis_regs = np.ndarray(
            (self.n,), dtype=R.AXIS_DTYPE, buffer=self.bar.buf, offset=R.AXIS_BASE
        )
        self._prev_flags = np.zeros(self.n, dtype=np.int64)
        self._axis_bit = np.left_shift(1, np.arange(self.n, dtype=np.int64))  # IRQ_STATUS bit n
        self.abort_input = False
        self._declare_hooks(end)
        self.reset()

    def _declare_hooks(self, end: int) -> None:
        ignore = self._ignore_write
        self.bar.hook(R.ID, R.TICK_HI + 4 - R.ID, on_write=ignore)
        self.bar.hook(R.IRQ_STATUS, 4, on_write=self._write_irq_status)
        self.bar.hook(R.IRQ_ENABLE, 4, on_write=self._write_irq_enable)
        self.bar.hook(R.INPUTS, 4, on_write=ignore)
        self.bar.hook(R.CARD_STATUS, 4, on_write=ignore)
        for axis in range(self.n):
            base = R.AXIS_BASE + R.AXIS_STRIDE * axis
            self.bar.hook(base + AxisReg.COMMAND, 4, on_write=self._write_command)
            self.bar.hook(base + AxisReg.STATUS, AxisReg.ERROR + 4 - AxisReg.STATUS,
                          on_write=ignore)

    # -- power-on --------------------------------------------------------------------------------
    def reset(self) -> None:
        """Power-on: identity registers, default motion parameters, saved parameters restored."""
        self.bar.buf[:] = bytes(R.BAR_SIZE)
        self.bar.set(R.ID, R.CARD_ID)
        self.bar.set(R.VERSION, R.FIRMWARE_VERSION)
        self.bar.set(R.AXES, self.n)
        self.bar.set(R.PERIOD_NS, self.period_ns)
        self._store_card_status()
        regs = self.axis_regs
        regs["vmax"], regs["acc"], regs["dec"] = 50_000, 500_000, 500_000
        saved = self.ctx.nvram.load(self.name, self._check_image) if self.ctx.nvram else None
        if saved:
            for field in _SAVED:
                if field in saved:
                    regs[field] = saved[field]
        self.core.servo_on(slice(None))
        self._world_changed()

    def nvram(self) -> dict[str, Any]:
        return {f: self.axis_regs[f].tolist() for f in _SAVED}

    def _check_image(self, image: dict[str, Any]) -> None:
        """A saved image: per axis what a host write of the register takes (u32)."""
        nvcheck.only(image, _SAVED)
        for field in _SAVED:
            if field in image:
                for a, v in enumerate(nvcheck.sequence(image[field], field, self.n)):
                    nvcheck.number(v, f"{field}[{a}]", 0, 0xFFFF_FFFF, integer=True)

    # -- firmware --------------------------------------------------------------------------------
    def tick(self, n: int) -> int:
        """Run up to n ticks in the motion core; stop at a tick that interrupted the host. At
        rest the ticks run in closed form (Card.rest_enter, rest_before, rest_after): a tick
        the card looks around runs alone, the others in runs of the core."""
        sensing = self.world.mechanical  # the switches follow the stage: sense every tick
        done = self.rest_enter(n)
        while done < n:
            before = self.rest_before()
            run = 1 if sensing or before is not None else n - done
            if self.skip_quiet and run > 1:  # up to the next look
                run = max(1, min(run, self._rest_due - self.ticks))
            retimes = self.retimes
            if retimes:  # a new period from that tick: no batch runs across it
                if retimes[0][0] == self.ticks + 1:
                    self.period_changed(retimes.pop(0)[1])
                if retimes:
                    run = min(run, retimes[0][0] - self.ticks - 1)
            k, events = self.core.run(run)
            done += k
            self.ticks_run(k)
            if sensing:
                self.sense_world()
            if events:
                self._on_events()
                if self.pause:
                    self.pause = False
                    break
            if before is not None:
                done += self.rest_after(before, n - done)
        self._store_status()
        return done

    def rest_state(self) -> bytes | None:
        """The motion core's (the registers are stored from it at the end of a batch)."""
        return self.core.rest_state()

    def skip(self, k: int) -> None:
        self.core.skip(k)
        super().skip(k)

    def period_changed(self, period: Fraction) -> None:
        """A tick of a new servo period (`set_period`): the motion core's step and PERIOD_NS
        follow."""
        self.core.set_period(float(period))
        self.bar.set(R.PERIOD_NS, round(period))

    def _store_status(self) -> None:
        """Refresh every axis's read-only registers from the core in one vectorised store."""
        ax = self.core.axes
        live = self.axis_regs["live"]
        live["status"] = ax.flags
        live["position"] = ax.encoder
        live["commanded"] = np.rint(ax.cmd_pos)
        live["ferr"] = np.rint(ax.ferr)
        live["velocity"] = np.rint(ax.vel)
        live["output"] = np.rint(ax.out)
        self.bar.set(R.TICK_LO, self.ticks & 0xFFFFFFFF)
        self.bar.set(R.TICK_HI, self.ticks >> 32)

    def _store_card_status(self) -> None:
        self.bar.set(R.CARD_STATUS, int(CardStatus.ABORT_INPUT) if self.abort_input else 0)

    def _on_events(self) -> None:
        """A profile ended or a fault stopped an axis: raise the IRQ_STATUS bits (README.md)."""
        flags = self.core.axes.flags
        new = flags & ~self._prev_flags
        np.copyto(self._prev_flags, flags)
        # distinct powers of two: a dot product with the axes' bits is their OR
        done = int(self._axis_bit @ ((new & _DONE) != 0))
        stopped = int(self._axis_bit @ ((new & _STOPS) != 0))
        bits = done | stopped << 16
        if bits:
            self._set_irq_status(self.bar.get(R.IRQ_STATUS) | bits)

    # -- interrupts ------------------------------------------------------------------------------
    def _set_irq_status(self, status: int) -> None:
        old = self.bar.get(R.IRQ_STATUS) & self.bar.get(R.IRQ_ENABLE)
        self.bar.set(R.IRQ_STATUS, status)
        self._update_line(old)

    def _update_line(self, old_pending: int) -> None:
        pending = self.bar.get(R.IRQ_STATUS) & self.bar.get(R.IRQ_ENABLE)
        if pending & ~old_pending:
            self.inta.trigger(pending)  # a new cause: one assertion
        elif not pending:
            self.inta.clear()

    def _write_irq_status(self, offset: int, data: bytes) -> None:
        shift = 8 * (offset - R.IRQ_STATUS)
        ones = int.from_bytes(data, "little") << shift
        old = self.bar.get(R.IRQ_STATUS) & self.bar.get(R.IRQ_ENABLE)
        self.bar.set(R.IRQ_STATUS, self.bar.get(R.IRQ_STATUS) & ~ones)
        self._update_line(old)

    def _write_irq_enable(self, offset: int, data: bytes) -> None:
        old = self.bar.get(R.IRQ_STATUS) & self.bar.get(R.IRQ_ENABLE)
        self.bar.mem[offset : offset + len(data)] = data
        self._update_line(old)

    @staticmethod
    def _ignore_write(offset: int, data: bytes) -> None:
        """Read-only registers ignore writes, as a PCI target does."""

    # -- commands --------------------------------------------------------------------------------
    def _write_command(self, offset: int, data: bytes) -> None:
        axis = (offset - R.AXIS_BASE) // R.AXIS_STRIDE
        base = R.AXIS_BASE + R.AXIS_STRIDE * axis
        self.bar.mem[offset : offset + len(data)] = data
        code = self.bar.get(base)
        self.bar.set(base + AxisReg.ERROR, self._execute(axis, code))

    def _execute(self, axis: int, code: int) -> CommandError:
        regs = self.axis_regs[axis]
        flags = int(self.core.axes.flags[axis])
        try:
            cmd = Command(code)
        except ValueError:
            return CommandError.UNKNOWN_COMMAND
        target, vmax = int(regs["target"]), float(regs["vmax"])
        acc, dec, jerk = float(regs["acc"]), float(regs["dec"]), float(regs["jerk"])
        if cmd in _MOTION:
            if vmax <= 0 and cmd != Command.JOG or acc <= 0 or dec <= 0:
                return CommandError.BAD_PARAMETER
            if flags & _FAULTS:
                return CommandError.FAULT
            if not flags & AxisFlag.SERVO_ON:
                return CommandError.SERVO_OFF
            if self.abort_input:
                return CommandError.ABORT_INPUT
            self._prev_flags[axis] &= ~_DONE
        if cmd == Command.MOVE_ABS:
            self.core.move_absolute(axis, target, vmax, acc, dec, jerk)
        elif cmd == Command.MOVE_REL:
            self.core.move_relative(axis, target, vmax, acc, dec, jerk)
        elif cmd == Command.JOG:
            self.core.jog(axis, target, acc, dec, jerk)
        elif cmd == Command.HOME:
            self.core.home(axis, vmax if target >= 0 else -vmax, acc, dec, jerk)
        elif cmd == Command.STOP:
            self.core.stop(axis, dec if dec > 0 else None)
        elif cmd == Command.ABORT:
            self.core.abort(axis)
        elif cmd == Command.SERVO_ON:
            self.core.servo_on(axis)
        elif cmd == Command.SERVO_OFF:
            self.core.servo_off(axis)
        elif cmd == Command.SET_POSITION:
            self.core.set_position(axis, target)
        self._store_status()
        return CommandError.OK

    # -- backdoor --------------------------------------------------------------------------------
    def _axis(self, axis: int) -> int:
        if not isinstance(axis, int) or not 0 <= axis < self.n:
            raise ValueError(f"axis {axis!r} outside 0..{self.n - 1}")
        return axis

    def push_axis(self, a: int, counts: float) -> None:
        """Backdoor `push`: the axis moved by hand (MotionCore.push)."""
        self.core.push(a, counts)

    def physical_positions(self) -> np.ndarray:
        return self.core.physical()

    def apply_world(self) -> None:
        """The axis world's switch levels and faults on the core's inputs (README.md
        "Backdoor")."""
        w, core = self.world, self.core
        core.set_inputs(hard_limit_pos=w.limit_pos, hard_limit_neg=w.limit_neg, home=w.home,
                        amp_fault=w.amp_fault, encoder_loss=w.encoder_loss)
        core.follow_jams(w.jammed)
        self._store_status()

    def drive_input(self, line: int, level: bool) -> None:
        """Input `line` (0..31) of the INPUTS register."""
        if not isinstance(line, int) or not 0 <= line < 32:
            raise ValueError(f"line {line!r} outside 0..31")
        bit = 1 << line
        value = self.bar.get(R.INPUTS)
        self.bar.set(R.INPUTS, value | bit if level else value & ~bit)

    def drive_estop(self, active: bool) -> None:
        """The card's abort input: while active, axes in motion abort and motion commands are
        refused (ERROR ABORT_INPUT)."""
        self.abort_input = bool(active)
        if self.abort_input:
            self.core.abort(self.core.profile.moving)
        self._store_card_status()
        self._store_status()

    @control()
    def set_limit(self, axis: str | int, side: str = "positive", active: bool = True,
                  positive: bool | None = None, negative: bool | None = None) -> None:
        """Hold a hard-limit switch active (or release it to the mechanics): side is positive
        or negative. (`positive=`/`negative=` levels: deprecated, the form before the shared
        vocabulary; not together with side/active.)"""
        if positive is None and negative is None:
            super().set_limit(axis, side, active)
            return
        if side != "positive" or active is not True:
            raise ValueError("give side/active, or the deprecated positive/negative, not both")
        for flag, level in (("positive", positive), ("negative", negative)):
            if level is not None:
                super().set_limit(axis, flag, bool(level))

    @control(deprecated="set_amp_fault")
    def amp_fault(self, axis: int, active: bool = True) -> None:
        """Assert or clear the amplifier fault input of an axis."""
        self.set_amp_fault(axis, active)

    @control(deprecated="set_encoder_loss")
    def encoder_loss(self, axis: int, active: bool = True) -> None:
        """Lose (freeze) or restore the encoder of an axis."""
        self.set_encoder_loss(axis, active)

    @control(deprecated="set_estop")
    def set_abort(self, active: bool = True) -> None:
        """Drive the card's abort input (set_estop)."""
        self.drive_estop(active)

    @control(deprecated="set_input")
    def set_inputs(self, value: int) -> None:
        """Set the 32 general-purpose inputs (INPUTS register)."""
        if not isinstance(value, int) or not 0 <= value <= 0xFFFFFFFF:
            raise ValueError("value must be a 32-bit unsigned integer")
        self.bar.set(R.INPUTS, value)

    @control()
    def set_gains(self, axis: int, **gains: float) -> dict[str, float]:
        """Set PID parameters of an axis (kp, ki, kd, il, vff, aff, out_limit)."""
        a = self._axis(axis)
        self.core.pid.set(a, **gains)
        return {k: float(getattr(self.core.pid, k)[a]) for k in gains}

    @control()
    def set_plant(self, axis: int, **params: float) -> None:
        """Set servo plant parameters of an axis (amp_gain, peak_torque, inertia, viscous,
        coulomb; vdevd/rt/plants.py)."""
        self.core.plant.set(self._axis(axis), **params)

    @control()
    def save(self) -> None:
        """Save the motion parameters to flash (the state directory)."""
        if self.ctx.nvram is None:
            raise ValueError("the rack has no state directory ([state] dir)")
        self.ctx.nvram.save(self.name, self.nvram())

    @control()
    def axis_state(self, axis: int) -> dict[str, Any]:
        """The motion core's state of an axis (floats, for tests and scopes)."""
        a = self._axis(axis)
        ax = self.core.axes
        return {
            "cmd_pos": float(ax.cmd_pos[a]), "cmd_vel": float(ax.cmd_vel[a]),
            "pos": float(ax.pos[a]), "vel": float(ax.vel[a]), "encoder": int(ax.encoder[a]),
            "ferr": float(ax.ferr[a]), "out": float(ax.out[a]), "flags": int(ax.flags[a]),
        }
