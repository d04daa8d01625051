"""The transfers of the `snapshot` op (PROTOCOL.md "snapshot"): a snapshot file moves in chunks,
each request and reply within `max_message`; one transfer per client, MAX_TRANSFERS in all."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from typing import Any

from vdevd.errors import ErrorCode, VdevError
from vdevd.snapshot import MAX_SNAPSHOT
from vdevd.snapshot_pickle import bad

#: the largest chunk of a transfer (a request or reply stays within protocol.MAX_MESSAGE)
CHUNK = 512 << 10
#: transfers held at once, all clients together (each holds at most MAX_SNAPSHOT)
MAX_TRANSFERS = 4


class Transfers:
    """The snapshot transfers under way, one per client (PROTOCOL.md "snapshot"): a save held
    until its last chunk is read, a load gathered until its last chunk arrives."""

    def __init__(self) -> None:
        self.saves: dict[bytes, bytes] = {}
        self.loads: dict[bytes, bytearray] = {}

    def _room(self, client: bytes) -> None:
        self.saves.pop(client, None)  # one transfer in flight per client: a new one replaces
        self.loads.pop(client, None)
        if len(self.saves) + len(self.loads) >= MAX_TRANSFERS:
            raise VdevError(ErrorCode.BUSY, f"snapshot: {MAX_TRANSFERS} transfers under way, "
                            "the most the daemon holds")

    def read(self, client: bytes, offset: int, make: Callable[[], bytes]) -> dict[str, Any]:
        """The chunk at `offset` of the client's save; at offset 0 a new snapshot is taken."""
        if offset == 0:
            self._room(client)
            self.saves[client] = make()
        data = self.saves.get(client)
        if data is None:
            raise VdevError(ErrorCode.BAD_PARAM, "snapshot save: no save under way (begin at "
                            "offset 0)")
        if not 0 <= offset <= len(data):
            raise VdevError(ErrorCode.BAD_PARAM, f"snapshot save: offset {offset} outside "
                            f"0..{len(data)}")
        chunk = data[offset:offset + CHUNK]
        if offset + len(chunk) >= len(data):
            del self.saves[client]
        return {"size": len(data), "offset": offset, "data": chunk,
                "sha256": hashlib.sha256(data).hexdigest() if offset == 0 else None}

    def write(self, client: bytes, offset: int, size: int, chunk: bytes) -> bytes | None:
        """Add a chunk to the client's load; the whole file once its last chunk is here."""
        if not 0 < size <= MAX_SNAPSHOT:
            raise bad(f"a snapshot of {size} bytes (at most {MAX_SNAPSHOT})")
        if len(chunk) > CHUNK:
            raise VdevError(ErrorCode.TOO_LARGE, f"snapshot load: a chunk of {len(chunk)} "
                            f"bytes (at most {CHUNK})")
        if offset == 0:
            self._room(client)
            self.loads[client] = bytearray()
        got = self.loads.get(client)
        if got is None or offset != len(got):
            self.loads.pop(client, None)
            raise VdevError(ErrorCode.BAD_PARAM, f"snapshot load: a chunk at offset {offset}, "
                            f"expected {len(got) if got is not None else 0} (the load is "
                            "dropped: begin again at 0)")
        if offset + len(chunk) > size:
            del self.loads[client]
            raise bad(f"snapshot load: chunks beyond the size given ({size})")
        got += chunk
        if len(got) < size:
            return None
        del self.loads[client]
        return bytes(got)

    def held(self) -> int:
        """The bytes the transfers hold (stats)."""
        return sum(map(len, self.saves.values())) + sum(map(len, self.loads.values()))


