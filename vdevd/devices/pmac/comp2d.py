"""Two-dimensional position compensation tables: DEFINE COMP {Rows}.{Columns}, DELETE COMP, LIST
COMP and the correction each servo cycle [A §"DEFINE COMP (two-dimensional)" L3118-3219; spec
pmac.md §1.7].

A table belongs to the addressed motor (one per motor); it corrects a target motor as a function
of the positions of a row motor and a column motor. Its (Rows+1)·(Columns+1) entries, in 1/16
count, are E_k with k = i·(Columns+1) + j for column-motor position i·ColumnSpan/Rows and
row-motor position j·RowSpan/Columns; E_0 is the implied zero, the others arrive as the next
integer constants after the DEFINE [A L3153-3167].
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vdevd.devices.pmac.ivars import MAX_MOTORS, IVars

I_ENABLE = 51           # I51: compensation tables enable [A L3135]
ERR_DATA = 3            # a malformed command or entry
ERR_BUFFER = 7          # buffer in use: table order / other buffers [A L3139, L3185; spec §1.9 item 13]

_NUMBER = r"(\d+(?:\.\d*)?|\.\d+)"
_DEFINE = re.compile(
    r"^\s*(?:DEF(?:INE)?\s*COMP\s*)?(\d+)\s*\.\s*(\d+)\s*"
    r",\s*#\s*(\d+)\s*(D?)"
    r"(?:\s*,\s*#\s*(\d+)\s*(D?)(?:\s*,\s*#\s*(\d+))?)?"
    rf"\s*,\s*{_NUMBER}\s*,\s*{_NUMBER}\s*$",
    re.IGNORECASE,
)


class CompError(Exception):
    """A rejected command; `code` is the ERRnnn number the card reports."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code


@dataclass(frozen=True)
class CompDefinition:
    """The parameters of one DEFINE COMP (motors 1-based)."""

    owner: int
    rows: int
    columns: int
    row_motor: int
    row_desired: bool
    column_motor: int
    column_desired: bool
    target: int
    row_span: float
    column_span: float

    @property
    def entry_count(self) -> int:
        """(Rows+1)·(Columns+1) − 1 constants follow the command [A L3135]."""
        return (self.rows + 1) * (self.columns + 1) - 1

    @property
    def column_spacing(self) -> float:
        """Counts of the row motor between columns: RowSpan/Columns [A L3151]."""
        return self.row_span / self.columns

    @property
    def row_spacing(self) -> float:
        """Counts of the column motor between rows: ColumnSpan/Rows [A L3151]."""
        return self.column_span / self.rows

    def text(self) -> str:
        """The command that defines this table, all motors explicit (LIST COMP DEF)."""
        rd, cd = "D" if self.row_desired else "", "D" if self.column_desired else ""
        return (f"DEFINE COMP {self.rows}.{self.columns},#{self.row_motor}{rd},#{self.column_motor}{cd},"
                f"#{self.target},{_num(self.row_span)},{_num(self.column_span)}")


def _num(v: float) -> str:
    return str(int(v)) if v == int(v) else repr(v)


def parse_define(text: str, motor: int) -> CompDefinition:
    """Parse the arguments of DEFINE COMP (with or without the command words) addressed to
    `motor`. One source motor: row source, column source and target = `motor`; two: row, column,
    target = `motor`; three: row, column, target [A L3141-3143]. CompError(3) if malformed."""
    m = _DEFINE.match(text)
    if m is None:
        raise CompError(ERR_DATA, f"bad DEFINE COMP arguments {text!r}")
    rows, columns = int(m[1]), int(m[2])
    row_motor = int(m[3])
    column_motor = int(m[5]) if m[5] else motor
    target = int(m[7]) if m[7] else motor
    row_span, column_span = float(m[8]), float(m[9])
    if rows < 1 or columns < 1 or row_span <= 0 or column_span <= 0:
        raise CompError(ERR_DATA, "rows, columns and spans must be positive")
    if not all(1 <= n <= MAX_MOTORS for n in (motor, row_motor, column_motor, target)):
        raise CompError(ERR_DATA, "motor out of range")
    return CompDefinition(motor, rows, columns, row_motor, bool(m[4]), column_motor, bool(m[6]),
                          target, row_span, column_span)


