"""The DMC-13X8 host side of the A16 window (manual ch. 4; spec galil.md §2.2-2.5), over batches.

One `DmcBus` is one open controller: it sends command bytes to N+1 honouring the almost-full bit,
reads the reply from N+1 while bit 5 of N+3 says data, clears the FIFOs, pops interrupt codes and
reads the secondary-FIFO data record. Every exchange is one `batch` where it can be: a value
`wait` only peeks (PROTOCOL.md), so `[writes, wait data, reads, status]` sends a command and reads
its reply in one round trip. `vdevclient.galil` (the DMC library) and `vdevclient.gclib` build on it.
The register map and the data record's layout are `vdevmaps.galil`, the daemon's too.
"""

from __future__ import annotations

import enum
import logging
import struct
import time
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any, NamedTuple

from vdevmaps.galil import (
    AXIS_ITEMS,
    AXIS_SIZE,
    CLEAR_SEQUENCE,
    DEFAULT_ALMOST_FULL,
    EMPTY_READ,
    FIFO_SIZE,
    FIRST_AXIS,
    GENERAL_ITEMS,
    IRQ_ENABLE_SEQUENCE,
    IRQ_STATUS_SELECT,
    A16Reg,
    ControlStatus,
    REV4DMCDataRecordAxisOffsets,
    REV4DMCDataRecordGeneralOffsets,
    SecondaryStatus,
)

from vdevclient.core import Prepared, Rack

log = logging.getLogger(__name__)

CARD_TYPE = "galil-dmc13x8"
REGION = "a16"
WRITE_BURST = DEFAULT_ALMOST_FULL  # bytes allowed after bit 4 reads 0 [M Ch4]
TERMINATORS = b";\r"
#: the longest command (text between terminators) the command FIFO takes whole with its
#: terminator [M Ch4 Introduction: 512 characters]; the card answers a longer one `?`, TC 5
MAX_COMMAND = FIFO_SIZE - 1
REPLY_ENDS = b":?"
FIRST_READS = 32  # reply bytes read per command in the first batch of a line not seen before
MEMO_SIZE = 256  # commands whose reply length is remembered
_NS_PER_MS = 1_000_000
_ALMOST_FULL = int(ControlStatus.WRITE_ALMOST_FULL)  # plain ints: IntFlag arithmetic is slow
_READ_EMPTY = int(ControlStatus.READ_EMPTY)
#: a program's messages come with bit 7 set (the card's CW1, README "Application programs"):
#: bytes 0x80-0xFE are unsolicited, the rest are replies
_HIGH = bytes(range(0x80, 0x100))
_LOW = bytes(range(0x80))
_UNMARK = bytes(range(0x80)) * 2


class Reply(NamedTuple):
    """What an exchange brought back: the reply bytes, and whether a wait ran out first."""

    data: bytes
    timed_out: bool = False


