"""The DMC-13X8 firmware: the card's state and its sample loop, without I/O (manual ch. 3-6).

The card (card.py) hands it the A16 window (bus.py) and a callback that raises the VME interrupt
line; it runs `step()` every servo sample and `serve()` when a command arrives. The firmware owns
the motion (motion.py), the command interpreter (interpreter.py, which depends on it and never on
the card), the I/O, the error code, the variables, the EI conditions, the report formats, the
timing and the master reset, the application programs and their threads (threads.py: they run
at every sample while one runs) and the flash (flash.py). Register offsets and codes are
`vdevmaps.galil`.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from functools import lru_cache
from typing import Any

import numpy as np
from vdevmaps.galil import GeneralStatus, InterruptCondition, InterruptStatus

from vdevd.devices.galil import syntax
from vdevd.devices.galil.analog_feedback import align, counts, overlay
from vdevd.devices.galil.arrays import ArrayDownload, ArrayTable
from vdevd.devices.galil.bus import A16Window
from vdevd.devices.galil.coord import Coordinated
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.extended_io import FIRST_BANK, FIRST_POINT, LAST_BANK, LAST_POINT, ExtendedIO
from vdevd.devices.galil.flash import Flash
from vdevd.devices.galil.follow import Follow
from vdevd.devices.galil.follow_commands import operand
from vdevd.devices.galil.formats import DEFAULT_PF, DEFAULT_VF
from vdevd.devices.galil.interpreter import OK, Interpreter, Trippoint
from vdevd.devices.galil.motion import GalilMotion, StopCode
from vdevd.devices.galil.numbers import REPORT_FORMATS
from vdevd.devices.galil.output_compare import OutputCompare
from vdevd.devices.galil.params import COUNTS_PER_VOLT, PARAMS
from vdevd.devices.galil.program import ProgramDownload
from vdevd.devices.galil.program_commands import ProgramCommands
from vdevd.devices.galil.record import record_dtype
from vdevd.devices.galil.recorder import Recorder
from vdevd.devices.galil.threads import LIMSWI, POSERR, Threads
from vdevd.devices.galil.virtual import VirtualAxis
from vdevd.devices.galil.virtual_commands import operand as virtual_operand
from vdevd.devices.rest import ticks_before_multiple
from vdevd.rt import wrap_int32

#: a host repeats its lines (`TPX\r`): frame each content of the command FIFO once (pure)
_next_frame = lru_cache(maxsize=256)(syntax.next_frame)
_TERMINATOR = re.compile(rb"[\r;]")

_EXCESS_ERROR = int(InterruptCondition.EXCESS_ERROR)  # plain ints on the sample path
_ALL_COMPLETE = int(InterruptCondition.ALL_COMPLETE)
_COMMAND_DONE = int(InterruptCondition.COMMAND_DONE)
_LIMIT_SWITCH = int(InterruptCondition.LIMIT_SWITCH)
_INPUTS = int(InterruptCondition.INPUTS)
_PROGRAM_STOPPED = int(InterruptCondition.PROGRAM_STOPPED)
_MARK = bytes(b | 0x80 for b in range(256))  # CW1: a program's message with bit 7 set


class Firmware:
    """One card's firmware state over its A16 window; `raise_irq(code | vector << 8)` asserts the
    interrupt line, `clear_irq()` drops it (EI0); `clock()` is the time in ns (the card's, which
    the rack may set between samples; by default the time of the last sample)."""

    def __init__(self, n: int, period_ns: int, plant: str, tm_us: int, bus: A16Window, *,
                 raise_irq: Callable[[int], None], clear_irq: Callable[[], None],
                 clock: Callable[[], int] | None = None, record_endian: str = "little",
                 sense: Callable[[], None] | None = None,
                 on_reset: Callable[[], None] | None = None,
                 save_flash: Callable[[dict[str, Any]], None] | None = None,
                 flash_image: dict[str, Any] | None = None) -> None:
        self.n = n
        self.period_ns = period_ns
        self.plant = plant
        self.sm_jumper = plant == "stepper"  # SM jumpers installed [M Ch6 §Stepper Motor Operation]
        self.configured_tm_us = tm_us
        self.bus = bus
        self.raise_irq = raise_irq
        self.clear_irq = clear_irq
        self.clock = clock
        self.sense = sense
        self.on_reset = on_reset
        bus.on_assert = self._assert
        bus.on_clear = self.host_cleared
        self._dtype = record_dtype(n, record_endian)
        self.ticks = 0  # samples since power-on: the card's tick count
        self.env = _Env(self)
        self.analog = np.zeros(8)
        self.inputs = 0xFF  # IN1-IN8 logic levels: open inputs read 1
        self.ext = ExtendedIO()  # points 17-80 (CO)
        #: CMP pulses of a sample (OC): called with the count since RS (the card's `cmp` line)
        self.on_compare: Callable[[int], None] | None = None
        self.threads = Threads(self)  # the program buffer and its threads (threads.py)
        self.program_commands = ProgramCommands(self)
        #: objects whose methods run commands, bound with the interpreter's (commands.py)
        self.command_sets: tuple[object, ...] = (self.program_commands,)
        #: `_XX` operands other modules answer: "XQ" -> fn("XQ0"), see _Env.operand
        self.operands: dict[str, Callable[[str], float]] = {
            "XQ": self.threads.operand, "ED": self.threads.operand, "LK": self.threads.operand}
        self.flash = Flash(self, save_flash, flash_image)
        self.interp = Interpreter(self)
        self.reset()

    @property
    def now_ns(self) -> int:
        """The time now (WT measures from it)."""
        return self.clock() if self.clock is not None else self.ticks * self.period_ns

    # -- power-on, RS and ^R^S ---------------------------------------------------------------------
    def reset(self) -> None:
        """Power-on / RS: default parameters, positions 0, variables gone, interrupts and record
        off [M Ch4 §Clearing FIFO Buffer; spec §1.4]. The stage does not move: its physical
        positions carry over (the switches stay where they are) and the encoders read 0 there."""
        old = getattr(self, "motion", None)
        self.motion = GalilMotion(self.n, self.period_ns, self.plant)
        self.motion.sense = self.sense
        self.virtual = VirtualAxis(self.period_ns)  # the N axis [M Ch6 §Virtual Axis]
        self.follow = Follow(self.motion, self.virtual)
        self.follow.spm.on_error = lambda: self.threads.automatic(POSERR)  # YS 2 [M Ch6 §SPM]
        self.coord = Coordinated(self.motion, self.virtual)  # the S and T planes (coord.py)
        planes = self.coord.planes
        self.follow.gearing.planes = lambda: (planes["S"].travelled, planes["T"].travelled)
        if old is not None:
            self.motion.core.zero[:] = -old.core.physical()
        self.variables: dict[str, float] = {}
        self.arrays = ArrayTable()
        self.recorder = Recorder()  # record mode (RA RD RC)
        #: QD or DL taking its data from the command FIFO
        self.sink: ArrayDownload | ProgramDownload | None = None
        self.error_code = 0
        self.echo = 0
        self.lz = 0
        self.pf, self.vf = DEFAULT_PF, DEFAULT_VF  # PF, VF [formats.py]
        self.tm_us = float(self.configured_tm_us)
        self.record_rate = 0
        self.outputs = 0
        self.ext.reset()  # CO 0: banks 2-9 inputs; the levels driven on them stay
        self.compare = OutputCompare()  # OC
        self.af_on = np.zeros(self.n, dtype=bool)  # AF: axes reading their analog input
        self.ei_mask = 0
        self.ei_inputs = 0
        self.vector: int | None = None
        self.time_origin = self.ticks
        self.at_reference: dict[int | None, int] = {}  # per thread (None: the command line)
        self._trip: Trippoint | None = None
        self._dropping = False  # inside an over-long line: dropped through its terminator
        self._out = bytearray()
        self.ar_base: dict[int, float] = {}  # AR: where the last AR trippoint ended per axis
        self.mark_unsolicited = True  # CW1 (README "Application programs")
        self.threads.reset()
        self.flash.restore()  # BN, BV, BP: the burned state [spec §1.4]
        if self.on_reset is not None:
            self.on_reset()  # the card puts its inputs on the new motion firmware
        self.threads.start_auto()

    # -- the sample --------------------------------------------------------------------------------
    def step(self) -> None:
        """One sample: motion, interrupt conditions, the command interpreter, the data record."""
        self.ticks += 1
        if self.coord.active:
            self.coord.sample()
        if self.virtual.moving:  # N first: its followers see it in the same sample
            self.virtual.tick()
        self._after_motion(self.motion.tick())

    def _after_motion(self, done: np.ndarray | None) -> None:
        """The rest of a sample after its motion, in which the axes of `done` completed."""
        motion = self.motion
        if self.compare.armed:
            self._compare()
        if done is not None:
            self._motion_complete(done)
        over = motion.check_error()
        if over is not None and self.ei_mask & _EXCESS_ERROR:
            self.ei_mask &= ~_EXCESS_ERROR
            self.interrupt(InterruptStatus.EXCESS_ERROR)
        if self.threads.active:
            if over is not None:
                self.threads.automatic(POSERR)
            self.threads.run()
        if self._out or self._trip is not None or self.bus.commands_waiting:
            self.serve()
        if self.ticks >= self.recorder.next_tick:
            self.recorder.capture()  # record mode, after the commands of the sample [M Ch6 §Teach]
        rate = self.record_rate
        if rate and not (self.ticks - self.time_origin) % (1 << rate):
            self.bus.load_record(self.data_record())

    # -- runs of samples (Card.run) -------------------------------------------------------------------
    def idle_samples(self, room: int) -> int:
        """Of the next `room` samples, how many are motion and the ER check alone while no axis
        completes and none crosses ER: none while the interpreter has work (a reply to send, a
        trippoint, commands), none while a program thread runs or an output compare is armed,
        none from the next data record or record mode capture on."""
        if (self._out or self._trip is not None or self.bus.commands_waiting
                or self.threads.active or self.compare.armed):
            return 0
        room = min(room, self.recorder.next_tick - self.ticks - 1)
        rate = self.record_rate
        if rate:
            room = min(room, ticks_before_multiple(self.ticks - self.time_origin, 1 << rate))
        return room

    def run_samples(self, room: int, advance: Callable[[int], None]) -> int:
        """Up to `room` samples that `idle_samples` allowed, as `step` runs them; the first in
        which an axis completes or crosses ER runs the rest of its sample (interrupts, the
        interpreter) after `advance(k)`, the card's clock to it, and ends the run. `advance`
        sees the count run at the end; returned too."""
        motion, coord, virtual = self.motion, self.coord, self.virtual
        tick, changed = motion.tick, motion.error_changed
        for k in range(1, room + 1):
            self.ticks += 1
            if coord.active:
                coord.sample()
            if virtual.moving:
                virtual.tick()
            done = tick()
            if done is not None or changed():
                advance(k)
                self._after_motion(done)
                return k
        advance(room)
        return room

    # -- rest (decision 0008) -----------------------------------------------------------------------
    def rest_state(self) -> bytes | None:
        """What a sample may change, as bytes, but the sample count; None while the interpreter
        has work (a command, a reply to send, a trippoint), records (RC), a program thread runs,
        a coordinated plane runs, the virtual axis N moves or a home search runs."""
        if (self._out or self._trip is not None or self.bus.commands_waiting
                or self.recorder.active or self.threads.active or self.coord.active
                or self.virtual.moving):
            return None
        rest = self.motion.rest_state()
        return None if rest is None else rest + self.compare.state()

    def quiet_ticks(self) -> int:
        """At rest, the samples before the next data record (DR n: every 2^n samples)."""
        rate = self.record_rate
        if not rate:
            return 1 << 62
        return ticks_before_multiple(self.ticks - self.time_origin, 1 << rate)

    def skip(self, k: int) -> None:
        """k samples at rest: only the sample count and the profile clock move."""
        self.ticks += k
        self.motion.core.skip(k)

    def _compare(self) -> None:
        """OC: the pulses of the positions the watched encoder passed in this sample."""
        compare, a = self.compare, self.compare.axis
        core = self.motion.core
        if compare.check(int(self.motion.position()[a]), float(core.zero[a])) and self.on_compare:
            self.on_compare(compare.pulses)

    def _motion_complete(self, done: np.ndarray) -> None:
        """EI bits 0-3 per axis and bit 8 when every axis has stopped [M Ch4]."""
        mask = self.ei_mask
        for a in np.flatnonzero(done).tolist():
            if mask & (1 << a):
                self.interrupt(InterruptStatus.AXIS_COMPLETE + a)
        if mask & _ALL_COMPLETE and not self.motion.core.profile.moving.any():
            self.interrupt(InterruptStatus.ALL_COMPLETE)

    # -- the command FIFO --------------------------------------------------------------------------
    def serve(self) -> None:
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
            if self.sink is not None:  # QD's or DL's data, not commands
                used, code = self.sink.feed(bus.command_bytes())
                bus.consume(used)
                if code is None:
                    return
                self.sink = None
                self.error_code = code or self.error_code
                self._reply(b"?" if code else OK)
                continue
            buf = bus.command_bytes()
            if not buf:
                return
            if self._dropping:  # an over-long line: its bytes go, through its terminator
                end = _TERMINATOR.search(buf)
                bus.consume(len(buf) if end is None else end.end())
                if end is None:
                    return
                self._dropping = False
                continue
            frame, used = _next_frame(buf)
            if used:
                bus.consume(used)
            if frame is None:
                if used:
                    continue
                if len(buf) >= bus.fifo_size:  # full, and no command ends in it: none ever will
                    self._overlong(len(buf))
                    continue
                return
            if self.echo and not frame.binary:
                self._out += buf[:used]
            if not frame.binary and self.threads.answer(frame.data):
                continue  # a bare number answers IN, without a reply [DMCLIB DMCCommand]
            result = self._execute(frame)
            if isinstance(result, Trippoint):
                self._trip = result
            elif isinstance(result, (ArrayDownload, ProgramDownload)):
                self.sink = result
            else:
                self._reply(result)

    def _overlong(self, size: int) -> None:
        """A line longer than the command FIFO holds: answered `?` with TC 5 "Input buffer
        full" [M Ch4 Introduction: a 512-character FIFO; TC table], its bytes dropped through
        its terminator; the commands after it run (the Ethernet channel does the same,
        channel.py)."""
        self.bus.consume(size)
        self._dropping = True
        self.error_code = int(TC.INPUT_BUFFER_FULL)
        self._reply(b"?")

    def host_cleared(self) -> None:
        """The host cleared the FIFOs: "useful for emergency resets or Abort" [M Ch4]; a held
        command-line trippoint and a reply in progress go too."""
        self._trip = None
        self._out.clear()
        self.sink = None
        self._dropping = False

    def _execute(self, frame: syntax.Frame) -> bytes | Trippoint | ArrayDownload:
        if not frame.binary:
            return self.interp.execute(frame.data.decode("latin-1"))
        try:
            text = syntax.binary_to_ascii(syntax.decode_binary(frame.data))
        except GalilError as exc:
            self.error_code = exc.code
            return b"?"
        return self.interp.execute(text)

    def output(self, data: bytes) -> None:
        """A program's message to the host (MG, a report): into the response FIFO after what
        waits there, as an unsolicited message, with bit 7 set unless CW2."""
        self._out += data.translate(_MARK) if self.mark_unsolicited else data

    @property
    def pending_output(self) -> bytearray:
        return self._out

    def _reply(self, data: bytes) -> None:
        self._out += data
        if self.ei_mask & _COMMAND_DONE:
            self.interrupt(InterruptStatus.COMMAND_DONE)

    # -- interrupts [M Ch4 §Interrupts] --------------------------------------------------------------
    def enable_interrupts(self, m: int | None, n: int | None, vector: int | None) -> None:
        """EI: conditions, input mask, vector; EI0 clears the queue [M Ch4]."""
        if m is not None:
            self.ei_mask = m
            if m == 0:
                self.bus.clear_interrupts()
                self.clear_irq()
        if n is not None:
            self.ei_inputs = n
        if vector is not None:
            self.vector = vector

    def program_stopped(self) -> None:
        """A thread ended by itself: EI bit 13, status DB [M Ch4 §Configuring Interrupts]."""
        if self.ei_mask & _PROGRAM_STOPPED:
            self.interrupt(InterruptStatus.PROGRAM_STOPPED)

    def interrupt(self, code: int) -> None:
        """Queue a status code; the line asserts while the host has interrupts enabled."""
        self.bus.post_interrupt(int(code))

    def _assert(self, code: int) -> None:
        self.raise_irq(code | (self.vector or 0) << 8)

    # -- inputs (the backdoor drives them) ---------------------------------------------------------
    def set_limits(self, forward: np.ndarray, reverse: np.ndarray) -> None:
        """The limit switches of every axis (True = tripped); one becoming active raises EI bit 10
        [M Ch3 §Limit Switch Input]."""
        rising = self.motion.set_limits(forward, reverse)
        if rising.any() and self.ei_mask & _LIMIT_SWITCH:
            self.interrupt(InterruptStatus.LIMIT_SWITCH)
        if rising.any():
            self.threads.automatic(LIMSWI)  # [M Ch3 §Limit Switch Input]

    def set_abort(self, active: bool) -> None:
        """The ABORT input: motion stops at once, OE1 axes turn off [M Ch3 §Abort Input]."""
        if active and not self.motion.abort_input:
            self.motion.abort(list(range(self.n)), StopCode.ABORT_INPUT)
            self.virtual.abort()
            self.follow.aborted()
        self.motion.abort_input = bool(active)

    def set_input(self, input: int, level: int) -> None:
        """General input IN1..IN8 (17..80: an extended I/O point, extended_io.py); a falling
        edge latches an armed axis (IN1..IN4, Fig 3-1) and raises an enabled input interrupt
        (EI bit 15, then cleared) [M Ch4]."""
        if input >= FIRST_POINT:
            self.ext.set_input(input, bool(level))
            return
        bit = 1 << (input - 1)
        falling = bool(self.inputs & bit) and not level
        self.inputs = self.inputs | bit if level else self.inputs & ~bit
        if not falling:
            return
        a = input - 1
        if a < self.n:
            self.latch(a, float(self.motion.position()[a]))
        self._input_interrupt(input)
        self.threads.input_fell(input)

    def probe(self, axis: int, reading: float) -> None:
        """A pulse on the axis's latch input (IN1..IN4) shorter than a sample, the encoder
        reading `reading` at its falling edge: the latch and the input interrupt of a falling
        edge; the input reads its level again at the next sample."""
        self.latch(axis, reading)
        self._input_interrupt(axis + 1)

    def latch(self, axis: int, reading: float) -> None:
        """A falling edge on the latch input of an armed axis captures `reading` (Fig 3-1)."""
        m = self.motion
        if m.latch_armed[axis]:
            m.latched[axis] = reading
            m.latch_armed[axis], m.latch_occurred[axis] = False, True

    def _input_interrupt(self, input: int) -> None:
        """EI bit 15 for an input of the mask, then cleared [M Ch4]."""
        if self.ei_mask & _INPUTS and self.ei_inputs & (1 << (input - 1)):
            self.ei_mask &= ~_INPUTS
            self.interrupt(InterruptStatus.INPUT + input)

    # -- what the card reports ---------------------------------------------------------------------
    def report(self, name: str) -> np.ndarray:
        """The per-axis values of TP, TE, RP, TD, RL, TV, TT, SC, TS (spec §4.4)."""
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
        """TB: bit 7 executing a program, bit 6 data record active, bit 5 contouring, bit 0 echo
        on (spec §4.4)."""
        return ((0x80 if self.threads.active else 0) | (0x40 if self.record_rate else 0)
                | (0x20 if self.follow.contour.on else 0)
                | (0x01 if self.echo else 0))

    def input_bank(self, bank: int) -> int:
        """TI n: IN1-IN8 as a byte for bank 0 (spec §4.4)."""
        if bank == 0:
            return self.inputs
        if FIRST_BANK <= bank <= LAST_BANK:
            return self.ext.bank(bank)  # extended I/O (CO)
        if bank == 10:
            return 0xFF  # aux-encoder inputs 81-88 open
        raise GalilError(TC.NUMBER_OUT_OF_RANGE)

    # -- analog feedback (AF, analog_feedback.py) ------------------------------------------------------
    def set_analog_feedback(self, axes: list[int], values: list[float]) -> None:
        """AF: an axis turned on reads its analog input from now on (the sensor follows it)."""
        for a, v in zip(axes, values, strict=True):
            if v and not self.af_on[a]:
                self.af_on[a] = True
                self.analog_driven(a)
            elif not v:
                self.af_on[a] = False

    def analog_driven(self, channel: int) -> None:
        """The analog input `channel` (0: AN1) was driven: an AF axis's position reads it."""
        if channel < self.n and self.af_on[channel]:
            m = self.motion
            align(m.core, channel, counts(float(self.analog[channel])),
                  float(m.enc_offset[channel]))

    def analog_volts(self) -> np.ndarray:
        """AN1..AN8 as the card reads them: an AF axis's channel reads its sensor."""
        return overlay(self.analog, self.motion.position(), self.af_on)

    def latch_inputs(self) -> np.ndarray:
        """IN1..IN4 are the X..W latch inputs (Fig 3-1)."""
        return np.array([(self.inputs >> a) & 1 for a in range(self.n)], dtype=bool)

    def data_record(self) -> bytes:
        """The REV4 record of this sample [M Ch4 §DMA / Secondary FIFO Memory Map]."""
        m = self.motion
        rec = np.zeros((), dtype=self._dtype)
        rec["sample_number"] = (self.ticks - self.time_origin) & 0xFFFF
        rec["input_bank_0"] = self.inputs
        rec["input_bank_1"] = 0xFF  # no inputs 9-16 on a 4-axis card
        inputs, outputs = self.ext.record_bytes()
        for name_in, name_out, i, o in zip(_EXT_INPUT_BANKS, _EXT_OUTPUT_BANKS, inputs, outputs,
                                           strict=True):
            rec[name_in], rec[name_out] = i, o
        rec["output_bank_0"] = self.outputs & 0xFF
        rec["error_code"] = self.error_code & 0xFF
        rec["general_status"] = ((int(GeneralStatus.ECHO_ON) if self.echo else 0)
                                 | (0x80 if self.threads.active else 0))  # program running
        ax = rec["axis"]
        ax["status"] = (m.status_word() | self.follow.status_bits()
                        | self.coord.status_bits())
        for key, plane in (("s", self.coord.planes["S"]), ("t", self.coord.planes["T"])):
            rec[f"{key}_plane_segment_count"] = plane.seq.completed & 0xFFFF
            rec[f"{key}_plane_move_status"] = plane.move_status()
            rec[f"{key}_distance"] = wrap_int32(np.array([plane.seq.out]))[0]
        ax["switches"] = m.switches(self.latch_inputs())
        ax["stop_code"] = m.stop_code
        ax["reference_position"] = wrap_int32(m.reference())
        ax["motor_position"] = wrap_int32(m.position())
        ax["position_error"] = wrap_int32(m.error())
        ax["aux_position"] = wrap_int32(m.auxiliary())
        ax["velocity"] = wrap_int32(m.tv * 64)
        ax["torque"] = np.rint(m.torque() * COUNTS_PER_VOLT).clip(-32767, 32767)
        ax["analog_in"] = np.rint(self.analog_volts()[: self.n] * COUNTS_PER_VOLT).clip(-32767, 32767)
        return rec.tobytes()


