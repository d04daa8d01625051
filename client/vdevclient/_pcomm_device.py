"""An open PComm32 device (spec pmac.md §3.1): its connection and batches, the DPRAM ASCII handshake
(spec §2.10), the interrupt thread, the table of open devices and the guard that makes a closed
device or a transport failure a driver error. Shared by the `vdevclient.pcomm` modules."""

from __future__ import annotations

import ctypes
import functools
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zmq
from vdevmaps.pmac import (
    ACK,
    CMD_CHAR,
    CMD_CONTROL,
    CR,
    DPRAM,
    HOST,
    IR_STATUS,
    LINE,
    RESP_CONTROL,
)

from vdevclient._pcomm_codes import COMM_EOT, COMM_ERROR, COMM_TIMEOUT, INTRBUFFER, MAX_COMM_BUFFER
from vdevclient._pmac_bus import (
    RESP_HEAD,
    RESP_SLOT,
    Posted,
    command_bytes,
    error_text,
    parse_slot,
    slot_whole,
)
from vdevclient.core import Prepared, Rack, connect
from vdevclient.errors import VdevClientError

log = logging.getLogger("vdevclient.pcomm")  # the public module's logger, whichever module logs

DEFAULT_TIMEOUT_MS = 1000  # card time a missing line is waited for
MEMO_SIZE = 256  # commands whose reply length (slots posted) is remembered
MAX_READS = 64  # response slots read ahead in one batch
_NS_PER_MS = 1_000_000


# -- devices ----------------------------------------------------------------------------------------
@dataclass
class _Seen:
    """A command's reply length in response slots the last time, and the batch that sends it in
    the steady state with its slot reads (built at its first use)."""

    slots: int
    ops: list[dict[str, Any]] | None = None
    reads: list[int] = field(default_factory=list)
    message: Prepared | None = None  # the batch of `ops`, packed once