class DmcBus:
    """One controller: the card `card` of `rack`. Use from one thread at a time (like `Rack`)."""

    def __init__(self, rack: Rack, card: str, *, timeout_ms: int = 1000) -> None:
        self.rack = rack
        self.card = card
        self.timeout_ms = timeout_ms
        self.lockstep = rack.info.get("clock", {}).get("mode") == "lockstep"
        where = {"card": card, "region": REGION}
        self._status = {"op": "read", "offset": A16Reg.CONTROL.value, "size": 1, **where}
        self._where = where
        self._wait_cache: dict[tuple[int, int, int, int], dict[str, Any]] = {}
        self._send_cache: dict[tuple[bytes, bool, int], list[dict[str, Any]]] = {}
        #: bit 4 of the last CONTROL read, when nothing was written since: the command FIFO has
        #: room for a burst and the first chunk needs no wait (only the host fills that FIFO)
        self._room = False
        #: ':' / '?' the card still owes for bytes sent without reading the reply (DMCFastCommand,
        #: a timed-out command); the next exchange moves those replies to `unsolicited`
        self.owed = 0
        #: bytes may wait in the READ FIFO that belong to no command (bit 5 read 0 at the end)
        self.stale = True
        self.unsolicited = bytearray()
        #: read the reply in the batch that sends the command, with no wait before the read
        #: (the card decodes on arrival); cleared when a card had nothing to read at all
        self.eager = True
        self._reply_len: OrderedDict[bytes, int] = OrderedDict()  # the oldest learnt goes first
        #: line -> (its whole first batch, replies, reply length) for the common state: room
        #: known, nothing stale or owed, eager. A line of one burst then needs no wait at all
        self._quick: dict[bytes, tuple[Prepared, int, int]] = {}

    # -- ops ------------------------------------------------------------------------------------
    def _wait(self, offset: int, mask: int, value: int, timeout_ns: int) -> dict[str, Any]:
        key = (offset, mask, value, timeout_ns)
        op = self._wait_cache.get(key)
        if op is None:
            op = self._wait_cache[key] = {
                "op": "wait", "on": "value", "offset": int(offset), "size": 1, "mask": int(mask),
                "value": int(value), "timeout_ns": timeout_ns, **self._where}
        return op

    def _timeout_ns(self) -> int:
        return self.timeout_ms * _NS_PER_MS

    def write_op(self, offset: int, value: int) -> dict[str, Any]:
        return {"op": "write", "offset": int(offset), "data": bytes([value]), **self._where}

    def _fifo_write(self, data: bytes) -> dict[str, Any]:
        """Bytes written one by one to N+1 (a repeated write: PROTOCOL.md `rep`)."""
        return {"op": "write", "offset": int(A16Reg.DATA), "data": data, "rep": True, **self._where}

    def _fifo_read(self, offset: int, size: int) -> dict[str, Any]:
        """`size` single reads of one FIFO port (a repeated read: PROTOCOL.md `rep`)."""
        return {"op": "read", "offset": int(offset), "size": size, "rep": True, **self._where}

    def _send_ops(self, data: bytes, timeout_ns: int, memo: bool = True) -> list[dict[str, Any]]:
        """Command bytes to N+1 in bursts, each after bit 4 of N+3 reads 0 [M Ch4 §Write Procedure];
        the first burst skips the wait when the last status read showed room."""
        key = (data, self._room, timeout_ns)
        ops = self._send_cache.get(key)
        if ops is None:
            ops = []
            room_wait = self._wait(A16Reg.CONTROL, _ALMOST_FULL, 0, timeout_ns)
            for start in range(0, len(data), WRITE_BURST):
                if start or not self._room:
                    ops.append(room_wait)
                ops.append(self._fifo_write(data[start:start + WRITE_BURST]))
            if not memo:  # a program download: sent once, not worth keeping
                self._room = False
                return ops
            if len(self._send_cache) >= MEMO_SIZE:
                self._send_cache.clear()
            self._send_cache[key] = ops
        self._room = False
        return list(ops)

    def batch(self, ops: Sequence[dict[str, Any]], wait_ns: int = 0) -> list[Any]:
        """One round trip; `wait_ns`, the sum of its waits' timeouts, extends the wall-clock
        allowance for the reply."""
        return self.rack.call({"op": "batch", "ops": ops}, wait_ns / 1e9)

    # -- commands -------------------------------------------------------------------------------
    def download(self, data: bytes, replies: int) -> Reply:
        """`command` for a program download: its bursts and reply length are not remembered."""
        reply = self.command(data, replies, memo=False)
        self._reply_len.pop(data, None)
        self._quick.pop(data, None)
        return reply

    def command(self, data: bytes, replies: int, memo: bool = True) -> Reply:
        """Send `data` and read until `replies` ':' or '?' have come [DMCLIB DMCCommand].

        One batch: [bursts of command bytes, K + 1 reads of N+1 (one repeated read; an empty
        read gives 0xFF, so the last byte tells whether the FIFO is drained)]. A card that decodes
        a command when its terminator arrives has answered by then; while replies are missing,
        further batches [wait bit 5 = 0, reads] wait for them in the daemon. A card that had
        nothing at all to read after the bursts (it decodes at its next sample) gets the wait in
        the first batch from then on. K is the reply length this line had last time, else
        FIRST_READS per command; later batches read four times what came so far."""
        if self.stale:
            self.drain()
        if self._room and self.eager and not self.owed:
            quick = self._quick.get(data)
            if quick is not None and quick[1] == replies:
                return self._quick_command(data, quick)
        timeout_ns = self._timeout_ns()
        ops = self._send_ops(data, timeout_ns, memo)
        sent = len(ops)
        waits = sum(1 for op in ops if op["op"] == "wait")
        owed, self.owed = self.owed, 0
        reads = self._reply_len.get(data, FIRST_READS * replies) + owed
        ops.append(self._fifo_read(A16Reg.DATA, reads + 1))
        if not self.eager:
            ops.insert(-1, self._wait(A16Reg.CONTROL, _READ_EMPTY, 0, timeout_ns))
            waits += 1
        res = self.batch(ops, waits * timeout_ns)
        if waits and sent and not _fired(res[:sent]):  # a burst found no room: part of the line is out
            self.owed, self.stale = owed, True
            return Reply(b"", timed_out=True)
        if not self.eager and not res[-2]["fired"]:
            return self._answer(data, owed, owed + replies, b"")
        chunk = res[-1]
        reply = self._collect(data, owed, owed + replies, self._own(chunk.split(b"\xff", 1)[0]),
                              chunk)
        if (not owed and not reply.timed_out and self._room and self.eager
                and len(data) <= WRITE_BURST):
            self._learn_quick(data, replies)
        return reply

    def command_line(self, data: bytes, replies: int) -> Reply:
        """`command` for a line the command FIFO may not hold whole: in pieces of whole commands
        (`fifo_pieces`), each sent once the replies of the one before have come, so the card
        never waits for room to reply while the host waits for room to write."""
        if len(data) <= FIFO_SIZE:
            return self.command(data, replies)
        got = b""
        for piece in fifo_pieces(data):
            reply = self.command(piece, terminators(piece), memo=False)
            got += reply.data
            if reply.timed_out:
                return Reply(got, timed_out=True)
        return Reply(got)

    def _quick_command(self, data: bytes, quick: tuple[Prepared, int, int]) -> Reply:
        """`command` in the common state with its prebuilt batch [the line's bytes, its reply
        length + 1 reads]: the same exchange as the general path, less the building."""
        message, replies, length = quick
        self._room = False
        chunk = self.rack.call(message)[-1]
        got = chunk.split(b"\xff", 1)[0]
        if not got.isascii():
            got = self._own(got)
        if len(got) == length and _count(got) >= replies:
            self._room = True  # every reply came: the card took the whole line
            self.stale = chunk[-1] != EMPTY_READ
            return Reply(got)
        reply = self._collect(data, 0, replies, got, chunk)
        if not reply.timed_out and self._room and self.eager:
            self._learn_quick(data, replies)  # the reply's new length
        return reply

    def _collect(self, data: bytes, owed: int, want: int, got: bytes, chunk: bytes) -> Reply:
        """After the first batch brought `got` (its read `chunk`): further batches [wait bit 5 = 0,
        reads] while replies are missing; then what is owed moves to `unsolicited`."""
        if not got and want:
            self.eager = False  # nothing to read at all: the card answers at its next sample
        timeout_ns = self._timeout_ns()
        data_wait = self._wait(A16Reg.CONTROL, _READ_EMPTY, 0, timeout_ns)
        while True:
            if _count(got) >= want:
                # Every reply came, so the card took every byte sent: the command FIFO is empty
                # (only this host fills it). A 0xFF read means the READ FIFO was drained too.
                self._room = True
                self.stale = chunk[-1] != EMPTY_READ
                break
            reads = min(max(FIRST_READS, 4 * len(got)), FIFO_SIZE)
            res = self.batch([data_wait, self._fifo_read(A16Reg.DATA, reads + 1)], timeout_ns)
            if not res[0]["fired"]:
                break
            chunk = res[-1]
            got += self._own(chunk.split(b"\xff", 1)[0])
        return self._answer(data, owed, want, got)

    def _own(self, got: bytes) -> bytes:
        """The reply bytes of what was read; a program's messages (bit 7 set) go, unmarked, to
        `unsolicited` [DMCLIB DMCGetUnsolicitedResponse]."""
        if got.isascii():
            return got
        self.unsolicited += got.translate(_UNMARK, _LOW)
        return got.translate(None, _HIGH)

    def _answer(self, data: bytes, owed: int, want: int, got: bytes) -> Reply:
        """The reply of a line from what came (`got`): the `owed` replies before it go to
        `unsolicited`; its length is learnt; a missing reply is owed (timed out)."""
        answered = _count(got)
        if answered < want:
            self.owed = want - answered  # the card may still answer: those replies are not ours
            self.stale = True
        own = self._split_owed(got, owed) if owed else got
        if answered >= want:
            self._remember(data, len(own))
        return Reply(own, timed_out=answered < want)

    def _learn_quick(self, data: bytes, replies: int) -> None:
        """Keep the first batch of a one-burst line for the common state; its lines are those
        whose reply length is remembered, so `_remember` bounds and refreshes it."""
        length = self._reply_len[data]
        ops = [self._fifo_write(data), self._fifo_read(A16Reg.DATA, length + 1)]
        self._quick[data] = (self.rack.prepare({"op": "batch", "ops": ops}), replies, length)

    def command_until(self, data: bytes, end: bytes) -> Reply:
        """Send `data` (all its bursts in one batch) and read until `end` then a ':' or '?' has
        come, or a '?' before any `end`: UL, whose reply is the program then ^Z then ':'
        [DMCLIB DMCUploadFile]. Reads grow as in `command`."""
        if self.stale:
            self.drain()
        timeout_ns = self._timeout_ns()
        ops = self._send_ops(data, timeout_ns)
        waits = sum(1 for op in ops if op["op"] == "wait")
        data_wait = self._wait(A16Reg.CONTROL, _READ_EMPTY, 0, timeout_ns)
        ops += [data_wait, self._fifo_read(A16Reg.DATA, FIFO_SIZE + 1)]
        res = self.batch(ops, (waits + 1) * timeout_ns)
        got = b""
        while True:
            if not res[-2]["fired"]:
                self.stale = True
                return Reply(got, timed_out=True)
            got += self._own(res[-1].split(b"\xff", 1)[0])
            cut = got.find(end)
            if (cut >= 0 and _count(got[cut:])) or (cut < 0 and got.startswith(b"?")):
                self._room = True
                self.stale = res[-1][-1] != EMPTY_READ
                return Reply(got)
            res = self.batch([data_wait, self._fifo_read(A16Reg.DATA, FIFO_SIZE + 1)], timeout_ns)

    def send(self, data: bytes, replies: int) -> None:
        """Write without reading the reply (DMCFastCommand); the card owes `replies` answers."""
        timeout_ns = self._timeout_ns()
        ops = self._send_ops(data, timeout_ns)
        waits = sum(1 for op in ops if op["op"] == "wait")
        ops.append(self._status)
        res = self.batch(ops, waits * timeout_ns)
        if not _fired(res[:-1]):
            self.stale = True
        self._room = not res[-1][0] & _ALMOST_FULL
        self.owed += replies

    def _split_owed(self, got: bytes, owed: int) -> bytes:
        """Move the first `owed` replies (up to their ':' or '?') to the unsolicited buffer."""
        cut = 0
        for _ in range(owed):
            ends = [i for i in (got.find(b":", cut), got.find(b"?", cut)) if i >= 0]
            if not ends:
                cut = len(got)
                break
            cut = min(ends) + 1
        self.unsolicited += got[:cut]
        return got[cut:]

    def _remember(self, data: bytes, length: int) -> None:
        memo = self._reply_len
        if memo.get(data) != length:
            memo[data] = max(length, 1)
            self._quick.pop(data, None)  # its read was sized for the old length
            if len(memo) > MEMO_SIZE:
                self._quick.pop(memo.popitem(last=False)[0], None)

    def drain(self) -> None:
        """Read whatever waits in the READ FIFO into the unsolicited buffer, until bit 5 reads 1."""
        while True:
            res = self.batch([self._fifo_read(A16Reg.DATA, FIRST_READS), self._status])
            got = res[0].split(b"\xff", 1)[0]
            self._take_unsolicited(got)
            status = res[-1][0]
            self._room = not status & _ALMOST_FULL
            if status & _READ_EMPTY:
                self.stale = False
                return

    def _take_unsolicited(self, got: bytes) -> None:
        """Drained bytes: late replies (which settle what is owed) and program messages."""
        self.owed = max(0, self.owed - _count(got.translate(None, _HIGH)))
        self.unsolicited += got.translate(_UNMARK)

    def forget(self) -> None:
        """After a reset: what the card holds or owes is no longer known."""
        self._room, self.stale, self.owed = False, True, 0

    # -- FIFO control and interrupts [M Ch4] ------------------------------------------------------
    def clear(self) -> None:
        """Read N+3, write 01 80 01 80, read N+3 [M Ch4 §Clearing FIFO Buffer]."""
        ops = [self._status, *(self.write_op(A16Reg.CONTROL, b) for b in CLEAR_SEQUENCE), self._status]
        status = self.batch(ops)[-1][0]
        self.owed, self.stale = 0, False
        self._room = not status & _ALMOST_FULL

    def enable_interrupts(self) -> None:
        self.batch([self.write_op(A16Reg.CONTROL, b) for b in IRQ_ENABLE_SEQUENCE])

    def interrupt_status(self) -> int:
        """Write 6 to N+3, then read N+3: the oldest queued status code, 0 when none [M Ch4]."""
        res = self.batch([self.write_op(A16Reg.CONTROL, IRQ_STATUS_SELECT), self._status])
        return int(res[-1][0])

    def wait_interrupt(self, timeout_ms: int, after_seq: int | None) -> tuple[int, int | None]:
        """Wait for an assertion of the card's line after `after_seq` (None: the next one), then
        pop its code; (code, the assertion's seq), code 0 and seq None on timeout."""
        wait: dict[str, Any] = {"op": "wait", "on": "irq", "card": self.card,
                                "timeout_ns": timeout_ms * _NS_PER_MS}
        if after_seq is not None:
            wait["after_seq"] = after_seq
        res = self.batch([wait, self.write_op(A16Reg.CONTROL, IRQ_STATUS_SELECT), self._status],
                         wait["timeout_ns"])
        if not res[0]["fired"]:
            return 0, None
        return int(res[-1][0]), int(res[0]["event"]["seq"])

    # -- secondary FIFO [M Ch4 §Polling Mode Read Procedure] --------------------------------------
    def read_record(self, size: int) -> bytes | None:
        """One data record in one batch: wait not-empty, freeze (write N+5), wait not busy, read
        `size` bytes of N+5, resume (write N+5); None when no record came within the timeout."""
        timeout_ns = self._timeout_ns()
        freeze = self.write_op(A16Reg.SECONDARY_DATA, 0)
        ops = [self._wait(A16Reg.SECONDARY_STATUS, SecondaryStatus.NOT_EMPTY, SecondaryStatus.NOT_EMPTY,
                          timeout_ns),
               freeze,
               self._wait(A16Reg.SECONDARY_STATUS, SecondaryStatus.BUSY, 0, timeout_ns),
               self._fifo_read(A16Reg.SECONDARY_DATA, size),
               freeze]
        res = self.batch(ops, 2 * timeout_ns)
        if not res[0]["fired"]:
            return None
        if not res[2]["fired"]:  # frozen, and the record never completed: resume the updates
            self.batch([freeze])
            return None
        return bytes(res[3])

    # -- time --------------------------------------------------------------------------------------
    def pause(self, ms: int) -> None:
        """Let `ms` of the card's time pass: a lockstep clock step, or a wall-clock sleep."""
        if self.lockstep:
            self.rack.sim.step(ns=ms * _NS_PER_MS)
        else:
            time.sleep(ms / 1000)


