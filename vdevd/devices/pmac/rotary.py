"""Rotary motion-program buffers, one per coordinate system [Turbo SRM "DEFINE ROT", "DELETE ROT",
"OPEN ROT", "PR", I16, I17; Turbo UM "Rotary Motion Program Buffers"].

`&n DEFINE ROT {words}` reserves the buffer; it is refused (ERR007) while a data-gathering buffer
exists or out of order: define them from high to low C.S. (the UM's example `&3`, `&2`, `&1`; its
sentence "no rotary program buffer for a higher-numbered coordinate system" contradicts the
example, which is followed), delete them from low to high [UM "Required Buffer State for Defining";
A L3187] (ERR007, ASSUMPTION on the code, as the comp tables' order). `OPEN ROT` opens every
defined rotary buffer on this port; each line goes into the buffer of the C.S. addressed then (`&1
X10 Y10 F5 &2 X30`), `CLOSE` ends. Lines may be sent while the buffer runs (`B0` points a C.S. at
it, `R` runs it): the runner takes them one at a time and each line taken is gone from the buffer.
While the buffers are open, `B0` is a B-axis move; bare run-control commands (`R`, `S`, `A`, `H`,
`Q`, `K`, `PR`, `?`, `??`, `%`), `&n` and what follows a `#n` (motor commands, which are on-line
only: `#1P`, `#2J+`) act on-line [SRM OPEN ROT example "&1R &2R"; UM "Talking to Turbo PMAC":
on-line-only commands].

Room: each value in a line takes one word [UM "Defining a Rotary Buffer"]; a line that does not fit
answers ERR006 and is not stored. The host is told when to wait: once I17 (default 10) or more
lines wait ahead of the executing one the C.S.'s "rotary buffer full" status bit is 1, and it goes
back to 0 when execution has caught up to within I16 lines (default 5, ASSUMPTION) [SRM I17]. `PR`
reports the lines waiting in the addressed C.S.'s rotary buffer. Rotary buffers are not kept by
SAVE and are gone after `$$$` [UM: "not retained through a power-down or board reset"].
"""

from __future__ import annotations

import re
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from vdevd.devices.pmac import buffers, prog_statements
from vdevd.devices.pmac.buffers import MAX_LINE
from vdevd.devices.pmac.coord import CS_COUNT
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.reply import Reply

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

ERR_RUNNING = 1
ERR_NO_ROOM = 6
ERR_IN_USE = 7
#: the largest rotary buffer, words (ASSUMPTION: the Turbo's open memory is not in the sources)
MAX_WORDS = 65_536
I16, I17 = 16, 17

_ADDRESS = re.compile(r"&[ ]*(\d+)")
#: commands that act on-line while the rotary buffers are open (a bare letter before `&` or the
#: end of the line, or a report)
_ONLINE = re.compile(r"(\?\?\??|\?|PR(?![A-Z\d(])|%[ ]*[\d.]*|[RSAHQK](?=[ ]*(?:&|$)))")
_VALUE = re.compile(r"[A-Z][ ]*(?:[-+]?[ ]*[\d.$]|\()")


@dataclass
class RotaryBuffer:
    size: int
    lines: deque[tuple[str, int]] = field(default_factory=deque)
    words: int = 0
    full: bool = False
    taken: int = 0


