"""Application program threads of the DMC-13X8: XQ, HX, flow, automatic subroutines (spec galil.md
§4.5 "Programming and flow", §5.7; [M Ch2 Ex11-14], [M Ch3 §Limit Switch Input], [M Ch6 §SPM]).

`Threads` owns the program buffer (program.py) and MAX_THREADS threads. Each sample the firmware
calls `run()`: the running threads take turns, one statement each, until the sample's budget of
statements is spent (`budget`: a sample's time over the manual's 0.35 ms per ASCII command,
[M Ch4 §Controller Response to DATA]: 2 statements at TM 1000). A thread waiting on a trippoint
(AM, MC, WT, AD, ...) costs nothing and blocks no one: the command channel is served between
samples and by the firmware whenever a command arrives. Flow statements (JP JS EN RE RI IF ELSE
ENDIF XQ HX ZS IN II TR) run here; every other statement runs through the command interpreter,
whose data reply (TP X, V1=, MG) goes to the host as an unsolicited message.

Automatic subroutines run in thread 0 while it executes ("keep thread zero alive for #POSERR to
run in" [M Ch6 §SPM]): #LIMSWI when a limit switch becomes active, #POSERR when an axis's error
exceeds ER, #ININT on an input chosen with II, #MCTIME when MC waits longer than TW, #CMDERR when a
statement of thread 0 is refused. #AUTO starts thread 0 at power-up and RS.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING

from vdevd.devices.galil import syntax
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.interpreter import Trippoint
from vdevd.devices.galil.program import Program

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware

MAX_THREADS = 8  # XQ #label,0..7 (spec §1.5, Optima class)
MAX_STACK = 16  # TC 12 "Subroutine more than 16 deep" (spec §1.5)
COMMAND_NS = 350_000  # "approximately 0.35 ms" to decode an ASCII command [M Ch4]
#: a thread's unsolicited output waits while this much is waiting for the host (the response
#: FIFO's size, [M Ch4 Introduction]): a program cannot fill the daemon's memory
OUTPUT_LIMIT = 512
AUTO, LIMSWI, POSERR, ININT, MCTIME, CMDERR = "AUTO", "LIMSWI", "POSERR", "ININT", "MCTIME", "CMDERR"
#: statements the host may not give from a program: TC 3 "Command not valid in program"
_HOST_ONLY = frozenset({"DL", "UL", "LS", "ED", "BP", "BN", "BV", "\x12\x13", "RS", "QD"})

_split = lru_cache(maxsize=1024)(syntax.split_statement)
def _is_if(text: str) -> bool:
    """Whether a statement is an IF (`IFLAG=1` is an assignment, not one)."""
    try:
        return _split(text).name == "IF"
    except GalilError:
        return False


_BARE_NUMBER = re.compile(rb" *-?(\d+\.?\d*|\.\d+) *")


@dataclass
class Frame:
    """A return address: after JS, or where an automatic subroutine interrupted the thread (with
    the trippoint it was waiting on, which RE1 / RI1 restore)."""

    line: int
    stmt: int
    interrupt: str | None = None
    trip: Trippoint | None = None


@dataclass
class Thread:
    """One thread: the statement it runs next, its subroutine stack, its trippoint."""

    number: int
    line: int
    stmt: int = 0
    stack: list[Frame] = field(default_factory=list)
    trip: Trippoint | None = None
    #: IN: the variable the host must set before the thread goes on
    awaiting: str | None = None


class Threads:
    """The program buffer and the threads of one card's firmware."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.program = Program()
        self.threads: list[Thread | None] = [None] * MAX_THREADS
        self.trace = False
        self.ii_inputs = 0  # II: the inputs whose falling edge runs #ININT
        self._ii_armed = 0  # what II chose, armed again by RI
        #: TW per axis in ms (MC timeout, #MCTIME); None: no timeout
        self.tw_ms: list[float | None] = [None] * fw.n
        self.flow: dict[str, Callable[[Thread, str], None]] = {
            "#": lambda t, a: None, "JP": self._jp, "JS": self._js, "EN": self._en,
            "RE": self._re, "RI": self._ri, "IF": self._if, "EL": self._else, "XQ": self._xq,
            "HX": self._hx, "ZS": self._zs, "IN": self._in, "II": self._ii, "TR": self._tr,
        }

    # -- state ---------------------------------------------------------------------------------------
    @property
    def active(self) -> bool:
        """Whether a thread runs (the card is then not at rest, decision 0008)."""
        return any(t is not None for t in self.threads)

    def budget(self) -> int:
        """Statements per sample: the sample time over 0.35 ms per command, at least 1."""
        return max(1, self.fw.period_ns // COMMAND_NS)

    def operand(self, name: str) -> float:
        """`_XQn`: the line thread n runs, -1 when it is halted; `_ED`: the line of the last
        download or program error; `_LK`: 1 while `^L^K` locks the program."""
        if name.startswith("XQ"):
            n = int(name[2:]) if name[2:].isdigit() else 0
            if not 0 <= n < MAX_THREADS:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, name)
            t = self.threads[n]
            return float(t.line) if t is not None else -1.0
        if name == "ED":
            return float(self.program.error_line)
        if name == "LK":
            return float(self.program.locked)
        raise GalilError(TC.BAD_FUNCTION, name)

    def reset(self) -> None:
        """RS / power-on: threads halted, II and TR off, TW cleared (the program stays)."""
        self.threads = [None] * MAX_THREADS
        self.trace = False
        self.ii_inputs = self._ii_armed = 0
        self.tw_ms = [None] * self.fw.n

    def start_auto(self) -> None:
        """Power-up / RS: thread 0 runs #AUTO when the program has it."""
        if AUTO in self.program.labels:
            self.start(self.program.labels[AUTO], 0)

    # -- XQ, HX [spec §4.5] ----------------------------------------------------------------------------
    def start(self, line: int, n: int) -> None:
        self.threads[n] = Thread(n, line)

    def execute_label(self, arg: str, caller: Thread | None) -> None:
        """XQ #label,n / XQ (line 0, thread 0); a running thread n is TC 19 unless it is the
        caller (which then restarts at the label)."""
        text = arg.strip()
        label, _, rest = text.partition(",")
        label = label.strip()
        n = int(self.fw.interp.value(rest)) if rest.strip() else 0
        if not 0 <= n < MAX_THREADS:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"thread {n}")
        if not self.program.lines:
            raise GalilError(TC.EMPTY_PROGRAM_LINE, "no program")
        if label:
            if not label.startswith("#"):
                raise GalilError(TC.INVALID_LABEL, label)
            line = self.program.line_of(label[1:])
        else:
            line = 0
        running = self.threads[n]
        if running is not None and running is not caller:
            raise GalilError(TC.APPLICATION_STRAND_RUNNING, f"thread {n}")
        self.start(line, n)

    def halt(self, arg: str) -> None:
        """HX n halts thread n; HX every thread."""
        if not arg.strip():
            self.threads = [None] * MAX_THREADS
            return
        n = self.fw.interp.value(arg)
        if n != int(n) or not 0 <= n < MAX_THREADS:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"thread {n}")
        self.threads[int(n)] = None

    def halt_all(self) -> None:
        self.threads = [None] * MAX_THREADS

    # -- the sample --------------------------------------------------------------------------------
    def run(self) -> None:
        """The sample's statements, the running threads taking turns."""
        budget = self.budget()
        while budget > 0:
            progressed = False
            for n in range(MAX_THREADS):
                t = self.threads[n]
                if t is None or not self._ready(t):
                    continue
                self._step(t)
                progressed = True
                budget -= 1
                if budget <= 0:
                    return
            if not progressed:
                return

    def _ready(self, t: Thread) -> bool:
        if t.trip is not None:
            if not t.trip.ready():
                return False
            t.trip = None
        if t.awaiting is not None:
            if t.awaiting not in self.fw.variables:
                return False
            t.awaiting = None
        return len(self.fw.pending_output) < OUTPUT_LIMIT

    def _step(self, t: Thread) -> None:
        """Run the thread's next statement; past the last line the thread ends."""
        code = self.program.code
        while t.line < len(code) and t.stmt >= len(code[t.line]):
            t.line, t.stmt = t.line + 1, 0  # an empty line
        if t.line >= len(code):
            self._ended(t)
            return
        text = code[t.line][t.stmt]
        if self.trace and t.stmt == 0:
            self.fw.output(f"{t.line:03d} {self.program.lines[t.line]}\r\n".encode("latin-1"))
        line, stmt = t.line, t.stmt
        t.stmt += 1
        try:
            self._statement(t, text)
        except GalilError as exc:
            self.fw.error_code = exc.code
            self.program.error_line = line
            self._refused(t, line, stmt)

    def _statement(self, t: Thread, text: str) -> None:
        stmt = _split(text)
        flow = self.flow.get(stmt.name)
        if flow is not None:
            flow(t, stmt.arg)
            return
        if stmt.name in _HOST_ONLY:
            raise GalilError(TC.NOT_VALID_IN_PROGRAM, stmt.name)
        interp = self.fw.interp
        interp.thread = t.number
        try:
            result = interp.execute(text)
        finally:
            interp.thread = None
        if isinstance(result, Trippoint):
            t.trip = result
        elif not isinstance(result, bytes):
            raise GalilError(TC.NOT_VALID_IN_PROGRAM, text)  # a data phase (QD) is the host's
        elif result == b"?":
            raise GalilError(self.fw.error_code, text)
        elif len(result) > 1:
            self.fw.output(result[:-1])  # the data, without the ':' a command line gets

    def _refused(self, t: Thread, line: int, stmt: int) -> None:
        """A refused statement ends its thread; in thread 0, #CMDERR runs instead when present."""
        if t.number == 0 and CMDERR in self.program.labels and not self._inside(t, CMDERR):
            self._interrupt(t, CMDERR)
            return
        self._ended(t)

    def _ended(self, t: Thread) -> None:
        """The thread stopped by itself (EN, the last line, an error): interrupt DB when EI
        enables it [M Ch4 §Servicing Interrupts]."""
        self.threads[t.number] = None
        self.fw.program_stopped()

    # -- flow --------------------------------------------------------------------------------------
    def _target(self, arg: str) -> tuple[int, bool]:
        """`#label[,condition]` -> (the label's line, whether the condition holds)."""
        text = arg.strip()
        if not text.startswith("#"):
            raise GalilError(TC.INVALID_LABEL, text)
        label, _, cond = text[1:].partition(",")
        line = self.program.line_of(label.strip())
        return line, (not cond.strip()) or self.fw.interp.value(cond) != 0

    def _jp(self, t: Thread, arg: str) -> None:
        """JP #label[,cond]: jump when the condition holds [M Ch2 Ex12]."""
        line, go = self._target(arg)
        if go:
            t.line, t.stmt = line, 0

    def _js(self, t: Thread, arg: str) -> None:
        """JS #label[,cond]: call a subroutine, 16 deep at most (TC 12) [M Ch6 §Multiple Moves]."""
        line, go = self._target(arg)
        if not go:
            return
        if len(t.stack) >= MAX_STACK:
            raise GalilError(TC.SUBROUTINE_TOO_DEEP)
        t.stack.append(Frame(t.line, t.stmt))
        t.line, t.stmt = line, 0

    def _en(self, t: Thread, arg: str) -> None:
        """EN: return from a subroutine, or end the thread; ENDIF (read as EN + "DIF") closes an IF."""
        if arg.strip() == "DIF":
            return
        if t.stack:
            frame = t.stack.pop()
            t.line, t.stmt = frame.line, frame.stmt
            return
        self._ended(t)

    def _return(self, t: Thread, arg: str, kinds: tuple[str, ...]) -> None:
        """RE / RI n: back to where an automatic subroutine interrupted the thread; n = 1 restores
        the trippoint it was waiting on [1400-CR 113]. TC 8 outside such a routine."""
        n = self.fw.interp.value(arg) if arg.strip() else 0
        if n not in (0, 1):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        while t.stack and t.stack[-1].interrupt is None:
            t.stack.pop()  # JS frames inside the routine
        if not t.stack or t.stack[-1].interrupt not in kinds:
            raise GalilError(TC.NOT_VALID_WHEN_NOT_RUNNING, "no automatic subroutine to return from")
        frame = t.stack.pop()
        t.line, t.stmt = frame.line, frame.stmt
        if n == 1:
            t.trip = frame.trip

    def _re(self, t: Thread, arg: str) -> None:
        self._return(t, arg, (LIMSWI, POSERR, MCTIME, CMDERR))

    def _ri(self, t: Thread, arg: str) -> None:
        """RI n: return from #ININT; the input interrupt is armed again [1400-CR 113]."""
        self._return(t, arg, (ININT,))
        self.ii_inputs = self._ii_armed

    def _if(self, t: Thread, arg: str) -> None:
        """IF cond: go on when it holds, else after the matching ELSE or ENDIF (TC 63 without)."""
        if self.fw.interp.value(arg) == 0:
            self._skip(t, stop_at_else=True)

    def _else(self, t: Thread, arg: str) -> None:
        """ELSE (read as EL + "SE") reached from the true branch: on after the matching ENDIF."""
        if arg.strip() != "SE":
            raise GalilError(TC.UNRECOGNIZED_COMMAND, "EL" + arg)
        self._skip(t, stop_at_else=False)

    def _skip(self, t: Thread, stop_at_else: bool) -> None:
        code = self.program.code
        depth, line, stmt = 0, t.line, t.stmt
        while line < len(code):
            while stmt < len(code[line]):
                word = code[line][stmt].replace(" ", "")
                stmt += 1
                if _is_if(word):
                    depth += 1
                elif word == "ENDIF":
                    if depth == 0:
                        t.line, t.stmt = line, stmt
                        return
                    depth -= 1
                elif word == "ELSE" and depth == 0 and stop_at_else:
                    t.line, t.stmt = line, stmt
                    return
            line, stmt = line + 1, 0
        raise GalilError(TC.IF_WITHOUT_ENDIF)

    def _xq(self, t: Thread, arg: str) -> None:
        self.execute_label(arg, t)

    def _hx(self, t: Thread, arg: str) -> None:
        self.halt(arg)

    def _zs(self, t: Thread, arg: str) -> None:
        """ZS n: keep the first n levels of the subroutine stack (ZS, ZS0: none) [1400-CR 113]."""
        n = self.fw.interp.value(arg) if arg.strip() else 0
        if n != int(n) or not 0 <= n <= MAX_STACK:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        del t.stack[int(n):]

    def _in(self, t: Thread, arg: str) -> None:
        """IN "prompt",V: the prompt goes to the host, which answers with a bare number line
        (`5`, no reply) or by setting V (`V=5`); the thread waits until it does."""
        if t.number != 0:
            raise GalilError(TC.IN_ONLY_IN_THREAD_0)
        prompt, comma, name = arg.rpartition(",")
        name = name.strip()
        if not comma:
            raise GalilError(65)
        if not name or not name[0].isalpha() or not name.isalnum():
            raise GalilError(TC.IN_WITHOUT_VARIABLE, name)
        text = prompt.strip()
        if text.startswith('"') and text.endswith('"') and len(text) >= 2:
            self.fw.output(text[1:-1].encode("latin-1") + b"\r\n")
        self.fw.variables.pop(name, None)
        t.awaiting = name

    def answer(self, line: bytes) -> bool:
        """A host line that is a bare number answers the IN thread 0 waits on [DMCLIB
        DMCCommand: "numeric IN replies"]; whether it did."""
        t = self.threads[0]
        if t is None or t.awaiting is None or not _BARE_NUMBER.fullmatch(line):
            return False
        self.fw.variables[t.awaiting] = float(line)
        return True

    def _ii(self, t: Thread, arg: str) -> None:
        """II m[,n]: inputs m..n (1-8) run #ININT on a high-to-low transition; II 0 disables."""
        self.input_interrupts(arg)

    def input_interrupts(self, arg: str) -> None:
        fields = [f.strip() for f in arg.split(",")] if arg.strip() else ["0"]
        first = self.fw.interp.value(fields[0]) if fields[0] else 0
        last = self.fw.interp.value(fields[1]) if len(fields) > 1 and fields[1] else first
        if first == 0:
            self.ii_inputs = self._ii_armed = 0
            return
        if not (first == int(first) and last == int(last) and 1 <= first <= last <= 8):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        mask = sum(1 << (k - 1) for k in range(int(first), int(last) + 1))
        self.ii_inputs = self._ii_armed = mask

    def _tr(self, t: Thread, arg: str) -> None:
        self.set_trace(arg)

    def set_trace(self, arg: str) -> None:
        """TR1: every line a thread starts goes to the host with its number; TR0 off."""
        v = self.fw.interp.value(arg) if arg.strip() else 0
        if v not in (0, 1):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.trace = bool(v)

    # -- automatic subroutines -----------------------------------------------------------------------
    def _inside(self, t: Thread, label: str) -> bool:
        return any(f.interrupt == label for f in t.stack)

    def _interrupt(self, t: Thread, label: str) -> None:
        if len(t.stack) >= MAX_STACK:
            self._ended(t)
            return
        t.stack.append(Frame(t.line, t.stmt, label, t.trip))
        t.trip, t.awaiting = None, None
        t.line, t.stmt = self.program.labels[label], 0

    def automatic(self, label: str) -> bool:
        """Run the automatic subroutine `label` in thread 0 when it executes and the program has
        the label (not again while it runs); whether it started."""
        t = self.threads[0]
        if t is None or label not in self.program.labels or self._inside(t, label):
            return False
        self._interrupt(t, label)
        return True

    def input_fell(self, input: int) -> None:
        """A high-to-low transition of IN`input`: #ININT when II chose it; II is then off
        until RI [1400-CR 113]."""
        if self.ii_inputs & (1 << (input - 1)) and self.automatic(ININT):
            self.ii_inputs = 0

    def mc_timeout(self, axes: list[int]) -> float | None:
        """The shortest TW of `axes` in ms (None: MC waits for ever)."""
        times = [self.tw_ms[a] for a in axes if self.tw_ms[a] is not None]
        return min(t for t in times if t is not None) if times else None