def _fired(results: Sequence[Any]) -> bool:
    """No wait among these batch results ran out (the ops after one that did give None)."""
    return all(r["fired"] for r in results if isinstance(r, dict))


def _count(data: bytes | bytearray) -> int:
    """Replies in `data`: one ':' or '?' ends each [DMCLIB DMCCommand]."""
    return data.count(b":") + data.count(b"?")


def terminators(command: bytes) -> int:
    """Commands in a line: one per ';' or CR [DMCLIB DMCCommand]."""
    return command.count(b";") + command.count(b"\r")


def fifo_pieces(line: bytes) -> list[bytes]:
    """`line` cut after terminators into pieces of at most FIFO_SIZE bytes (a command longer
    than MAX_COMMAND, which no piece holds, is `too_long`)."""
    pieces: list[bytes] = []
    start = end = 0
    for k, byte in enumerate(line):
        if byte in TERMINATORS:
            if k + 1 - start > FIFO_SIZE and end > start:
                pieces.append(line[start:end])
                start = end
            end = k + 1
    if end > start and len(line) - start > FIFO_SIZE:
        pieces.append(line[start:end])
        start = end
    return [*pieces, line[start:]] if start < len(line) else pieces


def too_long(line: bytes) -> bool:
    """A command of `line` the command FIFO cannot take whole (longer than MAX_COMMAND): no
    client sends it, the card would answer it `?` (TC 5 "Input buffer full")."""
    return len(line) > MAX_COMMAND and any(
        len(command) > MAX_COMMAND for command in line.replace(b";", b"\r").split(b"\r"))


