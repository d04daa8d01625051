"""The virtual Delta Tau Turbo PMAC (type `pmac-turbo`): PCI DPRAM and host port, interrupts, the
on-line interpreter, motors, and the Ethernet protocol on its own TCP port [spec pmac.md].

Regions: `dpram` (16 KiB, little-endian: ASCII command/response handshake, reporting buffers,
the rest open memory at PMAC addresses $060000-$060FFF) and `host` (the host-port byte registers
and the interrupt controller). Line `inta`. Ports: the DPRAM ASCII channel, the host port and
each Ethernet connection have their own `#n`/`&n` addressing (online.PortState).
"""

from __future__ import annotations

import ipaddress
import logging
import re
from collections.abc import Mapping
from fractions import Fraction
from typing import Any, ClassVar

import numpy as np
from vdevmaps.pmac import (
    CARD_TYPE,
    CMD_CONTROL,
    DPRAM,
    DPRAM_BASE,
    DPRAM_SIZE,
    HOST,
    HOST_SIZE,
    IR_MASK,
    IR_STATUS,
    LINE,
    PCI_CLASS_CODE,
    PCI_DEVICE_ID,
    PCI_REVISION,
    PCI_SUBSYSTEM_ID,
    PCI_SUBSYSTEM_VENDOR_ID,
    PCI_VENDOR_ID,
    RESP_CONTROL,
    HostIrq,
)

from vdevd.devices.base import Card, CardContext, CardOptions, Option, control
from vdevd.devices.pmac import nv_image, prog_dpram
from vdevd.devices.pmac.dpram import AsciiChannel, Reporting
from vdevd.devices.pmac.dpram_gather import DpramGather
from vdevd.devices.pmac.dpram_rotary import BinaryRotary
from vdevd.devices.pmac.dpram_vars import VariableBuffers
from vdevd.devices.pmac.eth_framing import KeptFraming
from vdevd.devices.pmac.ethernet import MAX_PENDING
from vdevd.devices.pmac.ethernet_server import EthernetServer
from vdevd.devices.pmac.firmware import Firmware, Identity
from vdevd.devices.pmac.hostport import HostPort, InterruptController
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.reply import Reply, frame
from vdevd.devices.pmac.servo_ic import ChannelFlag
from vdevd.devices.pmac.status import MotorStatus2
from vdevd.devices.rest import state_bytes, ticks_before_multiple
from vdevd.pci import Bar, PciIdentity
from vdevd.region import Region, passive_except
from vdevd.security import is_local
from vdevd.tcp_listener import check_endpoint, listener_options

log = logging.getLogger("vdevd.pmac")
_CONTROL = re.compile("[\x01-\x1a]")  # control characters act at once, wherever they are

#: I10 default 3,713,707 / 8,388,608 ms = 0.44271 ms [PMAC1-SRM p.46], exact (Card.set_period)
SERVO_PERIOD_NS = Fraction(3_713_707 * 1_000_000, 1 << 23)
_ASCII_READY = int(HostIrq.ASCII_READY)  # plain ints: IntFlag operators are slow on 3.11
#: lines (DPRAM) a PLC's SEND messages may leave waiting for the host before the PLC waits
MESSAGE_BACKLOG = 64
#: the sources evaluated each servo cycle while their mask bit is set
_MOTOR_SOURCES = int(HostIrq.IN_POSITION | HostIrq.WARNING_FOLLOWING_ERROR
                     | HostIrq.FATAL_FOLLOWING_ERROR | HostIrq.COMPARE_EQU1 | HostIrq.COMPARE_EQU5)
_IN_POSITION, _WARN_FE, _FATAL_FE = (int(MotorStatus2.IN_POSITION),
                                     int(MotorStatus2.WARNING_FOLLOWING_ERROR),
                                     int(MotorStatus2.FATAL_FOLLOWING_ERROR))
#: the configuration header (README "PCI configuration space"): BAR0 the DPRAM (memory), BAR1 the
#: host port (I/O); the IDs are an ASSUMPTION (vdevmaps.pmac)
PCI_IDENTITY = PciIdentity(vendor=PCI_VENDOR_ID, device=PCI_DEVICE_ID, revision=PCI_REVISION,
                           class_code=PCI_CLASS_CODE, subsystem_vendor=PCI_SUBSYSTEM_VENDOR_ID,
                           subsystem=PCI_SUBSYSTEM_ID,
                           bars=(Bar(DPRAM_SIZE), Bar(HOST_SIZE, io=True)))
