"""The Galil DMC-13X8 VME card (type `galil-dmc13x8`): README.md in this package.

The A16 window (bus.py) is the host interface; every servo sample the card advances the motion
firmware (motion.py), decodes the commands waiting in the command FIFO (interpreter.py), raises
the EI interrupt conditions and refreshes the secondary-FIFO data record (record.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import Any, ClassVar

import numpy as np

from vdevd.devices.base import Card, CardContext, Option, axis_number, control
from vdevd.devices.galil import syntax
from vdevd.devices.galil.bus import FREEZE_MODES, WINDOW_SIZE, A16Reg, A16Window
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.interpreter import (
    AXIS_LETTERS,
    OK,
    REPORT_FORMATS,
    Interpreter,
    Trippoint,
)
from vdevd.devices.galil.motion import GalilMotion, StopCode
from vdevd.devices.galil.params import COUNTS_PER_VOLT, PARAMS
from vdevd.devices.galil.record import GeneralStatus, record_dtype
from vdevd.region import Region
from vdevd.rt import PlantKind, wrap_int32

_DATA = int(A16Reg.DATA)  # a plain int: an enum member costs a lookup on every access
#: a host repeats its lines (`TPX\r`): frame each content of the command FIFO once (pure)
_next_frame = lru_cache(maxsize=256)(syntax.next_frame)


class Condition:
    """Bits of EI's condition mask m [M Ch4 §Configuring Interrupts]."""

    ALL_COMPLETE = 1 << 8
    EXCESS_ERROR = 1 << 9  # re-enable after each occurrence
    LIMIT_SWITCH = 1 << 10
    WATCHDOG = 1 << 11
    PROGRAM_STOPPED = 1 << 13
    COMMAND_DONE = 1 << 14
    INPUTS = 1 << 15  # re-enable after each occurrence


