"""The bounds a request is held to before any work is done for it (issue 22, PROTOCOL.md "Size").

A reply over `max_message` is an error (`too_large`), so a read or a batch whose reply would
certainly exceed it is refused before a byte is read: a `rep` read of 16 MiB would otherwise run
16 million register accesses and build the reply first. Scheduled backdoor actions are counted
per client and in total (`ScheduledCount`), past the limit `busy`. Sans-I/O: plain functions of
the request's fields.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Any

from vdevd.errors import ErrorCode, VdevError
from vdevd.protocol import MAX_MESSAGE, Request

#: the fewest bytes a read reply holds beside its data: a fixmap {"id": nil, "ok": bin32}
READ_REPLY_OVERHEAD = 1 + 3 + 1 + 3 + 5
#: the largest `size` a read may ask for: its reply is at least `size + READ_REPLY_OVERHEAD`
MAX_READ = MAX_MESSAGE - READ_REPLY_OVERHEAD
#: the fewest bytes of a batch reply beside its results: {"id": nil, "ok": array32}
BATCH_REPLY_OVERHEAD = 1 + 3 + 1 + 3 + 5
#: scheduled `control` actions one client may have pending, and all clients together (defaults)
MAX_SCHEDULED_PER_CLIENT = 1_000
MAX_SCHEDULED = 10_000


def check_read(size: int) -> None:
    """A `read` (plain or `rep`) whose reply cannot fit `max_message`: `too_large`, at once."""
    if size > MAX_READ:
        raise VdevError(ErrorCode.TOO_LARGE, f"read of {size} bytes: the reply would exceed "
                        f"max_message ({MAX_MESSAGE} bytes; at most {MAX_READ} bytes a read)")


def _bin_size(n: int) -> int:
    """The bytes of a msgpack bin of `n` bytes (its header and the data)."""
    return n + (2 if n < 0x100 else 3 if n < 0x10000 else 5)


def batch_reply_floor(ops: Sequence[Request | Sequence[Any]]) -> int:
    """The fewest bytes the reply to a batch of `ops` (protocol.Access or Request) can take: every
    read's data with its header, one byte (at least) for any other result."""
    total = BATCH_REPLY_OVERHEAD
    for op in ops:
        if isinstance(op, Request):
            size = op.args["size"] if op.op == "read" else None
        else:
            size = op[4] if op[0] in ("r", "R") else None
        total += _bin_size(size) if isinstance(size, int) and size > 0 else 1
    return total


def check_batch(ops: Sequence[Request | Sequence[Any]]) -> None:
    """A batch whose reply cannot fit `max_message`: `too_large` before any of its ops runs."""
    floor = batch_reply_floor(ops)
    if floor > MAX_MESSAGE:
        raise VdevError(ErrorCode.TOO_LARGE, f"batch of {len(ops)} ops: its reply would take "
                        f"at least {floor} bytes, over max_message ({MAX_MESSAGE} bytes); "
                        "nothing was run")


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