class _Device:
    """An open device: its connection, the ops the next batch runs first (the deferred
    acknowledgement), the reply lengths seen, and the interrupt thread."""

    def __init__(self, number: int, rack: Rack, info: dict[str, Any]) -> None:
        self.number = number
        self.rack = rack
        self.card = str(info["name"])
        self.motors = int(info.get("motors") or 8)
        self.ethernet = str(info.get("ethernet") or "")
        self.timeout_ms = DEFAULT_TIMEOUT_MS
        self.lock = threading.RLock()
        where = {"card": self.card, "region": DPRAM}
        self.where = where
        #: the DPRAM as a Region: its passive bytes go through shared memory when mapped
        self.memory = rack.card(self.card).region(DPRAM)
        self.ack = {"op": "write", "offset": RESP_CONTROL, "data": b"\0\0", **where}
        self.slot = {"op": "read", "offset": RESP_CONTROL, "size": RESP_SLOT, **where}
        self.head = {"op": "read", "offset": RESP_CONTROL, "size": RESP_HEAD, **where}
        self.go = {"op": "write", "offset": CMD_CONTROL, "data": b"\1\0", **where}
        self.gate = {"op": "wait", "on": "value", "offset": RESP_CONTROL, "size": 2, "mask": 0xFFFF,
                     "value": ACK, "cmp": "eq", "timeout_ns": 0, **where}
        self.pending: list[dict[str, Any]] = []
        self.memo: dict[bytes, _Seen] = {}
        self.scale: dict[int, float] = {}  # motor -> Ixx08 * 32
        self.interrupts: _Interrupts | None = None
        self.gather: Any = None  # PmacCollectGatherData's upload (_pcomm_gather.py)
        self.vbg: Any = None  # the variable read buffer's users (_pcomm_dprvar.py)
        self.drain()

    # -- ops and batches ----------------------------------------------------------------------------
    def write(self, offset: int, data: bytes) -> dict[str, Any]:
        return {"op": "write", "offset": offset, "data": data, **self.where}

    def read(self, offset: int, size: int) -> dict[str, Any]:
        return {"op": "read", "offset": offset, "size": size, **self.where}

    def batch(self, ops: list[dict[str, Any]], wait_ns: int = 0) -> list[Any]:
        return self.rack.call({"op": "batch", "ops": ops}, wait_ns / 1e9)

    def begin(self) -> list[dict[str, Any]]:
        ops, self.pending = self.pending, []
        return ops

    def wait_posted(self) -> dict[str, Any]:
        return {"op": "wait", "on": "value", "offset": RESP_CONTROL, "size": 2, "mask": 0xFFFF,
                "value": 0, "cmp": "ne", "timeout_ns": self.timeout_ms * _NS_PER_MS, **self.where}

    def drain(self) -> None:
        """Acknowledge what a previous host left in the response slot (at most a reply's worth)."""
        ops = [self.slot]
        for _ in range(MAX_COMM_BUFFER):
            if parse_slot(self.batch(ops)[-1]) is None:
                return
            ops = [self.ack, self.slot]

    # -- the ASCII handshake ------------------------------------------------------------------------
    def collect(self, ops: list[dict[str, Any]], key: bytes | None, posted: list[Posted] | None = None,
                need_ack: bool = False) -> tuple[list[Posted], bool]:
        """Run `ops` (they make the card post lines) and read the response slot until the reply's
        end (ACK or an error): (the lines, True), or (the lines so far, False) on a time-out."""
        seen = self.memo.get(key) if key is not None else None
        reads = self._reads(ops, seen.slots if seen is not None else 2, need_ack)
        return self._read_reply(ops, reads, key, [] if posted is None else posted)

    def _reads(self, ops: list[dict[str, Any]], n: int, need_ack: bool) -> list[int]:
        """Append `n` reads of the response slot to `ops`, each after an acknowledgement of the
        line before it (the first only with `need_ack`); where the reads are. The last read takes
        the slot's head alone: an ACK or an error is complete there, a data line is read again
        whole by the next batch (nothing acknowledges it before)."""
        reads = []
        for _ in range(n):
            if need_ack:
                ops.append(self.ack)
            reads.append(len(ops))
            ops.append(self.slot)
            need_ack = True
        ops[-1] = self.head
        return reads

    def _read_reply(self, ops: list[dict[str, Any]], reads: list[int], key: bytes | None,
                    posted: list[Posted], waiting: bool = False,
                    prepared: Prepared | None = None) -> tuple[list[Posted], bool]:
        """Run `ops` (sent as `prepared` when given) and the batches after it until the reply's
        end (`collect`); `ops` is not changed (the steady-state batches are reused)."""
        while True:
            if prepared is not None:
                res, prepared = self.rack.call(prepared), None
            else:
                res = self.batch(ops, self.timeout_ms * _NS_PER_MS if waiting else 0)
            if waiting and not res[0]["fired"]:
                return posted, False
            last = reads[-1]
            for at in reads:
                slot = res[at]
                line = parse_slot(slot)
                if line is None:  # not posted yet: wait for it (the ack before this read ran)
                    ops, waiting = [self.wait_posted()], True
                    reads = self._reads(ops, 1, False)
                    break
                if at == last and not slot_whole(slot):  # a data line's head: read it whole
                    ops, waiting = [], False
                    reads = self._reads(ops, min(2 * len(reads), MAX_READS), False)
                    break
                posted.append(line)
                if line.terminator != CR:
                    if at == last:
                        self.pending.append(self.ack)  # deferred into the next call's batch
                    if key is not None:
                        self._learn(key, len(posted))
                    return posted, True
            else:
                ops, waiting = [], False
                reads = self._reads(ops, min(2 * len(reads), MAX_READS), True)

    def _learn(self, key: bytes, slots: int) -> None:
        """Remember how many slots `key`'s reply took (MEMO_SIZE commands, the oldest go first)."""
        seen = self.memo.get(key)
        if seen is not None and seen.slots == slots:
            return
        if seen is None and len(self.memo) >= MEMO_SIZE:
            del self.memo[next(iter(self.memo))]
        self.memo[key] = _Seen(slots)

    def command_ops(self, line: bytes, ops: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """`ops` (the pending ones) then the command: its bytes at 0x0E9E and 0x0E9C := 1. A
        pending acknowledgement as the last op rides in the bytes' write instead, padded up to
        0x0F40 (the buffer ends where the response control word starts): one op less."""
        data = command_bytes(line)
        if ops and ops[-1] is self.ack:
            ops.pop()
            data = data.ljust(RESP_CONTROL - CMD_CHAR, b"\0") + b"\0\0"
        ops += (self.write(CMD_CHAR, data), self.go)
        return ops

    def control_ops(self, ch: int) -> list[dict[str, Any]]:
        return [self.write(CMD_CHAR, bytes([ch])), self.go]

    def response(self, line: bytes) -> tuple[bytes, int]:
        """A command line's reply (CR-terminated lines, the error text) and its COMM status.
        In the steady state (the last reply's ACK still to acknowledge, a command seen before)
        the batch is the one built the first time for this command."""
        seen = self.memo.get(line)
        pending = self.pending
        if seen is None or len(pending) != 1 or pending[0] is not self.ack:
            return _reply(*self.collect(self.command_ops(line, self.begin()), line))
        if seen.ops is None:
            seen.ops = self.command_ops(line, [self.ack])
            seen.reads = self._reads(seen.ops, seen.slots, False)
            seen.message = self.rack.prepare({"op": "batch", "ops": seen.ops})
        self.pending = []
        return _reply(*self._read_reply(seen.ops, seen.reads, line, [], prepared=seen.message))

    def get_variable(self, ch: str, num: int) -> str | None:
        data, status = self.response(f"{ch}{num}".encode("latin-1"))
        return data.decode("latin-1").strip() if status == COMM_EOT else None


def _reply(posted: list[Posted], complete: bool) -> tuple[bytes, int]:
    data = b"".join([p.text + b"\r" for p in posted if p.terminator == CR])
    if not complete:
        return data, COMM_TIMEOUT
    last = posted[-1]
    if last.terminator is None:
        return data + error_text(last.error), COMM_ERROR
    return data, COMM_EOT


_devices: dict[int, _Device] = {}


def _device(dwDevice: Any) -> _Device | None:
    return _devices.get(int(getattr(dwDevice, "value", dwDevice)))


def _guarded(fail: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """A closed device gives `fail`, and so does a transport failure (logged), as a driver error."""

    def wrap(fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def call(dwDevice: Any, *args: Any, **kwargs: Any) -> Any:
            dev = _devices.get(dwDevice) if type(dwDevice) is int else _device(dwDevice)
            if dev is None:
                return fail() if callable(fail) else fail
            try:
                with dev.lock:
                    return fn(dev, *args, **kwargs)
            except (VdevClientError, zmq.ZMQError) as exc:
                log.warning("%s(%s): %s", fn.__name__, dev.number, exc)
                return fail() if callable(fail) else fail

        return call

    return wrap


def _number(text: str | None) -> float | None:
    """A variable's value as the card answers it (`$hex` read as hex); None when not a number."""
    if not text:
        return None
    try:
        return float(int(text[1:], 16)) if text.startswith("$") else float(text)
    except ValueError:
        return None


# -- interrupts -----------------------------------------------------------------------------------------
class _Interrupts:
    """A thread on its own connection that receives the card's `inta` events, acknowledges the
    interrupt controller's status bits of `mask` (W1C at host byte 8) and calls the callback once
    per bit, IR0 first."""

    def __init__(self, dev: _Device, callback: Any, msg: int, mask: int) -> None:
        self.callback, self.msg, self.mask = callback, msg, mask
        self.rack = connect(dev.rack.endpoint, dev.rack.events_endpoint or None)
        try:
            self.card = self.rack.card(dev.card)
            self.host = self.card.region(HOST)
            self.card.irq.subscribe()
        except BaseException:
            self.rack.close()
            raise
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"pcomm-intr-{dev.number}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            while not self.stopping.is_set():
                for event in self.card.irq.events(timeout_s=0.05):
                    if event.get("line") == LINE:
                        self._deliver(int(event.get("status", 0)) & self.mask)
                    if self.stopping.is_set():
                        break
        except (VdevClientError, zmq.ZMQError) as exc:
            if not self.stopping.is_set():
                log.warning("interrupt thread: %s", exc)

    def _deliver(self, bits: int) -> None:
        if not bits:
            return
        self.host.write(IR_STATUS, bytes([bits]))
        for irq in range(8):
            if bits >> irq & 1:
                buffer = INTRBUFFER(None, 0, irq)
                try:
                    self.callback(self.msg, ctypes.pointer(buffer))
                except Exception:
                    log.exception("interrupt callback for IR%d", irq)

    def stop(self) -> None:
        self.stopping.set()
        self.thread.join(5.0)
        self.rack.close()
