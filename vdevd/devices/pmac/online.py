"""The on-line command interpreter: one command line in, a `Reply` out [spec pmac.md §2.4, §2.5].

A line is a run of commands with or without spaces between them (`#1J+`, `i65???&1??%#1?PVF m190
p99` is twelve commands); case does not matter and `;` starts a comment. Commands run left to
right against the firmware state; the first invalid one ends the line with its error number and
the lines already produced stay in the reply. The `#n`/`&n` addressing and a pending table
download belong to the port (`PortState`), so each port addresses its own motor.

The commands are the table of commands.py, bound to the interpreter's methods once per
interpreter. Axis definitions and the rest of the coordinate systems are coord.py's (`&n#m->`).
PLC buffers and their run control are plc.py's (`OPEN PLC`, `ENABLE PLC`; while a port has a
buffer open its lines go there). Commands that belong to motion programs come in a later issue;
until then those the parser recognises answer the error the card gives for a command it cannot execute
(`commands.REFUSED`, README "Not yet").

Lines made only of reports and motor addressing (`#1P`, `#2?`, `#3?PVF`, `I130`, `P99`), what
hosts poll, are compiled once into their steps and then run without the general parse; each step
is the general handler's own effect (tests/devices/pmac/test_online_fastpath.py compares them).
"""

from __future__ import annotations

import functools
import re
import string
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vdevd.devices.pmac import altdest, expr, learn, prog_reports, stop_commands
from vdevd.devices.pmac.buffers import PLCC_BASE
from vdevd.devices.pmac.commands import CHAR, COMMANDS, REFUSED, VARIABLES, WORD
from vdevd.devices.pmac.errors import ERR_DATA, ERR_ILLEGAL, ERR_IN_USE, ERR_NOT_OPEN, CommandError
from vdevd.devices.pmac.mvars import MDefError, parse_definition
from vdevd.devices.pmac.numbers import format_value
from vdevd.devices.pmac.reply import Reply

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

#: a motion program runs: buffers that may not open meanwhile [SRM OPEN FORWARD]
ERR_RUNNING = 1
#: compiled report lines kept per interpreter (the cache starts afresh when full)
PLAN_CACHE = 256

_INT = re.compile(r"\d+")
_MOTOR = re.compile(r"#(\d+)(?![\d \t]*->)")
_WORD = re.compile(r"[A-Z]+")
_SIGNED = re.compile(r"\s*(-?\d+)")
_HEXNUM = re.compile(r"\s*(\$[0-9A-F]+|-?\d+)")
_AXIS_SET = re.compile(r"([XYZUVWABC])[ \t]*=(?!=)[ \t]*")
#: every word a run of letters may be: the table's and the refused ones [commands.py]
_WORD_NAMES = frozenset(name for name, cmd in COMMANDS.items() if cmd.kind == WORD) | set(REFUSED)
_LONGEST = max(map(len, _WORD_NAMES))


@dataclass
class PortState:
    """What one communications port remembers between lines [digest §2.4 "Ports"]."""

    motor: int = 1          # #n, 1-based
    cs: int = 1             # &n
    group: int = 1          # ##n: which eight motors ^B ^F ^P ^V report
    cs_mode: bool = False   # the last address was &n: K acts on the C.S. (README)
    table_motor: int = 0    # a DEFINE COMP download in progress: its motor (0 = none)
    table_left: int = 0


_JOG_CONSTANT = re.compile(r"-?(?:\$[0-9A-F]+|\d+\.?\d*|\.\d+)")


def _jog_value(line: Line, env: expr.Env) -> float | None:
    """A constant (decimal or $hex) or a parenthesised expression at the cursor, or None."""
    s, i = line.s, line.i
    if s.startswith("(", i):
        depth = 0
        for j in range(i, len(s)):
            if s[j] == "(":
                depth += 1
            elif s[j] == ")":
                depth -= 1
            if depth == 0:
                try:
                    value = expr.evaluate(s[i:j + 1], env)
                except expr.ExprError as exc:
                    raise CommandError(exc.code) from None
                line.i = j + 1
                return value
        raise CommandError(ERR_DATA, "unbalanced (")
    m = _JOG_CONSTANT.match(s, i)
    if m is None:
        return None
    line.i = m.end()
    text = m.group()
    negative = text.startswith("-")
    digits = text.lstrip("-")
    v = float(int(digits[1:], 16)) if digits.startswith("$") else float(digits)
    return -v if negative else v


class Line:
    """A cursor over one upper-cased command line."""

    def __init__(self, text: str) -> None:
        self.s = text.upper()
        self.i = 0

    def skip(self) -> None:
        s, i, n = self.s, self.i, len(self.s)
        while i < n and s[i] in " \t":
            i += 1
        self.i = i

    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.s[j] if j < len(self.s) else ""

    def take(self, word: str) -> bool:
        if self.s.startswith(word, self.i):
            self.i += len(word)
            return True
        return False

    def integer(self) -> int | None:
        m = _INT.match(self.s, self.i)
        if m is None:
            return None
        self.i = m.end()
        return int(m.group())

    def signed(self) -> int | None:
        m = _SIGNED.match(self.s, self.i)
        if m is None:
            return None
        self.i = m.end()
        return int(m.group(1))

    def expression(self, env: expr.Env) -> float:
        try:
            tree, self.i = expr.parse(self.s, self.i)
            return tree.eval(env)
        except expr.ExprError as exc:
            raise CommandError(exc.code) from None

    def word(self) -> str:
        j = self.i
        while j < len(self.s) and self.s[j].isalpha():
            j += 1
        return self.s[self.i:j]