#: the backdoor actions that take a motor (deprecated parameter name `motor`, README "Backdoor")
_AXIS_ACTIONS = ("set_limit", "set_home", "set_home_window", "set_index", "set_amp_fault",
                 "set_encoder_loss", "jam", "set_limits", "set_mldt_base")


class CommandPort:
    """A serial-style port (Ethernet connection, host port): framed replies as I3/I6 make them.

    An Ethernet connection (`ethernet=True`) keeps its framing across `$$$` and `$$$***`
    (eth_framing.py, README "Ethernet after a reset")."""

    def __init__(self, card: PmacCard, ethernet: bool = False) -> None:
        self.card = card
        self.state = PortState()
        self.framing = KeptFraming() if ethernet else None

    def reply(self, line: str) -> Reply:
        """Run a line; control characters in it act first and report ahead of its data."""
        self.card.touched()
        fw = self.card.fw
        controls = _CONTROL.findall(line)
        if not controls:
            return fw.execute(self.state, line)
        texts = [fw.control(self.state, ord(c)) for c in controls]
        rest = _CONTROL.sub("", line)
        reply = fw.execute(self.state, rest) if rest.strip() else Reply()
        reply.lines[:0] = [t for t in texts if t]
        return reply

    def command(self, line: str) -> bytes:
        self.card.touched()
        fw = self.card.fw
        # a printable line holds no control character: straight to the interpreter
        iv = fw.ivars.values
        if self.framing is not None:  # the framing this line starts with, kept if it resets the card
            self.framing.modes(int(iv[3]), int(iv[6]))
        reply = fw.interpreter.execute(self.state, line) if line.isprintable() else self.reply(line)
        if self.framing is not None:
            return frame(reply, *self.framing.modes(int(iv[3]), int(iv[6])))
        return frame(reply, int(iv[3]), int(iv[6]))

    def control(self, ch: int) -> bytes:
        self.card.touched()
        text = self.card.fw.control(self.state, ch)
        return (text + "\r").encode("latin-1") if text else b""

    def dpram_read(self, offset: int, count: int) -> bytes:
        self._check(offset, count)
        return self.card.dpram.read(offset, count)

    def dpram_write(self, offset: int, data: bytes) -> None:
        self._check(offset, len(data))
        self.card.dpram.write(offset, data)

    def _check(self, offset: int, count: int) -> None:
        if offset < 0 or count < 0 or offset + count > DPRAM_SIZE:
            raise ValueError(f"DPRAM {offset:#x}+{count} outside {DPRAM_SIZE:#x}")

    def host_port_read(self, offset: int) -> int:
        return self.card.host_read(offset)

    def host_port_write(self, offset: int, value: int) -> None:
        self.card.host_write(offset, value)

    def close(self) -> None:
        """A buffer this connection left open closes with it (plc.py `release`)."""
        self.card.fw.plc.release(self.state)
        self.card.fw.rotary.release(self.state)
        self.card.fw.kinematics.release(self.state)
        self.card.fw.motion.store.release(self.state)
        self.card.ethernet_ports.discard(self)


class DpramMemory:
    """The DPRAM seen from the PMAC side: address A is host offset 4(A - $060000), the Y word
    the low 16 bits and the X word the high 16 bits [PMAC1 DPRAM UM p.29; digest §2.10]."""

    def __init__(self, region: Region) -> None:
        self.region = region

    def read_word(self, space: str, addr: int) -> int:
        off = 4 * (addr - DPRAM_BASE) + (2 if space == "X" else 0)
        return self.region.get(off, 2)

    def write_word(self, space: str, addr: int, value: int) -> None:
        off = 4 * (addr - DPRAM_BASE) + (2 if space == "X" else 0)
        self.region.set(off, value & 0xFFFF, 2)
        self.region_written(off, 2)

    def region_written(self, offset: int, size: int) -> None:
        """Writes from the PMAC side do not trigger the host handshakes."""


