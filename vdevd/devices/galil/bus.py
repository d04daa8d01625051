"""The DMC-13X8's 16-byte A16 short-I/O window, without I/O (manual ch. 4, spec galil.md §2-3).

The register map (offsets, status bits, CONTROL sequences) is `vdevmaps.galil`, shared with the
client. The host side is `read`/`write`/`peek` of one byte at an offset 0..15 from the base N; the firmware
side fills and drains the FIFOs, queues interrupt codes and loads the data record. Nothing here
knows about time: the card calls it from its region hooks and its ticks.
"""

from __future__ import annotations

import enum
from collections import deque
from collections.abc import Callable

from vdevmaps.galil import (
    DEFAULT_ALMOST_FULL,
    EMPTY_READ,
    FIFO_SIZE,
    INTERRUPT_QUEUE_DEPTH,
    WINDOW_SIZE,
    A16Reg,
    ControlStatus,
    ControlWrite,
    SecondaryStatus,
)

# plain ints for the status reads: IntFlag arithmetic costs microseconds on every poll
_READ_EMPTY, _ALMOST_FULL = int(ControlStatus.READ_EMPTY), int(ControlStatus.WRITE_ALMOST_FULL)
_CLEARED = int(ControlStatus.CLEARED)
_FREEZE, _NOT_EMPTY = int(SecondaryStatus.FREEZE), int(SecondaryStatus.NOT_EMPTY)


class _Seq(enum.Enum):
    IDLE = enum.auto()
    LEVEL = enum.auto()  # 0x05 written: the next byte is m - 16
    CLEAR_1 = enum.auto()  # 01
    CLEAR_2 = enum.auto()  # 01 80
    CLEAR_3 = enum.auto()  # 01 80 01
    IRQ_ARMED = enum.auto()  # 02
    IRQ_SELECTED = enum.auto()  # 06: the next CONTROL read is the interrupt status


class _Act(enum.Enum):
    SET_LEVEL = enum.auto()
    CLEAR = enum.auto()
    ENABLE_IRQ = enum.auto()


#: CONTROL writes: state -> byte -> (next state, action). A byte the current state does not list is
#: taken as if written in IDLE (so it may start a new sequence); one IDLE does not list is ignored.
#: Reads of N+3 leave the state alone except in IRQ_SELECTED.
_CONTROL_SEQUENCES: dict[_Seq, dict[int, tuple[_Seq, _Act | None]]] = {
    _Seq.IDLE: {
        ControlWrite.ALMOST_FULL: (_Seq.LEVEL, None),
        ControlWrite.CLEAR_01: (_Seq.CLEAR_1, None),
        ControlWrite.IRQ_ENABLE_2: (_Seq.IRQ_ARMED, None),
        ControlWrite.IRQ_STATUS: (_Seq.IRQ_SELECTED, None),
    },
    # every byte is the argument; only m in 16..256 in multiples of 16 is taken
    _Seq.LEVEL: {v: (_Seq.IDLE, _Act.SET_LEVEL if v % 16 == 0 and v <= 240 else None) for v in range(256)},
    _Seq.CLEAR_1: {ControlWrite.CLEAR_80: (_Seq.CLEAR_2, None)},
    _Seq.CLEAR_2: {ControlWrite.CLEAR_01: (_Seq.CLEAR_3, None)},
    _Seq.CLEAR_3: {ControlWrite.CLEAR_80: (_Seq.IDLE, _Act.CLEAR)},
    _Seq.IRQ_ARMED: {ControlWrite.IRQ_ENABLE_4: (_Seq.IDLE, _Act.ENABLE_IRQ)},
    _Seq.IRQ_SELECTED: {},
}


class _Freeze(enum.Enum):
    SET = enum.auto()
    CLEAR = enum.auto()
    TOGGLE = enum.auto()


#: freeze_mode -> what a write to N+5 / N+7 does to the freeze bit. The manual conflicts (spec §2.5):
#: the numbered procedure writes N+5 to freeze and again to resume, the table says N+5 sets and N+7
#: clears, the prose says N+7 sets and N+5 clears. "toggle_n5" runs the procedure and the table.
_FREEZE_WRITES: dict[str, dict[int, _Freeze]] = {
    "toggle_n5": {A16Reg.SECONDARY_DATA: _Freeze.TOGGLE, A16Reg.SECONDARY_STATUS: _Freeze.CLEAR},
    "table": {A16Reg.SECONDARY_DATA: _Freeze.SET, A16Reg.SECONDARY_STATUS: _Freeze.CLEAR},
    "prose": {A16Reg.SECONDARY_DATA: _Freeze.CLEAR, A16Reg.SECONDARY_STATUS: _Freeze.SET},
}
FREEZE_MODES = tuple(_FREEZE_WRITES)


