"""One-dimensional compensation tables and backlash: DEFINE COMP (one source), DEFINE BLCOMP,
DEFINE TCOMP, their DELETE and LIST forms, I30 (wrap at download), Ixx85-Ixx87 (backlash) and the
position correction of each servo cycle [Turbo SRM "DEFINE COMP (one-dimensional)", "DEFINE
BLCOMP", "DEFINE TCOMP", I30 [A L1420-1432], Ixx85-Ixx87; spec pmac.md §1.7, §2.2].

Tables [Turbo SRM]: `DEFINE COMP {entries},[#{source}[D],[#{target},]]{count length}` belongs to
the addressed motor (one COMP table per motor, 1-D or 2-D); the source defaults to the addressed
motor, the target to the addressed motor; `D` reads the source's desired position.
`DEFINE BLCOMP {entries},{count length}` and `DEFINE TCOMP {entries},{count length}` act on the
addressed motor as a function of its own position. The next {entries} integer constants (1/16
count) are the entries: entry k is the correction at k·length/entries; the correction at 0 is 0,
or (I30 = 1, applied as the table is downloaded) the last entry [A L1426-1432]. The source
position is rolled over into 0..length and the correction interpolated linearly between entries.

Corrections [Turbo SRM, Turbo UM "Backlash Compensation"]: a leadscrew table's correction is
added to its target motor's position in both directions (as the 2-D table's, comp2d.py). Backlash:
when the commanded position reverses by more than Ixx87 (1/16 count), the card takes up Ixx86
(1/16 count) plus the backlash table's value at the nominal position, at Ixx85 (1/16 count per
background cycle, here per servo cycle: ASSUMPTION), subtracted from the commanded position while
the most recent direction is negative; Ixx85 = 0 disables backlash. Tables act only with I51 = 1;
the constant Ixx86 acts whatever I51. TCOMP tables are kept, listed and saved; their correction
(on the servo output) is not applied (README "Not emulated").
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vdevd.devices.pmac.comp2d import ERR_BUFFER, ERR_DATA, I_ENABLE, CompError
from vdevd.devices.pmac.ivars import MAX_MOTORS, IVars

I_WRAP = 30                  # I30: table wrap at download [A L1420-1432]
MAX_ENTRIES = 65_536         # per table (ASSUMPTION: the card's table memory bounds it; see README)
KINDS = ("COMP", "BLCOMP", "TCOMP")
#: the buffers above each table kind in Turbo memory: a DEFINE is refused (ERR007) while any exists
#: [Turbo SRM DEFINE COMP/BLCOMP; ASSUMPTION for TCOMP, README "Compensation tables"]
BLOCKED_BY = {
    "COMP": ("BLCOMP", "TCOMP", "TBUF", "ROTARY", "LOOKAHEAD", "GATHER"),
    "BLCOMP": ("TCOMP", "TBUF", "ROTARY", "LOOKAHEAD", "GATHER"),
    "TCOMP": ("TBUF", "ROTARY", "LOOKAHEAD", "GATHER"),
}

_NUM = r"(\d+(?:\.\d*)?|\.\d+)"
_COMP = re.compile(rf"^\s*(\d+)\s*(?:,\s*#\s*(\d+)\s*(D?)\s*(?:,\s*#\s*(\d+)\s*)?)?,\s*{_NUM}\s*$")
_OWN = re.compile(rf"^\s*(\d+)\s*,\s*{_NUM}\s*$")


def is_one_dimensional(text: str) -> bool:
    """DEFINE COMP arguments without the `{rows}.{columns}` period: the 1-D form."""
    return re.match(r"^\s*\d+\s*\.", text) is None


@dataclass(frozen=True)
class Table:
    """The parameters of one 1-D table (motors 1-based)."""

    kind: str
    owner: int
    entries: int
    source: int
    desired: bool
    target: int
    length: float

    def text(self) -> str:
        """The command that defines it (LIST ... DEF)."""
        length = str(int(self.length)) if self.length == int(self.length) else repr(self.length)
        if self.kind != "COMP":
            return f"DEFINE {self.kind} {self.entries},{length}"
        return (f"DEFINE COMP {self.entries},#{self.source}{'D' if self.desired else ''},"
                f"#{self.target},{length}")


def parse(kind: str, text: str, motor: int) -> Table:
    """The arguments of `DEFINE {kind}` addressed to `motor`; CompError(3) if malformed."""
    m = (_COMP if kind == "COMP" else _OWN).match(text)
    if m is None:
        raise CompError(ERR_DATA, f"bad DEFINE {kind} arguments {text!r}")
    entries = int(m[1])
    if kind == "COMP":
        source = int(m[2]) if m[2] else motor
        target = int(m[4]) if m[4] else motor
        desired, length = bool(m[3]), float(m[5])
    else:
        source = target = motor
        desired, length = False, float(m[2])
    if not 1 <= entries <= MAX_ENTRIES or length <= 0:
        raise CompError(ERR_DATA, "entries and count length must be positive")
    if not all(1 <= n <= MAX_MOTORS for n in (motor, source, target)):
        raise CompError(ERR_DATA, "motor out of range")
    return Table(kind, motor, entries, source, desired, target, length)


class Packed:
    """A set of tables as flat arrays, for one vectorised interpolation over all of them."""

    def __init__(self, tables: list[Table], values: dict[int, np.ndarray]) -> None:
        self.count = len(tables)
        self.flat = np.concatenate([values[t.owner] for t in tables]) if tables else np.zeros(0)
        sizes = np.array([t.entries + 1 for t in tables], dtype=np.int64)
        self.off = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64) if tables \
            else np.zeros(0, dtype=np.int64)
        self.src = np.array([t.source - 1 for t in tables], dtype=np.int64)
        self.des = np.array([t.desired for t in tables], dtype=bool)
        self.tgt = np.array([t.target - 1 for t in tables], dtype=np.int64)
        self.n = np.array([t.entries for t in tables], dtype=np.int64)
        self.length = np.array([t.length for t in tables])

    def values(self, actual: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """Each table's interpolated value, counts, at its source position rolled into 0..length."""
        x = np.mod(np.where(self.des, desired[self.src], actual[self.src]), self.length)
        f = x / self.length * self.n
        j = np.minimum(np.floor(f).astype(np.int64), self.n - 1)
        t = f - j
        k = self.off + j
        return (self.flat[k] * (1 - t) + self.flat[k + 1] * t) / 16.0


