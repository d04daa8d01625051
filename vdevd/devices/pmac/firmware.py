"""The Turbo PMAC firmware state of one card, without I/O: memory, variables, motors, the on-line
interpreter's operations, control characters, SAVE and reset [spec pmac.md §2].

The card (card.py) owns one `Firmware`, ticks it every servo cycle and connects its ports (DPRAM
ASCII, host port, Ethernet sessions) to `Interpreter.execute` and `control`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from vdevd.devices.pmac.comp1d import Tables1D, is_one_dimensional
from vdevd.devices.pmac.comp2d import CompError, CompTables
from vdevd.devices.pmac.coord import CoordSystems, parse_axis_def
from vdevd.devices.pmac.ect import ConversionTable, setup_address
from vdevd.devices.pmac.errors import ERR_DATA, ERR_PHASE, CommandError
from vdevd.devices.pmac.expr import ExprError
from vdevd.devices.pmac.feedback import FeedbackSelect
from vdevd.devices.pmac.gather import GATHER_ON, GATHER_ON_TRIGGER, Gather, valid_source
from vdevd.devices.pmac.gpio import GeneralIO
from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.kinematics import Kinematics
from vdevd.devices.pmac.macro import MacroStations
from vdevd.devices.pmac.memory import TOP, Memory
from vdevd.devices.pmac.motor_reports import MotorReports
from vdevd.devices.pmac.motors import MotorError, Motors
from vdevd.devices.pmac.mvars import MVars
from vdevd.devices.pmac.numbers import format_hex, format_value, quantize_float
from vdevd.devices.pmac.online import Interpreter, PortState
from vdevd.devices.pmac.plc import Plcs
from vdevd.devices.pmac.program_runner import Motion
from vdevd.devices.pmac.registers import (
    CS_BASE,
    CS_STRIDE,
    MOTOR_BASE,
    MOTOR_STRIDE,
    P_BASE,
    Q_BASE,
    CsBlocks,
    FloatVariables,
    GlobalRegisters,
    MotorBlocks,
)
from vdevd.devices.pmac.rotary import RotaryBuffers
from vdevd.devices.pmac.servo_ic import ServoIC
from vdevd.devices.pmac.timebase import TimeBase
from vdevd.rt import PlantKind

VARIABLES = 8192
CS_COUNT = 16
#: X:$000006 global status word 1 bits [digest §2.1]
PHASE_CLOCK_ERROR = 1 << 3
FIRMWARE_CHECKSUM_ERROR = 1 << 12
COMP_ACTIVE = 1 << 14
CPU_DSP56311 = 1 << 21


@dataclass(frozen=True)
class Identity:
    """What CID, VERSION, DATE, TYPE and CPU answer [DLS-lib, EPICS-HW; digest §2.4]."""

    cid: int = 603382
    version: str = "1.940"
    date: str = "06/26/2003"
    type: str = "TURBO2"
    cpu: str = "DSP56321"


class Firmware:
    """One card's firmware: everything the on-line commands read and write."""

    def __init__(self, motors: int, period_ns: float, plant: str = "servo",
                 identity: Identity | None = None,
                 store: Callable[[dict[str, Any]], None] | None = None) -> None:
        self.identity_ = identity or Identity()
        self.period_ns = period_ns
        self.now_ns = 0
        self.servo_cycles = 0
        self.global_bits = 0
        self.locks = 0
        self._comp_applied = False
        self._store = store
        #: called after a power-on or factory reset (the card resets its ports)
        self.on_reset: Callable[[], None] | None = None
        self.saved: dict[str, Any] = {}
        self.ivars = IVars(motors)
        self.memory = Memory()
        self.mvars = MVars(self.memory)
        self.p = np.zeros(VARIABLES)
        self.q = np.zeros((CS_COUNT, VARIABLES))
        self.feed = np.full(CS_COUNT, 100.0)
        self.motors = Motors(self.ivars, period_ns, plant)
        self.reports = self.motors.reports
        mem = self.memory
        mem.mount(0x000000, MOTOR_BASE - 1, GlobalRegisters(self))
        mem.mount(MOTOR_BASE, MOTOR_BASE + 32 * MOTOR_STRIDE - 1, MotorBlocks(self))
        mem.mount(CS_BASE, CS_BASE + CS_COUNT * CS_STRIDE - 1, CsBlocks(self))
        mem.mount(P_BASE, P_BASE + VARIABLES - 1, FloatVariables(P_BASE, self.p))
        mem.mount(Q_BASE, Q_BASE + VARIABLES - 1, FloatVariables(Q_BASE, self.q[0]))
        self.servo_ic = ServoIC(mem, self.ivars, _FineEncoders(self.reports))
        self.ect = ConversionTable(mem, self.ivars, self.servo_ic)
        self.gpio = GeneralIO(mem, self.ivars)
        self.gather = Gather(mem, self.ivars.values)
        self.comp = CompTables(self.ivars, self.ivars.motors, lambda: self.gather.defined)
        #: hooks answering which TBUF/ROTARY/LOOKAHEAD/GATHER buffers exist (they block DEFINE COMP,
        #: BLCOMP, TCOMP [spec §1.7]); the buffers' own modules register here
        self.buffer_checks: list[Callable[[], set[str]]] = [
            lambda: {"GATHER"} if self.gather.defined else set()]
        self.comp1d = Tables1D(self.ivars, self.ivars.motors, lambda: set(self.comp.tables),
                               self.existing_buffers)
        self.feedback = FeedbackSelect(mem, self.ivars)
        self.macro = MacroStations()
        self.coord = CoordSystems(self.ivars, self.motors.cs, self.motors.axis_code,
                                  lambda: self.servo_cycles)
        self.timebase = TimeBase(self.ivars, lambda: self.servo_cycles)  # `%` slew (Isx94)
        self.interpreter = Interpreter(self)
        self.plc = Plcs(self)
        self.rotary = RotaryBuffers(self)          # rotary.py
        self.kinematics = Kinematics(self)         # kinematics.py
        self.buffer_checks.append(lambda: {"ROTARY"} if self.rotary.defined else set())
        self.motion = Motion(self)  # motion programs (program_runner.py)
        self.buffer_checks.append(  # the lookahead buffers (DEFINE LOOKAHEAD, lookahead.py)
            lambda: {"LOOKAHEAD"} if any(r.lookahead_buffer for r in self.motion.cs) else set())

    # -- time -------------------------------------------------------------------------------------
    def tick(self, now_ns: int) -> int:
        """One servo cycle: compensation, motors, Servo IC registers and compare, conversion
        table, I/O."""
        self.now_ns = now_ns
        self.servo_cycles += 1
        if self.comp.tables or self._comp_applied or self.feedback.active or self.comp1d.active:
            self._offset_feedback()
        if self.motion.active:  # running programs give their motors this cycle's position
            self.motion.tick()
        events = self.motors.tick()
        self.servo_ic.tick()
        self.ect.tick()
        self.gpio.tick()
        if self.plc.running:  # PLC scans and their queued CMDs (plc.py)
            self.plc.tick(self.servo_cycles)
        if self.gather.on:  # after the cycle's motion: the values of this servo cycle
            self.gather.tick()
        return events

    def skip(self, k: int) -> None:
        """k servo cycles at rest (the card's rest_state holds): what k ticks would count."""
        self.servo_cycles += k
        self.motors.skip(k)

    def _offset_feedback(self) -> None:
        """What the loops see beside their own encoder, as an offset of the motion core's encoder
        reading (to the nearest count):
        - compensation tables (2-D, 1-D leadscrew) and backlash: the target motor's loop runs at
          commanded + correction while P and F report the commanded frame [A L3118-3219; Turbo
          SRM; README "Compensation tables"] (I51 = 0 or no table: none, backlash from Ixx85/86
          alone; an ideal motor follows its command only);
        - Ixx03 pointed at another conversion-table result: the loop reads that result
          (feedback.py)."""
        core = self.motors.core
        actual, commanded = self.reports.position(), self.reports.commanded()
        want = np.rint(self.comp.correction(actual, commanded) + self.comp1d.leadscrew(actual, commanded)
                       + self.comp1d.backlash(commanded))
        want[core.kinds != int(PlantKind.SERVO)] = 0
        self._comp_applied = bool(want.any())
        if self.feedback.active:
            source = self.feedback.offsets()
            chosen = ~np.isnan(source)
            true = core.axes.encoder + core.encoder_slip
            want[chosen] += np.rint(true[chosen] - source[chosen])
        delta = want - core.encoder_slip
        if delta.any():
            core.slip_encoder(np.flatnonzero(delta), delta[delta != 0])

    def comp_correction(self, motor: int) -> float:
        """Mxx69: the compensation tables' correction of `motor` (0-based), counts."""
        if not (self.comp.tables or self.comp1d.any_tables):
            return 0.0
        actual, commanded = self.reports.position(), self.reports.commanded()
        return float(self.comp.correction(actual, commanded)[motor]
                     + self.comp1d.leadscrew(actual, commanded)[motor])

    # -- on-line interface --------------------------------------------------------------------------
    def execute(self, port: PortState, line: str) -> Any:
        return self.interpreter.execute(port, line)

    def env(self, port: PortState) -> _Env:
        return _Env(self, port)

    @property
    def i9(self) -> int:
        return int(self.ivars.values[9])

    def variable_count(self, kind: str) -> int:
        return VARIABLES

    def get_variable(self, port: PortState, kind: str, n: int) -> float:
        match kind:
            case "I":
                if self.coord.is_timer(n):  # Isx11/Isx12 count down [§2.8]
                    return self.coord.timer(n)
                return float(self.ivars.values[n])
            case "P":
                return float(self.p[n])
            case "Q":
                return float(self.q[port.cs - 1, n])
        return self.mvars.read(n)

    def format_variable(self, port: PortState, kind: str, n: int) -> str:
        value = self.get_variable(port, kind, n)
        if kind == "I" and self.i9 & 2 and self.ivars.hex(n):
            return format_hex(value)
        return format_value(value)

    def set_variable(self, port: PortState, kind: str, n: int, value: float) -> None:
        match kind:
            case "I":
                self.set_ivar(n, value)
            case "P":
                self.p[n] = quantize_float(value)
            case "Q":
                self.q[port.cs - 1, n] = quantize_float(value)
            case _:
                self.mvars.write(n, value)

    def set_ivar(self, n: int, value: float) -> None:
        """Write I-variable n with its range check (ERR003 outside it) [digest §2.2]."""
        if n == 44:  # PMAC Ladder: standard firmware keeps 0, silently [A L1452]
            return
        if 100 <= n < 3300 and n % 100 == 75 and value < 0:
            # Ixx75: -Ixx71 <= v <= 0 is stored as Ixx71 + v since V1.939 [A L2191-2224]
            i71 = self.ivars.values[n - 75 + 71]
            if value < -i71:
                raise CommandError(ERR_DATA, "Ixx75 below -Ixx71")
            value += i71
        elif 100 <= n < 3300 and n % 100 == 75 and value > self.ivars.values[n - 75 + 71]:
            raise CommandError(ERR_DATA, "Ixx75 above Ixx71")  # rejected [A L2222]
        stored = self.ivars.check(n, value)
        if stored is None:
            raise CommandError(ERR_DATA, f"I{n}={value} out of range")
        if 5001 <= n <= 5048 and not valid_source(int(stored)):  # gather.py
            raise CommandError(ERR_DATA, f"I{n}: no such gather source")
        self.ivars.values[n] = stored
        self.on_ivar(n)

    def on_ivar(self, n: int) -> None:
        if 100 <= n < 3300:
            self.motors.on_ivar(n)
            if n % 100 == 3:
                core = self.motors.core
                self.feedback.refresh(core.axes.encoder + core.encoder_slip)
        elif 5100 <= n < 6700:
            self.coord.on_ivar(n)

    def address_of_ivar(self, n: int) -> float:
        """`I{a}=@I{b}`: the address of I-variable b; only the conversion table's setup lines
        have one (ect.setup_address) [A L2549, L3266]."""
        addr = setup_address(n)
        if addr is None:
            raise CommandError(ERR_DATA, f"I{n} has no address")
        return float(addr)

    # -- motors -----------------------------------------------------------------------------------
    def motor_call(self, name: str, motor: int, *args: Any) -> None:
        """A motor command; a motor that is not processed (Ixx00 = 0, or above the card's
        `motors`) ignores it, as a deactivated motor does."""
        if motor > self.ivars.motors or not self.ivars.values[100 * motor]:
            return
        if self.motion.motor_in_running_cs(motor):  # [UM "Kill All": not while it runs]
            raise CommandError(1, "the motor's coordinate system runs a program")
        try:
            getattr(self.motors, name)(motor - 1, *args)
        except MotorError as exc:
            raise CommandError(exc.code) from None
        if name in ("home", "home_zero"):  # homing sets the bias to the offset [A L932]
            self.coord.rebias(motor)

    def motor_report(self, what: str, motor: int) -> str:
        """P, F (counts, to 1/32) or V (counts per servo cycle, to 0.1); 0 for a motor that is not
        processed."""
        if motor > self.ivars.motors:
            return "0"
        m, rep = motor - 1, self.reports
        if what == "P":
            return report_counts(rep.position_of(m))
        if what == "F":
            return report_counts(float(rep.following_error()[m]))
        return report_velocity(float(rep.velocity()[m]))

    def motor_status(self, motor: int) -> tuple[int, int]:
        if motor > self.ivars.motors:
            return 0, 0
        w1, w2 = self.reports.status_words()
        return int(w1[motor - 1]), int(w2[motor - 1])

    def abort_cs(self, cs: int) -> None:
        """`A` of a coordinate system: its program stops, each of its motors aborts [§2.5]."""
        self.motion.runner(cs).abort()
        for motor in self.coord.members(cs):
            self.motor_call("abort", motor)

    def kill_cs(self, cs: int) -> None:
        """`K` with a C.S. addressed: its program stops, each of its motors is killed (README
        "Coordinate systems")."""
        self.motion.runner(cs).kill()
        for motor in self.coord.members(cs):
            self.motor_call("kill", motor)

    def cs_status(self, cs: int) -> tuple[int, int, int]:
        """`&n??`: the three status words of C.S. n [§2.6] (coord.py)."""
        p1, p2, running = self.motion.status(cs)  # the program's bits (program_runner.py)
        if not self.coord.has_members(cs):  # no motors: in position, nothing else (no work)
            return p1, p2 | (0 if running else 1 << 17), 0
        w1, w2 = self.reports.status_words()
        c1, c2, c3 = self.coord.status(cs, w1, w2)
        if running:
            c2 &= ~(1 << 17)  # in a timed move or DWELL: not in position [SRM "??" bit 17]
        return c1 | p1, c2 | p2, c3

    def define_axis(self, cs: int, motor: int, text: str, start: int) -> int:
        """`&cs#motor->{definition}`; where the definition ends in `text` (ERR001 while the
        C.S. runs a program)."""
        d, end = parse_axis_def(text, start)
        if self.motion.runner(cs).running:
            raise CommandError(1, "the coordinate system runs a program")
        self.coord.define(cs, motor, d)
        return end

    def set_axis(self, cs: int, axis: str, value: float) -> None:
        """`{axis}={value}` on-line: a new position bias for the axis's motors [A L932]."""
        self.coord.set_axis(cs, axis, value, self._commanded())

    def axis_position(self, cs: int, axis: str) -> float:
        return self.coord.axis_position(cs, axis, self._commanded())

    def _commanded(self) -> np.ndarray:
        return self.reports.commanded()

    def global_status(self) -> tuple[int, int]:
        bits = self.global_bits & ~(COMP_ACTIVE | CPU_DSP56311 | GATHER_ON | GATHER_ON_TRIGGER)
        if self.gather.on:  # bit 19 data gathering on [digest §2.1 X:$000006]
            bits |= GATHER_ON
        if self.ivars.values[51] and (self.comp.tables or self.comp1d.any_tables):
            bits |= COMP_ACTIVE
        return bits, 0

    def set_phase_clock_error(self, on: bool) -> None:
        self.global_bits = self.global_bits | PHASE_CLOCK_ERROR if on else \
            self.global_bits & ~PHASE_CLOCK_ERROR
        self.motors.set_phase_clock_error(on)

    # -- control characters -----------------------------------------------------------------------
    def control(self, port: PortState, ch: int) -> str:
        """A control character's action and its text [digest §2.4 "Control characters"]."""
        mot = self.motors
        group = range(8 * (port.group - 1), min(8 * port.group, self.ivars.motors))
        match ch:
            case 0x01:  # ^A abort all: programs stop too
                self.motion.abort_all()
                for m in range(self.ivars.motors):
                    if self.ivars.values[100 * (m + 1)]:
                        mot.abort(m)
                return ""
            case 0x02:  # ^B status of the eight motors
                w1, w2 = self.reports.status_words()
                return " ".join(f"{int(w1[m]):06X}{int(w2[m]):06X}" for m in group)
            case 0x03:  # ^C status of every coordinate system
                return " ".join("".join(f"{w:06X}" for w in self.cs_status(cs))
                                for cs in range(1, CS_COUNT + 1))
            case 0x06:  # ^F following errors
                fe = self.reports.following_error()
                return " ".join(report_counts(float(fe[m])) for m in group)
            case 0x07:  # ^G global status
                return "".join(f"{w:06X}" for w in self.global_status())
            case 0x0B:  # ^K kill all: programs stop too
                self.motion.abort_all()
                mot.kill_all()
                return ""
            case 0x10:  # ^P positions
                pos = self.reports.position()
                return " ".join(report_counts(float(pos[m])) for m in group)
            case 0x16:  # ^V velocities
                vel = self.reports.velocity()
                return " ".join(report_velocity(float(vel[m])) for m in group)
            case 0x18:  # ^X cancel: the port flushes; echoed when I63 = 1
                port.table_left = 0
                return "\x18" if self.ivars.values[63] else ""
            case 0x0F:  # ^O feed hold of every C.S. (program_runner.py)
                self.motion.hold_all()
                return ""
            case 0x04:  # ^D disable all PLCs (plc.py)
                self.plc.disable_all()
                return ""
        return ""  # ^O ^N ^Z and the rest: nothing to report

    # -- memory words (RX/WX ...) ----------------------------------------------------------------
    def read_words(self, space: str, addr: int, count: int) -> list[str]:
        if not 1 <= count <= 256 or addr < 0 or addr + count - 1 > TOP:
            raise CommandError(ERR_DATA)
        mem = self.memory
        if space == "L":
            return [format_value(mem.read_float(a)) for a in range(addr, addr + count)]
        if space == "D":
            return [format_value(mem.read_fixed(a)) for a in range(addr, addr + count)]
        return [f"${mem.read(space, a):06X}" for a in range(addr, addr + count)]

    def write_words(self, space: str, addr: int, values: list[int]) -> None:
        if not values or addr < 0 or addr + len(values) - 1 > TOP:
            raise CommandError(ERR_DATA)
        mem = self.memory
        for k, v in enumerate(values):
            if space in "LD":  # raw 48-bit words (EPICS WL:$addr,$…) [digest §3.4]
                mem.write("X", addr + k, (v >> 24) & 0xFFFFFF)
                mem.write("Y", addr + k, v & 0xFFFFFF)
            else:
                mem.write(space, addr + k, v)

    # -- compensation tables (DEFINE COMP) [A L3118-3219] ----------------------------------------------
    def existing_buffers(self) -> set[str]:
        """The TBUF, ROTARY, LOOKAHEAD and GATHER buffers that exist (`buffer_checks`)."""
        return set().union(*(check() for check in self.buffer_checks))

    def define_comp(self, motor: int, text: str, kind: str = "COMP") -> int:
        """`#n DEFINE COMP|BLCOMP|TCOMP ...` (COMP: 2-D with `{rows}.{columns}`, else 1-D); the
        number of entries still expected."""
        try:
            if kind == "COMP" and not is_one_dimensional(text):
                self.comp1d.check_define("COMP", motor)  # 1-D COMP owners and the buffers above
                self.comp.define(motor, text)
                self.comp1d.loading = None
                return self.comp.pending
            self.comp1d.define(kind, motor, text)
            self.comp.loading = None
        except CompError as exc:
            raise CommandError(exc.code) from None
        return self.comp1d.pending

    def comp_entry(self, motor: int, value: int) -> int:
        """One entry constant; the number still expected."""
        tables = self.comp1d if self.comp1d.loading is not None else self.comp
        try:
            tables.feed(value)
        except CompError as exc:
            raise CommandError(exc.code) from None
        return tables.pending

    def delete_comp(self, motor: int, kind: str = "COMP") -> None:
        """`#n DELETE COMP|BLCOMP|TCOMP`: from low to high motor number (ERR007 otherwise)."""
        try:
            if not self.comp1d.delete(kind, motor) and kind == "COMP" and motor in self.comp.tables:
                if any(owner < motor for owner in self.comp1d.owners("COMP")):
                    raise CompError(7, "DELETE COMP: delete tables from low to high motor number")
                self.comp.delete(motor)
        except CompError as exc:
            raise CommandError(exc.code) from None

    def list_comp(self, motor: int, definition: bool = False, kind: str = "COMP") -> list[str]:
        if motor in self.comp1d.tables[kind]:
            if definition:
                return [str(self.comp1d.list_definition(kind, motor))]
            return self.comp1d.list_text(kind, motor) or []
        if kind != "COMP":
            return []
        text = self.comp.list_definition(motor) if definition else self.comp.list_text(motor)
        return [] if text is None else text.rstrip("\n").split("\n")

    def _comp_image(self) -> list[dict[str, Any]]:
        return [{"motor": m, "define": d.text(), "entries": self.comp.entries[m][1:].tolist()}
                for m, d in sorted(self.comp.tables.items())]

    def _comp1d_image(self) -> list[dict[str, Any]]:
        t1 = self.comp1d
        return [{"kind": k, "motor": m, "define": t.text().split(" ", 2)[2],
                 "entries": t1.entries[k][m][1:].tolist(), "zero": float(t1.entries[k][m][0])}
                for k in t1.tables for m, t in sorted(t1.tables[k].items())]

    def _comp1d_restore(self, image: list[dict[str, Any]]) -> None:
        """The saved 1-D tables, with their correction at 0 as it was downloaded (I30 then)."""
        for table in image:
            self.comp1d.restore(str(table["kind"]), int(table["motor"]), str(table["define"]),
                                [float(v) for v in table["entries"]], float(table.get("zero", 0.0)))

    def _comp_restore(self, image: list[dict[str, Any]]) -> None:
        for table in sorted(image, key=lambda t: -int(t["motor"])):  # high to low [A L3139]
            self.comp.define(int(table["motor"]), str(table["define"]))
            for v in table["entries"]:
                self.comp.feed(v)

    # -- identity, SAVE, reset ------------------------------------------------------------------------
    def identity(self, name: str) -> str:
        ident = self.identity_
        return {"CID": str(ident.cid), "VER": ident.version, "VERSION": ident.version,
                "DATE": ident.date, "TYPE": ident.type, "CPU": ident.cpu, "VID": "1"}[name]

    def image(self) -> dict[str, Any]:
        """What SAVE writes to flash: I-variables that differ from the factory, M-definitions,
        P- and Q-variables that are not zero, compensation tables."""
        iv = self.ivars
        changed = np.nonzero(iv.values != iv.defaults)[0]
        return {
            "ivars": {str(int(n)): float(iv.values[n]) for n in changed},
            "mdefs": self.mvars.image(),
            "p": {str(int(n)): float(self.p[n]) for n in np.nonzero(self.p)[0]},
            "q": {f"{int(c)},{int(n)}": float(self.q[c, n]) for c, n in np.argwhere(self.q)},
            "comp": self._comp_image(),
            "comp1d": self._comp1d_image(),
            "axes": self.coord.image(),
            "plc": self.plc.image(),
            "kinematics": self.kinematics.image(),
            "prog": self.motion.store.image(),
        }

    def save(self) -> None:
        self.saved = self.image()
        if self._store is not None:
            self._store(self.saved)

    def restore(self, image: dict[str, Any]) -> None:
        """Power-up: factory state, then the saved image over it."""
        self.saved = image
        self._factory_state()
        for n, v in image.get("ivars", {}).items():
            if math.isfinite(v) and 0 <= int(n) < VARIABLES:
                self.ivars.values[int(n)] = v
        self.mvars.restore(image.get("mdefs", {}))
        for n, v in image.get("p", {}).items():
            self.p[int(n)] = v
        for key, v in image.get("q", {}).items():
            c, n = (int(k) for k in key.split(","))
            self.q[c, n] = v
        self._comp_restore(image.get("comp", []))
        self._comp1d_restore(image.get("comp1d", []))
        self.coord.restore(image.get("axes", []))
        self.plc.restore(image.get("plc", {}))
        self.kinematics.restore(image.get("kinematics", {}))
        self.motion.store.restore(image.get("prog", {}))
        self._reset_hardware()

    def power_on_reset(self) -> None:
        """`$$$`: reload what was saved, reset the motors and the ports' state."""
        self.restore(self.saved)

    def factory_reset(self) -> None:
        """`$$$***`: factory I-variables, no M-definitions, variables and tables cleared; the
        saved image is untouched until the next SAVE."""
        self._factory_state()
        self._reset_hardware()

    def _factory_state(self) -> None:
        self.ivars.factory()
        self.mvars.clear()
        self.p[:] = 0
        self.q[:] = 0
        self.feed[:] = 100
        self.timebase.reset()
        self.comp.clear()
        self.comp1d.clear()
        self.coord.undefine(None)
        self.plc.clear_all()
        self.kinematics.clear_all()
        self.motion.store.clear_all()
        for runner in self.motion.cs:  # the lookahead buffers go with the other buffers
            runner.lookahead_buffer = None
        self.locks = 0

    def _reset_hardware(self) -> None:
        self.comp1d.reset()
        self.memory.clear()
        self.motors.reset()
        for n in range(100, 100 * (self.ivars.motors + 1)):
            self.motors.on_ivar(n)
        self.servo_ic.reset()
        self.gpio.reset()
        self.ect.reset()
        self.feedback.reset()
        self.coord.reset()
        self.gather.reset()
        self.plc.power_on()
        self.rotary.power_on()
        self.kinematics.power_on()
        self.motion.power_on()
        core = self.motors.core
        self.feedback.refresh(core.axes.encoder + core.encoder_slip)
        if self.on_reset is not None:
            self.on_reset()


