"""The on-board 32K-word static RAM and its overlapping tables [Ch8 Table 8-1; spec octavia.md §6].

One `uint16[32768]` array with real aliasing: the cam table, the internal cubic-spline table and
compensation tables 1-4 all live in 2000h..3FFFh, so LOAD_CUBIC_TABLE overwrites cam points and
compensation entries exactly as on the card [Ch5 LOAD_* notes].

Assumptions (the manual gives only the word ranges of Table 8-1):

* Layouts of spec §6.1: cam point i (0..1599) at 2000h + 5i = master LSW, MSW, slave LSW, MSW,
  ratio; cubic point i (0..4095) at 2000h + 2i = LSW, MSW; position table t (1..8) at
  2000h + (t−1)·800h, velocity table t at 2400h + (t−1)·800h, 1024 words each.
* Values are stored modulo 2^16 per word (an int32 keeps its low 32 bits, a ratio its low 16),
  as the card's 16-bit stores do; compensation entries are raw words (their format is in the
  *Table Compensation Application Notes*, not included; spec Q-26).
* A store or read that would run past a table's capacity raises ValueError and writes nothing
  (spec Q-37: bound-check index + num ≤ capacity); the firmware turns it into its report.
* The state-file image is the 64 KiB of words, little-endian.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

RAM_WORDS = 0x8000           # 32K words [Ch8]
TABLE_BASE = 0x2000          # start of the cam / cubic / compensation area [Ch8 Table 8-1]
CUBIC_AREA_END = 0x4000      # CLEAR_CUBIC_TABLE clears 2000h..3FFFh (spec §6.1)

CAM_POINTS = 1600            # [Ch5 CAM, LOAD_CAM_TABLE]
CAM_POINT_WORDS = 5          # master i32, slave i32, ratio i16
CUBIC_POINTS = 4096          # [Ch5 LOAD_CUBIC_TABLE]
COMP_TABLES = 8              # position and velocity tables 1..8 [Ch8]
COMP_ENTRIES = 1024          # [Ch5 LOAD_POS_TABLE, LOAD_VEL_TABLE]
POS_TABLE_BASE = 0x2000
VEL_TABLE_BASE = 0x2400
COMP_TABLE_STRIDE = 0x800

IntArray = npt.NDArray[np.int64]


def wrap_i32(values: npt.ArrayLike) -> IntArray:
    """Values modulo 2^32 as two's complement int32, held in int64 (positions roll over)."""
    v = np.asarray(values, dtype=np.int64)
    return ((v + 0x8000_0000) & 0xFFFF_FFFF) - 0x8000_0000


def table_numbers(mask: int) -> list[int]:
    """The table numbers (1..8) a bit-coded table byte selects: bit 0 = table 1 [Ch5 CLEAR_POS_TABLE]."""
    if not 0 <= mask <= 0xFF:
        raise ValueError(f"table mask {mask:#x} is not a byte")
    return [t for t in range(1, COMP_TABLES + 1) if mask >> (t - 1) & 1]


def _check_span(what: str, index: int, count: int, capacity: int) -> None:
    if index < 0 or count < 0 or index + count > capacity:
        raise ValueError(f"{what}: index {index} + count {count} exceeds the {capacity} available")


def _check_table(table: int) -> None:
    if not 1 <= table <= COMP_TABLES:
        raise ValueError(f"compensation table {table} is not 1..{COMP_TABLES}")


def _int_array(values: npt.ArrayLike) -> IntArray:
    return np.atleast_1d(np.asarray(values, dtype=np.int64))


