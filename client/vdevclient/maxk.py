"""The OMS MAXk host library for the virtual `oms-maxk` PCI card: the thin-client API that spec
oms.md §6.1 proposes (the omsMAXkmc.dll function list is not public), implemented over the shared
window exactly as the EPICS MAXv drivers talk to the card: the command ring and its insert index,
the response ring, the message semaphore and OMISR, the doorbell register ODBR::

    from vdevclient import maxk

    with maxk.open(1) as card:                    # the card whose J5 board number is 1
        card.send_and_get_string("WY")            # 'MAXk-4000, Ver: ...'
        card.send_string("AX MR1000 GO ID")
        card.wait_done(0b1, timeout_ms=5000)      # X done (ODBR bit 0)
        card.send_and_get_string("AX RP")         # '1000'

`open` looks for the card on the daemon at $VDEVD_ENDPOINT (else tcp://127.0.0.1:5555, as
`vdevclient.connect`). Every call is one `batch` where it can be (PROTOCOL.md): a command and its
reply cost one round trip when the card answers as the command arrives (it parses on the write of
the insert index), two when the reply comes later. The reply is released (0x0FC := 0x0F8, OMISR
bit 0 cleared, semaphore 0) at the start of the next call's batch, which keeps the release off
the round trip (`defer_release=False` releases at once, in a second round trip).

On the daemon's machine the words the card publishes every cycle are read, and the command ring
is written, through the daemon's shared memory (`vdevclient.Region`, decision 0010): the status
poll (`read_limits`, `read_home`, `read_gpio`, `read_fw_status`, `get_positions()`) costs no
round trip at all.
"""

from __future__ import annotations

import logging
import re
import struct
from collections import deque
from dataclasses import dataclass
from typing import Any

from vdevmaps.oms import (
    AXES,
    CAPTURE_SIZE,
    CARD_TYPE,
    MAX_MESSAGE,
    MU,
    RING_SIZE,
    SHM,
    AxisFlags,
    DirectCommand,
    FirmwareState,
    MaxkDoorbell,
    Mu,
    Omisr,
    Shm,
)

from vdevclient._maxk_bus import (
    COMMAND_ERROR,
    EVENT_BITS,
    FIRMWARE_PHASE,
    INDICES,
    INDICES_SIZE,
    ODBR_ALL,
    RUNNING,
    WK_ALL,
    WK_NOTIFICATION,
    CaptureEntry,
    MessageTooLong,
    be32,
    capture_entries,
    frame,
    le32,
    ring_pieces,
    ring_slice,
    strip_reply,
)
from vdevclient.core import Rack, connect
from vdevclient.errors import VdevClientError

__all__ = [
    "AXES",
    "AxisFlags",
    "CaptureEntry",
    "CommandError",
    "DirectCommand",
    "FirmwareState",
    "Maxk",
    "MaxkDoorbell",
    "MaxkError",
    "MaxkTimeout",
    "MessageTooLong",
    "Positions",
    "StatusFlags",
    "open",
]

log = logging.getLogger(__name__)

#: "Host waits <= 0.1 s for the notification" [E-drvMAXv recv_mess], spec §2.5
DEFAULT_TIMEOUT_MS = 100
#: drivers poll the initializing bit for up to 3 s before refusing the card [A-MAXv]
STARTUP_TIMEOUT_MS = 3000
UNSOLICITED_KEPT = 64
_NS_PER_MS = 1_000_000
#: a batch op: a map, or a compact access [kind, card, region, offset, size|data] (PROTOCOL.md)
Op = dict[str, Any] | list[Any]
_POSITIONS = struct.Struct(">16i")  # X..S motor, then X..S encoder
_WK_POSITIONS = struct.Struct(">4i")  # W, K motor, then W, K encoder
_INDICES = struct.Struct(">4I")  # command insert, process; response insert, process
_RING = Shm.RESPONSE_RING - INDICES  # where the response ring starts in a read from the indices
_OM0I, _ODI = int(Omisr.OM0I), int(Omisr.ODI)
_COMMAND_RING = int(Shm.COMMAND_RING)


