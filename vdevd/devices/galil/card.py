"""The Galil DMC-13X8 VME card (type `galil-dmc13x8`): README.md in this package.

The card is the hardware around the firmware (firmware.py): the A16 window (bus.py, the register
map of `vdevmaps.galil`) behind region `a16`, the VME interrupt line `irq` at the jumpered level,
the stage (the axis world of `[[card.axis]]`, sensed after the motion of every sample and put on
the limit, home, index and latch inputs) and the backdoor. Every servo sample it runs the
firmware's `step()`; with `decode = "arrival"` a host write that completes a command runs the
firmware's `serve()` at once. A VME card: no PCI configuration space.
"""

from __future__ import annotations

import asyncio
import logging
import sys
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from vdevmaps.galil import WINDOW_SIZE, A16Reg

from vdevd.devices.base import Card, CardContext, CardOptions, Option, control
from vdevd.devices.galil.bus import FREEZE_MODES, A16Window
from vdevd.devices.galil.channel import CommandChannel
from vdevd.devices.galil.ethernet import MAX_CONNECTIONS, EthernetServer
from vdevd.devices.galil.firmware import Firmware
from vdevd.devices.galil.interpreter import revision
from vdevd.devices.galil.nv_image import check_image
from vdevd.devices.galil.params import COUNTS_PER_VOLT
from vdevd.devices.galil.syntax import AXIS_ALIASES, AXIS_LETTERS
from vdevd.nvram import NvramWriter
from vdevd.region import Region
from vdevd.rt import PlantKind
from vdevd.security import is_local
from vdevd.tcp_listener import check_endpoint, listener_options

log = logging.getLogger(__name__)

_DATA = int(A16Reg.DATA)  # a plain int: an enum member costs a lookup on every access
DEFAULT_INDEX_PERIOD = 4096.0  # counts between index pulses when [[card.axis]] gives none
SYNONYMS = AXIS_ALIASES[: len(AXIS_LETTERS)]  # A B C D name X Y Z W [M "Using This Manual"]
END_OF_TRAVEL = sys.float_info.max  # set_home_edge: the switch reaches the end of travel


