"""What one command line answers, and how a port frames it (I3, I6) [spec pmac.md §2.4].

The interpreter produces a `Reply`: the data lines in order and, when a command was invalid, the
error number (the rest of the line was abandoned; lines produced before it are still sent). A
port turns it into bytes:

| I3 | valid, no data | valid with data               | invalid            |
|----|----------------|-------------------------------|--------------------|
| 0  | nothing        | `DATA<CR>` per line           | `<BELL>`           |
| 1  | `<LF>`         | `<LF>DATA<CR>` per line, `<LF>` | `<BELL>`         |
| 2  | `<ACK>`        | `DATA<CR>`... `<ACK>`          | `<BELL>`           |
| 3  | `<ACK>`        | `<LF>DATA<CR>`... `<ACK>`      | `<BELL>`           |

With I6 = 1 or 3 the bell is followed by `ERRnnn<CR>` [UM p.384]; an error reply has no ACK.
"""

from __future__ import annotations

from dataclasses import dataclass, field

ACK, LF, CR, BELL = b"\x06", b"\n", b"\r", b"\x07"


@dataclass
class Reply:
    lines: list[str] = field(default_factory=list)
    error: int | None = None


def error_text(code: int) -> str:
    return f"ERR{code:03d}"


def frame(reply: Reply, i3: int, i6: int) -> bytes:
    """The bytes a serial-style port (Ethernet, host port) sends for `reply`."""
    if i3 == 2 and reply.error is None:  # what Ethernet clients set: DATA<CR>... <ACK>
        return "".join([line + "\r" for line in reply.lines]).encode("latin-1") + ACK
    lead = LF if i3 in (1, 3) else b""
    out = b"".join(lead + line.encode("latin-1") + CR for line in reply.lines)
    if reply.error is not None:
        tail = BELL + (error_text(reply.error).encode() + CR if i6 in (1, 3) else b"")
        return out + tail
    if i3 == 0:
        return out
    return out + (LF if i3 == 1 else ACK)
