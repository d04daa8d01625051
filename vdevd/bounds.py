"""The bounds a request is held to before any work is done for it (issue 22, PROTOCOL.md "Size").

A reply over `max_message` is an error (`too_large`), so a read or a batch whose reply would
certainly exceed it is refused before a byte is read: a `rep` read of 16 MiB would otherwise run
16 million register accesses and build the reply first. Scheduled backdoor actions are counted
per client and in total (`ScheduledCount`), past the limit `busy`. Sans-I/O: plain functions of
the request's fields.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from typing import Any

from vdevd.errors import ErrorCode, VdevError
from vdevd.protocol import MAX_MESSAGE, Request

#: the fewest bytes a read reply holds beside its data: a fixmap {"id": nil, "ok": bin32}
READ_REPLY_OVERHEAD = 1 + 3 + 1 + 3 + 5
#: the largest `size` a read may ask for: its reply is at least `size + READ_REPLY_OVERHEAD`
MAX_READ = MAX_MESSAGE - READ_REPLY_OVERHEAD
#: the fewest bytes of a batch reply beside its results: {"id": nil, "ok": array32}
BATCH_REPLY_OVERHEAD = 1 + 3 + 1 + 3 + 5
#: the hook calls (single accesses of registers with side effects) one request may make: its
#: repeated accesses (`rep`), and a batch's accesses of every kind summed (a block access of a
#: window of registers is one call per register): a FIFO port's hook costs 1-2 us a call, so
#: 65536 of them hold the event loop about 0.1 s
MAX_REP_HOOK_CALLS = 65_536
#: the `control` ops one batch may hold: a backdoor action costs 0.2-0.6 ms (the card's world
#: rebuilt), so 256 of them hold the event loop about 0.1 s; a request each is not limited
MAX_BATCH_CONTROLS = 256
#: the ops that batches holding a `wait` may hold in all while they run (a wait suspends its
#: batch, the ops after it kept until it resolves): a decoded op takes about 250 bytes, so the
#: 1,024 waits that may be pending, each holding a batch of 1 MiB (60,000 ops), took 14 GB;
#: this holds them to about 64 MB
MAX_HELD_OPS = 262_144
#: scheduled `control` actions one client may have pending, and all clients together (defaults)
MAX_SCHEDULED_PER_CLIENT = 1_000
MAX_SCHEDULED = 10_000


def check_read(size: int) -> None:
    """A `read` (plain or `rep`) whose reply cannot fit `max_message`: `too_large`, at once."""
    if size > MAX_READ:
        raise VdevError(ErrorCode.TOO_LARGE, f"read of {size} bytes: the reply would exceed "
                        f"max_message ({MAX_MESSAGE} bytes; at most {MAX_READ} bytes a read)")


def check_rep_work(calls: int) -> None:
    """Repeated accesses (`rep`) that would call registers' hooks more than MAX_REP_HOOK_CALLS
    times: `too_large`, before the first call."""
    if calls > MAX_REP_HOOK_CALLS:
        raise VdevError(ErrorCode.TOO_LARGE, f"repeated accesses of {calls} single accesses "
                        f"through register hooks exceed {MAX_REP_HOOK_CALLS} a request (a FIFO "
                        "port: read or write it in pieces)")


def _bin_size(n: int) -> int:
    """The bytes of a msgpack bin of `n` bytes (its header and the data)."""
    return n + (2 if n < 0x100 else 3 if n < 0x10000 else 5)


#: (card, region, offset, size, write, rep) -> the hook calls of that access
#: (`Region.hook_calls`, `Region.rep_hook_calls`; 0 for a region that does not exist: it fails
#: when it runs)
HookCalls = Callable[[str, str, int, int, bool, bool], int]

_KINDS = {"r": (True, False, False), "R": (True, True, False), "w": (False, False, True),
          "W": (False, True, True)}


def batch_cost(ops: Sequence[Request | Sequence[Any]],
               hook_calls: HookCalls) -> tuple[int, int, int, int]:
    """What a batch of `ops` (protocol.Access or Request) costs before it runs: the fewest
    bytes its reply can take (every read's data with its header, one byte at least for any other
    result), the hook calls of its accesses, its `control` ops and its `wait` ops."""
    total, calls, controls, waits = BATCH_REPLY_OVERHEAD, 0, 0, 0
    for op in ops:
        if isinstance(op, Request):
            if op.op not in ("read", "write"):
                total += 1
                controls += op.op == "control"
                waits += op.op == "wait"
                continue
            args = op.args
            read, rep = op.op == "read", bool(args.get("rep"))
            card, region, offset = args["card"], args["region"], args["offset"]
            size = args["size"] if read else len(args["data"])
        else:
            kind = _KINDS.get(op[0])
            if kind is None:
                total += 1
                continue
            read, rep, _ = kind
            card, region, offset, last = op[1], op[2], op[3], op[4]
            size = last if read else len(last)
        total += _bin_size(size) if read and size > 0 else 1
        calls += hook_calls(card, region, offset, size, not read, rep)
    return total, calls, controls, waits


def check_batch(ops: Sequence[Request | Sequence[Any]], hook_calls: HookCalls) -> int:
    """A batch whose reply cannot fit `max_message`, whose accesses would call hooks more than
    MAX_REP_HOOK_CALLS times, or with more than MAX_BATCH_CONTROLS `control` ops: `too_large`
    before any of its ops runs. Its `wait` ops are returned."""
    floor, calls, controls, waits = batch_cost(ops, hook_calls)
    if floor > MAX_MESSAGE:
        raise VdevError(ErrorCode.TOO_LARGE, f"batch of {len(ops)} ops: its reply would take "
                        f"at least {floor} bytes, over max_message ({MAX_MESSAGE} bytes); "
                        "nothing was run")
    if calls > MAX_REP_HOOK_CALLS:
        raise VdevError(ErrorCode.TOO_LARGE, f"batch of {len(ops)} ops: its accesses make "
                        f"{calls} single accesses through register hooks, over "
                        f"{MAX_REP_HOOK_CALLS} a request; nothing was run")
    if controls > MAX_BATCH_CONTROLS:
        raise VdevError(ErrorCode.TOO_LARGE, f"batch of {len(ops)} ops: {controls} control ops, "
                        f"over {MAX_BATCH_CONTROLS} a batch; nothing was run")
    return waits


class ScheduledCount:
    """Scheduled `control` actions pending, per client and in all (PROTOCOL.md "control"):
    `reserve(client)` before one is scheduled (`busy` past a limit), `release(client)` once it
    has run."""

    def __init__(self, per_client: int = MAX_SCHEDULED_PER_CLIENT,
                 total: int = MAX_SCHEDULED) -> None:
        self.per_client = per_client
        self.limit = total
        self.total = 0
        self._by_client: dict[Hashable, int] = {}

    def reserve(self, client: Hashable) -> None:
        """Count one more for `client`; `busy` (nothing counted) when a limit is reached."""
        mine = self._by_client.get(client, 0)
        if self.total >= self.limit:
            raise VdevError(ErrorCode.BUSY, f"control: {self.total} scheduled actions pending, "
                            f"the most the daemon holds ({self.limit})")
        if mine >= self.per_client:
            raise VdevError(ErrorCode.BUSY, f"control: this client has {mine} scheduled "
                            f"actions pending, the most one client may ({self.per_client})")
        self._by_client[client] = mine + 1
        self.total += 1

    def release(self, client: Hashable) -> None:
        """One of `client`'s scheduled actions has run."""
        mine = self._by_client.get(client, 0) - 1
        if mine > 0:
            self._by_client[client] = mine
        else:
            self._by_client.pop(client, None)
        self.total -= 1