class RotaryBuffers:
    """The rotary buffers of the 16 coordinate systems and their port."""

    def __init__(self, fw: Firmware, running: Callable[[int], bool] = lambda cs: False) -> None:
        self.fw = fw
        self.running = running   # the runner answers whether C.S. cs runs its rotary buffer
        self.bufs: dict[int, RotaryBuffer] = {}
        self.owner: PortState | None = None

    # -- DEFINE / DELETE ----------------------------------------------------------------------
    def define(self, cs: int, size: int | None) -> None:
        if size is None or not 1 <= size <= MAX_WORDS:
            raise CommandError(ERR_DATA, "DEFINE ROT needs a size")
        if cs in self.bufs or any(c < cs for c in self.bufs):
            raise CommandError(ERR_IN_USE, "define rotary buffers from high to low C.S.")
        if self.fw.gather.defined:
            raise CommandError(ERR_IN_USE, "a gather buffer exists: DELETE GATHER first")
        if "LOOKAHEAD" in self.fw.existing_buffers():  # the order ROTARY, LOOKAHEAD (README)
            raise CommandError(ERR_IN_USE, "a lookahead buffer exists: DELETE LOOKAHEAD first")
        self.bufs[cs] = RotaryBuffer(size)

    def delete(self, cs: int) -> None:
        if cs not in self.bufs:
            return
        if any(c < cs for c in self.bufs):
            raise CommandError(ERR_IN_USE, "delete rotary buffers from low to high C.S.")
        if self.running(cs):
            raise CommandError(ERR_RUNNING, "the C.S. runs its rotary buffer")
        if self.owner is not None:
            raise CommandError(ERR_IN_USE, "the rotary buffers are open")
        del self.bufs[cs]

    def exists(self, cs: int) -> bool:
        return cs in self.bufs

    @property
    def defined(self) -> bool:
        return bool(self.bufs)

    # -- entry --------------------------------------------------------------------------------
    def open(self, port: PortState) -> None:
        if self.owner is not None and self.owner is not port:
            raise CommandError(ERR_IN_USE, "another port has a buffer open")
        if not self.bufs:
            raise CommandError(ERR_DATA, "no rotary buffer defined")
        self.owner = port

    def close(self) -> None:
        self.owner = None

    def release(self, port: PortState) -> None:
        if self.owner is port:
            self.owner = None

    def enter(self, port: PortState, text: str) -> Reply:
        """A line while the rotary buffers are open on this port (module docstring)."""
        reply = Reply()
        s = buffers.normalise(text)
        i, n = buffers.skip(s, 0), len(s)
        execute = self.fw.interpreter.execute_general
        try:
            if n > MAX_LINE:
                raise CommandError(ERR_DATA, "line too long")
            while i < n:
                if m := _ADDRESS.match(s, i):
                    cs = int(m.group(1))
                    if not 1 <= cs <= CS_COUNT:
                        raise CommandError(ERR_DATA)
                    port.cs, port.cs_mode = cs, True
                    i = m.end()
                elif s.startswith(("CLOSE", "OPEN"), i):
                    if s.startswith("CLOSE", i):
                        self.close()
                        i += 5
                    rest = execute(port, s[i:])
                    reply.lines.extend(rest.lines)
                    reply.error = rest.error
                    return reply
                elif s.startswith("CLEAR", i):
                    self._buffer(port).lines.clear()
                    self._buffer(port).words = 0
                    i += 5
                elif s.startswith("#", i):   # motor commands are on-line only (`#1P`, `#2J+`)
                    j = s.find("&", i)
                    j = n if j < 0 else j
                    rest = execute(port, s[i:j])
                    reply.lines.extend(rest.lines)
                    if rest.error is not None:
                        raise CommandError(rest.error)
                    i = j
                elif m := _ONLINE.match(s, i):
                    rest = execute(port, m.group(1))
                    reply.lines.extend(rest.lines)
                    if rest.error is not None:
                        raise CommandError(rest.error)
                    i = m.end()
                else:
                    j = s.find("&", i)
                    j = n if j < 0 else j
                    self.append(port.cs, s[i:j].strip())
                    i = j
                i = buffers.skip(s, i)
        except CommandError as exc:
            reply.error = exc.code
        return reply

    def _buffer(self, port: PortState) -> RotaryBuffer:
        buf = self.bufs.get(port.cs)
        if buf is None:
            raise CommandError(ERR_DATA, f"C.S. {port.cs} has no rotary buffer")
        return buf

    def append(self, cs: int, line: str) -> None:
        """One program line into C.S. cs's buffer: ERR006 when it does not fit."""
        buf = self.bufs.get(cs)
        if buf is None:
            raise CommandError(ERR_DATA, f"C.S. {cs} has no rotary buffer")
        prog_statements.parse_line(line)   # a statement the card does not know: ERR003
        words = max(1, len(_VALUE.findall(line)))
        if buf.words + words > buf.size:
            raise CommandError(ERR_NO_ROOM, "rotary buffer full")
        buf.lines.append((line, words))
        buf.words += words
        if len(buf.lines) >= int(self.fw.ivars.values[I17]):
            buf.full = True

    # -- the runner's side --------------------------------------------------------------------
    def take(self, cs: int) -> str | None:
        """The next line of C.S. cs's buffer for execution (None: nothing waits)."""
        buf = self.bufs.get(cs)
        if buf is None or not buf.lines:
            return None
        line, words = buf.lines.popleft()
        buf.words -= words
        buf.taken += 1
        if buf.full and len(buf.lines) <= int(self.fw.ivars.values[I16]):
            buf.full = False
        return line

    def remaining(self, cs: int) -> int:
        """PR: the lines waiting ahead of the executing one."""
        buf = self.bufs.get(cs)
        return len(buf.lines) if buf is not None else 0

    def full(self, cs: int) -> bool:
        buf = self.bufs.get(cs)
        return buf is not None and buf.full

    # -- reset --------------------------------------------------------------------------------
    def power_on(self) -> None:
        """$$$ and $$$***: no rotary buffer survives a reset."""
        self.bufs.clear()
        self.owner = None
