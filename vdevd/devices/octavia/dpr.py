"""The card's side of the dual-port RAM [Ch6; spec octavia.md §2]: typed views of the per-axis
windows, the access-byte protocol of every protected window, and the interrupt mailbox.

The DPR is plain memory both sides poll: the card publishes a window only while the host does
not hold it (its HOSTACC byte 01h defers the update to the next publish, spec §2.5.1), marking
its own access byte around the write; it posts interrupts by OR-ing status bits and writing
1FFEh, and while the host holds the status window (3FDh = 01h) the posts wait in a queue that is
applied once it is released. Sans-I/O: the card's interrupt line is a callable.
"""

from __future__ import annotations

import mmap
from collections.abc import Callable

import numpy as np
from vdevmaps.octavia import BANK2, DPR_SIZE, Dpr, HostInt, Window

Memory = bytearray | memoryview | mmap.mmap
#: the bytes of the interrupt posts waiting for the host to release the status window; beyond
#: this many the oldest are merged (the bits are OR-ed anyway)
MAX_QUEUED = 64


def axis_window(buf: Memory, base: int, dtype: str = "<i4") -> tuple[np.ndarray, np.ndarray]:
    """The two banks of a per-axis window (axes 1-4 at `base`, 5-8 at `base` + 800h) as numpy
    views of the DPR memory."""
    return (np.ndarray((4,), dtype, buffer=buf, offset=base),
            np.ndarray((4,), dtype, buffer=buf, offset=base + BANK2))


class Windows:
    """Publish the per-axis state windows (ACTPOS, ACTVEL, ERROR) honouring the access bytes."""

    def __init__(self, buf: Memory) -> None:
        self.buf = buf
        self.actpos = axis_window(buf, Dpr.ACTPOS)
        self.actvel = axis_window(buf, Dpr.ACTVEL)
        self.error = axis_window(buf, Dpr.ERROR)
        self.indpos = axis_window(buf, Dpr.INDPOS)
        #: ACTPOS, ACTVEL and ERROR side by side (0D3h-102h, bank 2 +800h): a (3, 4) int32 view
        #: per bank, rows in that order, for the publish that finds all three windows free
        self.state = (np.ndarray((3, 4), "<i4", buffer=buf, offset=Dpr.ACTPOS),
                      np.ndarray((3, 4), "<i4", buffer=buf, offset=Dpr.ACTPOS + BANK2))
        self.prb = axis_window(buf, Dpr.PRB)
        #: PARREAD data of both banks [Ch5 PARREAD]
        self.parrdbk = (np.ndarray((8,), np.uint8, buffer=buf, offset=Dpr.PARRDBK),
                        np.ndarray((8,), np.uint8, buffer=buf, offset=Dpr.PARRDBK + BANK2))

    def free(self, window: Window) -> bool:
        """The host does not hold `window` (its HOSTACC byte is not 01h)."""
        return self.buf[window.host_flag] != 1

    def put(self, window: Window, views: tuple[np.ndarray, np.ndarray], values: np.ndarray,
            n: int) -> bool:
        """Write `values` (n axes, int32) into a per-axis window unless the host holds it; the
        card's access byte is 01h during the write. False when deferred."""
        buf = self.buf
        if buf[window.host_flag] == 1:
            return False
        buf[window.card_flag] = 1
        lo, hi = views
        lo[:min(n, 4)] = values[:4]
        if n > 4:
            hi[:n - 4] = values[4:n]
        buf[window.card_flag] = 0
        return True

    def put_bytes(self, window: Window, offset: int, data: bytes) -> bool:
        """Write `data` at `offset` inside `window` unless the host holds it."""
        buf = self.buf
        if buf[window.host_flag] == 1:
            return False
        buf[window.card_flag] = 1
        buf[offset:offset + len(data)] = data
        buf[window.card_flag] = 0
        return True


class Mailbox:
    """The interrupt registers [Ch6 Handling Interrupts; spec §3.1]: a post ORs a type bit into
    DSPSTAT1/2, source bits into an INTAXIS byte and a summary bit into HOSTINT1 (1FFEh), whose
    write asserts the line (`raise_line(status)`), again at every post. The card never clears
    these bits; the host does. While the host holds the status window (3FDh = 01h) posts queue
    and are applied, in order, when it releases it (`flush`, at every sample)."""

    def __init__(self, buf: Memory, raise_line: Callable[[int], None]) -> None:
        self.buf = buf
        self.raise_line = raise_line
        self.queue: list[tuple[int, int, int, int, int]] = []

    def post(self, hostint: int, stat_addr: int = -1, stat_bits: int = 0, src_addr: int = -1,
             src_bits: int = 0) -> None:
        """Post one interrupt: `hostint` bits of 1FFEh, `stat_bits` ORed at `stat_addr`
        (DSPSTAT1 or DSPSTAT2; -1: none), `src_bits` at `src_addr` (an INTAXIS byte)."""
        item = (hostint, stat_addr, stat_bits, src_addr, src_bits)
        if self.queue or self.buf[Dpr.HOSTACC_INT] == 1:
            if len(self.queue) >= MAX_QUEUED:  # merge into the last one of the same shape
                self.queue[-1] = _merge(self.queue[-1], item)
            else:
                self.queue.append(item)
            return
        self._apply(*item)

    def flush(self) -> None:
        """Apply the queued posts once the host released the status window."""
        if self.queue and self.buf[Dpr.HOSTACC_INT] != 1:
            queued, self.queue = self.queue, []
            for item in queued:
                self._apply(*item)

    def _apply(self, hostint: int, stat_addr: int, stat_bits: int, src_addr: int,
               src_bits: int) -> None:
        buf = self.buf
        buf[Dpr.MINTACC] = 1
        if stat_addr >= 0:
            buf[stat_addr] |= stat_bits
        if src_addr >= 0:
            buf[src_addr] |= src_bits
        value = buf[Dpr.HOSTINT1] | hostint
        buf[Dpr.HOSTINT1] = value
        buf[Dpr.MINTACC] = 0
        self.raise_line(value)

    def clear(self) -> None:
        """A reset: nothing queued."""
        self.queue.clear()


def _merge(a: tuple[int, int, int, int, int], b: tuple[int, int, int, int, int]
           ) -> tuple[int, int, int, int, int]:
    """Two posts as one when their addresses agree; else the newer (a full queue: the host has
    held the status window for MAX_QUEUED posts)."""
    if a[1] == b[1] and a[3] == b[3]:
        return a[0] | b[0], a[1], a[2] | b[2], a[3], a[4] | b[4]
    return b


def stat1_post(bit: int) -> tuple[int, int, int]:
    """(hostint, stat address, source address) of a DSPSTAT1 type bit (bit k's sources are at
    001h + k) [Table 6-2]."""
    return int(HostInt.STAT1), int(Dpr.DSPSTAT1), int(Dpr.DSPSTAT1) + 1 + bit.bit_length() - 1


def clear_dpr(buf: Memory) -> None:
    """RESET clears the whole 8K DPR [Ch7 Power-Up/Reset State]."""
    buf[:DPR_SIZE] = bytes(DPR_SIZE)
