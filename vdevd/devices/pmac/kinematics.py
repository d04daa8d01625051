"""Forward and inverse kinematic programs of the coordinate systems [Turbo SRM "OPEN FORWARD",
"OPEN INVERSE", "LIST FORWARD", "LIST INVERSE", Isx50; Turbo UM "Kinematic Calculations"].

Each C.S. has one forward and one inverse buffer (`&n OPEN FORWARD` / `OPEN INVERSE`, then
CLEAR, lines, CLOSE), entered through the port that opened it. A line is any math or logic
statement a PLC takes except ADDRESS, DISPLAY, CMD and SEND [UM "Creating the Inverse-Kinematic
Program"]: the same statements (buffers.py), checked as they come (ERR003), structure at CLOSE
(ERR009). No other buffer may be open when one opens (ERR007) [SRM OPEN FORWARD].

Running them (with Isx50 = 1, at R, S, PMATCH and every move segment: the runner calls them):
- forward: each motor xx of the C.S. has its commanded position (counts) in Pxx; after the
  program Q1-Q9 of the C.S. are the A B C U V W X Y Z axis positions [SRM OPEN FORWARD].
- inverse: Q1-Q9 hold the axis target positions (engineering units), Q10 = 0 (no velocities);
  after the program Pxx (counts) is the position of each motor xx defined `#xx->I` [UM].
A program runs to its end within the calculation; more than `MAX_STEPS` statements (a loop that
does not end) is a run-time error (ASSUMPTION: the card would overrun its segment time).
SAVE keeps both buffers (ASSUMPTION, as for PLC and motion programs); `$$$***` clears them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac import buffers
from vdevd.devices.pmac.buffers import MAX_LINE, MAX_LINES, Op
from vdevd.devices.pmac.coord import CS_COUNT
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.expr import ExprError
from vdevd.devices.pmac.mvars import MDefError
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.planerr import RUN_TIME_ERROR, PlanError
from vdevd.devices.pmac.plc import _true
from vdevd.devices.pmac.reply import Reply

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

KINDS = ("FORWARD", "INVERSE")
ERR_IN_USE = 7
#: statements one run of a kinematic program may execute
MAX_STEPS = 100_000
#: Q-variables of the axis positions: Q1 A ... Q9 Z [UM table]; Q10 the velocity flag
Q_AXES = np.arange(1, 10)
Q_VELOCITY_FLAG = 10


@dataclass
class KinBuffer:
    lines: list[str] = field(default_factory=list)
    ops: list[Op] | None = None


class Kinematics:
    """The 16 forward and 16 inverse kinematic buffers."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.buffers = {(cs, kind): KinBuffer() for cs in range(1, CS_COUNT + 1) for kind in KINDS}
        self.owner: PortState | None = None
        self.open_key: tuple[int, str] | None = None

    # -- buffers ------------------------------------------------------------------------------
    def open(self, port: PortState, kind: str) -> None:
        """`&n OPEN FORWARD|INVERSE` on this port; ERR007 if another port has a buffer open."""
        if self.owner is not None and self.owner is not port:
            raise CommandError(ERR_IN_USE, "another port has a buffer open")
        if self.owner is port:
            self.close()
        self.owner, self.open_key = port, (port.cs, kind)
        self.buffers[self.open_key].ops = None

    def enter(self, port: PortState, text: str) -> Reply:
        """A line of the port that has the buffer open: CLOSE, OPEN, CLEAR and LIST act;
        statements are appended (ERR003: the line is not kept)."""
        reply = Reply()
        s = buffers.normalise(text)
        assert self.open_key is not None
        buf = self.buffers[self.open_key]
        try:
            if len(s) > MAX_LINE:
                raise CommandError(ERR_DATA, "line too long")
            i = buffers.skip(s, 0)
            if s.startswith("CLEAR", i):
                buf.lines.clear()
                i = buffers.skip(s, i + 5)
            if s.startswith(("CLOSE", "OPEN"), i):   # OPEN: this buffer closes first
                self.close()
                if s.startswith("CLOSE", i):
                    i += 5
                return self.fw.interpreter.execute_general(port, s[i:])
            if s.startswith("LIST", i):
                reply.lines.extend(buf.lines)
                return reply
            if i < len(s):
                for st in buffers.parse_line(s[i:]):
                    if st.op is not None and st.op[0] in ("cmd", "address"):
                        raise CommandError(ERR_DATA, "not allowed in a kinematic program")
                if len(buf.lines) >= MAX_LINES:
                    raise CommandError(buffers.ERR_NO_ROOM, "buffer full")
                buf.lines.append(s[i:])
        except CommandError as exc:
            reply.error = exc.code
        return reply

    def close(self) -> None:
        """CLOSE: compile (ERR009 for a bad structure: the buffer closes and does not run)."""
        assert self.open_key is not None
        buf = self.buffers[self.open_key]
        self.owner, self.open_key = None, None
        buf.ops = buffers.compile_lines(buf.lines) if buf.lines else None

    def release(self, port: PortState) -> None:
        if self.owner is port:
            try:
                self.close()
            except CommandError:
                pass

    def list_lines(self, cs: int, kind: str) -> list[str]:
        return list(self.buffers[(cs, kind)].lines)

    def has(self, cs: int, kind: str) -> bool:
        return self.buffers[(cs, kind)].ops is not None

    # -- running ------------------------------------------------------------------------------
    def run(self, cs: int, kind: str) -> None:
        """Run the C.S.'s program once to its end; PlanError(run-time) if it does not end."""
        ops = self.buffers[(cs, kind)].ops
        if not ops:
            return
        fw = self.fw
        port = PortState(cs=cs)
        env = fw.env(port)
        pc, n, steps = 0, len(ops), 0
        while pc < n:
            steps += 1
            if steps > MAX_STEPS:
                raise PlanError(RUN_TIME_ERROR, f"{kind.lower()} kinematics did not end")
            op = ops[pc]
            name = op[0]
            pc += 1
            if name == "set":
                try:
                    fw.set_variable(port, op[1], int(op[2].eval(env)), op[3].eval(env))
                except (CommandError, ExprError, MDefError, IndexError):
                    pass   # a value the variable refuses: no effect (as in a PLC)
            elif name in ("if", "while"):
                if not _true(op[1], env):
                    pc = op[2]
            elif name == "jump" or name == "endwhile":
                pc = op[1]
            elif name in ("enable", "disable"):
                fw.plc.enable(op[1], name == "enable")

    def forward(self, cs: int, commanded: np.ndarray) -> np.ndarray:
        """The axis positions (A..Z) of C.S. cs from its motors' commanded positions (counts,
        index = motor − 1): Pxx in, Q1-Q9 out [SRM OPEN FORWARD]."""
        fw = self.fw
        for m in fw.coord.members(cs):
            if m - 1 < len(commanded):
                fw.p[m] = commanded[m - 1]
        self.run(cs, "FORWARD")
        return fw.q[cs - 1, Q_AXES].astype(float)

    def inverse_motors(self, cs: int) -> list[int]:
        """The motors (1-based) of C.S. cs defined `#n->I`."""
        defs = self.fw.coord.defs
        return [m for m in self.fw.coord.members(cs)
                if (d := defs[m - 1]) is not None and d.inverse]

    def inverse(self, cs: int, axes: np.ndarray) -> np.ndarray:
        """Motor positions (counts) of the C.S.'s `#n->I` motors, in `inverse_motors` order, for
        axis positions `axes` (A..Z): Q1-Q9 in (Q10 = 0), Pxx out [UM]."""
        fw = self.fw
        fw.q[cs - 1, Q_AXES] = axes
        fw.q[cs - 1, Q_VELOCITY_FLAG] = 0.0
        self.run(cs, "INVERSE")
        return np.array([fw.p[m] for m in self.inverse_motors(cs)], dtype=float)

    def inverse_many(self, cs: int, axes: np.ndarray) -> np.ndarray:
        """`inverse` at each row of `axes` (n, 9): shape (n, motors)."""
        return np.array([self.inverse(cs, row) for row in axes]).reshape(len(axes), -1)

    # -- reset, SAVE --------------------------------------------------------------------------
    def power_on(self) -> None:
        if self.open_key is not None:
            self.buffers[self.open_key].lines.clear()
        self.owner, self.open_key = None, None

    def clear_all(self) -> None:
        self.buffers = {key: KinBuffer() for key in self.buffers}
        self.owner, self.open_key = None, None

    def image(self) -> dict[str, list[str]]:
        return {f"{cs},{kind}": list(b.lines) for (cs, kind), b in self.buffers.items() if b.lines}

    def restore(self, image: dict[str, list[str]]) -> None:
        self.clear_all()
        for key, lines in image.items():
            cs_text, _, kind = key.partition(",")
            cs = int(cs_text)
            if kind not in KINDS or not 1 <= cs <= CS_COUNT or len(lines) > MAX_LINES:
                continue
            norm = [buffers.normalise(line) for line in lines]
            try:
                ops = buffers.compile_lines(norm)
            except CommandError:
                continue
            self.buffers[(cs, kind)] = KinBuffer(norm, ops)