#: a bound command: its static arguments applied, it takes the line, the port and the output
Handler = Callable[[Line, PortState, list[str]], None]
#: one step of a compiled report line: what its general handler does
Step = Callable[["Firmware", PortState, list[str]], None]
Plan = tuple[Step, ...]


class Interpreter:
    """Runs command lines against one card's firmware state."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self._plans: dict[str, Plan | None] = {}  # line -> its steps; None: not a report line
        bound = COMMANDS.bind(self)
        #: first character -> handler; a letter starts a variable or a word (`letter`)
        self._chars: dict[str, Handler] = {
            name: fn for name, fn in bound.items() if COMMANDS[name].kind == CHAR}
        self._chars.update(dict.fromkeys(string.ascii_uppercase, self.letter))
        self._words: dict[str, Handler] = {
            name: fn for name, fn in bound.items() if COMMANDS[name].kind == WORD}
        self._words.update({name: functools.partial(self.refuse, code, name)
                            for name, code in REFUSED.items()})

    # -- entry ---------------------------------------------------------------------------------
    def execute(self, port: PortState, text: str) -> Reply:
        if port is self.fw.plc.owner:  # a buffer is open on this port: its lines go there (plc.py)
            return self.fw.plc.enter(port, text)
        if (port is self.fw.rotary.owner or port is self.fw.motion.store.owner) \
                and learn.is_learn(text):  # LEARN: the line of present axis positions (learn.py)
            try:
                text = learn.learn_line(self.fw, port.cs, text)
            except CommandError as exc:
                return Reply(error=exc.code)
            if not text:
                return Reply()
        if port is self.fw.rotary.owner:  # rotary.py
            return self.fw.rotary.enter(port, text)
        if port is self.fw.kinematics.owner:  # kinematics.py
            return self.fw.kinematics.enter(port, text)
        if port is self.fw.motion.store.owner:  # a PROG buffer (programs.py)
            return self.fw.motion.store.enter(port, text)
        plans = self._plans
        if text in plans:
            plan = plans[text]
        else:
            if len(plans) >= PLAN_CACHE:
                plans.clear()
            plan = plans[text] = compile_reports(text)
        if plan is not None and not port.table_left:
            reply = Reply()
            try:
                for step in plan:
                    step(self.fw, port, reply.lines)
            except CommandError as exc:
                reply.error = exc.code
            return reply
        return self.execute_general(port, text)

    def execute_general(self, port: PortState, text: str) -> Reply:
        """Parse and run `text` command by command (every line can take this path)."""
        text = text.split(";", 1)[0]  # comments, including characters > 127 [A L3311]
        reply = Reply()
        line = Line(text)
        s, n = line.s, len(line.s)
        try:
            while True:
                i = line.i
                while i < n and s[i] in " \t":
                    i += 1
                if i >= n:
                    break
                line.i = i
                c = s[i]
                if port.table_left and (c.isdigit() or c == "-"):
                    self._table_entry(line, port)
                    continue
                handler = self._chars.get(c)
                if handler is None:
                    # ERR004: a character above 127 outside a comment [digest §2.4; A L3311]
                    raise CommandError(ERR_ILLEGAL if ord(c) > 127 else ERR_DATA,
                                       f"unrecognised {c!r}")
                handler(line, port, reply.lines)
        except CommandError as exc:
            reply.error = exc.code
        return reply

    # -- addressing ------------------------------------------------------------------------------
    def address_motor(self, line: Line, port: PortState, out: list[str]) -> None:
        """#n addresses motor n (1-32), # reports it, ##n the group of eight, #n-> queries the
        axis definition [§2.4, §2.5]."""
        m = _MOTOR.match(line.s, line.i)  # `#n` alone, the common case
        if m is not None:
            motor = int(m.group(1))
            if not 1 <= motor <= 32:
                raise CommandError(ERR_DATA)
            port.motor = motor
            port.cs_mode = False
            line.i = m.end()
            return
        line.take("#")
        if line.take("#"):  # ##n: the group of eight for the control-character reports
            port.group = _select(line, out, port.group, 4)
            return
        port.motor = _select(line, out, port.motor, 32)
        port.cs_mode = False
        line.skip()
        if line.take("->"):  # the axis definition in the addressed C.S. [§2.8; coord.py]
            line.skip()
            if line.peek() in ("", "#", "&") or (line.peek().isalpha() and line.peek(1).isalpha()):
                # `#n->` alone or before a command word: report it (EPICS asks `&1#1->`)
                out.append(self.fw.coord.query(port.cs, port.motor))
                return
            line.i = self.fw.define_axis(port.cs, port.motor, line.s, line.i)

    def address_cs(self, line: Line, port: PortState, out: list[str]) -> None:
        """&n addresses coordinate system n (1-16), & reports it [§2.5]."""
        line.take("&")
        port.cs = _select(line, out, port.cs, 16)
        port.cs_mode = True

    # -- status ----------------------------------------------------------------------------------
    def status(self, line: Line, port: PortState, out: list[str]) -> None:
        """? motor, ?? coordinate system, ??? global status words [§2.6]."""
        k = 0
        while line.take("?"):
            k += 1
        out.append(status_text(self.fw, port, k))

    # -- letters ---------------------------------------------------------------------------------
    def letter(self, line: Line, port: PortState, out: list[str]) -> None:
        """A variable (I/P/Q/M with a number or an expression) or the longest word the letters
        start with [§2.5]."""
        s, i = line.s, line.i
        if s[i] in VARIABLES and i + 1 < len(s) and (s[i + 1].isdigit() or s[i + 1] == "("):
            self._variable(line, port, out)
            return
        m = _AXIS_SET.match(s, i)
        if m is not None:  # `{axis}={v}`: a new position bias [A L932]
            line.i = m.end()
            self.fw.set_axis(port.cs, m.group(1), line.expression(self.fw.env(port)))
            return
        word = _longest_word(s, i)
        if not word:
            m = _WORD.match(s, i)
            raise CommandError(ERR_DATA, f"unrecognised {m.group() if m is not None else ''!r}")
        line.i += len(word)
        self._words[word](line, port, out)

    # variables -----------------------------------------------------------------------------------
    def _variable(self, line: Line, port: PortState, out: list[str]) -> None:
        fw = self.fw
        kind = line.peek()
        line.i += 1
        if line.peek() == "(":
            line.i += 1
            first = int(line.expression(fw.env(port)))
            line.skip()
            if not line.take(")"):
                raise CommandError(ERR_DATA)
        else:
            first = line.integer() or 0
        numbers = [first]
        if line.take(".."):
            last = line.integer()
            if last is None or last < first:
                raise CommandError(ERR_DATA)
            numbers = list(range(first, last + 1))
        elif line.peek() == "," and line.peek(1).isdigit():
            line.i += 1
            count = line.integer()
            step = 1
            if line.take(","):
                step = line.integer() or 0
            if count is None or count < 1 or step < 1:
                raise CommandError(ERR_DATA)
            numbers = [first + k * step for k in range(count)]
        limit = fw.variable_count(kind)
        if numbers[-1] >= limit or numbers[0] < 0:
            raise CommandError(ERR_DATA, f"{kind}{numbers[-1]} does not exist")
        line.skip()
        if kind == "M" and line.take("->"):
            self._m_definition(line, numbers, out)
            return
        if line.peek() == "=" and line.peek(1) != "=":
            line.i += 1
            line.skip()
            if kind == "I" and line.take("*"):
                for n in numbers:
                    fw.set_ivar(n, fw.ivars.defaults[n])
                return
            if kind == "I" and line.take("@I"):
                src = line.integer()
                if src is None:
                    raise CommandError(ERR_DATA)
                for n in numbers:
                    fw.set_ivar(n, fw.address_of_ivar(src))
                return
            value = line.expression(fw.env(port))
            for n in numbers:
                fw.set_variable(port, kind, n, value)
            return
        for n in numbers:
            out.append(variable_text(fw, port, kind, n))

    def _m_definition(self, line: Line, numbers: list[int], out: list[str]) -> None:
        fw = self.fw
        line.skip()
        if not line.peek() or line.peek() == " " or line.peek() in "#&":
            for n in numbers:
                out.append(f"M{n}->{fw.mvars.defs[n].text()}")
            return
        try:
            d, line.i = parse_definition(line.s, line.i)
        except MDefError:
            raise CommandError(ERR_DATA) from None
        for n in numbers:
            fw.mvars.define(n, d)

    # motor reports and commands ----------------------------------------------------------------------
    def report(self, what: str, line: Line, port: PortState, out: list[str]) -> None:
        """P, V, F: the addressed motor's position, velocity, following error [§2.5]."""
        out.append(self.fw.motor_report(what, port.motor))

    def jog(self, line: Line, port: PortState, out: list[str]) -> None:
        fw, m = self.fw, port.motor
        c = line.peek()
        line.i += 1 if c else 0
        if c in "+-":
            fw.motor_call("jog", m, 1 if c == "+" else -1)
        elif c == "/":
            fw.motor_call("jog_stop", m)
        elif c == "!":
            fw.motor_call("round_commanded", m)
        elif c in "=:^":
            if self._jog_until_trigger(c, line, port):
                return
            if line.take("*"):
                fw.motor_call("jog_variable", m, c)
            elif c == "=" and not (line.peek().isdigit() or line.peek() in "-.$(PQIM"):
                fw.motor_call("jog_to", m, None)
            else:
                value = line.expression(fw.env(port))
                if c == "=":
                    fw.motor_call("jog_to", m, value)
                else:
                    fw.motor_call("jog_relative", m, value, c == "^")
        else:
            raise CommandError(ERR_DATA, "J needs + - / ! = : or ^")

    def _jog_until_trigger(self, c: str, line: Line, port: PortState) -> bool:
        """`{jog}^{c}` after J=, J:, J^ (c the letter after J): the definite jog `J=`, `J={c}`,
        `J=*`, `J:{c}`, `J:*`, `J^{c}`, `J^*` with `^{c}`, the distance from the trigger to end
        at (counts) [PMAC1-SRM p.241, UM "Jog-until-trigger"]. True if it was one (and ran);
        False leaves the line where it was. Values are constants or `(expressions)`, since `^`
        is also the XOR operator."""
        start, fw = line.i, self.fw
        env = fw.env(port)
        value: float | None = None
        variable = line.take("*")
        if not variable and not (c == "=" and line.peek() == "^"):
            value = _jog_value(line, env)
        if line.peek() != "^" or (value is None and not variable and c != "="):
            line.i = start
            return False
        line.i += 1
        distance = _jog_value(line, env)
        if distance is None:
            raise CommandError(ERR_DATA, "^ needs the post-trigger distance")
        fw.motor_call("jog_trigger", port.motor, c, value, distance, variable)
        return True

    def altered_destination(self, line: Line, port: PortState, out: list[str]) -> None:
        """!{axis}{data}...: the addressed C.S.'s altered-destination RAPID move (altdest.py)
        [A L3232]."""
        line.take("!")
        dest, named = altdest.parse(line, self.fw.env(port))
        altdest.altered_destination(self.fw, port.cs, dest, named)

    def home(self, zero: bool, line: Line, port: PortState, out: list[str]) -> None:
        """HM/HOME home search, HMZ/HOMEZ zero-move homing [§2.7]."""
        self.fw.motor_call("home_zero" if zero else "home", port.motor)

    def kill(self, line: Line, port: PortState, out: list[str]) -> None:
        """K: kill the addressed motor, or with a C.S. addressed last (`&n`) its motors."""
        if port.cs_mode:
            self.fw.kill_cs(port.cs)
            return
        self.fw.motor_call("kill", port.motor)

    def open_loop(self, line: Line, port: PortState, out: list[str]) -> None:
        if line.word().startswith("PEN"):
            raise CommandError(ERR_DATA, "program buffers come in a later issue")
        self.fw.motor_call("open_loop", port.motor, line.expression(self.fw.env(port)))

    def abort(self, line: Line, port: PortState, out: list[str]) -> None:
        self.fw.abort_cs(port.cs)

    def dollar(self, line: Line, port: PortState, out: list[str]) -> None:
        fw = self.fw
        if line.take("$$$***"):
            fw.factory_reset()
        elif line.take("$$$"):
            fw.power_on_reset()
        elif line.take("$$*") or line.take("$$"):
            fw.abort_cs(port.cs)
        elif line.take("$*") or line.take("$"):
            fw.motor_call("jog_stop", port.motor)
        else:  # pragma: no cover - the dispatcher only calls with '$'
            raise CommandError(ERR_DATA)

    def feed(self, line: Line, port: PortState, out: list[str]) -> None:
        line.take("%")
        line.skip()
        if line.peek().isdigit() or line.peek() == ".":
            value = line.expression(self.fw.env(port))
            if not 0 <= value <= 838.8607:
                raise CommandError(ERR_DATA)
            self.fw.feed[port.cs - 1] = value
            self.fw.timebase.command(port.cs - 1, value)  # the present value slews (Isx94)
        else:
            out.append(format_value(round(self.fw.feed[port.cs - 1], 1)))

    # words ---------------------------------------------------------------------------------------
    def identity(self, name: str, line: Line, port: PortState, out: list[str]) -> None:
        """CID, VERSION, DATE, TYPE, CPU, VID [§2.4]."""
        out.append(self.fw.identity(name))

    def save(self, line: Line, port: PortState, out: list[str]) -> None:
        """SAVE: the non-volatile image [§2.5]."""
        self.fw.save()

    def refuse(self, code: int, name: str, line: Line, port: PortState, out: list[str]) -> None:
        """A command of a later issue: the error the card answers for it (commands.REFUSED)."""
        raise CommandError(code, f"{name} comes in a later issue")

    def hold(self, line: Line, port: PortState, out: list[str]) -> None:
        """H: feed hold of the addressed C.S.'s program (program_runner.py); with none running it
        holds nothing."""
        self.fw.motion.runner(port.cs).feed_hold()

    def stop_at_move_end(self, line: Line, port: PortState, out: list[str]) -> None:
        """`/`: the addressed C.S.'s program stops at the end of the executing move
        (stop_commands.py) [SRM /]."""
        line.i += 1
        stop_commands.stop_at_end_of_move(self.fw.motion.runner(port.cs))

    def quick_stop(self, line: Line, port: PortState, out: list[str]) -> None:
        """`\\`: quick stop; outside a lookahead sequence a feed hold (stop_commands.py)."""
        line.i += 1
        stop_commands.quick_stop(self.fw.motion.runner(port.cs))

    def begin(self, line: Line, port: PortState, out: list[str]) -> None:
        """B{n}[.label] points the addressed C.S. to PROG n; B alone back to its top [SRM B]."""
        self.fw.motion.runner(port.cs).point(_program_label(line))

    def run(self, step: bool, line: Line, port: PortState, out: list[str]) -> None:
        """R (run) / S (single step) of the addressed C.S.'s program [SRM R, S]."""
        self.fw.motion.runner(port.cs).run(step)

    def abort_run(self, line: Line, port: PortState, out: list[str]) -> None:
        """ABR[{n}[.label]]: abort the addressed C.S.'s program and run PROG n, or the one
        pointed to from its top (program_runner.py) [A L3261]."""
        self.fw.motion.runner(port.cs).abort_and_run(_program_label(line))

    def program_report(self, name: str, line: Line, port: PortState, out: list[str]) -> None:
        """PC (program counter), PE (executing line) of the addressed C.S.: `P{prog}:{offset}`
        (prog_reports.py) [SRM PC, PE]; PR is rotary.py's (`program_remaining`)."""
        r = self.fw.motion.runner(port.cs)
        if name == "PC":
            out.append(prog_reports.program_counter(r))
        else:
            out.append(prog_reports.execution_line(r))

    def pmatch(self, line: Line, port: PortState, out: list[str]) -> None:
        """PMATCH: the addressed C.S.'s axis positions from its motors' commanded positions, through
        the forward kinematic program with Isx50 = 1 [SRM OPEN FORWARD: "any time an R (run), S
        (step), or PMATCH command is given"]; ERR001 while its program runs (ASSUMPTION)."""
        self.fw.motion.runner(port.cs).pmatch_online()

    def quit(self, line: Line, port: PortState, out: list[str]) -> None:
        """Q: quit at the end of the moves already calculated [SRM Q]."""
        self.fw.motion.runner(port.cs).quit()

    def macro_station(self, line: Line, port: PortState, out: list[str]) -> None:
        """MS{node},MI{n} reads and MS{node},MI{n}={v} writes a station's MI-variable (`I` for `MI`
        as dls-pmaclib sends it); MSR{node},{address},{variable} reads a station register into a
        variable, MSW{node},{address},{variable} writes one (macro.py) [Turbo SRM; spec §3.3]."""
        fw = self.fw
        op = "R" if line.take("R") else "W" if line.take("W") else ""
        line.skip()
        node = line.integer()
        line.skip()
        if node is None or not line.take(","):
            raise CommandError(ERR_DATA)
        line.skip()
        if op:
            if line.peek() in ("X", "Y") and line.peek(1) == ":":
                line.i += 2
            m = _HEXNUM.match(line.s, line.i)
            if m is None:
                raise CommandError(ERR_DATA)
            address = int(m.group(1)[1:], 16) if m.group(1)[0] == "$" else int(m.group(1))
            line.i = m.end()
            line.skip()
            if not line.take(","):
                raise CommandError(ERR_DATA)
            line.skip()
            kind = line.peek()
            line.i += 1
            n = line.integer()
            if kind not in VARIABLES or n is None or n >= fw.variable_count(kind):
                raise CommandError(ERR_DATA)
            if op == "R":
                fw.set_variable(port, kind, n, fw.macro.read_register(node, address))
            else:
                fw.macro.write_register(node, address, fw.get_variable(port, kind, n))
            return
        line.take("M")
        n = line.integer() if line.take("I") else None
        if n is None:
            raise CommandError(ERR_DATA)
        line.skip()
        if line.peek() == "=" and line.peek(1) != "=":
            line.i += 1
            fw.macro.write_mi(node, n, line.expression(fw.env(port)))
            return
        out.append(str(fw.macro.read_mi(node, n)))

    def list_table(self, line: Line, port: PortState, out: list[str]) -> None:
        line.skip()
        kind = _table_kind(line)
        if kind is not None:
            line.skip()
            out.extend(self.fw.list_comp(port.motor, definition=line.take("DEF"), kind=kind))
            return
        if line.take("GAT"):
            line.take("HER")
            out.extend(self.fw.gather.list_lines())
            return
        if line.take("FORWARD") or line.take("FWD"):  # LIST FORWARD / INVERSE (kinematics.py)
            out.extend(self.fw.kinematics.list_lines(port.cs, "FORWARD"))
            return
        if line.take("INV"):
            line.take("ERSE")
            out.extend(self.fw.kinematics.list_lines(port.cs, "INVERSE"))
            return
        if line.take("PLC") and not line.take("C"):  # LIST PLC n[,start[,count]] (plc.py)
            n, args = _list_numbers(line)
            out.extend(self.fw.plc.list_lines(n, *args))
            return
        if line.take("PROG"):  # LIST PROG n[,start[,count]] (programs.py)
            line.take("RAM")
            n, args = _list_numbers(line)
            out.extend(self.fw.motion.store.list_lines(n, *args))
            return
        raise CommandError(ERR_DATA, "LIST of this buffer is not emulated")

    def open_buffer(self, line: Line, port: PortState, out: list[str]) -> None:
        """OPEN PLC n / OPEN PROG n: the rest of the line and the port's next lines go into the
        buffer (plc.py, programs.py)."""
        line.skip()
        if self._open_other(line, port, out):
            return
        if any(o is not None and o is not port for o in (self.fw.rotary.owner, self.fw.kinematics.owner)):
            raise CommandError(ERR_IN_USE, "another port has a buffer open")
        if line.take("PROG"):
            line.take("RAM")
            line.skip()
            n = line.integer()
            if n is None:
                raise CommandError(ERR_DATA)
            store = self.fw.motion.store
            store.open(port, n)
            rest, line.i = line.s[line.i:], len(line.s)
            reply = store.enter(port, rest)
            out.extend(reply.lines)
            if reply.error is not None:
                raise CommandError(reply.error)
            return
        if not line.take("PLC"):
            raise CommandError(ERR_DATA, "only OPEN PLC n and OPEN PLCC n are emulated yet")
        compiled = line.take("C")
        line.skip()
        n = line.integer()
        if n is None:
            raise CommandError(ERR_DATA)
        self.fw.plc.open(port, n, compiled)
        rest, line.i = line.s[line.i:], len(line.s)
        reply = self.fw.plc.enter(port, rest)
        out.extend(reply.lines)
        if reply.error is not None:
            raise CommandError(reply.error)

    def _open_other(self, line: Line, port: PortState, out: list[str]) -> bool:
        """OPEN ROT (rotary.py), OPEN FORWARD / OPEN INVERSE of the addressed C.S.
        (kinematics.py): the rest of the line goes into the buffer. False for another OPEN."""
        fw = self.fw
        kind = ""
        if line.take("ROT"):
            line.take("ARY")
        elif line.take("FORWARD") or line.take("FWD"):
            kind = "FORWARD"
        elif line.take("INV"):
            line.take("ERSE")
            kind = "INVERSE"
        else:
            return False
        owners = (fw.plc.owner, fw.motion.store.owner, fw.rotary.owner, fw.kinematics.owner)
        if any(o is not None and o is not port for o in owners):
            raise CommandError(ERR_IN_USE, "another port has a buffer open")
        if kind and fw.motion.any_running():
            raise CommandError(ERR_RUNNING, "a motion program is running")
        if fw.plc.owner is port:
            fw.plc.close()
        if fw.motion.store.owner is port:
            fw.motion.store.close()
        if kind:
            fw.kinematics.open(port, kind)
        else:
            fw.rotary.open(port)
        rest, line.i = line.s[line.i:], len(line.s)
        reply = (fw.kinematics if kind else fw.rotary).enter(port, rest)
        out.extend(reply.lines)
        if reply.error is not None:
            raise CommandError(reply.error)
        return True

    def program_remaining(self, line: Line, port: PortState, out: list[str]) -> None:
        """PR: the lines waiting in the addressed C.S.'s rotary buffer (rotary.py)."""
        out.append(str(self.fw.rotary.remaining(port.cs)))

    def trigger_alone(self, line: Line, port: PortState, out: list[str]) -> None:
        """`^{c}` belongs to a definite jog (`J=^{c}`, `J:{c}^{c}` ..., parsed by `jog`); on its
        own, or after J+/J- (which cannot be triggered [PMAC1-SRM p.241]), it is ERR003."""
        raise CommandError(ERR_DATA, "^ follows a definite jog")

    def close_nothing(self, line: Line, port: PortState, out: list[str]) -> None:
        """CLOSE with no buffer open on this port (the opening port's CLOSE is plc.py's): nothing
        to close, no error; the SRM's examples start every download with CLOSE "to make sure no
        other buffers have been left open" [SRM OPEN PROGRAM], and so do pmac_motorhome's PLCs.
        While another port has a buffer open only that port may CLOSE it: ERR005 [A L3234]."""
        fw = self.fw
        if any(o is not None for o in (fw.plc.owner, fw.motion.store.owner, fw.rotary.owner,
                                       fw.kinematics.owner)):
            raise CommandError(ERR_NOT_OPEN, "another port has the buffer open")
        line.take(" ALL")

    def plc_control(self, on: bool, line: Line, port: PortState, out: list[str]) -> None:
        """ENABLE PLC n[,m...] / DISABLE PLC n[,m...], and PLCC for the compiled PLCs [§2.9]."""
        self.fw.plc.enable(_plc_numbers(line), on)

    def plc_pause(self, resume: bool, line: Line, port: PortState, out: list[str]) -> None:
        """PAUSE PLC n[,m...] stops PLCs where they are, RESUME PLC n[,m...] goes on from there
        (PLCC too) [Turbo SRM PAUSE PLC, RESUME PLC; plc.py]."""
        self.fw.plc.pause(_plc_numbers(line), resume)

    def define(self, line: Line, port: PortState, out: list[str]) -> None:
        line.take("INE")
        line.skip()
        if line.take("GAT"):  # DEFINE GATHER [n] (gather.py)
            line.take("HER")
            line.skip()
            self.fw.gather.define(line.integer())
            return
        if line.take("ROT"):  # DEFINE ROT n (rotary.py)
            line.take("ARY")
            line.skip()
            self.fw.rotary.define(port.cs, line.integer())
            return
        if line.take("LOOK"):  # DEFINE LOOKAHEAD {segments}[,{outputs}] (lookahead.py)
            line.take("AHEAD")
            line.skip()
            segments = line.integer()
            line.skip()
            outputs: int | None = 0
            if line.take(","):
                line.skip()
                outputs = line.integer()
            if segments is None or outputs is None:
                raise CommandError(ERR_DATA, "DEFINE LOOKAHEAD {segments},{outputs}")
            self.fw.motion.runner(port.cs).define_lookahead(segments, outputs)
            return
        kind = _table_kind(line)
        if kind is None:
            raise CommandError(ERR_DATA, "only DEFINE GATHER, COMP, BLCOMP and TCOMP are supported yet")
        end = len(line.s)
        port.table_left = self.fw.define_comp(port.motor, line.s[line.i:end], kind)
        port.table_motor = port.motor
        line.i = end

    def delete(self, line: Line, port: PortState, out: list[str]) -> None:
        line.take("ETE")
        line.skip()
        kind = _table_kind(line)
        if kind is not None:
            self.fw.delete_comp(port.motor, kind)
        elif line.take("GAT"):
            line.take("HER")
            self.fw.gather.delete()
        elif line.take("LOOK"):  # DELETE LOOKAHEAD: the addressed C.S.'s (lookahead.py)
            line.take("AHEAD")
            self.fw.motion.runner(port.cs).define_lookahead(None, 0)
        elif line.take("ROT"):  # DELETE ROT (rotary.py)
            line.take("ARY")
            self.fw.rotary.delete(port.cs)
        elif line.take("TBUF"):
            pass  # no TBUF buffer exists: deleting it is a no-op
        else:
            raise CommandError(ERR_DATA)

    def gather(self, line: Line, port: PortState, out: list[str]) -> None:
        """GATHER: start data gathering (gather.py); GATHER TRIGGER is not emulated (ERR003)."""
        line.skip()
        if line.word().startswith("TRIG"):
            raise CommandError(ERR_DATA, "GATHER TRIGGER is not emulated (README)")
        self.fw.gather.start()

    def end_gather(self, spaced: bool, line: Line, port: PortState, out: list[str]) -> None:
        """ENDGATHER, ENDG, END GAT[HER]: stop data gathering."""
        if spaced:
            line.skip()
            if not line.take("GAT"):
                raise CommandError(ERR_DATA, "END without GATHER")
            line.take("HER")
        self.fw.gather.stop()

    def _table_entry(self, line: Line, port: PortState) -> None:
        value = line.signed()
        if value is None or line.peek() == ".":  # entries are integers: a fraction stores nothing
            raise CommandError(ERR_DATA)
        port.table_left = self.fw.comp_entry(port.table_motor, value)
        line.skip()
        line.take(",")

    def memory(self, space: str, write: bool, line: Line, port: PortState,
               out: list[str]) -> None:
        """R{space}:{addr}[,{count}] reads, W{space}:{addr},{value}[,...] writes memory words
        [§2.5]."""
        line.skip()
        line.take(":")
        m = _HEXNUM.match(line.s, line.i)
        if m is None:
            raise CommandError(ERR_DATA)
        addr = _number(m.group(1))
        line.i = m.end()
        values: list[int] = []
        while line.take(","):
            m = _HEXNUM.match(line.s, line.i)
            if m is None:
                raise CommandError(ERR_DATA)
            values.append(_number(m.group(1)))
            line.i = m.end()
        if write:
            self.fw.write_words(space, addr, values)
        else:
            count = values[0] if values else 1
            out.extend(self.fw.read_words(space, addr, count))

    def lock(self, unlock: bool, line: Line, port: PortState, out: list[str]) -> None:
        """LOCK{n},P{m} / UNLOCK{n} [A L3264]."""
        n = line.integer()
        if n is None or not 0 <= n <= 7:
            raise CommandError(ERR_DATA)
        line.skip()
        if unlock:
            self.fw.locks &= ~(1 << n)
            return
        if not line.take(",P"):
            raise CommandError(ERR_DATA)
        p = line.integer()
        if p is None or p >= 8192:
            raise CommandError(ERR_DATA)
        # LOCK{n},P{m}: P{m} = 1 if the bit was already set, else 0 and the bit is set [A L3264]
        held = bool(self.fw.locks >> n & 1)
        self.fw.locks |= 1 << n
        self.fw.p[p] = 1.0 if held else 0.0

    def movetime(self, line: Line, port: PortState, out: list[str]) -> None:
        """MOVETIME: time left in the C.S.'s present move, ms (V1.937 [A L3262]), 0 with no
        program running (program_runner.py)."""
        out.append(format_value(round(self.fw.motion.runner(port.cs).move_time_left(), 3)))

    def undefine(self, line: Line, port: PortState, out: list[str]) -> None:
        """UNDEFINE [ALL]: clears axis definitions, of the addressed C.S. only since V1.938
        [A L3284]."""
        line.skip()
        every = line.take("ALL")
        if self.fw.motion.any_running() if every else self.fw.motion.runner(port.cs).running:
            raise CommandError(1, "a coordinate system runs a program")
        self.fw.coord.undefine(None if every else port.cs)

    def setphase(self, line: Line, port: PortState, out: list[str]) -> None:
        """SETPHASE: Ixx75 into the phase position register [A L3263]; the motors here are not
        commutated (Ixx01 = 0), so the register is not used."""

    def passthrough(self, line: Line, port: PortState, out: list[str]) -> None:
        """A word accepted and ignored (PASSWORD on a card without one)."""
        line.i = len(line.s)


