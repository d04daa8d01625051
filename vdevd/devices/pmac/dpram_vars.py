"""The DPRAM background variable read and write buffers (I55), without I/O.

Sources:
- Turbo PMAC User Manual p.407-410 "DPRAM Background Variable Read Buffer" / "... Write Buffer"
  (manualsbrain 797543 pages 423, 425, 426): up to 128 registers copied into the DPRAM during the
  background cycle, single-user mode (bit 8 of 0x1044 clear) or multi-user (set); a 4-word header
  at 0x1044, two 16-bit words of address specification per register from the start the header
  names, then the data: a short (X or Y) register two 16-bit words, a long one four, each 24-bit
  half sign-extended to 32 bits, "the same as for data gathering to dual-ported RAM"; the host
  checks bit 15 of an entry's data type specifier (data ready) and clears it when done; the
  size register 0x1048 (Y:$060412) = 0 disables. The write buffer: up to 32 registers, a 2-word
  header at $060413: 0x104C (Y) the number of entries (1-32; the card writes 0 when it has
  copied them), 0x104E (X) the start, as a Turbo PMAC word offset from $060450 ($0000-$0BAF for
  the 8k x 16 DPRAM); six 16-bit words an entry: the low 16 bits of the address, a word of
  "type, width, offset, and high 3 bits of address", and the data; address 0 ends the list.
- EPICS tpmac pmacApp/src/drvPmac.c `drvPmacVarSetup`/`drvPmacVarRead` (a working Turbo host):
  0x1048 := 0, 0x104A := start offset, each entry's words (address, type: PMAC_VARTYP_Y 0x00,
  PMAC_VARTYP_L 0x10, PMAC_VARTYP_X 0x20), 0x1048 := entries, 0x1044 := 0; then waits for bit 0
  of 0x1044 (data ready), reads the data, writes 0 to 0x1044 for the next; X:$060411 is the
  buffer's time stamp.
- PComm32 dprbkg.h `struct backgvar` {dataready, servotimer, bufsize, bufstart},
  `backgvarwrite` {num_entries, buf_start}, `VBGWFormat` {long type_addr, data1, data2}.

ASSUMPTIONS (README "Variable buffers"): the type word's bits 0-2 are address bits 16-18 and bits
4-5 the register (0 Y, 1 L, 2 X; 3 is skipped); its width/offset bits (a bit field) are not
known and are ignored, whole registers are copied; a write entry's data are VBGWFormat's data1
(the Y or X value, an L register's Y half) and data2 (an L register's X half), 32 bits each;
X:$060411 holds the servo-cycle count's low 16 bits when a single-user update is posted.
"""

from __future__ import annotations

import struct

from vdevmaps.pmac import (
    DPRAM_SIZE,
    OPEN_USE,
    VB_CONTROL,
    VB_ENTRY_READY,
    VB_MAX_ENTRIES,
    VB_MULTI_USER,
    VB_READY,
    VB_SIZE,
    VB_START,
    VB_TIMER,
    VB_TYPE_L,
    VB_TYPE_X,
    VB_TYPE_Y,
    VBW_MAX_ENTRIES,
    VBW_SIZE,
    VBW_START,
)

from vdevd.devices.pmac.memory import Memory as PmacMemory
from vdevd.devices.pmac.numbers import from_pmac_float_words
from vdevd.region import Memory

_U16 = struct.Struct("<H")
_I32 = struct.Struct("<i")
_WRITE_ENTRY = struct.Struct("<HHii")  # address, type word, data1, data2 (VBGWFormat)


def _sign32(word: int) -> int:
    word &= 0xFFFFFF
    return word - 0x1000000 if word & 0x800000 else word


def _spec(type_word: int, low: int) -> tuple[int, str | None]:
    """(Turbo address, register: "Y", "X", "L" or None) of an address specification."""
    kind = {VB_TYPE_Y: "Y", VB_TYPE_X: "X", VB_TYPE_L: "L"}.get(type_word & 0x30)
    return (type_word & 0x7) << 16 | low, kind


