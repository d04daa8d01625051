"""Rack snapshots from a client (PROTOCOL.md "snapshot"): the file moves in chunks, each
request and reply within the daemon's `max_message`, so a snapshot is saved to and loaded from
the client's machine."""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vdevclient.core import Rack

#: the bytes a `load` request carries at most (the daemon takes chunks of up to 512 KiB)
CHUNK = 512 << 10
#: wall seconds a load may take past the client's timeout (the daemon rebuilds the rack)
LOAD_WAIT_S = 30.0
#: the largest snapshot a daemon takes (vdevd.snapshot.MAX_SNAPSHOT)
MAX_SNAPSHOT = 64 << 20


def save(rack: Rack) -> bytes:
    """The snapshot of the daemon's rack, whole (its SHA-256 checked)."""
    first = rack.request("snapshot", action="save", offset=0)
    size, digest = first["size"], first["sha256"]
    parts = [first["data"]]
    got = len(first["data"])
    while got < size:
        chunk = rack.request("snapshot", action="save", offset=got)["data"]
        if not chunk:
            raise ValueError(f"snapshot save: the daemon sent nothing at offset {got} of {size}")
        parts.append(chunk)
        got += len(chunk)
    data = b"".join(parts)
    if hashlib.sha256(data).hexdigest() != digest:
        raise ValueError("snapshot save: the bytes received do not match the daemon's checksum")
    return data


def load(rack: Rack, data: bytes) -> dict[str, Any]:
    """Send a snapshot to the daemon, which serves it in place of its rack once it is whole
    (`RemoteError` `bad_snapshot` naming why it does not load: the rack is then untouched)."""
    if not data:
        raise ValueError("snapshot load: the file is empty")
    result: dict[str, Any] = {}
    for offset in range(0, len(data), CHUNK):
        chunk = data[offset:offset + CHUNK]
        last = offset + len(chunk) >= len(data)
        result = rack.request("snapshot", _wait_s=LOAD_WAIT_S if last else 0.0, action="load",
                              offset=offset, size=len(data), data=chunk)
    return result


def run(rack: Rack, action: str, path: Path) -> str:
    """`vdevctl snapshot save|load FILE`: what was done, in one line (OSError, RemoteError
    naming what failed)."""
    if action == "save":
        data = save(rack)
        write_file(path, data)
        return f"saved {len(data)} bytes to {path} at {rack.sim.now_ns()} ns"
    size = path.stat().st_size
    if size > MAX_SNAPSHOT:
        raise OSError(f"{path}: {size} bytes, a snapshot is at most {MAX_SNAPSHOT}")
    result = load(rack, path.read_bytes())
    return f"loaded {path}: {len(result.get('cards', []))} cards at {result.get('now_ns')} ns"


def write_file(path: Path, data: bytes) -> None:
    """`data` to `path` atomically (a temporary file beside it, renamed): a reader sees the old
    file or the whole new one."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
