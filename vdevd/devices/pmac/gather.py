"""Data gathering: DEFINE GATHER, GATHER, ENDGATHER, DELETE GATHER, LIST GATHER and I5000-I5051
[spec pmac.md §2.2 "I5000-I5099 data gathering", §2.5 table, §3.3 "dls-pmac-control ... data
gathering"; README "Data gathering"].

I5001-I5048 name the sources: the top hex digit of the 24-bit value is the format, the low 20
bits the address [DLS-ctl gatherchannel.py: `"$%X%05X" % (size, address)`, first digit 0/4 a
24-bit word, 8 a 48-bit integer, C a 48-bit float]:

| digit | gathered | words |
|---|---|---|
| 0 | Y:{addr} | 1 |
| 4 | X:{addr} | 1 |
| 8 | X:Y of {addr} (D: format) | 2, low (Y) first |
| C | X:Y of {addr} (L: format) | 2, low (Y) first |

I5050 bit k-1 enables source k (1-24), I5051 bit k-25 source k (25-48) [DLS-ctl gather.py]; I5049
is the period in servo cycles (0 counts as 1, ASSUMPTION); I5000 the mode: 0 stop when the
buffer is full, 1 wrap (GATMODE of [PComm Gather.h]: GAT_RAM_NOWRAP, GAT_RAM_WRAP); 2 and 3 the
same into the DPRAM (GAT_DPR_NOWRAP, GAT_DPR_WRAP; dpram_gather.py has the layout and its
sources). I5000 at `DEFINE GATHER` places the buffer [Turbo SRM I5000: "where the data gathering
buffer will be located when it is defined"], I5000 at `GATHER` says whether it wraps.

A sample is the enabled sources' words in source order, padded with a zero word to a whole
number of 48-bit words; `DEFINE GATHER n` reserves n 48-bit words. LIST GATHER prints each 48-bit
word as 12 hex digits, X (high) then Y (low), one sample a line (16 words at most, a longer
sample goes on over the next lines), so a host that splits the text
and takes `[6:]` then `[:6]` of each word reads the words in the order the card wrote them, as
dls-pmaccontrol's `collectData` does [DLS-ctl gather.py].
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from vdevmaps.pmac import OPEN_USE_WORDS

from vdevd.devices.pmac.dpram import sign24
from vdevd.devices.pmac.dpram_gather import DpramGather
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.memory import TOP, Memory

ERR_BUFFER = 7  # buffer already in use [digest §2.4 error codes]
#: the 48-bit words DEFINE GATHER reserves without a size, and the most it may name (ASSUMPTION:
#: the open buffer memory of a standard Turbo PMAC, README "Data gathering")
MAX_WORDS = 0x30000
SOURCES = 48
#: 48-bit words a LIST GATHER line holds (12 digits and a space each: 207 characters, within the
#: DPRAM response buffer's 255, digest §2.10); a longer sample goes on over the next lines
LINE_WORDS = 16
#: global status word 1 bits [digest §2.1, X:$000006]
GATHER_ON_TRIGGER = 1 << 17
GATHER_ON = 1 << 19
#: I5001-I5048 format digit -> (spaces read, in buffer order)
FORMATS: dict[int, tuple[str, ...]] = {0x0: ("Y",), 0x4: ("X",), 0x8: ("Y", "X"), 0xC: ("Y", "X")}


def valid_source(value: int) -> bool:
    """An I5001-I5048 value the card can gather: a known format digit and an address in the
    Turbo data memory ($000000-$07FFFF)."""
    return (value >> 20) in FORMATS and (value & 0xFFFFF) <= TOP


class Gather:
    """The gather buffer and the gathering state of one card (sans-I/O)."""

    def __init__(self, memory: Memory, ivars: np.ndarray) -> None:
        self.memory = memory
        self.iv = ivars                # the card's I-variable values
        self.size = 0                  # 48-bit words reserved (0: no buffer)
        self.on = False
        self.words = np.zeros(0, dtype=np.uint32)  # the buffer as 24-bit words, Y X Y X ...
        self.samples = 0               # samples written since GATHER
        self.per_sample = 0            # 24-bit words a sample takes (even)
        self.capacity = 0              # samples the buffer holds
        self.wrap = False
        self.period = 1
        self.countdown = 0             # servo cycles to the next sample
        self._reads: list[tuple[Callable[[str, int], int], str, int]] = []
        #: the DPRAM buffer (the card's; None: no DPRAM, I5000 = 2 or 3 refused) and whether the
        #: defined buffer is there
        self.dpram: DpramGather | None = None
        self.in_dpram = False

    @property
    def defined(self) -> bool:
        return self.size > 0

    # -- commands ------------------------------------------------------------------------------
    def define(self, size: int | None) -> None:
        """`DEFINE GATHER [n]`: reserve n 48-bit words (all of MAX_WORDS without n), or with
        I5000 = 2 or 3 n 32-bit words of the DPRAM's open-use space (all of it without n).
        ERR007 while gathering; an existing buffer is replaced (ASSUMPTION, README)."""
        if self.on:
            raise CommandError(ERR_BUFFER, "DEFINE GATHER while gathering")
        in_dpram = int(self.iv[5000]) >= 2
        if in_dpram and self.dpram is None:
            raise CommandError(ERR_DATA, "DEFINE GATHER in the DPRAM: no DPRAM")
        top = OPEN_USE_WORDS if in_dpram else MAX_WORDS
        n = top if size is None else size
        if not 1 <= n <= top:
            raise CommandError(ERR_DATA, f"DEFINE GATHER {n}: 1-{top} words")
        self.size, self.in_dpram = n, in_dpram
        if self.dpram is not None and in_dpram:
            self.dpram.define(n)
            self.words = np.zeros(0, dtype=np.uint32)
            self.samples = 0
            return
        self.words = np.zeros(2 * n, dtype=np.uint32)
        self.samples = 0

    def delete(self) -> None:
        """`DELETE GATHER`: the buffer goes; ERR007 while gathering (ASSUMPTION)."""
        if self.on:
            raise CommandError(ERR_BUFFER, "DELETE GATHER while gathering")
        self.size = 0
        self.words = np.zeros(0, dtype=np.uint32)
        self.samples = 0
        if self.dpram is not None and self.in_dpram:
            self.dpram.define(0)  # ASSUMPTION: the size register reads 0 with no buffer
        self.in_dpram = False

    def start(self) -> None:
        """`GATHER`: gathering starts afresh at the buffer's start, with the sources, mask,
        period and mode as they are now; the first sample is taken at the next servo cycle.
        ERR003 without a buffer or with no source enabled (ASSUMPTION)."""
        if not self.defined:
            raise CommandError(ERR_DATA, "GATHER without DEFINE GATHER")
        iv = self.iv
        mask = int(iv[5050]) | int(iv[5051]) << 24
        reads: list[tuple[Callable[[str, int], int], str, int]] = []
        for k in range(SOURCES):
            if mask >> k & 1:
                value = int(iv[5001 + k])
                if not valid_source(value):  # only a restored image can hold one
                    raise CommandError(ERR_DATA, f"I{5001 + k}: no such gather source")
                addr = value & 0xFFFFF
                dev = self.memory.device(addr)
                read = self._plain() if dev is None else _masked(dev.read_word)
                reads.extend((read, space, addr) for space in FORMATS[value >> 20])
        if not reads:
            raise CommandError(ERR_DATA, "GATHER with no source enabled (I5050, I5051)")
        self._reads = reads
        if self.dpram is not None and self.in_dpram:  # one 32-bit word per 24-bit word, no pad
            self.per_sample = len(reads)
            self.capacity = self.dpram.begin(self.per_sample, self.size)
        else:
            self.per_sample = len(reads) + len(reads) % 2
            self.capacity = 2 * self.size // self.per_sample
        self.wrap = int(iv[5000]) in (1, 3)
        self.period = max(int(iv[5049]), 1)
        self.countdown = 1
        self.samples = 0
        self.words[:] = 0
        self.on = True

    def stop(self) -> None:
        """`ENDGATHER`: gathering stops; the buffer keeps what was gathered."""
        self.on = False

    def reset(self) -> None:
        """`$$$`, `$$$***`: gathering stops and the buffer is gone (ASSUMPTION)."""
        self.on = False
        self.delete()

    def _plain(self) -> Callable[[str, int], int]:
        """A plain word of memory (no device mounted there)."""
        mem = self.memory
        return lambda space, a: (mem.x if space == "X" else mem.y).get(a, 0)

    # -- servo cycle -----------------------------------------------------------------------------
    def tick(self) -> None:
        """One servo cycle while gathering: a sample every `period` cycles."""
        self.countdown -= 1
        if self.countdown:
            return
        self.countdown = self.period
        if not self.capacity:  # not one sample fits
            self.on = False
            return
        k = self.per_sample
        start = (self.samples % self.capacity) * k
        row = [read(space, addr) for read, space, addr in self._reads]
        self.samples += 1
        if self.dpram is not None and self.in_dpram:
            # the index of the next item: 0 again after the last sample when wrapping
            nxt = (self.samples % self.capacity if self.wrap else self.samples) * k
            self.dpram.post(start, sign24(np.array(row, dtype=np.int64)), nxt)
        else:
            self.words[start:start + len(row)] = row
        if self.samples >= self.capacity and not self.wrap:
            self.on = False  # full (I5000 = 0): gathering ends [PComm Gather.h GAT_RAM_NOWRAP]

    # -- LIST GATHER -----------------------------------------------------------------------------
    def list_lines(self) -> list[str]:
        """The gathered samples, one a line (LINE_WORDS at most), each 48-bit word as 12 hex
        digits X then Y; after a wrap, the whole buffer in memory order. Nothing for a buffer in
        the DPRAM: the host reads it there (ASSUMPTION)."""
        if not self.defined or not self.per_sample or self.in_dpram:
            return []
        n = min(self.samples, self.capacity)
        k = self.per_sample
        w = self.words[:n * k].reshape(n, k // 2, 2).astype(np.int64)
        longs = (w[:, :, 1] << 24) | w[:, :, 0]
        return [" ".join(f"{int(v):012X}" for v in row[i:i + LINE_WORDS])
                for row in longs for i in range(0, len(row), LINE_WORDS)]


def _masked(read: Callable[[str, int], int]) -> Callable[[str, int], int]:
    return lambda space, addr: read(space, addr) & 0xFFFFFF