def _plc_numbers(line: Line) -> tuple[int, ...]:
    """`PLC n[,m...]` or `PLCC n[,m...]` after ENABLE/DISABLE/PAUSE/RESUME (PLCC n: PLCC_BASE + n)."""
    line.skip()
    if not line.take("PLC"):
        raise CommandError(ERR_DATA, "ENABLE/DISABLE PLC n or PLCC n")
    base = PLCC_BASE if line.take("C") else 0
    plcs: list[int] = []
    while True:
        line.skip()
        n = line.integer()
        if n is None or not 0 <= n <= 31:
            raise CommandError(ERR_DATA)
        plcs.append(base + n)
        line.skip()
        if not line.take(","):
            break
    return tuple(plcs)


def status_text(fw: Firmware, port: PortState, k: int) -> str:
    """`?` (motor), `??` (coordinate system) or `???` (global) status as hex words [SRM]."""
    if k == 1:
        w1, w2 = fw.motor_status(port.motor)
        return f"{w1:06X}{w2:06X}"
    if k == 2:
        return "".join(f"{w:06X}" for w in fw.cs_status(port.cs))
    return "".join(f"{w:06X}" for w in fw.global_status())


def variable_text(fw: Firmware, port: PortState, kind: str, n: int) -> str:
    """A variable as its read prints it; `I{n}={value}` with I9 bit 0 (long form)."""
    text = fw.format_variable(port, kind, n)
    return f"{kind}{n}={text}" if fw.i9 & 1 else text