#: the record's fields of the extended I/O banks 2-9 (extended_io.py)
_EXT_INPUT_BANKS = tuple(f"input_bank_{b}" for b in range(FIRST_BANK, LAST_BANK + 1))
_EXT_OUTPUT_BANKS = tuple(f"output_bank_{b}" for b in range(FIRST_BANK, LAST_BANK + 1))
#: `_DEx` and `_DPx` read what DE and DP defined: the auxiliary encoder and the reference
_DEFINED = {"DE": "TD", "DP": "RP"}


class _Env:
    """Operands (`_TPX`), variables and @IN/@OUT/@AN for the expression evaluator (spec §4.4)."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw

    def operand(self, name: str) -> float:
        fw, m = self.fw, self.fw.motion
        if name == "TIME":
            return float(fw.ticks - fw.time_origin)
        hook = fw.operands.get(name[:2])
        if hook is not None:
            return hook(name)
        coordinated = fw.coord.operand(name)
        if coordinated is not None:
            return coordinated
        scalars = {"TC": fw.error_code, "TB": fw.status_byte(), "OP": fw.outputs,
                   "EO": fw.echo, "LZ": fw.lz, "TM": fw.tm_us, "DR": fw.record_rate,
                   "DM": fw.arrays.free_elements, "DA": fw.arrays.free_arrays,
                   "RC": fw.recorder.active, "RD": fw.recorder.next_index,
                   "PF": fw.pf.number(), "VF": fw.vf.number(), "CO": fw.ext.config}
        if name in scalars:
            return float(scalars[name])
        followed = operand(fw.follow, name)
        if followed is not None:
            return followed
        if name.startswith("TI") and (name[2:].isdigit() or name == "TI"):
            return float(fw.input_bank(int(name[2:] or 0)))  # _TI: bank 0, as TI
        cmd, letter = name[:2], name[2:]
        if letter == "N":  # the virtual axis [M Ch6 §Virtual Axis]
            return virtual_operand(fw, cmd)
        if len(letter) != 1 or letter not in "XYZWABCD":
            raise GalilError(TC.BAD_FUNCTION, name)
        a = "XYZWABCD".index(letter) % 4
        if a >= fw.n:
            raise GalilError(TC.ONLY_ABCD_VALID, name)
        cmd = _DEFINED.get(cmd, cmd)
        if cmd in REPORT_FORMATS:
            return float(fw.report(cmd)[a])
        if cmd == "PA":
            return float(m.destination()[a])
        if cmd in PARAMS:
            return float(m.values[cmd][a])
        per_axis = {
            "LF": not m.forward_limit[a], "LR": not m.reverse_limit[a], "HM": m.home_input[a],
            "MO": not m.core.servo_on_mask[a], "BG": m.moving(a), "AL": m.latch_armed[a],
            "AF": fw.af_on[a],
        }
        if cmd in per_axis:
            return float(per_axis[cmd])
        raise GalilError(TC.BAD_FUNCTION, name)

    def variable(self, name: str) -> float:
        try:
            return self.fw.variables[name]
        except KeyError:
            raise GalilError(TC.VARIABLE_ERROR, name) from None

    def array(self, name: str, index: int) -> float:
        return self.fw.arrays.read(name, index)

    def function(self, name: str, arg: float) -> float:
        fw = self.fw
        n = int(arg)
        if name == "IN":
            if 1 <= n <= 8:
                return float((fw.inputs >> (n - 1)) & 1)
            if FIRST_POINT <= n <= LAST_POINT:
                return float(fw.ext.read(n))  # extended I/O (CO)
            if 81 <= n <= 88:
                return 1.0  # unused aux-encoder inputs open
        elif name == "OUT":
            if 1 <= n <= 8:
                return float((fw.outputs >> (n - 1)) & 1)
            if FIRST_POINT <= n <= LAST_POINT:
                return float(fw.ext.output(n))
        elif name == "AN":
            if 1 <= n <= 8:
                return float(fw.analog_volts()[n - 1])
        else:
            raise GalilError(TC.BAD_FUNCTION, name)
        raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"@{name}[{n}]")