class PmacCard(Card):
    type_name: ClassVar[str] = CARD_TYPE
    axes_option: ClassVar[str] = "motors"
    endian: ClassVar[str] = "little"
    default_period_ns: ClassVar[int | Fraction] = SERVO_PERIOD_NS
    options: ClassVar[Mapping[str, Option]] = {
        "device": Option(int, 0, min=0, max=15, help="PComm32 device number (OpenPmacDevice)"),
        "motors": Option(int, 8, min=1, max=32, help="motors processed (Ixx00 = 1)"),
        "cid": Option(int, 603382, min=0, max=999999,
                      help="card ID (603382 Geo Brick: DLS tools count 8 on-board axes)"),
        "ethernet": Option(str, "tcp://127.0.0.1:1025",
                           help="endpoint of the Ethernet protocol; empty: off"),
        "ethernet_allow": Option(list, None,
                                 help="client addresses allowed on a non-loopback Ethernet endpoint"),
        **listener_options(),
        "max_pending_kib": Option(int, MAX_PENDING >> 10, min=2, max=65536,
                                  help="KiB of output an Ethernet connection leaves unfetched "
                                       "(SENDLINE replies) before it is closed"),
        "plant": Option(str, "servo", choices=("servo", "ideal"),
                        help="servo: amplifier and motor model; ideal: motors follow exactly"),
        "macro_stations": Option(list, [], choices=tuple(range(64)),
                                 help="MACRO nodes (0-63) with a virtual station (MS, MSR, MSW); "
                                      "I20-I23 then hold their MACRO ICs' bases"),
    }

    #: motors are numbered from 1 [SRM]
    axis_base: ClassVar[int] = 1
    control_params: ClassVar[Mapping[str, Mapping[str, str]]] = {
        action: {"motor": "axis"} for action in _AXIS_ACTIONS}

    period_from: ClassVar[str | None] = "I10's default, not configurable"
    runs_ticks: ClassVar[bool] = True  # cycles that are the firmware's tick alone (`run`)

    @classmethod
    def check_options(cls, opts: CardOptions, where: str) -> None:
        """The servo period is I10/2^23 ms, what I10 reports [PMAC1-SRM p.46]: a `period_ns`
        of its own would run the card at a rate it does not report."""
        if opts.period_ns is not None:
            raise ValueError(f"{where}.period_ns: a pmac-turbo runs at its servo period I10/2^23 "
                             "ms (I10 default 3713707)")
        cls._check_ethernet(opts, where)

    @staticmethod
    def _check_ethernet(opts: CardOptions, where: str) -> None:
        """`ethernet` is tcp://HOST:PORT (or empty), each `ethernet_allow` entry an address or
        network, and a non-loopback endpoint has an allow-list (the protocol has no
        authentication): each refused naming its key, before anything is bound."""
        allow = opts.ethernet_allow or []
        for i, entry in enumerate(allow):
            try:
                ipaddress.ip_network(str(entry), strict=False)
            except ValueError:
                raise ValueError(f"{where}.ethernet_allow[{i}]: {entry!r} is not an IP address "
                                 "or network (\"192.168.1.0/24\", \"10.0.0.5\")") from None
        if not opts.ethernet:
            return
        check_endpoint(opts.ethernet, where)
        if not is_local(opts.ethernet) and not allow:
            raise ValueError(f"{where}.ethernet: {opts.ethernet!r} is not loopback: add "
                             "ethernet_allow, the client addresses allowed (the PMAC protocol "
                             "has no authentication)")

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        opts = self.opts
        self.device = opts.device
        self.motors = opts.motors
        self.ethernet = opts.ethernet
        self.allow = [str(a) for a in opts.ethernet_allow] if opts.ethernet_allow is not None else []
        if self.ethernet and not is_local(self.ethernet) and not self.allow:
            raise ValueError("ethernet: a non-loopback endpoint needs ethernet_allow "
                             "(the PMAC protocol has no authentication)")
        self.ethernet_endpoint = ""
        self._server: EthernetServer | None = None
        self.ethernet_ports: set[CommandPort] = set()
        # passive (decision 0010): all but the two handshake control words, which have hooks
        self.dpram = self.add_region(Region(
            DPRAM, DPRAM_SIZE, widths=(1, 2, 4), endian="little",
            description="DPRAM: ASCII command/response buffers, reporting buffers (UM p.402)",
            passive=passive_except(DPRAM_SIZE, [(CMD_CONTROL, 2), (RESP_CONTROL, 2)]),
            memory=ctx.memory))
        self.host = self.add_region(Region(
            HOST, HOST_SIZE, widths=(1,), endian="little",
            description="host port (HI08 bytes 0-7) and interrupt controller (8 status, 9 mask)"))
        self.host.hook(0, HOST_SIZE, on_read=lambda o, n: bytes([self.host_read(o)]),
                       on_write=lambda o, d: self.host_write(o, d[0]),
                       peek=lambda o, n: bytes([self.host_read(o, peek=True)]))
        self.inta = self.add_irq(LINE)
        self.pci = self.add_config_space(PCI_IDENTITY, self.inta)
        self.irq = InterruptController(self.inta.trigger, self.inta.clear)
        store = ctx.nvram
        self.fw = Firmware(self.motors, float(self.period), opts.plant, Identity(cid=opts.cid),
                           store=self._store)
        self.fw.macro.configure(opts.macro_stations)
        self.fw.ivars.defaults[20:24] = self.fw.macro.ic_bases()  # I20-I23 [A L3228]
        self.make_world(self.motors)
        self._world_setup()
        self.fw.memory.mount(DPRAM_BASE, DPRAM_BASE + DPRAM_SIZE // 4 - 1, DpramMemory(self.dpram))
        self.dpram_port = PortState()
        self.ascii = AsciiChannel(self.dpram.buf, self._dpram_execute, self._dpram_controlchar,
                                  lambda: self.irq.raise_(_ASCII_READY))
        self.dpram.hook(CMD_CONTROL, 2, on_write=self.ascii.command_control)
        self.dpram.hook(RESP_CONTROL, 2, on_write=self.ascii.response_control)
        self.reporting = Reporting(self.dpram.buf)
        self.fw.gather.dpram = DpramGather(self.dpram.buf)  # I5000 = 2, 3 (dpram_gather.py)
        self.varbufs = VariableBuffers(self.dpram.buf, self.fw.memory)  # I55 (dpram_vars.py)
        #: I45's ring; its `on_rotary_line(cs, text)` feeds a C.S.'s rotary buffer (dpram_rotary.py)
        self.binrot = BinaryRotary(self.dpram.buf)
        self.binrot.on_rotary_line = self.fw.rotary.append
        self.fw.binary_rotary_open = lambda: self.binrot.is_open(self.fw.ivars.values[45])
        #: BREQ high again: IR1 [SRM I17; digest §2.11's proposed controller]
        self.fw.rotary.on_request = lambda: self.irq.raise_(HostIrq.BUFFER_REQUEST)
        self.host_port_state = CommandPort(self)
        self.hostport = HostPort(self.host_port_state.command, self.host_port_state.control)
        self.fw.plc.on_message = self._plc_message
        self._last_status2 = np.zeros(self.motors, dtype=np.int64)
        nv_image.restore(self.fw, store, name)  # a saved image checked first (issue 22 §4)
        self.fw.on_reset = self._firmware_reset
        self.dpram.buf[:] = bytes(DPRAM_SIZE)
        self.ascii.reset()
        self._firmware_reset()

    def _world_setup(self) -> None:
        """The axis world's state beside `world`: the positions last sensed, the emergency stop,
        whether index pulses or probes need a look every servo cycle (README "Axis world")."""
        n = self.motors
        self._prev_phys = self.physical_positions()
        self._edges = np.full((4, n), np.nan)  # HMFL, PLIM, MLIM, USER edges (encoder counts)
        self._user = np.zeros(n, dtype=bool)
        self._chc = np.zeros(n, dtype=bool)
        self._pulses = False
        self._sensing = False

    def _plc_message(self, port: str, text: str) -> bool:
        """A PLC's SEND (the response port) or SENDP (the bus host port): with I58 = 1 a data line
        of the DPRAM ASCII response buffer, without ACK (IR4 raised as for any line); with
        I58 = 0 the host port's characters, text and CR. SENDS (the serial port, which this card
        does not have) goes nowhere. False (the PLC waits) while 64 lines wait for the host
        (README "PLCs", assumptions)."""
        if port == "S":
            return True
        if self.fw.ivars.values[58]:
            return self.ascii.post_message(text, MESSAGE_BACKLOG)
        if len(self.hostport.out) >= MESSAGE_BACKLOG * 256:
            return False
        self.hostport.out.extend(text.encode("latin-1") + b"\r")
        return True

    def _open_ethernet_port(self) -> CommandPort:
        port = CommandPort(self, ethernet=True)
        self.ethernet_ports.add(port)
        return port

    # -- power-up ---------------------------------------------------------------------------------
    def _firmware_reset(self) -> None:
        """After `$$$`, `$$$***` and at start: the host port, the interrupt controller and the
        ports' addressing start afresh; I58 = 1 since a DPRAM is present [A L3250]. The DPRAM
        bytes stay (the reset command's own acknowledgement is still to be posted)."""
        self.hostport.reset()
        self.irq.reset()
        self.dpram_port.motor, self.dpram_port.cs = 1, 1
        self.host_port_state.state = PortState()
        self.fw.ivars.values[58] = 1
        iv = self.fw.ivars.values
        for port in list(self.ethernet_ports):  # they keep their framing (eth_framing.py)
            port.state.motor, port.state.cs = 1, 1
            if port.framing is not None:
                port.framing.reset(int(iv[3]), int(iv[6]))
        if hasattr(self, "_prev_phys"):  # the inputs as the world has them, sensed now
            self._world_changed()

    def reset(self) -> None:
        """The rack's reset: power cycle, DPRAM cleared."""
        self.fw.power_on_reset()
        self.dpram.buf[:] = bytes(DPRAM_SIZE)
        self.ascii.reset()

    def _store(self, image: dict[str, Any]) -> None:
        if self.ctx.nvram is not None:
            self.ctx.nvram.save(self.name, image)

    def nvram(self) -> dict[str, Any]:
        return self.fw.saved

    # -- ticks ------------------------------------------------------------------------------------
    def step(self) -> None:
        fw = self.fw
        fw.tick(self.now_ns)
        if self._sensing:
            self._sense()
        cycle = fw.servo_cycles
        iv = fw.ivars.values
        rep = self.reporting
        if iv[48] and rep.realtime_due(cycle, iv[47]):
            self._report_realtime(cycle)
        if iv[49] and rep.background_due(cycle, iv[50]):
            self._report_background(cycle)
        if iv[55] and self.varbufs.due():  # the variable buffers, served each cycle (ASSUMPTION)
            self.varbufs.service(cycle)
        if iv[45] and self.binrot.due():  # the binary rotary ring, each cycle (foreground)
            self.binrot.service()
        if self.irq.mask & _MOTOR_SOURCES:
            self._irq_sources()

    def run(self, room: int) -> int:
        """Servo cycles in which the card does nothing beside the firmware's tick run as a loop
        of `begin_tick` and those ticks: not while the world is sensed or a motor interrupt
        source is enabled, and up to the next cycle that looks whether a reporting buffer is
        requested (a multiple of I47 with I48 = 1, of I50 with I49 = 1), as `step` looks."""
        if self._sensing or self.irq.mask & _MOTOR_SOURCES:
            return 0
        cycle, iv = self.fw.servo_cycles, self.fw.ivars.values
        if (iv[55] and self.varbufs.due()) or (iv[45] and self.binrot.due()):
            return 0
        if iv[48]:
            room = min(room, ticks_before_multiple(cycle, max(int(iv[47]), 1)))
        if iv[49]:
            room = min(room, ticks_before_multiple(cycle, max(int(iv[50]), 1)))
        begin, tick = self.begin_tick, self.fw.tick
        for _ in range(room):
            begin()
            tick(self.now_ns)
        return room

    # -- rest (decision 0008) -------------------------------------------------------------------------
    #: what changes at every cycle and `skip` advances in closed form, left out of rest_state
    _COUNTERS = ("now_ns", "ticks", "_last_tick_ns", "quiet_skipped", "pause", "servo_cycles",
                 "_vcount", "_vslot", "inpos_scans",
                 # and the P and Q variables (1.1 MB): only commands write them between batches
                 "p", "q")

    def rest_state(self) -> bytes | None:
        """The firmware's state, the card's inputs and both windows, as bytes (the ASCII and
        host-port channels answer at the access, not at the tick); None while the card has
        work: a home search, an in-position scan count still short of its Ixx88, conversion
        entries with memory or the A/D ring running, a velocity buffer still filling (I60's
        slots hold different readings), armed compare, data gathering on (gather.py), backlash
        still being taken up (comp1d.py), a PLC scanning (plc.py), a motion program running
        (program_runner.py)."""
        fw = self.fw
        m = fw.motors
        if (m.homing.any_searching or fw.ect._stateful or fw.servo_ic._any_armed or fw.gather.on
                or fw.plc.running or fw.motion.active or not (m._vbuf == m.core.axes.fb).all()
                or m.counting_to_inpos()
                or (fw.comp1d.active and fw.comp1d.busy(fw.reports.commanded()))):
            return None
        core = m.core.rest_state()
        if core is None:
            return None
        fw.servo_ic.materialize()  # its counters as they read, not what they are computed from
        skip = self._COUNTERS
        return b"".join((core, state_bytes(self, self.irq, fw, m, m.pid, m.homing, fw.servo_ic, fw.gpio,
                                           fw.feedback, skip=skip),
                         self.dpram.buf, self.host.buf))

    def polled_state(self) -> bytes:
        """The DPRAM: a motor's feedback (Ixx03) or a conversion-table entry may read a word of
        it at every cycle, and a local client writes it through the shared mapping."""
        return bytes(self.dpram.buf)

    def quiet_ticks(self) -> int:
        """At rest, the cycles before the next reporting buffer the host asked for (I47, I50)."""
        cycle, iv, rep = self.fw.servo_cycles, self.fw.ivars.values, self.reporting
        if (iv[55] and self.varbufs.due()) or (iv[45] and self.binrot.due()):
            return 0  # the host waits for a variable buffer, or binary rotary lines wait
        k = 1 << 62
        if iv[48] and rep.realtime_requested():
            k = min(k, ticks_before_multiple(cycle, max(int(iv[47]), 1)))  # 0 counts as 1
        if iv[49] and rep.background_requested():
            k = min(k, ticks_before_multiple(cycle, max(int(iv[50]), 1)))
        return k

    def skip(self, k: int) -> None:
        """k cycles at rest: the servo cycle count, the profile clock, I60's slot and the
        in-position scan counts move; the firmware's clock (X/Y:$000017) reads the card's."""
        self.fw.skip(k)
        super().skip(k)
        self.fw.now_ns = self.now_ns

    def _report_realtime(self, cycle: int) -> None:
        """The motors selected at L:$06001C, copied from their registers (README "Reporting
        buffers"): the position bias is 0, the home origin being already out of the actual
        position as in D:$00008B."""
        fw, rep = self.fw, self.fw.motors.reports
        sel = self.reporting.motor_mask(self.motors)
        scale = (fw.ivars.motor(8) * 32)[sel]
        w1, w2 = rep.status_words()
        self.reporting.realtime(
            cycle, sel, (w1[sel], w2[sel]), rep.following_error()[sel] * scale, rep.dac()[sel],
            np.zeros(len(sel)), rep.velocity()[sel] * (fw.ivars.motor(9) * 32)[sel],
            rep.position()[sel] * scale)

    def _report_background(self, cycle: int) -> None:
        """Global status and the first Y:$06019D coordinate systems; the time base in I10 units
        (ASSUMPTION: % override x I10 / 100)."""
        fw = self.fw
        n = self.reporting.cs_count()
        self.reporting.background(cycle, fw.global_status(),
                                  [fw.cs_status(c) for c in range(1, n + 1)],
                                  fw.feed[:n] * fw.ivars.values[10] / 100,
                                  prog_dpram.program_words(fw, n))

    def _irq_sources(self) -> None:
        """Rising edges of in-position and following-error bits of any motor, compare outputs."""
        w2 = self.fw.motors.reports.status_words()[1].astype(np.int64)
        rising = w2 & ~self._last_status2
        self._last_status2 = w2
        bits = 0
        if np.count_nonzero(rising):
            if np.count_nonzero(rising & _IN_POSITION):
                bits |= HostIrq.IN_POSITION
            if np.count_nonzero(rising & _WARN_FE):
                bits |= HostIrq.WARNING_FOLLOWING_ERROR
            if np.count_nonzero(rising & _FATAL_FE):
                bits |= HostIrq.FATAL_FOLLOWING_ERROR
        equ = self.fw.servo_ic.equ_outputs()
        if len(equ) > 0 and equ[0]:
            bits |= HostIrq.COMPARE_EQU1
        if len(equ) > 4 and equ[4]:
            bits |= HostIrq.COMPARE_EQU5
        if bits:
            self.irq.raise_(bits)

    # -- DPRAM ------------------------------------------------------------------------------------
    def _dpram_execute(self, line: str) -> tuple[list[str], int | None]:
        reply = self.fw.interpreter.execute(self.dpram_port, line)
        return reply.lines, reply.error

    def _dpram_controlchar(self, ch: int) -> str:
        return self.fw.control(self.dpram_port, ch)

    # -- host port --------------------------------------------------------------------------------
    def host_read(self, offset: int, peek: bool = False) -> int:
        """A host-port byte; `peek` reads the data register without taking its character."""
        if not 0 <= offset < HOST_SIZE:
            raise ValueError(f"host port offset {offset} outside 0-{HOST_SIZE - 1}")
        if offset == IR_STATUS:
            return self.irq.status
        if offset == IR_MASK:
            return self.irq.mask
        if offset >= 8:
            return 0
        return self.hostport.peek(offset) if peek else self.hostport.read(offset)

    def host_write(self, offset: int, value: int) -> None:
        self.touched()
        if not 0 <= offset < HOST_SIZE:
            raise ValueError(f"host port offset {offset} outside 0-{HOST_SIZE - 1}")
        if offset == IR_STATUS:
            self.irq.write_status(value)
        elif offset == IR_MASK:
            if value & _MOTOR_SOURCES and not self.irq.mask & _MOTOR_SOURCES:
                # the edges are counted from now: what is already in position is no edge
                self._last_status2 = self.fw.motors.reports.status_words()[1].astype(np.int64)
            self.irq.write_mask(value)
        elif offset < 8:
            self.hostport.write(offset, value)

    # -- Ethernet ---------------------------------------------------------------------------------
    async def open_services(self) -> None:
        """Listen for the Ethernet protocol; a port that cannot be bound is a `StartError`."""
        if not self.ethernet:
            return
        self._server = await EthernetServer.start(
            self.ethernet, self._open_ethernet_port, allow=self.allow,
            name=f"{self.name} ethernet", max_connections=self.opts.max_connections,
            idle_timeout_s=self.opts.idle_timeout_s, max_pending=self.opts.max_pending_kib << 10)
        self.ethernet_endpoint = self._server.endpoint
        log.info("%s: PMAC Ethernet protocol on %s", self.name, self.ethernet_endpoint)

    async def close_services(self) -> None:
        if self._server is not None:
            self._server.close()
            await self._server.wait_closed()
            self._server = None

    def listeners(self) -> dict[str, str]:
        return {"ethernet": self.ethernet_endpoint} if self.ethernet_endpoint else {}

    def connections(self) -> int:
        return self._server.connections if self._server is not None else 0

    def describe(self) -> dict[str, Any]:
        info = super().describe()
        info.update(device=self.device, motors=self.motors, ethernet=self.ethernet_endpoint)
        return info


    # -- the axis world (README "Axis world") -----------------------------------------------------
    def axis_index(self, axis: str | int) -> int:
        """Motor n (1-based, as the manual numbers motors) as an index; ValueError naming the
        motors otherwise."""
        n = self.motors
        if isinstance(axis, str) and axis.strip().isdigit():
            axis = int(axis)
        if isinstance(axis, int) and not isinstance(axis, bool) and 1 <= axis <= n:
            return axis - 1
        raise ValueError(f"no motor {axis!r} on this {n}-motor card (motors 1..{n})")

    def push_axis(self, a: int, counts: float) -> None:
        """Backdoor `push`: the axis moved by hand (MotionCore.push)."""
        self.fw.motors.core.push(a, counts)

    def physical_positions(self) -> np.ndarray:
        """The stages' positions: homing moves only the motors' origins (Motors.origin) and a
        power-up reset redefines the core's zero, which `physical()` takes out."""
        return self.fw.motors.core.physical()

    def _sense(self) -> None:
        """Every servo cycle while the world has mechanics, index pulses or probes: the switch
        levels from the physical positions, where each changed level changed (for the capture),
        the index (CHC) and probe (USER) pulses crossed this cycle; applied when one changed."""
        w = self.world
        phys = self.physical_positions()
        prev, self._prev_phys = self._prev_phys, phys
        changed = False
        if w.mechanical:
            before = (w.limit_pos, w.limit_neg, w.home)  # sense() replaces these arrays
            if w.sense(phys):
                self._switch_edges(prev, phys, before)
                changed = True
        if self._pulses:
            changed = self._pulse(prev, phys) or changed
        if changed:
            self._apply(self._edges)
            self._edges.fill(np.nan)

    def _switch_edges(self, prev: np.ndarray, phys: np.ndarray,
                      before: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """Where the home flag and the limit flags changed level between prev and phys, in
        encoder counts (the Servo IC latches its counter at the flag's edge)."""
        w = self.world
        zero = self.fw.motors.core.zero
        low, high = np.minimum(prev, phys), np.maximum(prev, phys)

        def crossed(at: np.ndarray) -> np.ndarray:
            return (low <= at) & (at <= high)

        lo_in, hi_in = crossed(w.home_lo), crossed(w.home_hi)
        home = np.where(lo_in & (~hi_in | (phys >= prev)), w.home_lo,
                        np.where(hi_in, w.home_hi, np.nan))
        plim = np.where(crossed(w.pos_at), w.pos_at, np.nan)
        mlim = np.where(crossed(w.neg_at), w.neg_at, np.nan)
        for row, edge, old, new in ((0, home, before[2], w.home), (1, plim, before[0], w.limit_pos),
                                    (2, mlim, before[1], w.limit_neg)):
            self._edges[row] = np.where(old != new, edge + zero, np.nan)

    def _pulse(self, prev: np.ndarray, phys: np.ndarray) -> bool:
        """The probe (USERn) and index (CHCn) inputs: high for the servo cycle in which the
        stage crossed a probe position or an index pulse (CHC also while it stands on one)."""
        w = self.world
        user = np.zeros(self.motors, dtype=bool)
        for a in self._probe_axes:
            at = w.probe_between(a, float(prev[a]), float(phys[a]))
            if at is not None:
                user[a] = True
                self._edges[3, a] = at + float(self.fw.motors.core.zero[a])
        period = w.index_period
        safe = np.where(period > 0, period, 1.0)
        now = phys - w.index_phase
        chc = (period > 0) & ((np.floor((prev - w.index_phase) / safe) != np.floor(now / safe))
                              | (now % safe == 0))
        changed = not (np.array_equal(user, self._user) and np.array_equal(chc, self._chc))
        self._user, self._chc = user, chc
        return changed

    def apply_world(self) -> None:
        """The axis world's levels and faults on the motors' flag inputs and their Servo IC
        channels (README "Backdoor")."""
        self._apply(None)

    def _apply(self, edges: np.ndarray | None) -> None:
        w, fw = self.world, self.fw
        mo, ic, core = fw.motors, fw.servo_ic, fw.motors.core
        amp = w.amp_fault | w.estop
        mo.apply_inputs(w.limit_pos, w.limit_neg, w.home, amp, self._user, edges)
        for flag, levels in ((ChannelFlag.PLIM, w.limit_pos), (ChannelFlag.MLIM, w.limit_neg),
                             (ChannelFlag.HMFL, w.home), (ChannelFlag.FAULT, amp),
                             (ChannelFlag.USER, self._user), (ChannelFlag.CHC, self._chc)):
            ic.set_flag_levels(flag, levels)
        mo.set_encoder_losses(w.encoder_loss)
        core.follow_jams(w.jammed)
        # index pulses in physical counts: the home search sees them on the encoder's count
        mo.homing.index_period[:] = w.index_period
        mo.homing.index_phase[:] = w.index_phase + core.zero
        self._probe_axes = [a for a in range(w.n) if len(w.probes[a])]
        self._pulses = bool(self._probe_axes) or bool((w.index_period > 0).any())
        if not self._sensing:
            self._prev_phys = self.physical_positions()
        self._sensing = w.mechanical or self._pulses

    def drive_input(self, line: int, level: bool) -> None:
        """JIO line 0-31 at +5 V (True) or 0 V; reads follow direction and inversion."""
        if isinstance(line, bool) or not isinstance(line, int) or not 0 <= line < 32:
            raise ValueError(f"line {line!r} outside 0..31 (JIO)")
        self.fw.gpio.set_input(line, bool(level))

    def drive_analog(self, channel: int, volts: float) -> None:
        """The voltage at ANAI00-15 (JANA)."""
        if isinstance(channel, bool) or not isinstance(channel, int) or not 0 <= channel < 16:
            raise ValueError(f"channel {channel!r} outside 0..15 (ANAI00-15)")
        self.fw.gpio.set_analog(channel, float(volts))

    def drive_estop(self, active: bool) -> None:
        """ASSUMPTION (README "Backdoor"): the Turbo PMAC has no emergency-stop input; the
        installation's stop chain cuts the amplifiers, so every motor's amplifier-fault input
        (FAULTn) reads a fault while active: the motors are killed as Ixx24 says."""
        self.world.estop = bool(active)
        self.apply_world()

    # -- the card's own and the deprecated backdoor actions ---------------------------------------
    @control(deprecated="set_limit")
    def set_limits(self, axis: int, plus: bool | None = None, minus: bool | None = None) -> None:
        """The overtravel-limit flags of motor n (1-based), True = limit tripped (held), False =
        left to the mechanics; None: unchanged."""
        if plus is not None:
            self.set_limit(axis, "positive", bool(plus))
        if minus is not None:
            self.set_limit(axis, "negative", bool(minus))

    @control()
    def get_outputs(self) -> int:
        """The 32 JIO lines as the card drives them."""
        return int(self.fw.gpio.outputs())

    @control()
    def set_mldt_base(self, axis: int, mm: float) -> None:
        """MLDT: the magnet's distance from the sensor head at encoder count 0 of motor n's
        channel, mm (the timer reads base + encoder count, one count per timer LSB)."""
        m = self.axis_index(axis)
        if m >= self.fw.servo_ic.n:
            raise ValueError(f"motor {axis} has no on-board channel")
        self.fw.servo_ic.set_mldt_base(m, float(mm))

    @control()
    def set_phase_clock_error(self, active: bool) -> None:
        """X:$000006 bit 3: while set, enabling a motor answers ERR018 [A L3320]."""
        self.fw.set_phase_clock_error(bool(active))
