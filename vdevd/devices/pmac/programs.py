"""Fixed motion-program buffers `PROG 1`-`PROG 32767`: OPEN PROG / CLEAR / CLOSE / LIST PROG
[spec pmac.md §2.8; Turbo SRM OPEN PROGRAM, LIST PROGRAM; A L3234 (ports), L3235 (ERR009)].

Lines are checked when entered (prog_statements.py; ERR003: the line is not stored) and the
buffer is compiled at CLOSE (ERR009 for unmatched IF/WHILE: it closes but does not run, R
answers ERR016). Only the port that opened the buffer enters lines; one buffer (PLC or PROG) is
open at a time on the card: OPEN from another port answers ERR007 [SRM OPEN PROGRAM]; OPEN PROG
while a program runs anywhere answers ERR001 [SRM]. Up to 224 programs exist [UM "Buffered
Commands"]; a 225th, or lines past the buffer's room, answer ERR006.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from vdevd.devices.pmac import buffers, prog_statements
from vdevd.devices.pmac.buffers import MAX_LINES, MAX_TOTAL, Op
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.reply import Reply

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware
    from vdevd.devices.pmac.online import PortState

MAX_PROGRAM = 32767
#: regular motion-program buffers [Turbo UM "Buffered (Program) Commands": 224]
MAX_PROGRAMS = 224
ERR_RUNNING = 1
ERR_IN_USE = 7


@dataclass
class Program:
    """One PROG buffer: its lines, and at CLOSE its operations and line labels."""

    lines: list[str] = field(default_factory=list)
    ops: list[Op] | None = None
    labels: dict[int, int] = field(default_factory=dict)  # N/O label -> op index
    bad: bool = False  # CLOSE found it badly structured (ERR009)
    line_of: list[int] = field(default_factory=list)  # op index -> line number (PC, PE)


def compile_program(lines: list[str], line_of: list[int] | None = None
                    ) -> tuple[list[Op], dict[int, int]]:
    """The operations and label table of a program's lines (CommandError(9) for structure);
    `line_of` receives each operation's line number."""
    ops = buffers.compile_lines(lines, prog_statements.parse_line, line_of)
    labels = {op[1]: k for k, op in enumerate(ops) if op[0] == "label"}
    return ops, labels


class ProgramStore:
    """The card's PROG buffers."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.programs: dict[int, Program] = {}
        self.owner: PortState | None = None
        self.open_n = 0

    # -- OPEN / lines / CLOSE ------------------------------------------------------------------
    def open(self, port: PortState, n: int) -> None:
        """OPEN PROG n (1-32767): ERR007 with another buffer open elsewhere, ERR001 with a
        program running [SRM OPEN PROGRAM]."""
        if not 1 <= n <= MAX_PROGRAM:
            raise CommandError(ERR_DATA, "PROG 1-32767")
        plc = self.fw.plc
        if (self.owner is not None and self.owner is not port) or \
                (plc.owner is not None and plc.owner is not port):
            raise CommandError(ERR_IN_USE, "another port has a buffer open")
        if self.fw.motion.any_running():
            raise CommandError(ERR_RUNNING, "a motion program is running")
        if n not in self.programs and len(self.programs) >= MAX_PROGRAMS:
            raise CommandError(buffers.ERR_NO_ROOM, "no room for another program")
        if plc.owner is port:
            plc.close()
        if self.owner is port:
            self.close()
        prog = self.programs.setdefault(n, Program())
        prog.ops, prog.bad = None, False
        self.owner, self.open_n = port, n

    def enter(self, port: PortState, text: str) -> Reply:
        """A line from the port with the buffer open (buffers.enter_line)."""
        return buffers.enter_line(
            text, self.programs[self.open_n].lines, ("PROG", "PROGRAM"),
            parse=prog_statements.parse_statement, append=self._append, close=self.close,
            execute=lambda rest: self.fw.interpreter.execute_general(port, rest))

    def _append(self, line: str) -> None:
        if not line:
            return
        prog = self.programs[self.open_n]
        if len(prog.lines) >= MAX_LINES or \
                sum(len(p.lines) for p in self.programs.values()) >= MAX_TOTAL:
            raise CommandError(buffers.ERR_NO_ROOM, "buffer full")
        prog.lines.append(line)

    def close(self) -> None:
        """CLOSE: compile the open buffer; ERR009 for an unmatched IF/WHILE (it stays closed,
        and R answers ERR016 until it is fixed) [A L3235]."""
        n = self.open_n
        prog = self.programs[n]
        self.owner, self.open_n = None, 0
        prog.line_of = []
        try:
            prog.ops, prog.labels = compile_program(prog.lines, prog.line_of)
        except CommandError:
            prog.ops, prog.labels, prog.bad = None, {}, True
            raise

    def release(self, port: PortState) -> None:
        """The port is gone: a buffer it left open closes (as plc.py does)."""
        if self.owner is port:
            try:
                self.close()
            except CommandError:
                pass

    def list_lines(self, n: int, start: int = 0, count: int | None = None) -> list[str]:
        """LIST PROG n[,start[,count]]; ERR003 for a program that does not exist (ASSUMPTION)."""
        prog = self.programs.get(n)
        if prog is None:
            raise CommandError(ERR_DATA, f"no PROG {n}")
        lines = prog.lines
        return lines[start:] if count is None else lines[start:start + count]

    def runnable(self, n: int) -> Program | None:
        """The program R may run: it exists and compiled (None: not there or open)."""
        prog = self.programs.get(n)
        if prog is None or (self.owner is not None and self.open_n == n):
            return None
        return prog

    # -- reset, SAVE ---------------------------------------------------------------------------
    def power_on(self) -> None:
        """$$$: an open buffer closes (its lines as they stand)."""
        if self.owner is not None:
            self.release(self.owner)

    def clear_all(self) -> None:
        self.programs.clear()
        self.owner, self.open_n = None, 0

    def image(self) -> dict[str, list[str]]:
        return {str(n): list(p.lines) for n, p in self.programs.items() if p.lines}

    def restore(self, image: dict[str, list[str]]) -> None:
        self.clear_all()
        for key, lines in image.items():
            n = int(key)
            if not 1 <= n <= MAX_PROGRAM or len(lines) > MAX_LINES \
                    or len(self.programs) >= MAX_PROGRAMS:
                continue
            lines = [buffers.normalise(line) for line in lines]
            try:
                line_of: list[int] = []
                ops, labels = compile_program(lines, line_of)
                self.programs[n] = Program(lines, ops, labels, line_of=line_of)
            except CommandError:
                self.programs[n] = Program(lines, None, {}, True)