def _longest_word(s: str, i: int) -> str:
    """The longest of the words the letters at `i` start with ("" for none)."""
    m = _WORD.match(s, i)
    word = m.group() if m is not None else ""
    for k in range(min(len(word), _LONGEST), 0, -1):
        if word[:k] in _WORD_NAMES:
            return word[:k]
    return ""


def _list_numbers(line: Line) -> tuple[int, list[int]]:
    """`n[,start[,count]]` after LIST PLC and LIST PROG."""
    line.skip()
    n = line.integer()
    if n is None:
        raise CommandError(ERR_DATA)
    args: list[int] = []
    while len(args) < 2:
        line.skip()
        if not line.take(","):
            break
        line.skip()
        v = line.integer()
        if v is None:
            raise CommandError(ERR_DATA)
        args.append(v)
    return n, args


def _table_kind(line: Line) -> str | None:
    """The compensation-table word after DEFINE/DELETE/LIST: COMP, BLCOMP or TCOMP (comp1d.py)."""
    for kind in ("BLCOMP", "TCOMP", "COMP"):
        if line.take(kind):
            return kind
    return None


def compile_reports(text: str) -> Plan | None:
    """The steps of a line made only of `#n`, `P`, `V`, `F`, `?`/`??`/`???` and reads of
    I/P/Q/M{n}, parsed as the general path parses them; None for any other line (it takes the
    general path, which also gives every error)."""
    if not text.isascii() or ";" in text:
        return None
    s, i, n = text.upper(), 0, len(text)
    steps: list[Step] = []
    while True:
        while i < n and s[i] in " \t":
            i += 1
        if i >= n:
            return tuple(steps)
        c = s[i]
        if c == "#":
            m = _MOTOR.match(s, i)
            if m is None or not 1 <= int(m.group(1)) <= 32:
                return None
            steps.append(functools.partial(_address_motor, int(m.group(1))))
            i = m.end()
        elif c == "?":
            j = i
            while j < n and s[j] == "?":
                j += 1
            steps.append(functools.partial(_report_status, j - i))
            i = j
        elif c in VARIABLES and i + 1 < n and (s[i + 1].isdigit() or s[i + 1] == "("):
            m = _INT.match(s, i + 1)
            if m is None or s[m.end():m.end() + 1] in (".", ","):
                return None  # an expression index, a range or a list
            j = m.end()
            while j < n and s[j] in " \t":
                j += 1
            if s.startswith("=", j) or (c == "M" and s.startswith("->", j)):
                return None  # an assignment, an M-variable definition
            steps.append(functools.partial(_report_variable, c, int(m.group())))
            i = j
        else:
            what = _longest_word(s, i)
            cmd = COMMANDS.get(what)
            if cmd is None or cmd.handler != "report":
                return None
            steps.append(functools.partial(_report_motor, *cmd.args))
            i += len(what)