# -- the data record, revision 4 (`QZ` -> axes,24,16,28) [DMCLIB dmcdrc.h; M Ch4 memory map] -------
#: the items of the layout (`vdevmaps.galil`) with their little-endian struct formats (spec §8 q.1)
_GENERAL_FORMATS = tuple((name, int(off), "<" + fmt) for name, off, fmt in GENERAL_ITEMS)
_AXIS_FORMATS = tuple((name, int(off), "<" + fmt) for name, off, fmt in AXIS_ITEMS)


def record_size(qz: str) -> int | None:
    """The record size from a `QZ` reply "axes,general,coordinated,per axis", else None."""
    try:
        axes, general, coordinated, per_axis = (int(x) for x in qz.split(":")[0].split(","))
    except ValueError:
        return None
    return general + coordinated + axes * per_axis


def decode_record(record: bytes, axes: int, letters: str = "ABCDEFGH") -> dict[str, int]:
    """Every item of a revision-4 record by name (gclib's style: `axis_a_motor_position`)."""
    out = {name: struct.unpack_from(fmt, record, off)[0] for name, off, fmt in _GENERAL_FORMATS}
    for k in range(axes):
        base = FIRST_AXIS + AXIS_SIZE * k
        prefix = f"axis_{letters[k].lower()}_"
        for name, off, fmt in _AXIS_FORMATS:
            out[prefix + name] = struct.unpack_from(fmt, record, base + off)[0]
    return out