class A16Window:
    """Sans-I/O model of the DMC-13X8 16-byte A16 window, D08(O) (manual ch. 4).

    Offsets other than 1, 3, 5, 7 read 0xFF and ignore writes. CONTROL bit 7 (CLEARED) reads 1 from
    the clear sequence until the next byte enters either FIFO (a host write to N+1 or a `respond`).
    The clear empties both FIFOs and keeps the almost-full level and the interrupt queue.
    """

    def __init__(self, *, fifo_size: int = FIFO_SIZE, freeze_mode: str = "toggle_n5") -> None:
        if fifo_size <= 0:
            raise ValueError(f"fifo_size must be positive, not {fifo_size}")
        if freeze_mode not in _FREEZE_WRITES:
            raise ValueError(f"freeze_mode must be one of {', '.join(FREEZE_MODES)}, not {freeze_mode!r}")
        self.fifo_size = fifo_size
        self.freeze_mode = freeze_mode
        self._freeze_writes = _FREEZE_WRITES[freeze_mode]
        self.on_assert: Callable[[int], None] | None = None
        #: called at each clear sequence: the firmware drops a reply in progress and a held command
        self.on_clear: Callable[[], None] | None = None
        self._command = bytearray()
        self._response = bytearray()
        self._record = bytearray()
        self._interrupts: deque[int] = deque()
        self.reset()

    def reset(self) -> None:
        """Power-on state: FIFOs empty, level 16, interrupts disabled and none queued, not frozen."""
        self._command.clear()
        self._response.clear()
        self._record.clear()
        self._interrupts.clear()
        self._level = DEFAULT_ALMOST_FULL
        self._seq = _Seq.IDLE
        self._cleared = False
        self._frozen = False
        self.interrupts_enabled = False

    # -- host side ------------------------------------------------------------------------------
    def read(self, offset: int) -> int:
        """One host byte read with the register's side effects."""
        _check_offset(offset)
        if offset == A16Reg.DATA:
            if not self._response:
                return EMPTY_READ
            b = self._response[0]
            del self._response[0]
            return b
        if offset == A16Reg.CONTROL:
            if self._seq is _Seq.IRQ_SELECTED:
                self._seq = _Seq.IDLE
                return self._pop_interrupt()
            return self._status()
        if offset == A16Reg.SECONDARY_DATA:
            if not self._record:
                return EMPTY_READ
            b = self._record[0]
            del self._record[0]
            return b
        if offset == A16Reg.SECONDARY_STATUS:
            return self._secondary_status()
        return EMPTY_READ

    def write(self, offset: int, value: int) -> None:
        """One host byte write (0..255); a byte written to a full command FIFO is lost."""
        _check_offset(offset)
        if offset == A16Reg.DATA:
            if len(self._command) < self.fifo_size:
                self._command.append(value)
                self._cleared = False
        elif offset == A16Reg.CONTROL:
            self._control(value)
        elif offset in self._freeze_writes:
            action = self._freeze_writes[offset]
            self._frozen = action is _Freeze.SET or (action is _Freeze.TOGGLE and not self._frozen)

    def read_data(self, n: int) -> bytes:
        """`n` host reads of N+1 at once: the next n response bytes, 0xFF for each past the end."""
        got = bytes(self._response[:n])
        del self._response[:n]
        return got + bytes((EMPTY_READ,)) * (n - len(got))

    def write_data(self, data: bytes) -> None:
        """Host writes of N+1, one per byte; the bytes that do not fit are lost."""
        room = self.fifo_size - len(self._command)
        if data[:room]:
            self._command += data[:room]
            self._cleared = False

    def peek(self, offset: int) -> int:
        """The byte `read` would give, with no side effects; N+3 is always the status byte."""
        _check_offset(offset)
        if offset == A16Reg.DATA:
            return self._response[0] if self._response else EMPTY_READ
        if offset == A16Reg.CONTROL:
            return self._status()
        if offset == A16Reg.SECONDARY_DATA:
            return self._record[0] if self._record else EMPTY_READ
        if offset == A16Reg.SECONDARY_STATUS:
            return self._secondary_status()
        return EMPTY_READ

    # -- firmware side: communication FIFOs -----------------------------------------------------
    def command_bytes(self) -> bytes:
        """A copy of the unconsumed host->card command FIFO."""
        return bytes(self._command)

    @property
    def commands_waiting(self) -> bool:
        """Whether the command FIFO holds bytes (without copying them)."""
        return bool(self._command)

    def consume(self, n: int) -> None:
        """The interpreter took `n` bytes from the front of the command FIFO."""
        if not 0 <= n <= len(self._command):
            raise ValueError(f"cannot consume {n} of {len(self._command)} command bytes")
        del self._command[:n]

    def response_space(self) -> int:
        return self.fifo_size - len(self._response)

    def respond(self, data: bytes | bytearray) -> int:
        """Append to the card->host FIFO as much of `data` as fits; returns the count taken."""
        taken = data[: self.response_space()]
        if taken:
            self._response += taken
            self._cleared = False
        return len(taken)

    # -- firmware side: interrupts [M Ch4 §Interrupts, §Servicing Interrupts] ---------------------
    def post_interrupt(self, code: int) -> None:
        """Queue a status code (1..255); when the 8-deep queue is full the new code is dropped."""
        if not 0 < code <= 0xFF:
            raise ValueError(f"interrupt status code {code} outside 1..255")
        if len(self._interrupts) >= INTERRUPT_QUEUE_DEPTH:
            return
        self._interrupts.append(code)
        if self.interrupts_enabled and self.on_assert is not None:
            self.on_assert(code)

    def clear_interrupts(self) -> None:
        """EI0 clears the interrupt queue (and so drops the line)."""
        self._interrupts.clear()

    @property
    def line_asserted(self) -> bool:
        """The VME interrupt line: enabled by the host and a code queued (released on read, RORA)."""
        return self.interrupts_enabled and bool(self._interrupts)

    @property
    def pending_interrupts(self) -> tuple[int, ...]:
        return tuple(self._interrupts)

    # -- firmware side: secondary FIFO [M Ch4 §Polling FIFO] -------------------------------------
    def load_record(self, record: bytes) -> bool:
        """The periodic data-record update: unless frozen, replace the secondary FIFO with `record`.

        The record is loaded whole within one tick, so BUSY never reads 1 ("if the data is not read,
        the FIFO is updated with new data"). Returns whether it was loaded.
        """
        if self._frozen:
            return False
        self._record[:] = record
        return True

    @property
    def frozen(self) -> bool:
        return self._frozen

    @property
    def record_pending(self) -> bytes:
        """The bytes of the record not yet read by the host."""
        return bytes(self._record)

    @property
    def almost_full_level(self) -> int:
        return self._level

    # -- internals ------------------------------------------------------------------------------
    def _status(self) -> int:
        status = 0 if self._response else _READ_EMPTY
        if self.fifo_size - len(self._command) < self._level:
            status |= _ALMOST_FULL
        if self._cleared:
            status |= _CLEARED
        return status

    def _secondary_status(self) -> int:
        status = _FREEZE if self._frozen else 0  # BUSY: records are loaded atomically
        if self._record:
            status |= _NOT_EMPTY
        return status

    def _control(self, value: int) -> None:
        step = _CONTROL_SEQUENCES[self._seq].get(value) or _CONTROL_SEQUENCES[_Seq.IDLE].get(value)
        self._seq, action = step if step is not None else (_Seq.IDLE, None)
        if action is _Act.SET_LEVEL:
            self._level = value + 16
        elif action is _Act.CLEAR:
            self._command.clear()
            self._response.clear()
            self._cleared = True
            if self.on_clear is not None:
                self.on_clear()
        elif action is _Act.ENABLE_IRQ and not self.interrupts_enabled:
            self.interrupts_enabled = True
            if self._interrupts and self.on_assert is not None:
                self.on_assert(self._interrupts[0])

    def _pop_interrupt(self) -> int:
        return self._interrupts.popleft() if self._interrupts else 0x00


def _check_offset(offset: int) -> None:
    if not 0 <= offset < WINDOW_SIZE:
        raise ValueError(f"offset {offset} outside the {WINDOW_SIZE}-byte A16 window")