class Tables1D:
    """The card's 1-D tables (COMP, BLCOMP, TCOMP; one of each per owning motor) and each motor's
    backlash state.

    `comp2d_owners` answers which motors own a 2-D COMP table (they share the COMP ordering and
    the one-table-per-motor rule); `other_buffers` which later buffers (TBUF, ROTARY, LOOKAHEAD,
    GATHER) exist -- the card supplies it once it has them."""

    def __init__(self, ivars: IVars, motors: int, comp2d_owners: Callable[[], set[int]],
                 other_buffers: Callable[[], set[str]] = set) -> None:
        self.ivars = ivars
        self.motors = motors
        self.comp2d_owners = comp2d_owners
        self.other_buffers = other_buffers
        self.tables: dict[str, dict[int, Table]] = {k: {} for k in KINDS}
        self.entries: dict[str, dict[int, np.ndarray]] = {k: {} for k in KINDS}
        self.loading: tuple[str, int] | None = None
        self._filled = 0
        base = 100 * np.arange(1, motors + 1)
        self._i85, self._i86, self._i87 = base + 85, base + 86, base + 87
        self._rate = ivars.values[185:100 * motors + 86:100]   # a view: Ixx85 of every motor
        self._held = False                                      # any backlash taken up now
        #: backlash per motor: last commanded direction (-1 negative), the extreme commanded position
        #: since, the backlash taken up now (counts, <= 0)
        self.direction = np.ones(motors)
        self.extreme = np.zeros(motors)
        self.taken = np.zeros(motors)
        self._pack()

    # -- commands --------------------------------------------------------------------------------
    def owners(self, kind: str) -> set[int]:
        owners = set(self.tables[kind])
        return owners | self.comp2d_owners() if kind == "COMP" else owners

    def check_define(self, kind: str, motor: int) -> None:
        """ERR007 while a table of the kind exists for this or a lower-numbered motor (define from
        high to low) or a buffer above it exists [Turbo SRM; spec §1.7]."""
        if any(owner <= motor for owner in self.owners(kind)):
            raise CompError(ERR_BUFFER, f"DEFINE {kind}: define tables from high to low motor number")
        above = {k for k in BLOCKED_BY[kind] if k in KINDS and self.tables[k]}
        if above | (set(BLOCKED_BY[kind]) & set(self.other_buffers())):
            raise CompError(ERR_BUFFER, f"DEFINE {kind}: delete the buffers above it first")

    def define(self, kind: str, motor: int, text: str) -> Table:
        """`#{motor} DEFINE {kind} {text}`; the next `entries` constants go to `feed`."""
        t = parse(kind, text, motor)
        self.check_define(kind, motor)
        self.tables[kind][motor] = t
        self.entries[kind][motor] = np.zeros(t.entries + 1)
        self.loading, self._filled = (kind, motor), 0
        self._pack()
        return t

    @property
    def pending(self) -> int:
        if self.loading is None:
            return 0
        kind, motor = self.loading
        return self.tables[kind][motor].entries - self._filled

    def feed(self, value: float) -> None:
        """The next entry constant (integer, 1/16 count); the last one applies I30 [A L1426]."""
        if self.loading is None or not self.pending:
            raise CompError(ERR_DATA, "no compensation table is waiting for entries")
        if value != int(value):
            raise CompError(ERR_DATA, "compensation table entries must be integers")
        kind, motor = self.loading
        e = self.entries[kind][motor]
        self._filled += 1
        e[self._filled] = value
        if not self.pending:
            e[0] = e[-1] if self.ivars.values[I_WRAP] == 1 else 0.0
            self.loading = None
        self._pack()

    def delete(self, kind: str, motor: int) -> bool:
        """`#{motor} DELETE {kind}`: refused (ERR007) while a lower-numbered motor owns one (delete
        from low to high) [Turbo SRM]. False when the motor owns no 1-D table of the kind."""
        if motor not in self.tables[kind]:
            return False
        if any(owner < motor for owner in self.owners(kind)):
            raise CompError(ERR_BUFFER, f"DELETE {kind}: delete tables from low to high motor number")
        del self.tables[kind][motor]
        del self.entries[kind][motor]
        if self.loading == (kind, motor):
            self.loading = None
        self._pack()
        return True

    def restore(self, kind: str, motor: int, text: str, entries: list[float], zero: float) -> None:
        """A saved table back as it was (SAVE kept the correction at 0 I30 gave it); the ordering
        rules held when it was defined."""
        t = parse(kind, text, motor)
        if len(entries) != t.entries:
            raise CompError(ERR_DATA, "saved table does not match its definition")
        self.tables[kind][motor] = t
        self.entries[kind][motor] = np.array([zero, *entries], dtype=float)
        self._pack()

    def clear(self) -> None:
        for k in KINDS:
            self.tables[k].clear()
            self.entries[k].clear()
        self.loading = None
        self._pack()
        self.reset()

    def reset(self) -> None:
        """Power-up/reset: no backlash taken up, direction positive."""
        self.direction[:] = 1
        self.extreme[:] = 0
        self.taken[:] = 0
        self._held = False

    def list_text(self, kind: str, motor: int) -> list[str] | None:
        """LIST {kind}: the entries as sent, one per line (ASSUMPTION: layout); None: no table."""
        e = self.entries[kind].get(motor)
        return None if e is None else [str(int(v)) for v in e[1:]]

    def list_definition(self, kind: str, motor: int) -> str | None:
        t = self.tables[kind].get(motor)
        return None if t is None else t.text()

    # -- the servo cycle -------------------------------------------------------------------------
    def _pack(self) -> None:
        self._comp = Packed([self.tables["COMP"][m] for m in sorted(self.tables["COMP"])],
                            self.entries["COMP"])
        self._bl = Packed([self.tables["BLCOMP"][m] for m in sorted(self.tables["BLCOMP"])],
                          self.entries["BLCOMP"])

    @property
    def any_tables(self) -> bool:
        return any(self.tables[k] for k in KINDS)

    @property
    def active(self) -> bool:
        """Whether the servo cycle has anything to compute: a table, backlash configured or held."""
        return bool(self._comp.count or self._bl.count or self._held or self._rate.any())

    def leadscrew(self, actual: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The 1-D leadscrew tables' correction per motor (index motor-1), counts; 0 unless I51=1."""
        out = np.zeros(self.motors)
        if not self._comp.count or self.ivars.values[I_ENABLE] != 1:
            return out
        act, des = _pad(actual), _pad(desired)
        corr = self._comp.values(act, des)
        keep = self._comp.tgt < self.motors
        np.add.at(out, self._comp.tgt[keep], corr[keep])
        return out

    def backlash_size(self, desired: np.ndarray) -> np.ndarray:
        """Ixx86 plus the backlash table at the nominal position (I51 = 1), counts."""
        size = self.ivars.values[self._i86] / 16.0
        if self._bl.count and self.ivars.values[I_ENABLE] == 1:
            des = _pad(desired)
            keep = self._bl.tgt < self.motors
            np.add.at(size, self._bl.tgt[keep], self._bl.values(des, des)[keep])
        return size

    def _goal(self, desired: np.ndarray, direction: np.ndarray) -> np.ndarray:
        v = self.ivars.values
        on = (v[self._i85] > 0) & (direction < 0)
        return np.where(on, -self.backlash_size(desired), 0.0)

    def backlash(self, desired: np.ndarray) -> np.ndarray:
        """One servo cycle of backlash: direction reversals past Ixx87, then the taken-up amount
        moved toward its goal by at most Ixx85/16 counts. Returns the correction per motor."""
        v = self.ivars.values
        hyst = v[self._i87] / 16.0
        pos = self.direction > 0
        self.extreme = np.where(pos, np.maximum(self.extreme, desired), np.minimum(self.extreme, desired))
        flip = np.where(pos, desired < self.extreme - hyst, desired > self.extreme + hyst)
        if flip.any():
            self.direction[flip] = -self.direction[flip]
            self.extreme[flip] = desired[flip]
        rate = v[self._i85] / 16.0
        step = np.clip(self._goal(desired, self.direction) - self.taken, -rate, rate)
        self.taken += step
        self._held = bool(self.taken.any())
        return self.taken.copy()

    def busy(self, desired: np.ndarray) -> bool:
        """Backlash still being taken up (the card is not at rest)."""
        return bool((self._goal(desired, self.direction) != self.taken).any())


def _pad(values: np.ndarray) -> np.ndarray:
    out = np.zeros(MAX_MOTORS)
    out[: len(values)] = values
    return out