def _address_motor(motor: int, fw: Firmware, port: PortState, out: list[str]) -> None:
    port.motor = motor
    port.cs_mode = False


def _report_status(k: int, fw: Firmware, port: PortState, out: list[str]) -> None:
    out.append(status_text(fw, port, k))


def _report_variable(kind: str, n: int, fw: Firmware, port: PortState, out: list[str]) -> None:
    if n >= fw.variable_count(kind):
        raise CommandError(ERR_DATA, f"{kind}{n} does not exist")
    out.append(variable_text(fw, port, kind, n))


def _report_motor(what: str, fw: Firmware, port: PortState, out: list[str]) -> None:
    out.append(fw.motor_report(what, port.motor))


def _select(line: Line, out: list[str], current: int, top: int) -> int:
    """`#n`, `&n`, `##n`: the number 1..top that follows, or, with none, the current one reported
    and kept; ERR003 outside the range."""
    n = line.integer()
    if n is None:
        out.append(str(current))
        return current
    if not 1 <= n <= top:
        raise CommandError(ERR_DATA)
    return n


def _number(text: str) -> int:
    return int(text[1:], 16) if text.startswith("$") else int(text)


def _program_label(line: Line) -> float | None:
    """The `{n}[.{label}]` after B or ABR as one number (None: none given) [SRM B, ABR]."""
    line.skip()
    if not (line.peek().isdigit() or line.peek() == "."):
        return None
    m = _PROGRAM_LABEL.match(line.s, line.i)
    assert m is not None
    line.i = m.end()
    try:
        return float(m.group())
    except ValueError:
        raise CommandError(ERR_DATA) from None


_PROGRAM_LABEL = re.compile(r"\d*\.?\d*")