class VariableBuffers:
    """The read and write buffers over the DPRAM bytes `mem`, reading and writing the card's X/Y
    memory `memory`. `due()` says whether the host waits for either; `service(cycle)` serves."""

    def __init__(self, mem: Memory, memory: PmacMemory) -> None:
        self.mem = mem
        self.memory = memory

    def _u16(self, at: int) -> int:
        return int(_U16.unpack_from(self.mem, at)[0])

    # -- requests -------------------------------------------------------------------------------
    def _read_table(self) -> tuple[int, int]:
        """(first specification's byte offset, entries) of the read buffer; 0 entries when off or
        when the table would pass the end of the DPRAM."""
        n = self._u16(VB_SIZE)
        at = OPEN_USE + 4 * self._u16(VB_START)
        if not 1 <= n <= VB_MAX_ENTRIES or at + 4 * n > DPRAM_SIZE:
            return at, 0
        return at, n

    def read_requested(self) -> bool:
        """Single-user: the data-ready bit (0x1044 bit 0) is clear; multi-user: some entry's
        data-ready bit (its type word's bit 15) is clear."""
        at, n = self._read_table()
        if not n:
            return False
        control = self._u16(VB_CONTROL)
        if control & VB_MULTI_USER:
            return any(not self._u16(at + 4 * i + 2) & VB_ENTRY_READY for i in range(n))
        return not control & VB_READY

    def write_requested(self) -> bool:
        return 1 <= self._u16(VBW_SIZE) <= VBW_MAX_ENTRIES

    def due(self) -> bool:
        return self.write_requested() or self.read_requested()

    def service(self, cycle: int) -> None:
        """One background pass: the write buffer first (so a read in the same pass sees it)."""
        if self.write_requested():
            self._write()
        if self.read_requested():
            self._read(cycle)

    # -- read buffer ----------------------------------------------------------------------------
    def _read(self, cycle: int) -> None:
        at, n = self._read_table()
        mem, memory = self.mem, self.memory
        multi = bool(self._u16(VB_CONTROL) & VB_MULTI_USER)
        data = at + 4 * n
        for i in range(n):
            low, type_word = struct.unpack_from("<HH", mem, at + 4 * i)
            addr, kind = _spec(type_word, low)
            width = 8 if kind == "L" else 4
            if data + width > DPRAM_SIZE:
                break
            if kind is not None and not (multi and type_word & VB_ENTRY_READY):
                if kind == "L":
                    struct.pack_into("<ii", mem, data, _sign32(memory.read("Y", addr)),
                                     _sign32(memory.read("X", addr)))
                else:
                    _I32.pack_into(mem, data, _sign32(memory.read(kind, addr)))
                if multi:
                    _U16.pack_into(mem, at + 4 * i + 2, type_word | VB_ENTRY_READY)
            data += width
        if not multi:
            _U16.pack_into(mem, VB_TIMER, cycle & 0xFFFF)
            _U16.pack_into(mem, VB_CONTROL, self._u16(VB_CONTROL) | VB_READY)

    # -- write buffer ---------------------------------------------------------------------------
    def _write(self) -> None:
        """Copy the entries into the card, up to the first of address 0, then 0 to the size."""
        mem, memory = self.mem, self.memory
        at = OPEN_USE + 4 * self._u16(VBW_START)
        for i in range(self._u16(VBW_SIZE)):
            entry = at + _WRITE_ENTRY.size * i
            if entry + _WRITE_ENTRY.size > DPRAM_SIZE:
                break
            low, type_word, data1, data2 = _WRITE_ENTRY.unpack_from(mem, entry)
            addr, kind = _spec(type_word, low)
            if not addr:
                break
            if kind == "L":
                dev = memory.device(addr)
                if dev is not None and hasattr(dev, "write_float"):
                    memory.write_float(addr, from_pmac_float_words(data2 & 0xFFFFFF,
                                                                   data1 & 0xFFFFFF))
                else:
                    memory.write("Y", addr, data1)
                    memory.write("X", addr, data2)
            elif kind is not None:
                memory.write(kind, addr, data1)
        _U16.pack_into(mem, VBW_SIZE, 0)
