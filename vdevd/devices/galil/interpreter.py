"""The DMC command interpreter: one statement in, the card's reply out (manual ch. 4-6).

`Interpreter.execute(text)` runs one ASCII statement (binary commands arrive here converted to
their ASCII form) and returns the reply bytes: data lines ending CR LF, then `:`; or `?` with the
reason kept for `TC`. A trippoint (AM, MC, WT) returns a `Trippoint` the firmware checks every sample;
the interpreter takes no further command until it is satisfied (spec §5.7). No I/O here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.galil import InterruptStatus

from vdevd.devices.galil import syntax
from vdevd.devices.galil.array_commands import ArrayCommands
from vdevd.devices.galil.arrays import ArrayDownload
from vdevd.devices.galil.commands import COMMANDS, NOT_EMULATED_CODES
from vdevd.devices.galil.coord import VIRTUAL
from vdevd.devices.galil.errors import TC, TEXTS, GalilError
from vdevd.devices.galil.expr import evaluate
from vdevd.devices.galil.extended_io import FIRST_POINT, LAST_POINT
from vdevd.devices.galil.follow_commands import FollowCommands
from vdevd.devices.galil.formats import FormatCommands
from vdevd.devices.galil.io_commands import IoCommands
from vdevd.devices.galil.motion import Mode, StopCode
from vdevd.devices.galil.numbers import (
    POSITION_PARAMS,
    POSITION_REPORTS,
    REPORT_FORMATS,
    format_number,
)
from vdevd.devices.galil.params import MOTOR_TYPES, PARAMS
from vdevd.devices.galil.vector_commands import VectorCommands
from vdevd.devices.galil.virtual_commands import VirtualCommands, split_n
from vdevd.rt import PlantKind

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware

OK = b":"
CRLF = b"\r\n"


#: statements and axis lists repeat (a host polls `TPX`): parse each text once
_split_statement = lru_cache(maxsize=512)(syntax.split_statement)
_parse_axes = lru_cache(maxsize=512)(syntax.parse_axes)


def revision(n: int) -> str:
    """The revision report of an n-axis card (^R^V, gclib's GInfo)."""
    return f"DMC13{n}8 Rev 1.1a"


@dataclass
class Trippoint:
    """A command-line trippoint: the interpreter waits until `ready()` (spec §5.7)."""

    ready: Callable[[], bool]


class Interpreter(ArrayCommands, VectorCommands, FormatCommands, IoCommands):
    """The command language over one card's firmware state (`fw`); its commands are the table
    of commands.py, bound once."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.n = fw.n
        self.handlers: dict[str, Callable[[str], bytes | Trippoint | ArrayDownload]] = (
            COMMANDS.bind(self, FollowCommands(self), *getattr(fw, "command_sets", ())))
        #: the program thread whose statement runs now, None on the command line (threads.py)
        self.thread: int | None = None
        self.virtual_commands = VirtualCommands(self)  # `PRN=` ... (virtual_commands.py)

    # -- entry -------------------------------------------------------------------------------------
    def execute(self, text: str) -> bytes | Trippoint | ArrayDownload:
        """Run one statement; a refused one answers `?` and sets the TC code."""
        try:
            if not text.strip():
                return OK
            stmt = _split_statement(text)
            if stmt.arg[:1] == "N":  # `PR N=100`, `PRN=100`: the virtual axis
                virtual = self.virtual_commands.route(stmt.name, stmt.arg)
                if virtual is not None:
                    return virtual
            handler = self.handlers.get(stmt.name)
            if handler is None:
                raise GalilError(NOT_EMULATED_CODES.get(stmt.name, TC.UNRECOGNIZED_COMMAND), stmt.name)
            return handler(stmt.arg)
        except GalilError as exc:
            self.fw.error_code = exc.code
            return b"?"

    # -- helpers -----------------------------------------------------------------------------------
    def value(self, text: str) -> float:
        return evaluate(text, self.fw.env)

    def fmt(self, value: float, digits: int, frac: int) -> str:
        return format_number(value, digits, frac, lz=not self.fw.lz)

    def pos(self, value: float) -> str:
        """A position in the position format (PF)."""
        return self.fw.pf.text(value, lz=not self.fw.lz)

    def var(self, value: float) -> str:
        """A variable, array element or MG number in the variable format (VF)."""
        return self.fw.vf.text(value, lz=not self.fw.lz)

    @staticmethod
    def data(text: str) -> bytes:
        return text.encode("latin-1") + CRLF + OK

    def axes(self, arg: str) -> list[int]:
        return list(self._sel(arg).axes)

    def _sel(self, arg: str) -> syntax.AxisSet:
        """The axes of an action command (`_parse_axes`) on the card BA leaves: an axis whose
        DAC is a second phase is no longer available [M Ch2 Step 5: "BAX ... re-configured to a
        DMC-1338 ... The 'W' axis is no longer available"]: left out of "every axis", TC 90
        when named (as on the smaller card)."""
        sel = _parse_axes(arg, self.n)
        freed = self.fw.follow.commutation.freed()
        if not freed.size:
            return sel
        if arg.strip():
            if any(a in freed for a in sel.axes):
                raise GalilError(TC.ONLY_ABCD_VALID, "the axis drives a second phase (BA)")
            return sel
        return replace(sel, axes=tuple(a for a in sel.axes if a not in freed))

    def _sel_n(self, arg: str) -> tuple[syntax.AxisSet, bool]:
        """`_sel` of an action command that may name the virtual axis N too (`BG XN`): the
        real axes (none for `BG N` alone) and whether N was named [M Ch6 §Virtual Axis]."""
        rest, named = split_n(arg)
        if named and not rest.strip():
            return syntax.AxisSet(()), True
        return self._sel(rest), named

    def per_axis(self, arg: str) -> list[tuple[int, str | object]]:
        """(axis, field) pairs of `PR 1,,3` / `PRX=1` / `PR*=1` / `PR ?`; field text or QUERY."""
        assign = syntax.parse_axis_assign(arg, self.n)
        if assign is not None:
            axes, text = assign
            pairs: list[tuple[int, str | object]] = [
                (a, syntax.QUERY if text.strip() == "?" else text) for a in axes]
        else:
            fields = syntax.parse_fields(arg, self.n)
            pairs = [(a, f) for a, f in enumerate(fields) if f is not None]
        freed = self.fw.follow.commutation.freed()
        if freed.size and any(a in freed for a, _ in pairs):
            # `PR*=` names every axis: the freed ones are not the card's any more (BA)
            if assign is not None and len(assign[0]) > 1:
                return [(a, f) for a, f in pairs if a not in freed]
            raise GalilError(TC.ONLY_ABCD_VALID, "the axis drives a second phase (BA)")
        return pairs

    def _setter(self, name: str, arg: str, apply: Callable[[list[int], list[float]], None],
                query: Callable[[], np.ndarray], digits: int | Callable[[float], str], frac: int,
                check: Callable[[float], float | None] | None = None) -> bytes:
        """The common form of a per-axis command: set fields, or answer `?` queries in the
        format `digits`.`frac`, or the one `digits` prints (`self.pos`: PF)."""
        pairs = self.per_axis(arg)
        if not pairs:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, name)
        queries = [a for a, f in pairs if f is syntax.QUERY]
        if queries:
            current = query()
            text = digits if callable(digits) else lambda v: self.fmt(v, digits, frac)
            return self.data(",".join(text(float(current[a])) for a in queries))
        axes: list[int] = []
        values: list[float] = []
        for a, field in pairs:
            v = self.value(str(field))
            coerced = check(v) if check else v
            if coerced is None:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name} {v}")
            axes.append(a)
            values.append(coerced)
        apply(axes, values)
        return OK

    # -- parameters --------------------------------------------------------------------------------
    def _param(self, name: str, arg: str) -> bytes:
        """A per-axis parameter (`KP 10,20`, `KPX=10`, `KP ?`), spec §1.3."""
        param = PARAMS[name]
        motion = self.fw.motion

        def check(v: float) -> float | None:
            if name == "MT":
                if v not in MOTOR_TYPES:
                    return None
                if abs(v) >= 2 and not self.fw.sm_jumper:
                    raise GalilError(TC.SM_JUMPER_NEEDED)
            return param.coerce(v)

        def query() -> np.ndarray:
            return motion.destination() if name == "PA" else motion.values[name]

        if name == "JG":
            self._check_jog(arg)
        digits = self.pos if name in POSITION_PARAMS else param.digits
        return self._setter(name, arg, lambda ax, vs: motion.set_param(name, ax, vs), query,
                            digits, param.frac, check)

    def _check_jog(self, arg: str) -> None:
        """JG while an axis moves in another mode is TC 13 [M Ch6 §Independent Jogging]."""
        motion = self.fw.motion
        for a, field in self.per_axis(arg):
            if field is not syntax.QUERY and motion.moving(a) and motion.mode[a] != Mode.JG:
                raise GalilError(TC.JG_ONLY_IN_JOG_MODE)

    # -- motion ------------------------------------------------------------------------------------
    def _bg(self, arg: str) -> bytes:
        """BG axes; BG S/T begins the plane's sequence (vector_commands); BG N the virtual axis
        (TC 21 while it moves or a plane with it begins too, as an axis of a plane would)."""
        axes, n_named = self._sel_n(arg)
        planes = self._check_sequences(axes.s, axes.t, axes.axes) if axes.s or axes.t else []
        virtual = self.fw.virtual
        if (n_named and virtual.moving) or any(
                p.mode == "VM" and VIRTUAL in p.axes and (n_named or virtual.moving) for p in planes):
            raise GalilError(TC.BEGIN_WHILE_RUNNING, "the virtual axis N moves")
        self.fw.motion.begin(list(axes.axes))
        if n_named:
            virtual.begin()
        for plane in planes:
            self.fw.coord.begin(plane)
        return OK

    def _st(self, arg: str) -> bytes:
        """ST axes; from the host without axes it halts the programs too [spec §4.5]; ST S/T
        (and ST alone, or an axis of a running plane) stops the sequence along its path at VD
        [M Ch6 §Specifying Linear Segments]."""
        (sel, n_named), coord = self._sel_n(arg), self.fw.coord
        planes = [p for p in coord.planes_named(sel.s or not arg.strip(), sel.t or not arg.strip())
                  if p.running]
        planes += [p for a in sel.axes if (p := coord.plane_of(a)) is not None]
        if n_named or not arg.strip():  # ST N: N's own move, or the plane that drives it
            driving = [p for p in coord.planes.values() if p.running and p.virtual_dim is not None]
            planes += driving
            if not driving:
                self.fw.virtual.stop()
        for plane in planes:
            coord.stop(plane)
        self.fw.motion.stop([a for a in sel.axes if all(a not in p.track for p in planes)])
        self.fw.follow.stopped(list(sel.axes))
        if not arg.strip() and self.thread is None:
            self.fw.threads.halt_all()
        return OK

    def _ab(self, arg: str) -> bytes:
        """AB aborts motion at once and the programs; AB1 motion only [M Ch6]."""
        mode = self.value(arg) if arg.strip() else 0
        if mode not in (0, 1):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.fw.motion.abort(list(range(self.n)), StopCode.ABORT_COMMAND)
        self.fw.virtual.abort()
        self.fw.follow.aborted()
        if mode == 0:
            self.fw.threads.halt_all()
        self.fw.coord.abort()
        return OK

    def _mo(self, arg: str) -> bytes:
        self.fw.motion.motor_off(self.axes(arg))
        return OK

    def _sh(self, arg: str) -> bytes:
        self.fw.motion.servo_here(self.axes(arg))
        return OK

    def _mode_cmd(self, mode: Mode, arg: str) -> bytes:
        """HM, FE, FI: the search the next BG starts on the axes [M Ch3 §Home Switch Input]."""
        motion = self.fw.motion
        axes = self.axes(arg)
        if any(motion.moving(a) for a in axes):
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        motion.mode[axes] = mode
        return OK

    def _dp(self, arg: str) -> bytes:
        motion = self.fw.motion
        if any(motion.moving(a) for a, _ in self.per_axis(arg)):
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        return self._setter("DP", arg, motion.define_position, motion.reference, self.pos, 0,
                            PARAMS["PA"].coerce)

    def _de(self, arg: str) -> bytes:
        motion = self.fw.motion
        return self._setter("DE", arg, motion.define_aux, motion.auxiliary, self.pos, 0,
                            PARAMS["PA"].coerce)

    def _ip(self, arg: str) -> bytes:
        motion = self.fw.motion
        return self._setter("IP", arg, motion.increment, motion.reference, self.pos, 0,
                            PARAMS["PR"].coerce)

    def _am(self, arg: str) -> Trippoint:
        """AM: wait until the profiles of the axes are complete; AM S/T until the plane's sequence
        is [M Ch6]; AM N until the virtual axis's is."""
        (sel, n_named), moving = self._sel_n(arg), self.fw.motion.core.profile.moving
        axes, planes = list(sel.axes), self.fw.coord.planes_named(sel.s, sel.t)
        n_moving = self.fw.virtual.moving_flag[:1] if n_named else moving[:0]
        return Trippoint(lambda: not moving[axes].any() and not n_moving.any()
                         and not any(p.running for p in planes))

    def _mc(self, arg: str) -> Trippoint:
        """MC: the profile complete and the axis in position: a stepper when its step count
        (TD) equals the reference [M Ch6 §Motion Complete Trippoint]; a servo within one count
        of it (spec §4.5, open question 25); the virtual axis N (no encoder) when its profile is."""
        motion, (sel, n_named) = self.fw.motion, self._sel_n(arg)
        planes = self.fw.coord.planes_named(sel.s, sel.t)
        axes = sorted({*sel.axes, *(a for p in planes for a in p.track)})
        n_moving = self.fw.virtual.moving_flag[:1] if n_named else motion.core.profile.moving[:0]

        def ready() -> bool:
            if (any(p.running for p in planes) or motion.core.profile.moving[axes].any()
                    or n_moving.any()):
                return False
            if motion.plant_kind == PlantKind.STEPPER:
                steps = np.rint(motion.core.axes.pos[axes])
                return bool((steps == motion.reference()[axes]).all())
            return bool((np.abs(motion.error()[axes]) <= 1).all())

        return self.fw.program_commands.with_timeout(Trippoint(ready), axes, self.thread == 0)

    def _wt(self, arg: str) -> Trippoint:
        """WT n: wait n milliseconds [M Ch2 Ex10]."""
        ms = self.value(arg)
        if not 0 <= ms <= 2_147_483_647:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        fw = self.fw
        end = fw.now_ns + int(ms * 1e6)
        return Trippoint(lambda: fw.now_ns >= end)

    def _al(self, arg: str) -> bytes:
        """AL: arm the latch; IN1..IN4 capture X..W on a falling edge (Fig 3-1)."""
        motion = self.fw.motion
        for a in self.axes(arg):
            motion.latch_armed[a] = True
            motion.latch_occurred[a] = False
        return OK

    # -- reports -----------------------------------------------------------------------------------
    def _report(self, name: str, arg: str) -> bytes:
        """TP, TE, RP, TD, RL, TV, TT, SC, TS: one value per axis named (spec §4.4); RP and TP
        of the virtual axis N (its commanded position: it has no encoder) after them."""
        digits, frac = REPORT_FORMATS[name]
        values = self.fw.report(name).tolist()
        lz = not self.fw.lz
        if name in ("RP", "TP") and "N" in arg:
            sel, _ = self._sel_n(arg)
            at = [values[a] for a in sel.axes] + [self.fw.virtual.reference()]
            return self.data(",".join([self.pos(v) for v in at]))
        if name in POSITION_REPORTS:  # PF [Galil command reference PF]
            pos = self.pos
            return self.data(",".join([pos(values[a]) for a in self._sel(arg).axes]))
        return self.data(",".join([format_number(values[a], digits, frac, lz)
                                   for a in self._sel(arg).axes]))

    def _tc(self, arg: str) -> bytes:
        """TC: the code of the last `?`; TC1 adds its text [M Ch5 §Controller Response]."""
        n = self.value(arg) if arg.strip() else 0
        if n not in (0, 1):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        code = self.fw.error_code
        if n == 1:
            return self.data(f"{code} {TEXTS.get(code, '')}")
        return self.data(self.fmt(code, 3, 0))

    def _tb(self, arg: str) -> bytes:
        return self.data(self.fmt(self.fw.status_byte(), 3, 0))

    def _ti(self, arg: str) -> bytes:
        """TI n: input bank n as a byte (0: IN1-IN8)."""
        bank = int(self.value(arg)) if arg.strip() else 0
        return self.data(self.fmt(self.fw.input_bank(bank), 3, 0))

    def _tz(self, arg: str) -> bytes:
        """TZ: the I/O summary, one line per block."""
        fw = self.fw
        lines = [
            f"Block 0 (8-1) dedicated as input- value {fw.input_bank(0)} "
            f"({fw.input_bank(0):08b})",
            f"Block 0 (8-1) dedicated as output- value {fw.outputs & 0xFF} "
            f"({fw.outputs & 0xFF:08b})",
            # no ':' in the text: a host library counts ':' as the end of a reply
            "Analog inputs (1-8) " + ",".join(f"{v:.4f}" for v in fw.analog_volts().tolist()),
        ]
        return "\r\n".join(lines).encode() + CRLF + OK

    def _mg(self, arg: str) -> bytes:
        """MG: strings in quotes and expressions, separated by commas [M Ch6]."""
        out = []
        for item in _split_items(arg):
            if item.startswith('"'):
                if not item.endswith('"') or len(item) < 2:
                    raise GalilError(TC.MISSING_QUOTE)
                out.append(item[1:-1])
            elif item:  # numbers print with a sign column (decimal VF)
                v = self.value(item)
                out.append(("" if v < 0 or self.fw.vf.hex else " ") + self.var(v))
        return self.data("".join(out))

    def _version(self, arg: str) -> bytes:
        """^R^V: the firmware revision [DMCLIB DMCVersion parses "...v<rev>"]."""
        return self.data(revision(self.fw.follow.commutation.standard_axes))

    # -- settings ----------------------------------------------------------------------------------
    def _flag(self, name: str, arg: str) -> bytes:
        """EO (echo) and LZ (leading zeros): 0 or 1, `?` reports it."""
        if arg.strip() == "?":
            return self.data(self.fmt(getattr(self.fw, name), 1, 0))
        v = self.value(arg) if arg.strip() else 0
        if v not in (0, 1):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        setattr(self.fw, name, int(v))
        return OK

    def _tm(self, arg: str) -> bytes:
        """TM: the sample time in us; reported, the servo period stays the configured one."""
        if arg.strip() == "?":
            return self.data(self.fmt(self.fw.tm_us, 5, 0))
        v = self.value(arg)
        if not 250 <= v <= 20_000:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.fw.tm_us = v
        return OK

    def _dr(self, arg: str) -> bytes:
        """DR -n: the data record every 2^n samples into the secondary FIFO; DR 0 off [M Ch4]."""
        if arg.strip() == "?":
            return self.data(self.fmt(-self.fw.record_rate, 2, 0))
        v = self.value(arg) if arg.strip() else 0
        if v != int(v) or not -8 <= v <= 8:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.fw.record_rate = abs(int(v))
        return OK

    def _qz(self, arg: str) -> bytes:
        """QZ: axes, general, coordinated and per-axis block sizes of the record (REV4)."""
        return self.data(f"{self.n},24,16,28")

    def _rs(self, arg: str) -> bytes:
        """RS and ^R^S: the power-on state [M Ch4 §Clearing FIFO Buffer]."""
        self.fw.reset()
        return OK

    def _cn(self, arg: str) -> bytes:
        """CN: switch polarity; accepted and kept (the backdoor drives logic levels)."""
        for field in syntax.parse_fields(arg, 3):
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID)
            if field is not None and self.value(str(field)) not in (-1, 1):
                raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        return OK

    def _ignored(self, arg: str) -> bytes:
        return OK

    # -- I/O ---------------------------------------------------------------------------------------
    def _point(self, arg: str) -> int:
        """An output point: OUT1-OUT8, or 17-80 of the extended I/O (extended_io.py)."""
        n = self.value(arg)
        if n != int(n) or not (1 <= n <= 8 or FIRST_POINT <= n <= LAST_POINT):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        return int(n)

    def _output(self, point: int, on: bool) -> None:
        """Set or clear an output point; an extended point of an input bank is TC 6."""
        if point > 8:
            self.fw.ext.write(point, on)
            return
        bit = 1 << (point - 1)
        self.fw.outputs = self.fw.outputs | bit if on else self.fw.outputs & ~bit

    def _sb(self, arg: str) -> bytes:
        self._output(self._point(arg), True)
        return OK

    def _cb(self, arg: str) -> bytes:
        self._output(self._point(arg), False)
        return OK

    def _ob(self, arg: str) -> bytes:
        fields = syntax.parse_fields(arg, 2)
        if len(fields) != 2 or any(f is None or f is syntax.QUERY for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        point = self._point(str(fields[0]))
        self._output(point, self.value(str(fields[1])) != 0)
        return OK

    def _op(self, arg: str) -> bytes:
        """OP m,a,b,c,d: OUT1-8, then the extended outputs 17-80 in words of 16 bits (extended
        I/O appendix of the DMC-1700/1800: points of input banks ignored)."""
        if arg.strip() == "?":
            return self.data(self.fmt(self.fw.outputs, 3, 0))
        fields = syntax.parse_fields(arg, 5)
        values: list[int | None] = []
        for k, field in enumerate(fields):
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID)
            v = None if field is None else self.value(str(field))
            if v is not None and (v != int(v) or not 0 <= v <= (255 if k == 0 else 0xFFFF)):
                raise GalilError(TC.NUMBER_OUT_OF_RANGE)
            values.append(None if v is None else int(v))
        if not values:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        if values[0] is not None:
            self.fw.outputs = values[0]
        self.fw.ext.write_words(values[1:])
        return OK

    # -- interrupts --------------------------------------------------------------------------------
    def _ei(self, arg: str) -> bytes:
        """EI m,n,o: conditions, input mask, vector; EI0 clears the queue [M Ch4]."""
        fields = syntax.parse_fields(arg, 3) if arg.strip() else ["0"]
        values = [None if f is None else self.value(str(f)) for f in fields]
        if any(f is syntax.QUERY for f in fields):
            raise GalilError(TC.QUESTION_MARK_NOT_VALID)
        m, n, o = (values + [None, None, None])[:3]
        if m is not None and not (m == int(m) and 0 <= m <= 0xFFFF):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        if n is not None and not (n == int(n) and 0 <= n <= 0xFF):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        if o is not None and not (o == int(o) and 8 <= o <= 255):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.fw.enable_interrupts(None if m is None else int(m), None if n is None else int(n),
                                    None if o is None else int(o))
        return OK

    def _ui(self, arg: str) -> bytes:
        """UI n: user interrupt n (0-15), status 0xF0 + n [M Ch4 §Setting up Interrupts]."""
        n = self.value(arg) if arg.strip() else 0
        if n != int(n) or not 0 <= n <= 15:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.fw.interrupt(InterruptStatus.USER + int(n))
        return OK

    # -- variables ---------------------------------------------------------------------------------
    def _assign(self, text: str) -> bytes:
        """`V1=expr` sets a variable; `V1=` prints it [M Ch2 Ex14]; `A[i]=expr`, `A[i]=` an array
        element [M Ch6 §Multiple Moves]."""
        name, index, value = syntax.parse_assignment(text)
        if index is not None:
            return self._assign_element(name, index, value)
        if not value.strip():
            return self.data(self.var(self.fw.env.variable(name)))
        v = self.value(value)
        variables = self.fw.variables
        if name not in variables and len(variables) >= 254:
            raise GalilError(67)
        variables[name] = v
        return OK

    def _assign_element(self, name: str, index_text: str, value: str) -> bytes:
        """`A[i]=expr` (TC 57 no array A, TC 56 an index outside it) or `A[i]=` (prints it)."""
        arrays = self.fw.arrays
        index = self.value(index_text) if index_text else -1
        if index != int(index):
            raise GalilError(TC.ARRAY_INDEX_INVALID, f"{name}[{index}]")
        if not value.strip():
            return self.data(self.var(arrays.read(name, int(index))))
        arrays.read(name, int(index))  # the element exists before its value is computed
        arrays.write(name, int(index), self.value(value))
        return OK

    def _label(self, arg: str) -> bytes:
        raise GalilError(TC.ONLY_VALID_FROM_PROGRAM, "#" + arg)


def _split_items(arg: str) -> list[str]:
    """MG items: commas outside quotes separate them."""
    items: list[str] = []
    cur: list[str] = []
    quoted = False
    for ch in arg:
        if ch == '"':
            quoted = not quoted
        if ch == "," and not quoted:
            items.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    items.append("".join(cur).strip())
    return [i for i in items if i]