class Status:
    """Interrupt status codes read after writing 6 to N+3 [M Ch4 §Servicing Interrupts]."""

    LIMIT_SWITCH = 0xC0
    EXCESS_ERROR = 0xC8
    AXIS_COMPLETE = 0xD0  # + axis (X D0 ... W D3)
    ALL_COMPLETE = 0xD8
    COMMAND_DONE = 0xDA
    INPUT = 0xE0  # + input 1..8
    USER = 0xF0  # + n


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
    }

    def __init__(self, name: str, config: Mapping[str, Any], ctx: CardContext) -> None:
        super().__init__(name, config, ctx)
        cfg = self.config
        self.n = int(cfg.get("axes") or 4)
        self.configured_tm_us = int(cfg.get("tm_us") or 1000)
        if not cfg.get("period_ns"):
            self.period_ns = self.configured_tm_us * 1000
        base = int(cfg.get("base", 0xFFF0))
        if base % WINDOW_SIZE:
            raise ValueError(f"base: {base:#x} is not a multiple of 16 (A4..A15 jumpers)")
        self.base = base
        self.irq_level = int(cfg.get("irq_level") or 5)
        self.plant = str(cfg.get("plant") or "servo")
        self.sm_jumper = self.plant == "stepper"
        self.decode_on_arrival = str(cfg.get("decode") or "arrival") == "arrival"
        self.bus = A16Window(freeze_mode=str(cfg.get("freeze_mode") or "toggle_n5"))
        self.bus.on_assert = self._assert
        self.bus.on_clear = self._cleared
        self.a16 = self.add_region(Region(
            "a16", WINDOW_SIZE, widths=(1,), endian="big", aligned=False,
            description="A16 short I/O, D08(O): FIFOs N+1, control N+3, secondary FIFO N+5/N+7"))
        self.a16.hook(0, WINDOW_SIZE, on_read=self._host_read, on_write=self._host_write,
                      peek=self._host_peek, on_read_rep=self._host_read_rep,
                      on_write_rep=self._host_write_rep)
        self.irq = self.add_irq("irq")
        self._dtype = record_dtype(self.n, str(cfg.get("record_endian") or "little"))
        self.env = _Env(self)
        self.analog = np.zeros(8)
        self.inputs = 0xFF  # IN1-IN8 logic levels: open inputs read 1
        self.firmware_reset()

    # -- power-on and RS -----------------------------------------------------------------------------
    def firmware_reset(self) -> None:
        """Power-on / RS: default parameters, positions 0, interrupts and record off."""
        self.motion = GalilMotion(self.n, self.period_ns, self.plant)
        self.interp = Interpreter(self)
        self.error_code = 0
        self.echo = 0
        self.lz = 0
        self.tm_us = float(self.configured_tm_us)
        self.record_rate = 0
        self.outputs = 0
        self.ei_mask = 0
        self.ei_inputs = 0
        self.vector: int | None = None
        self.time_origin = self.ticks
        self._trip: Trippoint | None = None
        self._out = bytearray()

    def reset(self) -> None:
        self.bus.reset()
        self.irq.clear()
        self.firmware_reset()

    # -- the host's bus accesses -------------------------------------------------------------------
    def _host_read(self, offset: int, size: int) -> bytes:
        value = self.bus.read(offset)
        if self.irq.asserted and not self.bus.line_asserted:
            self.irq.clear()
        return bytes((value,))

    def _host_write(self, offset: int, data: bytes) -> None:
        self.bus.write(offset, data[0])
        if offset == _DATA and self.decode_on_arrival:
            self._serve()  # the command it completes is decoded at once
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
                self._serve()
        else:
            for b in data:
                self._host_write(offset, bytes((b,)))

    def _host_peek(self, offset: int, size: int) -> bytes:
        return bytes(self.bus.peek(o) for o in range(offset, offset + size))

    # -- the firmware ------------------------------------------------------------------------------
    def step(self) -> None:
        """One sample: motion, interrupt conditions, the command interpreter, the data record."""
        motion = self.motion
        done = motion.tick()
        if done is not None:
            self._motion_complete(done)
        over = motion.check_error()
        if over is not None and self.ei_mask & Condition.EXCESS_ERROR:
            self.ei_mask &= ~Condition.EXCESS_ERROR
            self.interrupt(Status.EXCESS_ERROR)
        if self._out or self._trip is not None or self.bus.commands_waiting:
            self._serve()
        rate = self.record_rate
        if rate and not (self.ticks - self.time_origin) % (1 << rate):
            self.bus.load_record(self.data_record())

    def _motion_complete(self, done: np.ndarray) -> None:
        """EI bits 0-3 per axis and bit 8 when every axis has stopped [M Ch4]."""
        mask = self.ei_mask
        for a in np.flatnonzero(done).tolist():
            if mask & (1 << a):
                self.interrupt(Status.AXIS_COMPLETE + a)
        if mask & Condition.ALL_COMPLETE and not self.motion.core.profile.moving.any():
            self.interrupt(Status.ALL_COMPLETE)

    def _serve(self) -> None:
        """Decode the complete commands in the command FIFO, replying into the response FIFO;
        a trippoint or a full response FIFO holds the interpreter (spec §2.4, §5.7)."""
        bus = self.bus
        while True:
            if self._out:  # self._out, no local name: RS replaces it
                del self._out[:bus.respond(self._out)]
                if self._out:
                    return
            if self._trip is not None:
                if not self._trip.ready():
                    return
                self._trip = None
                self._reply(OK)
                continue
            buf = bus.command_bytes()
            if not buf:
                return
            frame, used = _next_frame(buf)
            if used:
                bus.consume(used)
            if frame is None:
                if used:
                    continue
                return
            if self.echo and not frame.binary:
                self._out += buf[:used]
            result = self._execute(frame)
            if isinstance(result, Trippoint):
                self._trip = result
            else:
                self._reply(result)

    def _cleared(self) -> None:
        """The host cleared the FIFOs: "useful for emergency resets or Abort" [M Ch4]; a held
        command-line trippoint and a reply in progress go too."""
        self._trip = None
        self._out.clear()

    def _execute(self, frame: syntax.Frame) -> bytes | Trippoint:
        if not frame.binary:
            return self.interp.execute(frame.data.decode("latin-1"))
        try:
            text = syntax.binary_to_ascii(syntax.decode_binary(frame.data))
        except GalilError as exc:
            self.error_code = exc.code
            return b"?"
        return self.interp.execute(text)

    def _reply(self, data: bytes) -> None:
        self._out += data
        if self.ei_mask & Condition.COMMAND_DONE:
            self.interrupt(Status.COMMAND_DONE)

    # -- interrupts --------------------------------------------------------------------------------
    def enable_interrupts(self, m: int | None, n: int | None, vector: int | None) -> None:
        """EI: conditions, input mask, vector; EI0 clears the queue [M Ch4]."""
        if m is not None:
            self.ei_mask = m
            if m == 0:
                self.bus.clear_interrupts()
                self.irq.clear()
        if n is not None:
            self.ei_inputs = n
        if vector is not None:
            self.vector = vector

    def interrupt(self, code: int) -> None:
        """Queue a status code; the line asserts while the host has interrupts enabled."""
        self.bus.post_interrupt(code)

    def _assert(self, code: int) -> None:
        self.irq.trigger(code | (self.vector or 0) << 8 | self.irq_level << 16)

    # -- what the card reports ---------------------------------------------------------------------
    def report(self, name: str) -> np.ndarray:
        """The per-axis values of TP, TE, RP, TD, RL, TV, TT, SC, TS."""
        m = self.motion
        if name == "TP":
            return m.position()
        if name == "TE":
            return m.error()
        if name == "RP":
            return m.reference()
        if name == "TD":
            return m.auxiliary()
        if name == "RL":
            return m.latched
        if name == "TV":
            return np.rint(m.tv)
        if name == "TT":
            return m.torque()
        if name == "SC":
            return m.stop_code.astype(float)
        if name == "TS":
            return m.tell_switches().astype(float)
        raise KeyError(name)

    def status_byte(self) -> int:
        """TB: bit 6 data record active, bit 0 echo on (spec §4.4)."""
        return (0x40 if self.record_rate else 0) | (0x01 if self.echo else 0)

    def input_bank(self, bank: int) -> int:
        if bank == 0:
            return self.inputs
        if 2 <= bank <= 10:
            return 0xFF  # extended I/O banks unconfigured; aux-encoder inputs open
        raise GalilError(TC.NUMBER_OUT_OF_RANGE)

    def latch_inputs(self) -> np.ndarray:
        """IN1..IN4 are the X..W latch inputs (Fig 3-1)."""
        return np.array([(self.inputs >> a) & 1 for a in range(self.n)], dtype=bool)

    def data_record(self) -> bytes:
        """The REV4 record of this sample (ch. 4 "DMA / Secondary FIFO Memory Map")."""
        m = self.motion
        rec = np.zeros((), dtype=self._dtype)
        rec["sample"] = (self.ticks - self.time_origin) & 0xFFFF
        rec["inputs"][0] = self.inputs
        rec["inputs"][1:] = 0xFF
        rec["outputs"][0] = self.outputs & 0xFF
        rec["error_code"] = self.error_code & 0xFF
        rec["general_status"] = GeneralStatus.ECHO_ON if self.echo else 0
        ax = rec["axis"]
        ax["status"] = m.status_word()
        ax["switches"] = m.switches(self.latch_inputs())
        ax["stop_code"] = m.stop_code
        ax["reference"] = wrap_int32(m.reference())
        ax["position"] = wrap_int32(m.position())
        ax["error"] = wrap_int32(m.error())
        ax["aux"] = wrap_int32(m.auxiliary())
        ax["velocity"] = wrap_int32(m.tv * 64)
        ax["torque"] = np.rint(m.torque() * COUNTS_PER_VOLT).clip(-32767, 32767)
        ax["analog"] = np.rint(self.analog[: self.n] * COUNTS_PER_VOLT).clip(-32767, 32767)
        return rec.tobytes()

    # -- backdoor ----------------------------------------------------------------------------------
    def _axis(self, axis: str | int) -> int:
        return axis_number(axis, AXIS_LETTERS, self.n)

    @control()
    def set_switches(self, axis: str, forward_limit: bool | None = None,
                     reverse_limit: bool | None = None, home: int | None = None) -> None:
        """Limit switches (True = tripped) and the home input logic level of one axis."""
        a, m = self._axis(axis), self.motion
        forward, reverse = m.forward_limit.copy(), m.reverse_limit.copy()
        if forward_limit is not None:
            forward[a] = bool(forward_limit)
        if reverse_limit is not None:
            reverse[a] = bool(reverse_limit)
        rising = m.set_limits(forward, reverse)
        if rising.any() and self.ei_mask & Condition.LIMIT_SWITCH:
            self.interrupt(Status.LIMIT_SWITCH)
        if home is not None:
            m.set_home_edge(a, None)
            m.home_input[a] = bool(home)

    @control()
    def set_home_edge(self, axis: str, position: float | None = None) -> None:
        """A home switch at `position`: the input reads 1 below it and 0 above it (None: the
        level set by set_switches)."""
        self.motion.set_home_edge(self._axis(axis), position)

    @control()
    def set_index(self, axis: str, period: float = 4096, phase: float = 0) -> None:
        """Encoder index pulses at phase + k * period counts (default one per 4096 counts)."""
        if not period > 0:
            raise ValueError("period must be positive")
        a = self._axis(axis)
        self.motion.index_period[a], self.motion.index_phase[a] = float(period), float(phase)

    @control()
    def set_abort(self, active: bool) -> None:
        """The ABORT input: motion stops at once, OE1 axes turn off [M Ch3 §Abort Input]."""
        if active and not self.motion.abort_input:
            self.motion.abort(list(range(self.n)), StopCode.ABORT_INPUT)
        self.motion.abort_input = bool(active)

    @control()
    def set_input(self, input: int, level: int) -> None:
        """General input IN1..IN8 logic level; a falling edge latches an armed axis (IN1..IN4)
        and raises an enabled input interrupt (EI bit 15)."""
        if not 1 <= input <= 8:
            raise ValueError("input must be 1..8")
        bit = 1 << (input - 1)
        falling = bool(self.inputs & bit) and not level
        self.inputs = self.inputs | bit if level else self.inputs & ~bit
        if not falling:
            return
        a = input - 1
        m = self.motion
        if a < self.n and m.latch_armed[a]:
            m.latched[a] = m.position()[a]
            m.latch_armed[a], m.latch_occurred[a] = False, True
        if self.ei_mask & Condition.INPUTS and self.ei_inputs & bit:
            self.ei_mask &= ~Condition.INPUTS
            self.interrupt(Status.INPUT + input)

    @control()
    def set_analog(self, input: int, volts: float) -> None:
        """Analog input AN1..AN8 in volts (+-10 V, 12-bit)."""
        if not 1 <= input <= 8:
            raise ValueError("input must be 1..8")
        step = 20 / 4096  # 4096 levels from -10 V to 10 V - one step
        self.analog[input - 1] = min(max(round(float(volts) / step), -2048), 2047) * step

    @control()
    def set_amp_fault(self, axis: str, active: bool) -> None:
        """An amplifier fault: the amplifier stops driving the motor (it coasts), the card keeps
        servoing, so the position error grows until ER/OE act as on the real card."""
        a = self._axis(axis)
        core = self.motion.core
        if core.kinds[a] == PlantKind.SERVO:
            core.plant.set(a, peak_torque=1e-9 if active else np.inf)
        else:
            fault = core.amp_fault.copy()
            fault[a] = bool(active)
            core.set_inputs(amp_fault=fault)

    @control()
    def set_encoder_loss(self, axis: str, active: bool) -> None:
        """A lost encoder: the position reading freezes (the servo then runs away)."""
        a = self._axis(axis)
        loss = self.motion.core.encoder_loss.copy()
        loss[a] = bool(active)
        self.motion.core.set_inputs(encoder_loss=loss)

    @control()
    def set_friction(self, axis: str, volts: float) -> None:
        """Coulomb friction of a servo motor, as the DAC voltage it takes to overcome it."""
        if not volts >= 0:
            raise ValueError("volts must be >= 0")
        a = self._axis(axis)
        core = self.motion.core
        core.plant.set(a, coulomb=float(volts) * COUNTS_PER_VOLT * float(core.plant.amp_gain[a]))