class GalilCard(Card):
    type_name: ClassVar[str] = "galil-dmc13x8"
    endian: ClassVar[str] = "big"
    options: ClassVar[Mapping[str, Option]] = {
        "axes": Option(int, 4, min=1, max=4, help="1-4: DMC-1318 ... DMC-1348"),
        "tm_us": Option(int, 1000, min=250, max=20000, help="sample time in us, as TM sets it"),
        "base": Option(int, 0xFFF0, min=0, max=0xFFF0, help="A16 base address (JP10)"),
        "irq_level": Option(int, 5, min=1, max=7, help="VME IRQ level (JP9/JP11)"),
        "plant": Option(str, "servo", choices=("servo", "stepper", "ideal"),
                        help="servo; stepper (SM jumpers installed); ideal"),
        "freeze_mode": Option(str, "toggle_n5", choices=FREEZE_MODES,
                              help="secondary FIFO freeze control (README.md)"),
        "record_endian": Option(str, "little", choices=("little", "big"),
                                help="byte order of the data record"),
        "decode": Option(str, "arrival", choices=("arrival", "sample"),
                         help="decode a command when its terminator arrives, or at the next sample"),
        "address": Option(str, None,
                          help="the controller's address as gclib opens it (\"192.168.0.42\"): "
                               "the drop-in gclib finds the card by it"),
        "serial": Option(int, 0, min=0, max=999_999, help="serial number (gclib's GInfo)"),
        "ethernet": Option(str, "",
                           help="tcp://HOST:PORT: serve the DMC command protocol there "
                                "(loopback only, port 0: any free one); empty: off"),
        **listener_options(MAX_CONNECTIONS),
    }

    #: the manual's axis letters; A B C D are synonyms of X Y Z W (any case)
    axis_letters: ClassVar[str] = AXIS_LETTERS
    control_params: ClassVar[Mapping[str, Mapping[str, str]]] = {
        "set_input": {"input": "line"}, "set_analog": {"input": "channel"}}

    #: the period comes from an option of the card's own (types, README)
    period_from: ClassVar[str | None] = "tm_us sets it"
    runs_ticks: ClassVar[bool] = True  # samples with nothing to serve (`run`)

    @classmethod
    def check_options(cls, opts: CardOptions, where: str) -> None:
        """The servo period is the sample time `tm_us`, what TM reports [M Ch6 TM]: a
        `period_ns` of its own would run the card at a rate it does not report."""
        if opts.period_ns is not None:
            raise ValueError(f"{where}.period_ns: a galil-dmc13x8 runs at its sample time; "
                             "set tm_us instead")
        address = opts.address
        if address is not None and (not address or address.startswith("-")
                                    or any(c.isspace() or c == "," for c in address)):
            raise ValueError(f"{where}.address: {address!r} is not a gclib address (one word, "
                             "no commas, not a --flag)")
        if opts.ethernet:
            check_endpoint(opts.ethernet, where)
            if not is_local(opts.ethernet):
                raise ValueError(f"{where}.ethernet: {opts.ethernet!r} is not loopback (the DMC "
                                 "command protocol has no authentication)")

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        opts = self.opts
        self.n = opts.axes
        self.configured_tm_us = opts.tm_us
        self.period_ns = self.configured_tm_us * 1000
        if opts.base % WINDOW_SIZE:
            raise ValueError(f"base: {opts.base:#x} is not a multiple of 16 (A4..A15 jumpers)")
        self.base = opts.base
        self.irq_level = opts.irq_level
        self.plant = opts.plant
        self.decode_on_arrival = opts.decode == "arrival"
        self.make_world(self.n)
        for a in range(self.n):  # no [[card.axis]] index: one pulse per 4096 counts (README.md)
            if a >= len(opts.axis) or opts.axis[a].index is None:
                self.world.set_index(a, DEFAULT_INDEX_PERIOD, 0.0)
        self._probing = any(len(p) for p in self.world.probes)
        self._phys_prev = np.zeros(self.n)
        self.bus = A16Window(freeze_mode=opts.freeze_mode)
        self.a16 = self.add_region(Region(
            "a16", WINDOW_SIZE, widths=(1,), endian="big", aligned=False,
            description="A16 short I/O, D08(O): FIFOs N+1, control N+3, secondary FIFO N+5/N+7"))
        self.a16.hook(0, WINDOW_SIZE, on_read=self._host_read, on_write=self._host_write,
                      peek=self._host_peek, on_read_rep=self._host_read_rep,
                      on_write_rep=self._host_write_rep, rep_at=_DATA)
        self.irq = self.add_irq("irq")
        # the flash (BP BV BN): one image in the state directory, restored at power-up
        store = ctx.nvram
        self._writer = NvramWriter(store, name) if store is not None else None
        saved = (store.load(name, lambda image: check_image(self.n, image))  # issue 22 §4
                 if store is not None else None)
        self._flash: dict[str, Any] | None = saved.get("flash") if isinstance(saved, dict) else None
        self.firmware = Firmware(self.n, self.period_ns, self.plant, self.configured_tm_us, self.bus,
                                 raise_irq=self._raise_irq, clear_irq=self.irq.clear,
                                 clock=lambda: self.now_ns, record_endian=opts.record_endian,
                                 sense=self._sense, save_flash=self._save_flash,
                                 flash_image=self._flash)
        self.firmware.on_reset = self._on_reset
        self.cmp = self.add_irq("cmp")  # the CMP output of OC: an event per sample with pulses
        self.firmware.on_compare = self._compare_pulses
        self._world_changed()
        self.address: str | None = opts.address
        self.serial: int = opts.serial
        self.ethernet: str = opts.ethernet
        self.ethernet_endpoint = ""
        self._server: EthernetServer | None = None

    def _save_flash(self, image: dict[str, Any]) -> None:
        """BP, BV, BN, ^R^S: the flash image goes to the state directory, atomically."""
        self._flash = image
        if self._writer is not None:
            self._writer.submit({"flash": image})

    def nvram(self) -> dict[str, Any]:
        return {"flash": self._flash} if self._flash is not None else {}

    def reset(self) -> None:
        """Power-on: the window empty, the line released, the firmware reset."""
        self.bus.reset()
        self.irq.clear()
        self.firmware.reset()

    # -- the host's bus accesses -------------------------------------------------------------------
    def _host_read(self, offset: int, size: int) -> bytes:
        value = self.bus.read(offset)
        if self.irq.asserted and not self.bus.line_asserted:
            self.irq.clear()
        return bytes((value,))

    def _host_write(self, offset: int, data: bytes) -> None:
        self.bus.write(offset, data[0])
        if offset == _DATA and self.decode_on_arrival:
            self.firmware.serve()  # the command it completes is decoded at once
        elif self.irq.asserted and not self.bus.line_asserted:
            self.irq.clear()

    def _host_read_rep(self, offset: int, size: int) -> bytes:
        if offset == _DATA:
            return self.bus.read_data(size)
        return bytes(self._host_read(offset, 1)[0] for _ in range(size))

    def _host_write_rep(self, offset: int, data: bytes) -> None:
        if offset == _DATA:
            self.bus.write_data(data)
            if self.decode_on_arrival:
                self.firmware.serve()
        else:
            for b in data:
                self._host_write(offset, bytes((b,)))

    def _host_peek(self, offset: int, size: int) -> bytes:
        return bytes(self.bus.peek(o) for o in range(offset, offset + size))

    # -- the firmware ------------------------------------------------------------------------------
    def _on_reset(self) -> None:
        """RS: the world on the new motion firmware; no channel stays held by a trippoint."""
        self._world_changed()
        server: EthernetServer | None = getattr(self, "_server", None)  # None while constructing
        if server is not None:
            server.reset()

    def step(self) -> None:
        """One sample of the firmware: motion, interrupts, commands, the data record; then the
        Ethernet connections a trippoint holds."""
        self.firmware.step()
        server = self._server
        if server is not None and server.held:
            server.serve()

    def run(self, room: int) -> int:
        """Samples with nothing to serve nor record run in a loop of motion and ER checks
        (Firmware.run_samples): not while the stage is sensed after each sample (a switch or
        a probe it crosses may interrupt in the middle of one)."""
        fw = self.firmware
        if fw.motion.sense is not None or self._server is not None and self._server.held:
            return 0
        room = fw.idle_samples(room)
        return fw.run_samples(room, self.ticks_run) if room else 0

    def rest_state(self) -> bytes | None:
        if self._server is not None and self._server.held:
            return None
        return self.firmware.rest_state()

    def quiet_ticks(self) -> int:
        return self.firmware.quiet_ticks()

    def skip(self, k: int) -> None:
        self.firmware.skip(k)
        super().skip(k)

    def _compare_pulses(self, count: int) -> None:
        """CMP pulsed in this sample (OC): one event on line `cmp`, status the pulses since RS
        (low 32 bits); the line is a pulse, released at once."""
        self.cmp.trigger(count & 0xFFFF_FFFF)
        self.cmp.clear()

    def _raise_irq(self, status: int) -> None:
        """The firmware queued `code | vector << 8` with the output enabled: the line asserts at
        the jumpered level (README.md "Interrupts")."""
        self.irq.trigger(status | self.irq_level << 16)

    # -- the Ethernet command channel (README.md "Ethernet command channel") -------------------------
    async def open_services(self) -> None:
        """Listen for the DMC command protocol at `ethernet`; a port that cannot be bound is a
        `StartError`."""
        if not self.ethernet:
            return
        self._server = await EthernetServer.start(
            self.ethernet, lambda: CommandChannel(self.firmware), self.touched,
            name=f"{self.name} ethernet", max_connections=self.opts.max_connections,
            idle_timeout_s=self.opts.idle_timeout_s)
        self.ethernet_endpoint = self._server.endpoint
        log.info("%s: DMC command protocol on %s", self.name, self.ethernet_endpoint)

    async def close_services(self) -> None:
        """The daemon stops: the Ethernet server closes; the last flash image is written."""
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()
            self._server = None
        if self._writer is not None:
            await asyncio.to_thread(self._writer.close)

    def listeners(self) -> dict[str, str]:
        return {"ethernet": self.ethernet_endpoint} if self.ethernet_endpoint else {}

    def connections(self) -> int:
        return self._server.connections if self._server is not None else 0

    def describe(self) -> dict[str, Any]:
        """`hello`'s card info, with what the drop-in gclib looks for: the address, the
        revision report (^R^V), the serial number and the Ethernet endpoint."""
        info = super().describe()
        info.update(address=self.address, revision=revision(self.n), serial=self.serial,
                    ethernet=self.ethernet_endpoint)
        return info

    # -- the axis world (README.md "Axis world") ---------------------------------------------------
    def _sense(self) -> None:
        """After the motion of every sample: the switches where the stage now is, and the probe
        positions it crossed (only for a world with mechanics or probes)."""
        if self.world.mechanical:
            self.sense_world()
        if self._probing:
            self._sense_probes()

    def _sense_probes(self) -> None:
        """A probe position crossed pulses the axis's latch input; the latch reads the encoder
        at the probe position (physical position plus the card's zero)."""
        core, world = self.firmware.motion.core, self.world
        now = core.physical()
        for a in range(self.n):
            at = world.probe_between(a, float(self._phys_prev[a]), float(now[a]))
            if at is not None:
                reading = np.floor((at + float(core.zero[a])) * float(core.encoder_scale[a]))
                self.firmware.probe(a, float(reading) + float(self.firmware.motion.enc_offset[a]))
        self._phys_prev = now

    def push_axis(self, a: int, counts: float) -> None:
        """Backdoor `push`: the axis moved by hand (MotionCore.push)."""
        self.firmware.motion.core.push(a, counts)

    def physical_positions(self) -> np.ndarray:
        """Where the stage is: the core's position less every zero DP, HM, FI and RS defined
        (DE on a servo axis defines the auxiliary encoder only; on a stepper axis TP's offset)."""
        return self.firmware.motion.core.physical()

    def apply_world(self) -> None:
        """The world's levels and faults on the card's inputs: a tripped switch is an active
        FLS/RLS input, an active home switch reads 0 on the HOME input (README.md "Backdoor")."""
        w, fw = self.world, self.firmware
        m = fw.motion
        core = m.core
        fw.set_limits(w.limit_pos, w.limit_neg)
        np.logical_not(w.home, out=m.home_input)
        m.index_period[:], m.index_phase[:] = w.index_period, w.index_phase
        servo = core.kinds == PlantKind.SERVO
        for a in np.flatnonzero(servo).tolist():  # no amplifier-fault input: the motor coasts
            core.plant.set(a, peak_torque=1e-9 if w.amp_fault[a] else np.inf)
        core.set_inputs(amp_fault=w.amp_fault & ~servo, encoder_loss=w.encoder_loss)
        core.follow_jams(w.jammed)
        fw.set_abort(w.estop)
        # sensed after every sample only while positions matter (switches placed, probes)
        m.sense = self._sense if w.mechanical or self._probing else None

    def axis_index(self, axis: str | int) -> int:
        """X Y Z W, or A B C D (the manual's synonyms), any case; or 0..n-1."""
        if isinstance(axis, str) and len(axis) == 1 and axis.upper() in SYNONYMS:
            axis = AXIS_LETTERS[SYNONYMS.index(axis.upper())]
        return super().axis_index(axis)

    def drive_input(self, line: int, level: bool) -> None:
        """General input IN1..IN8 logic level; a falling edge latches an armed axis (IN1..IN4)
        and raises an enabled input interrupt (EI bit 15). Lines 17..80: the extended I/O."""
        if (isinstance(line, bool) or not isinstance(line, int)
                or not (1 <= line <= 8 or 17 <= line <= 80)):
            raise ValueError(f"line {line!r} outside 1..8 (IN1..IN8) and 17..80 (extended I/O)")
        self.firmware.set_input(line, level)

    def drive_analog(self, channel: int, volts: float) -> None:
        """Analog input AN1..AN8 in volts (+-10 V, 12-bit)."""
        if isinstance(channel, bool) or not isinstance(channel, int) or not 1 <= channel <= 8:
            raise ValueError(f"channel {channel!r} outside 1..8 (AN1..AN8)")
        step = 20 / 4096  # 4096 levels from -10 V to 10 V - one step
        self.firmware.analog[channel - 1] = min(max(round(volts / step), -2048), 2047) * step
        self.firmware.analog_driven(channel - 1)  # an AF axis's sensor reads it now

    def drive_estop(self, active: bool) -> None:
        """The ABORT input: motion stops at once, OE1 axes turn off [M Ch3 §Abort Input]."""
        self.world.estop = active
        self.firmware.set_abort(active)

    # -- backdoor: the card's own actions ------------------------------------------------------------
    @control()
    def set_home_edge(self, axis: str | int, position: float | None = None) -> None:
        """A home switch from `position` to the end of travel (physical counts): the HOME input
        reads 1 below it, 0 at and above it (None: no switch there; set_home drives the input)."""
        a = self.axis_index(axis)
        if position is None:
            self.world.remove_home_window(a)
        else:
            self.world.set_home_window(a, float(position), END_OF_TRAVEL)
        self._world_changed()

    @control()
    def set_friction(self, axis: str | int, volts: float) -> None:
        """Coulomb friction of a servo motor, as the DAC voltage it takes to overcome it."""
        if not volts >= 0:
            raise ValueError("volts must be >= 0")
        a = self.axis_index(axis)
        core = self.firmware.motion.core
        core.plant.set(a, coulomb=float(volts) * COUNTS_PER_VOLT * float(core.plant.amp_gain[a]))

    @control()
    def compare_pulses(self) -> int:
        """The CMP output's pulses since power-on or RS (OC; README "Formats, extended I/O,
        output compare, analog feedback")."""
        return self.firmware.compare.pulses

    # -- backdoor: deprecated names ----------------------------------------------------------------
    @control(deprecated="set_limit")
    def set_switches(self, axis: str | int, forward_limit: bool | None = None,
                     reverse_limit: bool | None = None, home: int | None = None) -> None:
        """Limit switches (True = tripped: set_limit positive/negative) and the home input's
        logic level (0 = switch active: set_home); a level given replaces a home switch edge
        (set_home_edge) or window, as it did before the shared vocabulary."""
        a = self.axis_index(axis)
        if forward_limit is not None:
            self.set_limit(axis, "positive", bool(forward_limit))
        if reverse_limit is not None:
            self.set_limit(axis, "negative", bool(reverse_limit))
        if home is not None:
            self.world.remove_home_window(a)
            self.set_home(axis, not home)

    @control(deprecated="set_estop")
    def set_abort(self, active: bool) -> None:
        """The ABORT input (set_estop)."""
        self.set_estop(active)