class BoardRam:
    """The card's static RAM (`words`, uint16[32768]) and typed views of its tables [Ch8]."""

    def __init__(self) -> None:
        self.words: npt.NDArray[np.uint16] = np.zeros(RAM_WORDS, dtype=np.uint16)

    # --- cam table: 1600 points of 5 words at 2000h [Ch5 LOAD_CAM_TABLE, CAM_POINT] ---

    def _cam_rows(self) -> npt.NDArray[np.uint16]:
        end = TABLE_BASE + CAM_POINTS * CAM_POINT_WORDS
        return self.words[TABLE_BASE:end].reshape(CAM_POINTS, CAM_POINT_WORDS)

    def cam_points(self, start: int, size: int) -> tuple[IntArray, IntArray, IntArray]:
        """(master, slave, ratio) of cam points start..start+size−1; ratios are the raw ×128 codes."""
        _check_span("cam table", start, size, CAM_POINTS)
        rows = self._cam_rows()[start:start + size].astype(np.int64)
        master = wrap_i32(rows[:, 0] | rows[:, 1] << 16)
        slave = wrap_i32(rows[:, 2] | rows[:, 3] << 16)
        ratio = rows[:, 4] - ((rows[:, 4] & 0x8000) << 1)
        return master, slave, ratio

    def store_cam_points(self, index: int, master: npt.ArrayLike, slave: npt.ArrayLike,
                         ratio: npt.ArrayLike) -> None:
        """Write cam points from `index` on (LOAD_CAM_TABLE's 10-byte points, or one CAM_POINT)."""
        m, s, r = _int_array(master), _int_array(slave), _int_array(ratio)
        if not len(m) == len(s) == len(r):
            raise ValueError("cam points: master, slave and ratio differ in length")
        _check_span("cam table", index, len(m), CAM_POINTS)
        rows = self._cam_rows()[index:index + len(m)]
        rows[:, 0], rows[:, 1] = m & 0xFFFF, m >> 16 & 0xFFFF
        rows[:, 2], rows[:, 3] = s & 0xFFFF, s >> 16 & 0xFFFF
        rows[:, 4] = r & 0xFFFF

    # --- internal cubic-spline table: 4096 int32 at 2000h [Ch5 LOAD_CUBIC_TABLE] ---

    def _cubic_pairs(self) -> npt.NDArray[np.uint16]:
        return self.words[TABLE_BASE:CUBIC_AREA_END].reshape(CUBIC_POINTS, 2)

    def cubic_points(self, start: int, count: int) -> IntArray:
        """Cubic-table positions start..start+count−1 (int32 values)."""
        _check_span("cubic table", start, count, CUBIC_POINTS)
        pairs = self._cubic_pairs()[start:start + count].astype(np.int64)
        return wrap_i32(pairs[:, 0] | pairs[:, 1] << 16)

    def store_cubic_points(self, index: int, values: npt.ArrayLike) -> None:
        """Write cubic-table positions from `index` on (LOAD_CUBIC_TABLE)."""
        v = _int_array(values)
        _check_span("cubic table", index, len(v), CUBIC_POINTS)
        pairs = self._cubic_pairs()[index:index + len(v)]
        pairs[:, 0], pairs[:, 1] = v & 0xFFFF, v >> 16 & 0xFFFF

    def clear_cubic(self) -> None:
        """CLEAR_CUBIC_TABLE: zero 2000h..3FFFh, which also erases the cam table and compensation
        tables 1-4 (spec §6.1)."""
        self.words[TABLE_BASE:CUBIC_AREA_END] = 0

    # --- compensation tables 1..8, 1024 words each [Ch5 LOAD_POS_TABLE, LOAD_VEL_TABLE] ---

    def _comp(self, base: int, table: int) -> npt.NDArray[np.uint16]:
        _check_table(table)
        start = base + (table - 1) * COMP_TABLE_STRIDE
        return self.words[start:start + COMP_ENTRIES]

    def pos_table(self, table: int) -> npt.NDArray[np.uint16]:
        """A copy of position compensation table `table` (1..8)."""
        return self._comp(POS_TABLE_BASE, table).copy()

    def vel_table(self, table: int) -> npt.NDArray[np.uint16]:
        """A copy of velocity compensation table `table` (1..8)."""
        return self._comp(VEL_TABLE_BASE, table).copy()

    def store_pos_table(self, mask: int, index: int, values: npt.ArrayLike) -> None:
        """LOAD_POS_TABLE: write `values` from `index` on into every table whose bit is set in
        `mask` (spec Q-37: several bits write each table)."""
        self._store_comp(POS_TABLE_BASE, mask, index, values)

    def store_vel_table(self, mask: int, index: int, values: npt.ArrayLike) -> None:
        """LOAD_VEL_TABLE: as `store_pos_table`, into the velocity tables."""
        self._store_comp(VEL_TABLE_BASE, mask, index, values)

    def _store_comp(self, base: int, mask: int, index: int, values: npt.ArrayLike) -> None:
        v = _int_array(values) & 0xFFFF
        _check_span("compensation table", index, len(v), COMP_ENTRIES)
        for table in table_numbers(mask):
            self._comp(base, table)[index:index + len(v)] = v

    def clear_pos_table(self, mask: int) -> None:
        """CLEAR_POS_TABLE: zero the position tables whose bits are set in `mask`."""
        for table in table_numbers(mask):
            self._comp(POS_TABLE_BASE, table)[:] = 0

    def clear_vel_table(self, mask: int) -> None:
        """CLEAR_VEL_TABLE: zero the velocity tables whose bits are set in `mask`."""
        for table in table_numbers(mask):
            self._comp(VEL_TABLE_BASE, table)[:] = 0

    # --- non-volatile image [Ch7: reset keeps the tables; battery option: power-off too] ---

    def to_bytes(self) -> bytes:
        """The RAM image for the state file: 32768 little-endian words."""
        return self.words.astype("<u2").tobytes()

    @classmethod
    def from_bytes(cls, data: bytes | bytearray | memoryview) -> BoardRam:
        """A RAM restored from `to_bytes`' image."""
        if len(data) != RAM_WORDS * 2:
            raise ValueError(f"RAM image is {len(data)} bytes, not {RAM_WORDS * 2}")
        ram = cls()
        ram.words[:] = np.frombuffer(data, dtype="<u2")
        return ram
