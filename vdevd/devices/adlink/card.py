"""The ADLINK AMP-204C/208C (type `adlink-amp20xc`): README.md in this package.

One PCI BAR, `bar0`: vdevd's host interface of the motion kernel (vdevmaps.adlink): a mailbox
whose doorbell (the only register with a hook) runs a kernel command at once, and a status block
the kernel refreshes every motion cycle; the interrupt line `inta`; the PCI `config` space. The
kernel (kernel.py) runs one motion cycle per tick; the parameters saved to flash are kept in the
state directory, written atomically.
"""

from __future__ import annotations

import asyncio
import logging
import math
import struct
import time
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import numpy as np
from vdevmaps.adlink import (
    BAR,
    BAR_SIZE,
    CARD_TYPE,
    CYCLES_US,
    MODELS,
    PCI_CLASS_CODE,
    PCI_DEVICE_IDS,
    PCI_REVISION_ID,
    PCI_VENDOR_ID,
    Bar,
)

from vdevd import nvcheck
from vdevd.devices.adlink import cmd_io, pwm, trigger
from vdevd.devices.adlink.kernel import Kernel
from vdevd.devices.adlink.modes import IDLE
from vdevd.devices.base import Card, CardContext, Option, control
from vdevd.devices.rest import state_bytes
from vdevd.nvram import NvramWriter
from vdevd.pci import Bar as PciBar
from vdevd.pci import PciIdentity
from vdevd.region import Region, passive_except

log = logging.getLogger(__name__)
_DOORBELL = int(Bar.DOORBELL)
_MAILBOX = struct.Struct("<II")  # code, length


