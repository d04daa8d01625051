"""Motion-program reports of a coordinate system: `PC` (program counter), `PE` (executing line),
the rotary lines remaining (`PR`, rotary.py) and the program fields of the DPRAM background buffer [Turbo SRM
PC, PE, PR; PComm32 dprbkg.h `backcTURBO`: pr, timrem, tats, pe; README "Motion programs"].

A program location is `P{prog}:{offset}`, the offset being the line number in the buffer as
`LIST PROG {prog},{offset}` counts it (the real card counts words of compiled code; here the
buffer keeps lines, so its offsets are line numbers, ASSUMPTION)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from vdevd.devices.pmac.program_runner import CsProgram
    from vdevd.devices.pmac.programs import ProgramStore


def line_at(store: ProgramStore, prog: int, pc: int) -> int:
    """The buffer line of operation `pc` of PROG `prog` (past the end: the line count; 0 for a
    program that is not there)."""
    program = store.programs.get(prog)
    if program is None:
        return 0
    if 0 <= pc < len(program.line_of):
        return program.line_of[pc]
    return len(program.lines)


def location(prog: int, line: int) -> str:
    return f"P{prog}:{line}"


def program_counter(r: CsProgram) -> str:
    """PC: the program and offset of the line the C.S. calculates next [SRM PC]."""
    return location(r.prog, line_at(r.fw.motion.store, r.prog, r.pc))


def execution_line(r: CsProgram) -> str:
    """PE: the program and offset of the move executing now, else of the last one executed
    (after B: the line pointed to) [SRM PE]."""
    prog, pc = r.exec_at
    return location(prog, line_at(r.fw.motion.store, prog, pc))


def lines_remaining(r: CsProgram) -> int:
    """PR: the lines waiting in the C.S.'s rotary buffer (rotary.py) [SRM PR]."""
    return int(r.fw.rotary.remaining(r.cs))


def tats_time_left(r: CsProgram) -> float:
    """Program time left in the present move's acceleration (TA/TS) stretch, ms: the time up to
    the end of the first cubic piece of the move that does not accelerate (ASSUMPTION: the
    dprbkg.h `tats` word, "time remain in TA/TS", in ms as `MOVETIME`)."""
    if not r.running or r.cur is None:
        return 0.0
    if _accelerating(r.cur.piece.coef):
        left = r.cur.piece.dur - r.tau
        for q in r.queue:
            if q.starts or not _accelerating(q.piece.coef):
                break
            left += q.piece.dur
        return left * 1000
    return 0.0


def _accelerating(coef: np.ndarray) -> bool:
    """A cubic piece (rows: the position's coefficients) with a second or third order term."""
    return bool(np.any(np.abs(coef[2:]) > 1e-12))
