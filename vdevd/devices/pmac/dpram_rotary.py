"""The DPRAM binary rotary program buffer (I45): the host's ring of program lines, without I/O.

Sources:
- PComm32 dpr.h `struct rotbuf` (with its Turbo notes): Y:$060414 the status (bits 0-7 error
  code, bit 14 "internal rotary buffer full", bit 15 error flag), X:$060414 the coordinate
  system, Y:$060415 the host index, X:$060415 the PMAC index, Y:$060416 the size, X:$060416 the
  start ("TURBO = offset from fixed buf", $060450). Turbo UM p.402: control at 0x1050 ($060414);
  p.45: "DPRAM Binary Rotary Buffer Foreground Transfer: I45".
- PMAC(1) DPRAM User Manual p.30 "DPRAM Binary Rotary Program Buffer": the host sets start and
  size, both indexes to 0, fills the buffer with whole lines, then moves its index; empty when the
  PMAC index equals the host index; the host must not write when PMAC index = (host index + 4) %
  size; after each transfer the host leaves the end-of-buffer command ($0800, $FFFF) at its index;
  the smallest size is six words; the card copies each command into the coordinate system's
  rotary program buffer, as if it had come as text.

ASSUMPTIONS (README "Binary rotary buffer"): Delta Tau's binary coding of program commands was
not published ("Contact the factory for details", PMAC1 DPRAM UM p.30), so a line travels as a
header word (its length in characters, 1-255) and its ASCII text, four characters a 32-bit word,
NUL-padded; a real PComm32 binary stream does not decode here. Indexes count 32-bit words from the
ring's start, a line may wrap past the ring's end, the end-of-buffer word is 0xFFFF0800. The card
takes up to LINES_PER_CYCLE lines each servo cycle while I45 = 1; a line the rotary buffer cannot
take now (ERR006, full) stays, with bit 14 set, and is offered again next cycle; a line it refuses
(any other error) is dropped with bit 15 and the error number in bits 0-7, until the host clears
the status word (the card takes no line while bit 15 is set).
"""

from __future__ import annotations

import struct
from collections.abc import Callable

from vdevmaps.pmac import (
    DPRAM_SIZE,
    OPEN_USE,
    ROT_BUSY,
    ROT_CS,
    ROT_END,
    ROT_ERROR,
    ROT_HOST,
    ROT_MIN_SIZE,
    ROT_PMAC,
    ROT_SIZE,
    ROT_START,
    ROT_STATUS,
)

from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.region import Memory

ERR_NO_ROOM = 6  # the rotary buffer is full [SRM; rotary buffers]
LINES_PER_CYCLE = 16
MAX_TEXT = 255  # characters a line (vdevmaps.pmac.rot_line_words codes it)

_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")


def _no_rotary_buffer(cs: int, text: str) -> None:
    raise CommandError(ERR_DATA, f"C.S. {cs} has no rotary buffer")


class BinaryRotary:
    """The ring over the DPRAM bytes `mem`. `on_rotary_line(cs, text)` hands a line to C.S. cs's
    rotary buffer (raising CommandError: ERR006 when full, another code when refused); by default
    no C.S. has one (ERR003)."""

    def __init__(self, mem: Memory) -> None:
        self.mem = mem
        self.on_rotary_line: Callable[[int, str], None] = _no_rotary_buffer

    def _u16(self, at: int) -> int:
        return int(_U16.unpack_from(self.mem, at)[0])

    def _ring(self) -> tuple[int, int] | None:
        """(byte offset of word 0, size in words), None when not set up or past the DPRAM."""
        size = self._u16(ROT_SIZE)
        base = OPEN_USE + 4 * self._u16(ROT_START)
        if size < ROT_MIN_SIZE or base + 4 * size > DPRAM_SIZE:
            return None
        return base, size

    def due(self) -> bool:
        """Lines wait (the indexes differ) and no error waits for the host."""
        ring = self._ring()
        if ring is None or self._u16(ROT_STATUS) & ROT_ERROR:
            return False
        return self._u16(ROT_PMAC) % ring[1] != self._u16(ROT_HOST) % ring[1]

    def service(self) -> None:
        """Take the waiting lines (at most LINES_PER_CYCLE) into the coordinate system's rotary
        buffer, each advancing the PMAC index past it."""
        ring = self._ring()
        if ring is None:
            return
        base, size = ring
        mem = self.mem
        cs = self._u16(ROT_CS)
        for _ in range(LINES_PER_CYCLE):
            pmac, host = self._u16(ROT_PMAC) % size, self._u16(ROT_HOST) % size
            status = self._u16(ROT_STATUS)
            if pmac == host or status & ROT_ERROR:
                return
            head = int(_U32.unpack_from(mem, base + 4 * pmac)[0])
            if head == ROT_END:
                return
            n = head & 0xFFFF
            words = -(-n // 4)
            if not 1 <= n <= MAX_TEXT or (host - pmac) % size < 1 + words:
                self._error(ERR_DATA, host)  # not a line: dropped up to the host's index
                return
            at = [base + 4 * ((pmac + 1 + k) % size) for k in range(words)]
            raw = b"".join(bytes(mem[o:o + 4]) for o in at)
            text = raw[:n].decode("latin-1")
            try:
                self.on_rotary_line(cs, text)
            except CommandError as exc:
                if exc.code == ERR_NO_ROOM:
                    _U16.pack_into(mem, ROT_STATUS, status | ROT_BUSY)
                    return
                self._error(exc.code, (pmac + 1 + words) % size)
                return
            _U16.pack_into(mem, ROT_STATUS, status & ~ROT_BUSY & 0xFFFF)
            _U16.pack_into(mem, ROT_PMAC, (pmac + 1 + words) % size)

    def _error(self, code: int, at: int) -> None:
        """Bit 15 and the error number; the PMAC index past the refused line."""
        _U16.pack_into(self.mem, ROT_STATUS, ROT_ERROR | (code & 0xFF))
        _U16.pack_into(self.mem, ROT_PMAC, at)