def report_counts(v: float) -> str:
    """A position or following error as P, F, ^P and ^F print it: counts to 1/32 [SRM p.260]."""
    return format_value(round(v * 32) / 32)


def report_velocity(v: float) -> str:
    """A velocity as V and ^V print it: counts per servo cycle to 0.1 [PMAC1-SRM p.175]."""
    return format_value(round(v, 1))


class _FineEncoders:
    """The motors as the Servo ICs read them: counters with their sub-count fraction."""

    __slots__ = ("reports",)

    def __init__(self, reports: MotorReports) -> None:
        self.reports = reports

    def encoder(self) -> np.ndarray:
        return self.reports.encoder_fine()

    def encoder_into(self, out: np.ndarray) -> None:
        self.reports.encoder_fine_into(out)

    def keep_into(self, pos: np.ndarray, counter: np.ndarray) -> bool:
        return self.reports.keep_fine(pos, counter)

    def encoder_from(self, pos: np.ndarray, counter: np.ndarray, out: np.ndarray) -> None:
        self.reports.fine_from(pos, counter, out)


class _Env:
    """The expression environment of one port: variables and the addressed C.S.'s Q0."""

    __slots__ = ("fw", "port")

    def __init__(self, fw: Firmware, port: PortState) -> None:
        self.fw, self.port = fw, port

    def get(self, kind: str, n: int) -> float:
        if not 0 <= n < VARIABLES:
            raise ExprError(ERR_DATA)
        return self.fw.get_variable(self.port, kind, n)

    def q0(self) -> float:
        return float(self.fw.q[self.port.cs - 1, 0])

    @property
    def radians(self) -> bool:
        return bool(self.fw.ivars.values[15])


__all__ = ["ERR_PHASE", "Firmware", "Identity"]