# -- the names of Galil's dmcdrc.h for that layout ----------------------------------------------------
class DMCDataRecordTypes(enum.IntEnum):
    DRTypeUnknown = 0
    DRTypeCHAR = 1
    DRTypeUCHAR = 2
    DRTypeSHORT = 3
    DRTypeUSHORT = 4
    DRTypeLONG = 5
    DRTypeULONG = 6


class DMCDataRecordItemIds(enum.IntEnum):
    """Item ids of DMCGetDataRecordByItemId, the same in every record revision."""

    DRIdSampleNumber = 1
    DRIdGeneralInput0 = 2
    DRIdGeneralInput1 = 3
    DRIdGeneralInput2 = 4
    DRIdGeneralInput3 = 5
    DRIdGeneralInput4 = 6
    DRIdGeneralInput5 = 7
    DRIdGeneralInput6 = 8
    DRIdGeneralInput7 = 9
    DRIdGeneralInput8 = 10
    DRIdGeneralInput9 = 11
    DRIdGeneralOutput0 = 12
    DRIdGeneralOutput1 = 13
    DRIdGeneralOutput2 = 14
    DRIdGeneralOutput3 = 15
    DRIdGeneralOutput4 = 16
    DRIdGeneralOutput5 = 17
    DRIdGeneralOutput6 = 18
    DRIdGeneralOutput7 = 19
    DRIdGeneralOutput8 = 20
    DRIdGeneralOutput9 = 21
    DRIdErrorCode = 22
    DRIdGeneralStatus = 23
    DRIdThreadStatus = 24
    DRIdBufferSpaceContour = 25
    DRIdSegmentCountContour = 26
    DRIdSegmentCountS = 27
    DRIdCoordinatedMoveStatusS = 28
    DRIdCoordinatedMoveDistanceS = 29
    DRIdBufferSpaceS = 30
    DRIdSegmentCountT = 31
    DRIdCoordinatedMoveStatusT = 32
    DRIdCoordinatedMoveDistanceT = 33
    DRIdBufferSpaceT = 34
    DRIdAnalogInput1 = 35
    DRIdAnalogInput2 = 36
    DRIdAnalogInput3 = 37
    DRIdAnalogInput4 = 38
    DRIdAnalogInput5 = 39
    DRIdAnalogInput6 = 40
    DRIdAnalogInput7 = 41
    DRIdAnalogInput8 = 42
    DRIdAxisStatus = 43
    DRIdAxisSwitches = 44
    DRIdAxisStopCode = 45
    DRIdAxisReferencePosition = 46
    DRIdAxisMotorPosition = 47
    DRIdAxisPositionError = 48
    DRIdAxisAuxillaryPosition = 49
    DRIdAxisVelocity = 50
    DRIdAxisTorque = 51
    DRIdUserVariable = 52


