"""PLC programs 0-31: their buffers (`OPEN PLC n` ... `CLOSE`), ENABLE/DISABLE and their scans
[spec pmac.md §2.9; A L3234 (V1.936 ports), A L3235 (ERR009)].

While a port has a buffer open, its lines go into the buffer (`Plcs.enter`); other ports keep
running on-line commands. PLC 0 scans every I8+1 servo cycles (the real-time interrupt); PLC 1-31
scan once each in the same cycle after it (the background cycle: README assumption). I5 gates
them (0 none, 1 PLC 0, 2 PLC 1-31, 3 all). A scan runs from where the last one stopped to the end
of the program, or to an ENDWHILE whose loop continues: the scan ends there and the next one
re-tests the WHILE, so a PLC that loops forever never holds the card. `CMD"..."` queues an
on-line command run after the scans of the cycle, on the PLC's own addressing (`ADDRESS #n &n`),
with no reply [SRM p.424].
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from vdevd.devices.pmac import buffers
from vdevd.devices.pmac.buffers import MAX_LINES, MAX_TOTAL, Cond, Op
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.expr import ExprError
from vdevd.devices.pmac.mvars import MDefError
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.reply import Reply

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

PLC_COUNT = 32
#: compiled PLC n (PLCC n) is program PLC_COUNT + n of `Plcs.plcs`
PLCC = PLC_COUNT
PROGRAMS = 2 * PLC_COUNT
#: on-line commands PLCs may have queued (CMD"..."): a PLC meeting a full queue waits there
CMD_QUEUE = 64
#: SEND messages waiting for their port: a PLC meeting a full queue waits there
MESSAGE_QUEUE = 64
ERR_IN_USE = 7
VARIABLES = 8192


@dataclass
class Plc:
    """One PLC buffer and its run state."""

    lines: list[str] = field(default_factory=list)
    ops: list[Op] | None = None   # compiled at CLOSE; None: empty, open or badly structured
    enabled: bool = False
    pc: int = 0
    port: PortState = field(default_factory=PortState)


class Plcs:
    """The card's 32 PLC programs and 32 compiled PLCs (PLCC n at index 32 + n): a compiled PLC
    takes the same text, runs the same statements and scans at the same rate as the PLC of its
    number (PLCC 0 in the foreground with PLC 0, PLCC 1-31 in the background), after it (README
    assumption)."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.plcs = [Plc() for _ in range(PROGRAMS)]
        self.owner: PortState | None = None   # the port that has a buffer open
        self.open_n = -1
        self.queue: deque[tuple[PortState, str]] = deque()
        #: SEND/SENDS/SENDP messages (port "", "S", "P"; text) not yet taken by their port
        self.messages: deque[tuple[str, str]] = deque()
        #: the card's ports: takes a message (True) or has no room yet (False); None: no port
        #: (a firmware without a host), messages are dropped
        self.on_message: Callable[[str, str], bool] | None = None
        self.on: set[int] = set()   # enabled PLCs with a program: what scans (I5 permitting)

    # -- buffers ------------------------------------------------------------------------------
    def open(self, port: PortState, n: int, compiled: bool = False) -> None:
        """OPEN PLC n (OPEN PLCC n, `compiled`): the PLC stops (ENABLE restarts it after CLOSE);
        ERR007 if another port has a buffer open (V1.936 [A L3234])."""
        if not 0 <= n < PLC_COUNT:
            raise CommandError(ERR_DATA, "PLC number 0-31")
        n += PLCC if compiled else 0
        progs = self.fw.motion.store  # a PROG buffer counts too (programs.py)
        if (self.owner is not None and self.owner is not port) or \
                (progs.owner is not None and progs.owner is not port):
            raise CommandError(ERR_IN_USE, "another port has a buffer open")
        if self.owner is port:  # another buffer of this port: it closes first
            self.close()
        if progs.owner is port:
            progs.close()
        plc = self.plcs[n]
        plc.enabled, plc.ops, plc.pc = False, None, 0
        self.on.discard(n)
        self.owner, self.open_n = port, n

    def enter(self, port: PortState, text: str) -> Reply:
        """A line from the port that has the buffer open (buffers.enter_line)."""
        return buffers.enter_line(
            text, self.plcs[self.open_n].lines, ("PLC",), parse=buffers.parse_statement, append=self._append,
            close=self.close, execute=lambda rest: self.fw.interpreter.execute_general(port, rest))

    def _append(self, line: str) -> None:
        if not line:
            return
        plc = self.plcs[self.open_n]
        if len(plc.lines) >= MAX_LINES or sum(len(p.lines) for p in self.plcs) >= MAX_TOTAL:
            raise CommandError(buffers.ERR_NO_ROOM, "buffer full")
        plc.lines.append(line)

    def close(self) -> None:
        """CLOSE: compile the open buffer; ERR009 for an unmatched IF/WHILE (the buffer closes
        and does not run until fixed [A L3235])."""
        plc = self.plcs[self.open_n]
        self.owner, self.open_n = None, -1
        plc.ops = buffers.compile_lines(plc.lines) if plc.lines else None

    def release(self, port: PortState) -> None:
        """The port is gone (an Ethernet connection closed): a buffer it left open closes, so
        other ports can open buffers again (README assumption)."""
        if self.owner is port:
            try:
                self.close()
            except CommandError:
                pass  # badly structured: closed, does not run

    def list_lines(self, n: int, start: int = 0, count: int | None = None) -> list[str]:
        """LIST PLC n[,start[,count]]: the stored lines (PLC 0-31 only: a compiled PLC is
        machine code on the card, nothing to list)."""
        if not 0 <= n < PLC_COUNT:
            raise CommandError(ERR_DATA)
        lines = self.plcs[n].lines
        return lines[start:] if count is None else lines[start:start + count]

    # -- run control ----------------------------------------------------------------------------
    def enable(self, plcs: tuple[int, ...], on: bool) -> None:
        """ENABLE PLC n (restarts from the top) / DISABLE PLC n; an open buffer stays off."""
        for n in plcs:
            plc = self.plcs[n]
            if on and self.open_n == n:
                continue
            plc.enabled, plc.pc = on, 0
            if on and plc.ops:
                self.on.add(n)
            else:
                self.on.discard(n)

    def pause(self, plcs: tuple[int, ...], resume: bool) -> None:
        """PAUSE PLC n: the PLC stops where it is; RESUME PLC n: it goes on from there (from the
        top after a DISABLE, which leaves it there) [Turbo SRM PAUSE PLC, RESUME PLC]."""
        for n in plcs:
            plc = self.plcs[n]
            if resume and self.open_n == n:
                continue
            plc.enabled = resume
            if resume and plc.ops:
                self.on.add(n)
            else:
                self.on.discard(n)

    def disable_all(self) -> None:
        """^D: every PLC off."""
        for plc in self.plcs:
            plc.enabled = False
        self.on.clear()

    def _runnable(self, i5: int) -> list[Plc]:
        """The foreground (PLC 0, PLCC 0: I5 bit 0) then the background (PLC 1-31, PLCC 1-31:
        I5 bit 1) programs that scan."""
        order = sorted(self.on, key=lambda n: (n % PLC_COUNT != 0, n))
        return [self.plcs[n] for n in order if i5 & (1 if n % PLC_COUNT == 0 else 2)]

    @property
    def running(self) -> bool:
        """A PLC that scans, or a queued CMD: the card is not at rest (decision 0008)."""
        if self.queue or self.messages:
            return True
        if not self.on:
            return False
        i5 = int(self.fw.ivars.values[5])
        return any(i5 & (1 if n % PLC_COUNT == 0 else 2) for n in self.on)

    def tick(self, cycle: int) -> None:
        """The scans due in this servo cycle, then the queued CMD commands."""
        iv = self.fw.ivars.values
        if cycle % (int(iv[8]) + 1) == 0:
            for plc in self._runnable(int(iv[5])):
                if plc.enabled:  # an earlier scan of this cycle may have disabled it
                    self._scan(plc)
        execute = self.fw.interpreter.execute
        while self.queue:
            port, text = self.queue.popleft()
            if len(text) == 1 and ord(text) < 32:  # CMD^{c}: the control character [SRM p.424]
                self.fw.control(port, ord(text))
            else:
                execute(port, text)  # no ACK, no reply [SRM p.424]
        deliver = self.on_message
        while self.messages:
            if deliver is not None and not deliver(*self.messages[0]):
                break  # the port has no room: the message waits
            self.messages.popleft()

    def _scan(self, plc: Plc) -> None:
        fw, ops, port = self.fw, plc.ops, plc.port
        assert ops is not None
        env = fw.env(port)
        pc, n = plc.pc, len(ops)
        while pc < n:  # every jump is forward but ENDWHILE's, which ends the scan
            op = ops[pc]
            name = op[0]
            pc += 1
            if name == "set":
                try:
                    index = int(op[2].eval(env))
                    if 0 <= index < VARIABLES:
                        fw.set_variable(port, op[1], index, op[3].eval(env))
                except (CommandError, ExprError, MDefError):
                    pass  # a value the variable refuses: the statement has no effect (README)
            elif name in ("if", "while"):
                if not _true(op[1], env):
                    pc = op[2]
            elif name == "jump":
                pc = op[1]
            elif name == "endwhile":
                plc.pc = op[1]
                return
            elif name == "cmd":
                if len(self.queue) >= CMD_QUEUE:
                    plc.pc = pc - 1
                    return
                self.queue.append((port, op[1]))
            elif name == "send":
                if len(self.messages) >= MESSAGE_QUEUE:
                    plc.pc = pc - 1
                    return
                self.messages.append((op[1], op[2]))
            elif name in ("enable", "disable"):
                self.enable(op[1], name == "enable")
                if not plc.enabled:
                    plc.pc = 0
                    return
            elif name in ("pause", "resume"):
                self.pause(op[1], name == "resume")
                if not plc.enabled:  # paused itself: on from the next statement at RESUME
                    plc.pc = pc
                    return
            elif name == "address":
                if op[1]:
                    port.motor, port.cs_mode = op[1], False
                if op[2]:
                    port.cs = op[2]
        plc.pc = 0

    # -- reset ------------------------------------------------------------------------------------
    def power_on(self) -> None:
        """$$$: any open buffer closes unsaved, the queue empties, every compiled PLC starts (I5
        gates them) [SRM power-up]."""
        if self.owner is not None:
            self.plcs[self.open_n].lines.clear()
        self.owner, self.open_n = None, -1
        self.queue.clear()
        self.messages.clear()
        for plc in self.plcs:
            plc.enabled, plc.pc, plc.port = plc.ops is not None, 0, PortState()
        self.on = {n for n, plc in enumerate(self.plcs) if plc.ops}

    def clear_all(self) -> None:
        """$$$***: every buffer empty."""
        self.plcs = [Plc() for _ in range(PROGRAMS)]
        self.owner, self.open_n = None, -1
        self.queue.clear()
        self.messages.clear()
        self.on.clear()


    def image(self) -> dict[str, list[str]]:
        """What SAVE keeps: the closed buffers' lines (an open buffer as it stands)."""
        return {str(n): list(plc.lines) for n, plc in enumerate(self.plcs) if plc.lines}

    def restore(self, image: dict[str, list[str]]) -> None:
        """Power-up: the saved buffers, compiled (one that no longer compiles stays empty)."""
        self.clear_all()
        for key, lines in image.items():
            n = int(key)
            if not 0 <= n < PROGRAMS or len(lines) > MAX_LINES:
                continue
            try:
                ops = buffers.compile_lines([buffers.normalise(line) for line in lines])
            except CommandError:
                continue
            plc = self.plcs[n]
            plc.lines, plc.ops = [buffers.normalise(line) for line in lines], ops



def _true(cond: Cond, env: Any) -> bool:
    """OR of ANDs of comparisons [spec §2.9]."""
    return any(all(_term(t, env) for t in group) for group in cond)


def _term(t: tuple[Any, ...], env: Any) -> bool:
    if t[0] == "nested":
        return _true(t[1], env)
    op = t[0]
    try:
        a, b = t[1].eval(env), t[2].eval(env)
    except ExprError:
        return False
    if op == "=":
        return bool(a == b)
    if op == "!=":
        return bool(a != b)
    if op == ">":
        return bool(a > b)
    if op == "<":
        return bool(a < b)
    if op == "!>":
        return bool(a <= b)
    return bool(a >= b)  # !<