class CompTables:
    """The card's 2-D compensation tables (one per owning motor).

    `other_buffers` answers whether any TCOMP, BLCOMP, TBUF, ROTARY or GATHER buffer exists (they
    block DEFINE COMP [A L3139]); the card supplies it once it has those buffers.
    """

    def __init__(self, ivars: IVars, motors: int, other_buffers: Callable[[], bool] = lambda: False) -> None:
        self.ivars = ivars
        self.motors = motors
        self.other_buffers = other_buffers
        self.tables: dict[int, CompDefinition] = {}
        self.entries: dict[int, np.ndarray] = {}
        self.loading: int | None = None
        self._filled = 0
        self._pack()

    # -- commands --------------------------------------------------------------------------------
    def define(self, motor: int, text: str) -> CompDefinition:
        """`#{motor} DEFINE COMP {text}`. Refused with ERR007 while a table exists for a lower-numbered
        motor or another buffer exists; also (ASSUMPTION) when `motor` already owns a table. The
        next `entry_count` constants go to `feed`."""
        d = parse_define(text, motor)
        if any(owner <= motor for owner in self.tables) or self.other_buffers():
            raise CompError(ERR_BUFFER, "DEFINE COMP: define tables from high to low motor number, "
                                        "with no TCOMP, BLCOMP, TBUF, ROTARY or GATHER buffer")
        self.tables[motor] = d
        self.entries[motor] = np.zeros((d.rows + 1) * (d.columns + 1))
        self.loading, self._filled = motor, 0
        self._pack()
        return d

    @property
    def pending(self) -> int:
        """Entries still expected by the table being loaded."""
        if self.loading is None:
            return 0
        return self.tables[self.loading].entry_count - self._filled

    def feed(self, value: float) -> None:
        """The next entry constant, 1/16 count, integers only (CompError(3) otherwise)."""
        if self.loading is None or not self.pending:
            raise CompError(ERR_DATA, "no compensation table is waiting for entries")
        if value != int(value):
            raise CompError(ERR_DATA, "compensation table entries must be integers")
        self._filled += 1
        self.entries[self.loading][self._filled] = value
        self._flat[self._offsets[self.loading] + self._filled] = value
        if not self.pending:
            self.loading = None

    def delete(self, motor: int) -> None:
        """`#{motor} DELETE COMP`: tables go from low to high motor number [A L3139]; deleting while
        a lower-numbered motor owns a table is refused with ERR007 (ASSUMPTION). No table: no-op."""
        if motor not in self.tables:
            return
        if any(owner < motor for owner in self.tables):
            raise CompError(ERR_BUFFER, "DELETE COMP: delete tables from low to high motor number")
        del self.tables[motor]
        del self.entries[motor]
        if self.loading == motor:
            self.loading = None
        self._pack()

    def clear(self) -> None:
        """All tables gone ($$$***)."""
        self.tables.clear()
        self.entries.clear()
        self.loading = None
        self._pack()

    def list_text(self, motor: int) -> str | None:
        """LIST COMP: the entries of `motor`'s table as sent, one table row per line (row 0 without
        the implied E_0), or None when the motor owns no table (ASSUMPTION: layout)."""
        d = self.tables.get(motor)
        if d is None:
            return None
        e = self.entries[motor].astype(np.int64).reshape(d.rows + 1, d.columns + 1)
        lines = [" ".join(str(v) for v in (row[1:] if i == 0 else row)) for i, row in enumerate(e)]
        return "\n".join(lines) + "\n"

    def list_definition(self, motor: int) -> str | None:
        """LIST COMP DEF."""
        d = self.tables.get(motor)
        return None if d is None else d.text()

    # -- the servo cycle -------------------------------------------------------------------------
    def _pack(self) -> None:
        """Tables as arrays for one vectorised correction over all of them."""
        ds = [self.tables[m] for m in sorted(self.tables)]
        self._offsets: dict[int, int] = {}
        off = 0
        for d in ds:
            self._offsets[d.owner] = off
            off += (d.rows + 1) * (d.columns + 1)
        self._flat = np.concatenate([self.entries[d.owner] for d in ds]) if ds else np.zeros(0)
        self._off = np.array([self._offsets[d.owner] for d in ds], dtype=np.int64)
        self._rm = np.array([d.row_motor - 1 for d in ds], dtype=np.int64)
        self._rd = np.array([d.row_desired for d in ds], dtype=bool)
        self._cm = np.array([d.column_motor - 1 for d in ds], dtype=np.int64)
        self._cd = np.array([d.column_desired for d in ds], dtype=bool)
        self._tgt = np.array([d.target - 1 for d in ds], dtype=np.int64)
        self._rspan = np.array([d.row_span for d in ds])
        self._cspan = np.array([d.column_span for d in ds])
        self._rows = np.array([d.rows for d in ds], dtype=np.int64)
        self._cols = np.array([d.columns for d in ds], dtype=np.int64)

    def correction(self, actual: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The correction per motor (index motor−1), in counts, from the source motors' actual and
        desired positions (counts): bilinear interpolation in the table cell (ASSUMPTION, the
        addendum gives none), sources rolled over into 0..Span [A L3149]; the sum over tables
        that target the motor; zero unless I51 = 1. The card adds it to the target motor and shows
        it in Mxx69 (D:$000090 + $80·(motor−1))."""
        out = np.zeros(self.motors)
        if not self._off.size or self.ivars.values[I_ENABLE] != 1:
            return out
        pad = max(self.motors, MAX_MOTORS)
        act = np.zeros(pad)
        des = np.zeros(pad)
        act[: len(actual)] = actual
        des[: len(desired)] = desired
        x = np.mod(np.where(self._rd, des[self._rm], act[self._rm]), self._rspan)
        y = np.mod(np.where(self._cd, des[self._cm], act[self._cm]), self._cspan)
        fx = x / self._rspan * self._cols
        fy = y / self._cspan * self._rows
        j = np.minimum(np.floor(fx).astype(np.int64), self._cols - 1)
        i = np.minimum(np.floor(fy).astype(np.int64), self._rows - 1)
        tx, ty = fx - j, fy - i
        k = self._off + i * (self._cols + 1) + j
        e = self._flat
        below = e[k] * (1 - tx) + e[k + 1] * tx
        above = e[k + self._cols + 1] * (1 - tx) + e[k + self._cols + 2] * tx
        corr = (below * (1 - ty) + above * ty) / 16.0
        keep = self._tgt < self.motors
        np.add.at(out, self._tgt[keep], corr[keep])
        return out