class DMCDataRecordAxisIds(enum.IntEnum):
    DRIdAxis1 = 1
    DRIdAxis2 = 2
    DRIdAxis3 = 3
    DRIdAxis4 = 4
    DRIdAxis5 = 5
    DRIdAxis6 = 6
    DRIdAxis7 = 7
    DRIdAxis8 = 8


_TYPE_OF_FORMAT = {"<B": DMCDataRecordTypes.DRTypeUCHAR, "<H": DMCDataRecordTypes.DRTypeUSHORT,
                   "<h": DMCDataRecordTypes.DRTypeSHORT, "<i": DMCDataRecordTypes.DRTypeLONG}
_FORMAT_OF_TYPE: dict[int, str] = {int(t): f for f, t in _TYPE_OF_FORMAT.items()} | {
    DMCDataRecordTypes.DRTypeCHAR: "<b", DMCDataRecordTypes.DRTypeULONG: "<I"}
_GENERAL_TYPES: dict[int, int] = {off: _TYPE_OF_FORMAT[fmt] for _, off, fmt in _GENERAL_FORMATS}
_AXIS_TYPES: dict[int, int] = {off: _TYPE_OF_FORMAT[fmt] for _, off, fmt in _AXIS_FORMATS}
#: item id -> offset, for the items of the general section and of an axis block [dmcdma.c]
_GENERAL_BY_ID: dict[int, int] = {
    DMCDataRecordItemIds["DRId" + m.name.removeprefix("DRREV4GenOff")]: m.value
    for m in REV4DMCDataRecordGeneralOffsets if m.value < FIRST_AXIS}