class AdlinkCard(Card):
    type_name: ClassVar[str] = CARD_TYPE
    axis_base: ClassVar[int] = 0  # axes 0..7, as the API numbers them [M §4.10.1.2]
    period_from: ClassVar[str | None] = "cycle_us sets it"
    options: ClassVar[Mapping[str, Option]] = {
        "model": Option(str, "AMP-208C", choices=tuple(MODELS),
                        help="AMP-204C (4 axes) or AMP-208C (8 axes) [M §1.1]"),
        "card_id": Option(int, 15, min=0, max=15,
                          help="the card ID DIP switch SW2, 0-15 (default 1111 = 15) [M §2.6.1]"),
        "cycle_us": Option(int, 1000, choices=CYCLES_US,
                           help="the motion control cycle, us [M §1.1, §4.1.2.2]"),
        "drive": Option(str, "ideal", choices=("ideal", "servo"),
                        help="ideal: feedback = command; servo: a drive with lag and INP"),
        "inp_window": Option(float, 1.0, min=0.0, max=1e9,
                             help="INP when |command - feedback| <= this many pulses at rest"),
        "refused_rc": Option(int, 0, choices=(0, -13),
                             help="what a motion command ignored for EMG/ALM/EL returns: 0 as "
                                  "the manual's 'ignored', or -13 (spec Q15) [M §4.10]"),
    }
    axes_option: ClassVar[str] = ""  # the model counts the axes (check_options)
    runs_ticks: ClassVar[bool] = True  # cycles of the motion core's tick alone (`run`)
    #: the wall clock the kernel's load figures (timing, over-cycle flags) are measured with
    wall_ns: Callable[[], int] = staticmethod(time.perf_counter_ns)

    @classmethod
    def check_options(cls, opts: Any, where: str) -> None:
        n = MODELS[opts.model]
        if len(opts.axis) > n:
            raise ValueError(f"{where}.axis: {len(opts.axis)} [[card.axis]] tables for the "
                             f"{opts.model}'s {n} axes")

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        opts = self.opts
        self.n = n = MODELS[opts.model]
        self.set_period(opts.cycle_us * 1000)
        self.bar = self.add_region(Region(
            BAR, BAR_SIZE, widths=(1, 2, 4, 8), endian="little", aligned=True,
            description="vdevd's motion-kernel interface: mailbox and status block",
            passive=passive_except(BAR_SIZE, [(_DOORBELL, 4)]), memory=ctx.memory))
        self.bar.hook(_DOORBELL, 4, on_write=self._doorbell, peek=self._peek)
        self.inta = self.add_irq("inta")
        model_code = 0x204 if n == 4 else 0x208
        self.pci = self.add_config_space(PciIdentity(
            vendor=PCI_VENDOR_ID, device=PCI_DEVICE_IDS[opts.model], revision=PCI_REVISION_ID,
            class_code=PCI_CLASS_CODE, subsystem_vendor=PCI_VENDOR_ID, subsystem=opts.card_id,
            bars=(PciBar(BAR_SIZE),)), self.inta)
        self.kernel = Kernel(self.bar.buf, n, model_code, opts.card_id, opts.cycle_us,
                             opts.drive, self.inta.trigger, inp_window=opts.inp_window,
                             clear_line=self.inta.clear)
        self.kernel.refused_rc = opts.refused_rc
        store = ctx.nvram
        self._writer = NvramWriter(store, name) if store is not None else None
        saved = (store.load(name, lambda image: self._check_image(image, model_code))
                 if store is not None else None)
        if saved:  # checked: every entry legal on this card (issue 22 §4)
            self.kernel.restore_parameters(saved["flash"])
            self.kernel.board_params.values[0x8000] = float(opts.cycle_us)
            self.kernel.flash = self.kernel.parameter_image()  # what load_parameter_from_flash loads
        self.make_world(n)
        self._feedback_offset = np.zeros(n)
        self._ez_at = np.zeros(n)
        self._ran = False
        self._world_changed()
        self.kernel.publish()
        self.inta.clear()

    def _check_image(self, image: dict[str, Any], model_code: int) -> None:
        """A saved image (`{"flash": parameters}`) whose every entry the commands could have set
        on this card: restored on trial into a kernel of its own; `ImageError` otherwise (the
        image is set aside and the card starts from its defaults, issue 22 §4)."""
        nvcheck.only(image, ("flash",))
        flash = nvcheck.mapping(image.get("flash"), "flash")
        nvcheck.only(flash, self.kernel.parameter_image().keys(), "flash")
        opts = self.opts
        trial = Kernel(bytearray(BAR_SIZE), self.n, model_code, opts.card_id, opts.cycle_us,
                       opts.drive, lambda *args: None, inp_window=opts.inp_window)
        dropped = trial.restore_parameters(flash)
        if dropped:
            raise nvcheck.ImageError(f"flash: {dropped} entries not legal on this card (an "
                                     "image of another program, version or model)")

    # -- the mailbox -----------------------------------------------------------------------------
    def _doorbell(self, offset: int, data: bytes) -> None:
        """The host rang: run the command in CODE/LENGTH/ARGS with this sequence number."""
        buf = self.bar.buf
        seq = int.from_bytes(data, "little")
        code, length = _MAILBOX.unpack_from(buf, Bar.CODE)
        if length > Bar.ARGS_END - Bar.ARGS:
            length = 1 << 31  # refused by the codec (-10)
            args = b"\xff"
        else:
            args = bytes(buf[Bar.ARGS:Bar.ARGS + length])
        t0 = self.wall_ns()
        self.kernel.execute(seq, code, args)
        self.kernel.measure_host(self.wall_ns() - t0)
        self._after_command()

    def _peek(self, offset: int, size: int) -> bytes:
        return bytes(self.bar.buf[offset:offset + size])

    def _after_command(self) -> None:
        k = self.kernel
        if k.new_cycle_us is not None:
            us, k.new_cycle_us = k.new_cycle_us, None
            k.cycle_us, k.dt = us, us / 1e6
            k.core.set_period(us * 1000)
            k.write_identity()
            self.set_period(us * 1000)
        if k.flash_dirty:
            k.flash_dirty = False
            if self._writer is not None:
                self._writer.submit({"flash": k.flash})

    # -- the kernel ------------------------------------------------------------------------------
    def step(self) -> None:
        if self.world.mechanical:
            self.sense_world()
        self._index_pulses()
        t0 = self.wall_ns()
        self.kernel.cycle()
        self.kernel.measure_motion(self.wall_ns() - t0)
        self._ran = True

    def run(self, room: int) -> int:
        """Motion cycles that are the motion core's tick alone run as a loop of core ticks
        (runs.py): not while the stage is sensed or index marks pass at every cycle. The last
        cycle of the run does the rest of its kernel work at its time."""
        w = self.world
        if w.mechanical or np.count_nonzero(w.index_period):
            return 0
        runs = self.kernel.runs
        room = runs.room(room)
        if not room:
            return 0
        t0 = self.wall_ns()
        ran = runs.ticks(room)
        self.ticks_run(ran)
        runs.finish(ran)
        self.kernel.measure_motion((self.wall_ns() - t0) // ran)
        self._ran = True
        return ran

    def batch_done(self) -> None:
        """The status block after a batch that ran a cycle; after cycles skipped at rest only
        the cycle counter changed."""
        if self._ran:
            self._ran = False
            self.kernel.publish()
        else:
            self.kernel.publish_cycles()

    def nvram(self) -> dict[str, Any]:
        return {"flash": self.kernel.flash} if self.kernel.flash is not None else {}

    async def close_services(self) -> None:
        """The daemon stops: the last flash image is written before it exits."""
        if self._writer is not None:
            await asyncio.to_thread(self._writer.close)

    def reset(self) -> None:
        self.kernel.power_up()
        self.kernel.publish()

    def rest_state(self) -> bytes | None:
        """None while an axis moves, waits or runs a sequence, or a unit is busy; else the
        kernel's state, the core's and the bar (the cycle counter aside)."""
        k = self.kernel
        if (k.mode != IDLE).any() or k.wait.any() or any(u.busy() for u in k.units):
            return None
        if self.world.index_period.any():
            return None
        core = k.core.rest_state()
        if core is None:
            return None
        return (core + state_bytes(k, skip=("cycles",)) + bytes(self.bar.buf[:Bar.CYCLE_COUNT])
                + bytes(self.bar.buf[Bar.CYCLE_COUNT + 4:]) + bytes((self.inta.asserted,)))

    def polled_state(self) -> bytes:
        return b""  # the kernel reads the mailbox only when the doorbell rings

    def skip(self, k: int) -> None:
        self.kernel.core.skip(k)
        self.kernel.cycles += k
        super().skip(k)

    # -- the axis world and the backdoor ---------------------------------------------------------
    def push_axis(self, a: int, counts: float) -> None:
        """Backdoor `push`: the axis moved by hand (MotionCore.push)."""
        self.kernel.core.push(a, counts)

    def physical_positions(self) -> np.ndarray:
        return self.kernel.core.physical()

    def apply_world(self) -> None:
        """PEL/MEL from the limits, ORG from the home switch, ALM from the amplifier fault (or
        set_alarm), jams and lost encoders on the motion core."""
        w, k = self.world, self.kernel
        k.settle_conditions()  # edges against the last cycle's conditions
        k.raw_pel = w.limit_pos.copy()
        k.raw_mel = w.limit_neg.copy()
        k.raw_org = w.home.copy()
        k.raw_alm = w.amp_fault | self._alarm
        k.core.set_inputs(encoder_loss=w.encoder_loss)
        k.follow_drive(w.jammed.copy())
        k.logic()

    @property
    def _alarm(self) -> np.ndarray:
        if not hasattr(self, "_alarm_forced"):
            self._alarm_forced = np.zeros(self.n, dtype=bool)
        return self._alarm_forced

    def _index_pulses(self) -> None:
        """EZ: on in the cycle the stage crosses an index mark (or sits on one) [M §4.3]."""
        w = self.world
        if not np.count_nonzero(w.index_period):
            return
        k = self.kernel
        phys = self.physical_positions()
        period = np.where(w.index_period > 0, w.index_period, 1.0)
        mark = np.floor((phys - w.index_phase) / period)
        prev = getattr(self, "_last_mark", mark)
        on = (w.index_period > 0) & ((mark != prev) | ((phys - w.index_phase) % period < 1.0))
        self._last_mark = mark
        k.raw_ez = on
        k.ez_mark = np.maximum(mark, prev) * period + w.index_phase  # the mark last crossed

    def drive_input(self, line: int, level: bool) -> None:
        """DI channel `line` (bits of the DI word: 0-7 EDI, 8-23 TDI; spec §2.18)."""
        if isinstance(line, bool) or not isinstance(line, int) or not 0 <= line < 24:
            raise ValueError(f"line {line!r} outside 0..23 (the DI word)")
        if self.n == 4 and 4 <= line < 8:
            raise ValueError(f"line {line}: the AMP-204C has EDI0-3 only")
        k = self.kernel
        k.di_raw = k.di_raw | 1 << line if level else k.di_raw & ~(1 << line)
        k.publish()

    def drive_analog(self, channel: int, volts: float) -> None:
        raise ValueError("the AMP-204C/208C has no analog inputs (spec §1.2)")

    def drive_estop(self, active: bool) -> None:
        """The card's EMG input [M §4.10.1.1]."""
        self.kernel.raw_emg = bool(active)
        self.kernel.logic()
        self.kernel.publish()

    @control()
    def set_alarm(self, axis: int, active: bool = True) -> None:
        """Drive the servo alarm input ALM of `axis` (0-7) [M §4.10.1.2]."""
        a = self.axis_index(axis)
        self._alarm[a] = bool(active)
        self.apply_world()
        self.kernel.publish()

    @control()
    def set_inp(self, axis: int, active: bool | None = True) -> None:
        """Drive the in-position input INP of `axis` (None: from the drive again)."""
        a = self.axis_index(axis)
        self.kernel.inp_force[a] = -1 if active is None else int(bool(active))
        self.kernel.logic()
        self.kernel.publish()

    @control()
    def set_di(self, channel: int, level: bool = True) -> None:
        """Drive DI `channel` (a bit of the DI word, spec §2.18)."""
        self.drive_input(channel, bool(level))

    @control()
    def set_feedback_offset(self, axis: int, counts: float) -> None:
        """The encoder reads `counts` away from the command (a gantry deviation, a lagging
        drive); 0 removes it."""
        a = self.axis_index(axis)
        counts = float(counts)
        if not math.isfinite(counts):
            raise ValueError("counts must be finite")
        core = self.kernel.core
        core.slip_encoder([a], self._feedback_offset[a] - counts)
        self._feedback_offset[a] = counts
        self.kernel.publish()

    @control()
    def get_outputs(self) -> dict[str, Any]:
        """What the card outputs (read-only): the DO word at the connector (`do`, after
        PRB_DO_LOGIC; `do_written` as the application wrote it), the DI word, the TRG outputs
        (`trg_count`, `trg_level`, `trg_width_ns`, `trg_last_s`), timer 0, the PWM channels
        (on, frequency Hz, width ns, duty %) and the VAO controller [M §4.9.2-4.9.3]."""
        k = self.kernel
        pwm_unit = pwm.unit(k)
        pwm_unit.refresh()
        return ({"do": cmd_io.do_pins(k), "do_written": cmd_io.read_d_output(k, 0),
                 "di": k.di_word()} | trigger.unit(k).outputs() | pwm_unit.outputs())