class MaxkError(VdevClientError):
    """A MAXk library failure: no such board, a card that is not running."""


class CommandError(MaxkError):
    """The card refused a command: ODBR bit 24 (command error) came instead of a reply."""

    def __init__(self, command: bytes) -> None:
        super().__init__(f"command error: {command.decode('latin-1')!r}")
        self.command = command


class MaxkTimeout(MaxkError, TimeoutError):
    """The card did not answer (reply, done flag, mailbox) within the time-out of card time."""


@dataclass(frozen=True)
class StatusFlags:
    """The event flags of ODBR and of the W/K words; axis masks have bit i = axis AXES[i]."""

    done: int = 0
    overtravel: int = 0
    slip: int = 0
    cmd_error: bool = False

    @classmethod
    def from_words(cls, odbr: int, w: int, k: int) -> StatusFlags:
        def axes(shift: int) -> int:
            return ((odbr >> shift) & 0xFF) | ((w >> shift) & 1) << 8 | ((k >> shift) & 1) << 9

        return cls(axes(0), axes(8), axes(16), bool(odbr & COMMAND_ERROR))

    def only(self, mask: int) -> StatusFlags:
        """These flags for the axes of `mask`, without the command error."""
        return StatusFlags(self.done & mask, self.overtravel & mask, self.slip & mask)


@dataclass(frozen=True)
class Positions:
    """Motor (commanded) and encoder positions in counts, one per axis of the card, in AXES order."""

    motor: tuple[int, ...]
    encoder: tuple[int, ...]


def open(board: int, *, endpoint: str | None = None, name: str | None = None,
         timeout_ms: int = DEFAULT_TIMEOUT_MS, defer_release: bool = True) -> Maxk:
    """Open board `board` (the J5 number, 1-8): the oms-maxk card whose `board` is `board`, or the
    board-th oms-maxk card in the order `hello` lists them when the cards do not tell their board.
    `name` opens a card by name instead. `timeout_ms` is the reply time-out (card time)."""
    rack = connect(endpoint)
    try:
        card = _find_card(rack, board, name)
        return Maxk(rack, card, timeout_ms=timeout_ms, owns_rack=True, defer_release=defer_release)
    except BaseException:
        rack.close()
        raise


def _find_card(rack: Rack, board: int, name: str | None) -> str:
    cards = [c for c in rack.info["cards"] if c["type"] == CARD_TYPE]
    if name is not None:
        found = [c for c in cards if c["name"] == name]
    elif any("board" in c for c in cards):
        found = [c for c in cards if c.get("board") == board]
    else:
        found = cards[board - 1:board] if board >= 1 else []
    if not found:
        what = f"named {name!r}" if name is not None else f"with board {board}"
        listed = ", ".join(c["name"] for c in cards) or "none"
        raise MaxkError(f"no {CARD_TYPE} card {what} at {rack.endpoint} ({CARD_TYPE} cards: {listed})")
    return str(found[0]["name"])