#: `_DEx` and `_DPx` read what DE and DP defined: the auxiliary encoder and the reference
_DEFINED = {"DE": "TD", "DP": "RP"}


class _Env:
    """Operands (`_TPX`), variables and @IN/@OUT/@AN for the expression evaluator."""

    def __init__(self, card: GalilCard) -> None:
        self.card = card

    def operand(self, name: str) -> float:
        card, m = self.card, self.card.motion
        if name == "TIME":
            return float(card.ticks - card.time_origin)
        scalars = {"TC": card.error_code, "TB": card.status_byte(), "OP": card.outputs,
                   "EO": card.echo, "LZ": card.lz, "TM": card.tm_us, "DR": card.record_rate}
        if name in scalars:
            return float(scalars[name])
        if name.startswith("TI") and name[2:].isdigit():
            return float(card.input_bank(int(name[2:])))
        cmd, letter = name[:2], name[2:]
        if len(letter) != 1 or letter not in "XYZWABCD":
            raise GalilError(TC.BAD_FUNCTION, name)
        a = "XYZWABCD".index(letter) % 4
        if a >= card.n:
            raise GalilError(TC.ONLY_ABCD_VALID, name)
        cmd = _DEFINED.get(cmd, cmd)
        if cmd in REPORT_FORMATS:
            return float(card.report(cmd)[a])
        if cmd == "PA":
            return float(m.destination()[a])
        if cmd in PARAMS:
            return float(m.values[cmd][a])
        per_axis = {
            "LF": not m.forward_limit[a], "LR": not m.reverse_limit[a], "HM": m.home_input[a],
            "MO": not m.core.servo_on_mask[a], "BG": m.moving(a), "AL": m.latch_armed[a],
        }
        if cmd in per_axis:
            return float(per_axis[cmd])
        raise GalilError(TC.BAD_FUNCTION, name)

    def variable(self, name: str) -> float:
        try:
            return self.card.interp.variables[name]
        except KeyError:
            raise GalilError(TC.VARIABLE_ERROR, name) from None

    def array(self, name: str, index: int) -> float:
        raise GalilError(TC.BAD_FUNCTION, f"no array {name}")

    def function(self, name: str, arg: float) -> float:
        card = self.card
        n = int(arg)
        if name == "IN":
            if 1 <= n <= 8:
                return float((card.inputs >> (n - 1)) & 1)
            if 17 <= n <= 88:
                return 1.0  # extended inputs unconfigured, unused aux-encoder inputs open
        elif name == "OUT":
            if 1 <= n <= 8:
                return float((card.outputs >> (n - 1)) & 1)
            if 17 <= n <= 80:
                return 0.0
        elif name == "AN":
            if 1 <= n <= 8:
                return float(card.analog[n - 1])
        else:
            raise GalilError(TC.BAD_FUNCTION, name)
        raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"@{name}[{n}]")