_AXIS_BY_ID: dict[int, int] = {
    DMCDataRecordItemIds["DRId" + m.name.removeprefix("DRREV4AxisOff")]: m.value
    for m in REV4DMCDataRecordAxisOffsets if m.name.startswith("DRREV4AxisOffAxis")}


def standard_type(general: int, axis: int) -> int:
    """The type of the item at standard offsets [dmcdma.c GetDataType, revision 4]; 0 unknown."""
    if general < FIRST_AXIS:
        return _GENERAL_TYPES.get(general, 0)
    return _AXIS_TYPES.get(axis, 0)


def record_item(record: bytes, size: int, general: int, axis: int, data_type: int) -> int | None:
    """One item of a record [dmcdma.c DMCGetDataRecord, revision 4]; None if out of range."""
    if not (0 <= general < size and 0 <= axis < AXIS_SIZE):
        return None
    offset = general + (axis if general >= FIRST_AXIS else 0)
    fmt = _FORMAT_OF_TYPE.get(data_type)
    if fmt is None or offset + struct.calcsize(fmt) > len(record):
        return None
    return int(struct.unpack_from(fmt, record, offset)[0])


def item_place(item: int, axis_id: int) -> tuple[int, int, int] | None:
    """(general offset, axis offset, type) of an item id in a revision-4 record [dmcdma.c
    DMCGetDataRecordByItemId]; None for an item this revision lacks."""
    if item in _GENERAL_BY_ID:
        general = _GENERAL_BY_ID[item]
        return general, 0, _GENERAL_TYPES[general]
    analog = item - DMCDataRecordItemIds.DRIdAnalogInput1
    if 0 <= analog < 8:  # analog input n rides in axis n's block
        return (FIRST_AXIS + AXIS_SIZE * analog, REV4DMCDataRecordAxisOffsets.DRREV4AxisOffAnalogInput,
                DMCDataRecordTypes.DRTypeSHORT)
    if item in _AXIS_BY_ID and 1 <= axis_id <= 8:
        axis = _AXIS_BY_ID[item]
        return FIRST_AXIS + AXIS_SIZE * (axis_id - 1), axis, _AXIS_TYPES[axis]
    return None