class Maxk:
    """One open board: card `card` of `rack`. Use from one thread at a time (like `Rack`)."""

    def __init__(self, rack: Rack, card: str, *, timeout_ms: int = DEFAULT_TIMEOUT_MS,
                 owns_rack: bool = False, defer_release: bool = True) -> None:
        self.rack = rack
        self.card = card
        self.timeout_ms = timeout_ms
        self.defer_release = defer_release
        self._owns_rack = owns_rack
        self._shm: dict[str, Any] = {"card": card, "region": SHM}
        self._mu: dict[str, Any] = {"card": card, "region": MU}
        #: the shared memory as a Region: its passive words go through the mapping when mapped
        self._memory = rack.card(card).region(SHM)
        #: reads and writes go as compact accesses when the daemon takes them (PROTOCOL.md)
        self._compact = bool(getattr(rack, "compact", False))
        self._indices = self._read(INDICES, INDICES_SIZE)
        #: the four indices and both rings in one read (one op instead of two)
        self._window = self._read(INDICES, _RING + RING_SIZE)
        self._odbr = self._read(Mu.ODBR, 4, mu=True)
        # the constant ops of every command, made once
        self._release_om0i = self._mu_word(Mu.OMISR, _OM0I)
        self._release_semaphore = self._word(Shm.MESSAGE_SEMAPHORE, 0)
        info: dict[str, Any] = next((c for c in rack.info["cards"] if c["name"] == card), {})
        self._axes: int | None = info.get("axes")
        #: ops the next batch runs first: the release of the last reply, W1C of a seen error
        self._pending: list[Op] = []
        self._put = 0  # command ring insert index (the host's)
        self._proc = 0  # command ring process index, as last read
        self._fc = 0  # response ring process index, once the pending ops have run
        self._sticky = 0  # ODBR bits cleared here that get_status_flags still has to report
        self._synced = False
        self._omimr: int | None = None  # OMIMR as found, when this client masked OM0I
        #: the latest replies that belonged to no call (a query sent with send_string, a second
        #: reply of one string), oldest first
        self.unsolicited: deque[str] = deque(maxlen=UNSOLICITED_KEPT)
        self._sync(STARTUP_TIMEOUT_MS)

    # -- ops ----------------------------------------------------------------------------------------
    def _read(self, offset: int, size: int, *, mu: bool = False) -> Op:
        if self._compact:
            return ["r", self.card, MU if mu else SHM, int(offset), size]
        return {"op": "read", "offset": int(offset), "size": size, **(self._mu if mu else self._shm)}

    def _write(self, offset: int, data: bytes, *, mu: bool = False) -> Op:
        if self._compact:
            return ["w", self.card, MU if mu else SHM, int(offset), data]
        return {"op": "write", "offset": int(offset), "data": data, **(self._mu if mu else self._shm)}

    def _word(self, offset: int, value: int) -> Op:
        """A 32-bit write to shared memory (big-endian)."""
        return self._write(offset, value.to_bytes(4, "big"))

    def _mu_word(self, offset: int, value: int) -> Op:
        """A 32-bit write to a message-unit register (little-endian)."""
        return self._write(offset, value.to_bytes(4, "little"), mu=True)

    def _wait(self, offset: int, mask: int, value: int, timeout_ns: int, *, equal: bool = True,
              mu: bool = False) -> dict[str, Any]:
        return {"op": "wait", "on": "value", "offset": int(offset), "size": 4, "mask": mask,
                "value": value, "cmp": "eq" if equal else "ne", "timeout_ns": timeout_ns,
                **(self._mu if mu else self._shm)}

    def _timeout_ns(self, timeout_ms: int | None) -> int:
        return (self.timeout_ms if timeout_ms is None else timeout_ms) * _NS_PER_MS

    def _begin(self) -> list[Op]:
        """The ops every batch starts with (what the last call left to do); resynchronises first
        after a failed exchange."""
        if not self._synced:
            self._sync(self.timeout_ms)
        ops, self._pending = self._pending, []
        return ops

    def _batch(self, ops: list[Op], wait_ns: int = 0) -> list[Any]:
        """One round trip; `wait_ns`, the sum of the waits' time-outs, extends the wall-clock
        allowance for the reply."""
        try:
            return self.rack.call({"op": "batch", "ops": ops}, wait_ns / 1e9)
        except VdevClientError:
            self._synced = False  # what ran is unknown: read the indices again next time
            raise

    def _sync(self, timeout_ms: int) -> None:
        """Wait until the firmware runs (Table 3-4), learn the ring indices and flush a reply
        left in the response ring (the housekeeping of E-drvMAXv send_mess)."""
        ops, self._pending = self._pending, []
        first = len(ops)
        timeout_ns = timeout_ms * _NS_PER_MS
        ops += [self._wait(Shm.FIRMWARE_STATE, FIRMWARE_PHASE, RUNNING, timeout_ns),
                self._indices, self._odbr, self._read(Mu.OMIMR, 4, mu=True)]
        self._synced = True
        res = self._batch(ops, timeout_ns)
        if not res[first]["fired"]:
            state = self.read_fw_status()
            raise MaxkError(f"{self.card}: the firmware is not running (state {state:#010x})")
        self._put, self._proc, ins, self._fc = _INDICES.unpack_from(res[-3])
        if ins != self._fc:
            log.debug("%s: flushing a reply left in the response ring", self.card)
            self._release(ins)
        self._seen_error(le32(res[-2]), reported=False)
        omimr = le32(res[-1])
        if not omimr & _OM0I:
            # Replies are polled, not interrupt-driven (spec §3.3, as E-drvMAXv enables only the
            # done and command-error interrupts): with OM0I masked a reply does not toggle INTA.
            if self._omimr is None:
                self._omimr = omimr
            self._pending.append(self._mu_word(Mu.OMIMR, omimr | _OM0I))

    def _release(self, ins: int) -> None:
        """Release the reply that ends at `ins` [E-drvMAXv readbuf]: 0x0FC := 0x0F8, OMISR OM0I
        cleared (W1C), semaphore 0. The card then posts its next reply, if it has one."""
        self._pending += [self._word(Shm.RESPONSE_PROCESS, ins), self._release_om0i,
                          self._release_semaphore]
        self._fc = ins

    def _seen_error(self, odbr: int, *, reported: bool) -> None:
        """ODBR bit 24 was read: clear it first thing next time, so that a later one is a later
        command's; `get_status_flags` reports it unless a CommandError did."""
        if odbr & COMMAND_ERROR:
            self._pending.append(self._mu_word(Mu.ODBR, COMMAND_ERROR))
            if not reported:
                self._sticky |= COMMAND_ERROR

    def _send_ops(self, ops: list[Op], data: bytes, timeout_ns: int) -> int:
        """Append the §2.4 procedure to `ops`: the bytes at 0x100 + put (mod 1024), then the new
        put to 0x0F0 ("Message Sent"), after a wait for the card to consume the ring when `data`
        would overfill it; the number of waits among them (0 or 1, the first)."""
        put, size = self._put, len(data)
        waits = 0
        if (put - self._proc) % RING_SIZE + size > MAX_MESSAGE:
            ops.append(self._wait(Shm.COMMAND_PROCESS, 0xFFFF_FFFF, put, timeout_ns))
            waits = 1
        memory = self._memory
        for offset, start, length in ring_pieces(put, size):
            at, piece = _COMMAND_RING + offset, data[start:start + length]
            # past the card's insert index: the bytes go through shared memory at once, unless
            # they must wait for room in the ring; the index write that hands them over is an op
            if not waits and memory.is_mapped(at, length):
                memory.write(at, piece)
            else:
                ops.append(self._write(at, piece))
        self._put = put = (put + size) % RING_SIZE
        ops.append(self._word(Shm.COMMAND_INSERT, put))
        return waits

    def _check_sent(self, results: list[Any], at: int) -> None:
        """A room wait (`results[at]`) that ran out means nothing of the command was written."""
        if not results[at]["fired"]:
            self._synced = False
            raise MaxkTimeout(f"{self.card}: the card did not empty the command ring")

    def _note_indices(self, indices: bytes) -> int:
        """Take the card's command indices from a 16-byte read; the response insert index."""
        self._put, self._proc, ins, _ = _INDICES.unpack_from(indices)
        return int(ins)

    # -- text commands ------------------------------------------------------------------------------
    def send_string(self, command: str | bytes) -> None:
        """Send a command string (`;` appended if missing) without waiting for a reply; a reply
        it causes is flushed by the next call, its text kept in `unsolicited`. CommandError if
        the card flagged a command error."""
        data = frame(command)
        ops = self._begin()
        first = len(ops)
        waits = self._send_ops(ops, data, self._timeout_ns(None))
        ops += (self._window, self._odbr)
        res = self._batch(ops, waits * self._timeout_ns(None))
        if waits:
            self._check_sent(res, first)
        window = res[-2]
        ins = self._note_indices(window)
        if ins != self._fc:  # the housekeeping flush of E-drvMAXv send_mess, one call early
            self._unsolicited(ring_slice(memoryview(window)[_RING:], self._fc, ins))
            self._release(ins)
        odbr = le32(res[-1])
        self._seen_error(odbr, reported=True)
        if odbr & COMMAND_ERROR:
            raise CommandError(data)

    def send_and_get_string(self, command: str | bytes, timeout_ms: int | None = None) -> str:
        """Send a command string and return its reply without the LF. CommandError when the card
        flags a command error instead of replying, MaxkTimeout when no reply comes in time.

        One batch: [the last reply's release, the indices, the command bytes and the insert index
        (the card parses them on that write), the indices and both rings in one read, ODBR]. A
        reply the card posts later (it parses at its next cycle) costs a second batch that waits
        in the daemon for it, or for a command error."""
        data = frame(command)
        timeout_ns = self._timeout_ns(timeout_ms)
        ops = self._begin()
        first = len(ops)
        ops.append(self._indices)
        waits = self._send_ops(ops, data, timeout_ns)
        ops += (self._window, self._odbr)
        res = self._batch(ops, waits * timeout_ns)
        if waits:
            self._check_sent(res, first + 1)
        start = self._fc
        window, odbr = res[-2], le32(res[-1])
        before = be32(res[first], 8)
        if before != start:  # the release let out a reply nobody asked for: ours is behind it
            self._unsolicited(ring_slice(memoryview(window)[_RING:], start, before))
            self._release(before)
            start = before
        ins = self._note_indices(window)
        if ins == start:
            window, odbr = self._await_reply(data, start, odbr, timeout_ns)
            ins = self._note_indices(window)
        self._seen_error(odbr, reported=False)  # a command of the string failed, another replied
        reply = ring_slice(memoryview(window)[_RING:], start, ins)
        self._release(ins)
        if not self.defer_release:
            self._batch(self._begin())
        return strip_reply(reply)

    def _await_reply(self, data: bytes, start: int, odbr: int, timeout_ns: int) -> tuple[bytes, int]:
        """(window, ODBR) once the reply to `data` is posted after `start`: waits in the daemon
        for OMISR OM0I or ODI when ODBR was clear (a reply or a command error ends it), else for
        0x0F8 to move; a doorbell bit that is not a command error (a move done meanwhile) costs
        one more batch. Raises CommandError or MaxkTimeout."""
        if odbr & COMMAND_ERROR:
            self._seen_error(odbr, reported=True)
            raise CommandError(data)
        omisr = not odbr
        while True:
            if omisr:
                wait = self._wait(Mu.OMISR, _OM0I | _ODI, 0, timeout_ns, equal=False, mu=True)
            else:
                wait = self._wait(Shm.RESPONSE_INSERT, 0xFFFF_FFFF, start, timeout_ns, equal=False)
            ops = self._begin()
            ops += (wait, self._window, self._odbr)
            res = self._batch(ops, timeout_ns)
            if res[-3]["fired"]:
                window, odbr = res[-2], le32(res[-1])
                if be32(window, 8) != start:
                    return window, odbr
            elif not omisr:  # the wait does not see a command error: look once more
                odbr = le32(self._batch(self._begin() + [self._odbr])[-1])
            if odbr & COMMAND_ERROR:
                self._seen_error(odbr, reported=True)
                raise CommandError(data)
            if not res[-3]["fired"]:
                self._synced = False  # a late reply would be taken for the next command's
                raise MaxkTimeout(f"{self.card}: no reply to {data.decode('latin-1')!r} within "
                                  f"{timeout_ns // _NS_PER_MS} ms")
            omisr = False

    def _unsolicited(self, message: bytes) -> None:
        text = strip_reply(message)
        log.debug("%s: reply to no call: %r", self.card, text)
        self.unsolicited.append(text)

    # -- flags and motion ---------------------------------------------------------------------------
    def get_status_flags(self) -> StatusFlags:
        """Read and clear (W1C) ODBR and the W/K flag words, in one batch so nothing set between
        the read and the clear is lost."""
        ops = self._begin()
        first = len(ops)
        ops += (self._odbr, self._read(Shm.W_STATUS_FLAGS, 8),
                self._mu_word(Mu.ODBR, ODBR_ALL), self._word(Shm.W_STATUS_FLAGS, WK_ALL),
                self._word(Shm.K_STATUS_FLAGS, WK_ALL))
        res = self._batch(ops)
        odbr, wk = le32(res[first]), res[first + 1]
        flags = StatusFlags.from_words(odbr | self._sticky, be32(wk), be32(wk, 4))
        self._sticky = 0
        return flags

    def wait_done(self, mask: int, timeout_ms: int | None = None) -> StatusFlags:
        """Block until every axis of `mask` (bit i = axis AXES[i]) has a done, over-travel or slip
        flag (an axis that stops on a limit never gets its done flag), then read and clear those
        axes' flags; returns them. MaxkTimeout if one of them has none within `timeout_ms` (each
        axis waits at most that long, server side: in lockstep, time runs only until then)."""
        mask &= (1 << len(AXES)) - 1
        if not mask:
            raise ValueError("wait_done: the axis mask is empty")
        timeout_ns = self._timeout_ns(timeout_ms)
        waits = [self._wait(Mu.ODBR, EVENT_BITS << i, 0, timeout_ns, equal=False, mu=True)
                 for i in range(8) if mask >> i & 1]
        clear = sum(EVENT_BITS << i for i in range(8) if mask >> i & 1)
        words = []
        for i, (offset, notify) in enumerate(zip((Shm.W_STATUS_FLAGS, Shm.K_STATUS_FLAGS), WK_NOTIFICATION,
                                                 strict=True)):
            if mask >> (8 + i) & 1:
                waits.append(self._wait(offset, WK_ALL, 0, timeout_ns, equal=False))
                words.append(self._word(offset, WK_ALL))
                clear |= notify
        ops = self._begin()
        first = len(ops)
        ops += waits
        ops += (self._odbr, self._read(Shm.W_STATUS_FLAGS, 8), self._mu_word(Mu.ODBR, clear), *words)
        res = self._batch(ops, len(waits) * timeout_ns)
        if not all(r and r["fired"] for r in res[first:first + len(waits)]):  # None after one ran out
            raise MaxkTimeout(f"{self.card}: axes {_letters(mask)} not done within "
                              f"{timeout_ns // _NS_PER_MS} ms")
        wk = res[first + len(waits) + 1]
        odbr = le32(res[first + len(waits)])
        return StatusFlags.from_words(odbr, be32(wk), be32(wk, 4)).only(mask)

    def kill_all(self) -> None:
        """Direct command 2, KILL_ALL_MOTION (spec §2.6): every axis stops without deceleration
        and the queues are flushed; returns when the card has written 0 back to the mailbox."""
        timeout_ns = self._timeout_ns(None)
        ops = self._begin()
        ops += (self._word(Shm.DIRECT_COMMAND, DirectCommand.KILL_ALL_MOTION),
                self._wait(Shm.DIRECT_COMMAND, 0xFFFF_FFFF, 0, timeout_ns))
        if not self._batch(ops, timeout_ns)[-1]["fired"]:
            raise MaxkTimeout(f"{self.card}: the direct command was not taken")

    # -- positions and words ------------------------------------------------------------------------
    @property
    def axes(self) -> int:
        """The card's axis count: from its description, else from the model in `WY`
        ("MAXk-4000" has 4, "MAXk-A000" 10); 10 if neither tells."""
        if self._axes is None:
            model = re.search(r"MAXk-([1-9A])000", self.send_and_get_string("WY"))
            self._axes = int(model.group(1), 16) if model else len(AXES)
        return self._axes

    def get_positions(self, coherent: bool = False) -> Positions:
        """Motor and encoder positions of the card's axes: the words the card updates every cycle,
        or (`coherent`) the snapshot of one cycle that the position request mailbox asks for."""
        n = self.axes
        memory = self._memory
        if not coherent and memory.is_mapped(Shm.MOTOR_POSITION, _POSITIONS.size) \
                and memory.is_mapped(Shm.WK_MOTOR_POSITION, _WK_POSITIONS.size):
            # the pending ops (the reply channel's) wait for the next batch, as in _read_word
            return _positions(memory.read(Shm.MOTOR_POSITION, _POSITIONS.size),
                              memory.read(Shm.WK_MOTOR_POSITION, _WK_POSITIONS.size), n)
        ops = self._begin()
        first = len(ops)
        timeout_ns = 0
        if coherent:
            timeout_ns = self._timeout_ns(None)
            ops += (self._word(Shm.POSITION_REQUEST, 1),
                    self._wait(Shm.POSITION_REQUEST, 0xFFFF_FFFF, 0, timeout_ns))
            xs, wk = Shm.COHERENT_MOTOR_POSITION, Shm.WK_COHERENT_MOTOR_POSITION
        else:
            xs, wk = Shm.MOTOR_POSITION, Shm.WK_MOTOR_POSITION
        ops.append(self._read(xs, _POSITIONS.size))
        if n > 8:
            ops.append(self._read(wk, _WK_POSITIONS.size))
        res = self._batch(ops, timeout_ns)
        if coherent and not res[first + 1]["fired"]:
            raise MaxkTimeout(f"{self.card}: the position request was not served")
        return _positions(res[first + 2 if coherent else first], res[-1] if n > 8 else b"", n)

    def get_rt_capture(self) -> list[CaptureEntry]:
        """Drain the real-time capture ring (spec §2.8): clear OMISR OM1I, read the entries from
        the removal index up to the insert index, then set the removal index."""
        ops = self._begin()
        ops += (self._mu_word(Mu.OMISR, int(Omisr.OM1I)), self._read(Shm.CAPTURE_INSERT, CAPTURE_SIZE))
        insert, _, entries = capture_entries(self._batch(ops)[-1])
        if entries:
            self._batch([self._write(Shm.CAPTURE_REMOVAL, bytes([insert]))])
        return entries

    def _read_word(self, offset: int) -> int:
        """A word the card publishes: through shared memory when mapped (what the last call
        left to do waits for the next batch: it concerns the reply channel, not these words),
        else one batch."""
        if self._memory.is_mapped(offset, 4):
            return self._memory.read32(offset)
        ops = self._begin()
        ops.append(self._read(offset, 4))
        return be32(self._batch(ops)[-1])

    def read_limits(self) -> int:
        """The limit switch word (Table 3-2): raw input levels, bit i negative and bit i+8 positive
        limit of X..S; W, K at bits 16/17 and 24/25."""
        return self._read_word(Shm.LIMIT_SWITCH_STATUS)

    def read_home(self) -> int:
        """The home switch word (Table 3-3): bits 0-7 X..S, 8-9 W, K."""
        return self._read_word(Shm.HOME_SWITCH_STATUS)

    def read_gpio(self) -> int:
        """The general-purpose I/O word: bit n = IOn."""
        return self._read_word(Shm.GPIO_STATUS)

    def read_fw_status(self) -> int:
        """The firmware state word (Table 3-4, FirmwareState)."""
        return self._read_word(Shm.FIRMWARE_STATE)

    # -- closing ------------------------------------------------------------------------------------
    def close(self) -> None:
        """Release what the last call left (its reply), give OMIMR back its OM0I bit as found,
        then close the connection if `open` made it. Closing again does nothing."""
        ops, self._pending = (self._pending if self._synced else []), []
        try:
            if self._omimr is not None:
                ops.append(self._mu_word(Mu.OMIMR, self._omimr))
                self._omimr = None
            if ops:
                self._batch(ops)
        finally:
            if self._owns_rack:
                self.rack.close()

    def __enter__(self) -> Maxk:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _positions(xs: bytes, wk: bytes, n: int) -> Positions:
    """The first `n` axes' positions from the X..S words and (more than 8 axes) the W, K ones."""
    words = _POSITIONS.unpack(xs)
    motor, encoder = words[:8], words[8:]
    if n > 8:
        w_motor, k_motor, w_encoder, k_encoder = _WK_POSITIONS.unpack(wk)
        motor += (w_motor, k_motor)
        encoder += (w_encoder, k_encoder)
    return Positions(motor[:n], encoder[:n])


def _letters(mask: int) -> str:
    return "".join(letter for i, letter in enumerate(AXES) if mask >> i & 1)

