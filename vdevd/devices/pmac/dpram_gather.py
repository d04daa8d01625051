"""The DPRAM data gathering buffer (I5000 = 2 or 3), without I/O.

Sources:
- Turbo PMAC User Manual p.422 "Real-Time Data Gathering Through the Dual-Ported RAM" (manualsbrain
  797543 page 438): I5000 = 3 selects the DPRAM; `DEFINE GATHER {constant}` sizes the buffer in
  Turbo PMAC words, each 32 bits in the DPRAM; the buffer always starts at $060450, host offset
  0x1140; a short source takes one 32-bit word, a long (fixed or floating) source two.
- The same text in the ACC-24E2 manual (geabb.com/product/acc-24e2-4-axis): the size is stored at
  0x113C; as the card gathers it advances the pointer at 0x113E, "the address offset where the
  next item to be gathered will be placed", which the host watches.
- Turbo SRM `DEFINE GATHER` (p.307): with I5000 = 2 or 3 the size counts 32-bit DPRAM words; a
  size that is not a whole number of samples grows to the next multiple.
- PMAC(1) DPRAM User Manual p.26 (the same function at $D1FF/$D200): 24-bit values sign-extended
  to 32 bits, a 48-bit value as its two 24-bit halves each sign-extended, low word first; with no
  wrap, once the index reaches the size `DEFINE GATHER` must be given again.
- EPICS tpmac drvPmac.c `drvPmacGatRead` (the PMAC(1) layout): the index counts 32-bit words from
  the buffer's start and the host wraps at the size; PComm32 dpr.h `struct gatbuf` {bufsize,
  bufstart}: Y word the size, X word the index.
"""

from __future__ import annotations

import struct

import numpy as np
from vdevmaps.pmac import GAT_BUFFER, GAT_INDEX, GAT_SIZE, OPEN_USE_WORDS

from vdevd.region import Memory


class DpramGather:
    """Y:$06044F size, X:$06044F next-item offset, and the ring of 32-bit words from $060450."""

    def __init__(self, mem: Memory) -> None:
        self.mem = mem
        self.ring = np.frombuffer(mem, dtype="<i4", count=OPEN_USE_WORDS, offset=GAT_BUFFER)

    def define(self, words: int) -> None:
        """`DEFINE GATHER`: the size register holds the words reserved, the index 0."""
        struct.pack_into("<HH", self.mem, GAT_SIZE, words & 0xFFFF, 0)

    def begin(self, per_sample: int, words: int) -> int:
        """`GATHER` with `per_sample` words a sample: the buffer grows to a whole number of
        samples (Turbo SRM DEFINE GATHER), within the open-use space (ASSUMPTION: a size that
        would pass $060FFF is cut to the samples that fit); the size register says the words
        used, the index restarts at 0. Returns the samples the buffer holds."""
        fit = OPEN_USE_WORDS // per_sample
        capacity = min(-(-words // per_sample), fit)
        struct.pack_into("<HH", self.mem, GAT_SIZE, capacity * per_sample, 0)
        return capacity

    def post(self, at: int, row: np.ndarray, index: int) -> None:
        """A sample's words (already sign-extended) at word `at`, then the index of the next."""
        self.ring[at:at + len(row)] = row
        struct.pack_into("<H", self.mem, GAT_INDEX, index)

