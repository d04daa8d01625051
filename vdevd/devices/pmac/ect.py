"""The encoder conversion table (ECT): setup lines I8000-I8191 in Y:$003501-$0035C0, results in
the X words of the same addresses [A L2445-3116; spec pmac.md §1.6].

An entry is 1-3 lines; its first line holds the source address (bits 0-18), the mode switch (bit
19) and the method digit (bits 20-23); a first line of $000000 ends the active table [A L2551].
The final result is in X of the entry's last line, in 1/32 count for feedback methods; earlier
lines hold intermediate results [A L2545]. The table is processed once per servo cycle, top to
bottom, before the servo loops.

Cost: entries whose result is a pure function of their sources ($0, $1, $2/$6 wide enough not to
need rollover extension, $8, $C, $E without integration, $F/$0, $F/$2) are computed when their
result is read, so the default table of eight 1/T entries costs the tick nothing but a check that
the setup lines did not change. Entries with memory ($3/$7/$F-$3 filters, $4 time base, $5 and
integrating $E sums, $9/$A/$B triggered time base, $D filter, narrow $2/$6) run every cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.memory import WORD, Memory

TABLE = 0x003501
LINES = 192
FIRST_IVAR = 8000
SOURCE = 0x07FFFF       # bits 0-18 of a first line
MODE = 1 << 19

#: lines per method digit [A table L2557-2576]; $F depends on its second line
LINES_OF = {0x0: 1, 0x1: 1, 0x2: 2, 0x3: 3, 0x4: 2, 0x5: 2, 0x6: 2, 0x7: 3, 0x8: 1,
            0x9: 2, 0xA: 2, 0xB: 2, 0xC: 1, 0xD: 3, 0xE: 1}
#: $F extended entries: type (first digit of line 2) -> lines [A L2574-2576]; others: 2 lines, result 0
EXTENDED_LINES = {0x0: 3, 0x2: 2, 0x3: 3}


class ChannelSource(Protocol):
    """The Servo IC: a channel's counter with `bits` fraction bits (None if `addr` is not one of its
    channel bases). `hardware` selects hardware 1/T ($C mode 1) rather than software 1/T ($0)."""

    def extended_position(self, addr: int, bits: int, hardware: bool) -> int | None: ...


def setup_address(ivar: int) -> int | None:
    """The address of ECT I-variable `ivar` (I8000 -> $003501 ... I8191 -> $0035C0), what
    `I{constant}=@I{constant}` stores, e.g. I103=@I8000 -> $3501 [A L2494-2549, L3266]; None
    for other I-variables."""
    return TABLE + ivar - FIRST_IVAR if FIRST_IVAR <= ivar < FIRST_IVAR + LINES else None


def sext(v: int, width: int = 24) -> int:
    """`v` modulo 2**width read as a signed number."""
    v &= (1 << width) - 1
    return v - (1 << width) if v >> (width - 1) else v


@dataclass
class Entry:
    """One parsed entry: its first line, its setup words, the method (`0xF0 | type` for $F)."""

    first: int
    words: tuple[int, ...]
    method: int
    state: dict[str, int] = field(default_factory=dict)

    @property
    def last(self) -> int:
        return self.first + len(self.words) - 1

    @property
    def key(self) -> tuple[int, tuple[int, ...]]:
        return self.first, self.words

    @property
    def stateful(self) -> bool:
        m = self.method
        if m in (0x3, 0x4, 0x5, 0x7, 0x9, 0xA, 0xB, 0xD, 0xF3):
            return True
        if m in (0x2, 0x6, 0xF2):
            return _parallel_format(self)[0] + _shift(self) < 24
        return m == 0xE and bool(self.words[0] & MODE)


def _shift(e: Entry) -> int:
    """Bit 19 = 1: source LSB at result bit 0 ("unshifted"), else at bit 5 [A L2725]."""
    return 0 if e.words[0] & MODE else 5


def _parallel_format(e: Entry) -> tuple[int, int]:
    """(width, lsb) of a parallel entry's second line [A L2735-2743, L3097-3112]."""
    w = e.words[1]
    if e.method in (0xF2, 0xF3):
        return min(max((w >> 12) & 0xFF, 1), 24), w & 0x07
    return min(max((w >> 12) & 0xFFF, 1), 24), min(w & 0xFFF, 47)


class ConversionTable:
    """The ECT as a memory Device on $003501-$0035C0 over the card's I-variables."""

    def __init__(self, memory: Memory, ivars: IVars, channels: ChannelSource | None = None) -> None:
        self.memory = memory
        self.ivars = ivars
        self.channels = channels
        #: the setup lines I8000-I8191, a view (the I-variable array is never replaced): read
        #: at every cycle
        self._lines = ivars.values[FIRST_IVAR:FIRST_IVAR + LINES]
        memory.mount(TABLE, TABLE + LINES - 1, self)
        self.reset()

    def reset(self) -> None:
        """Power-up: results 0, filters and time bases start afresh."""
        self._res = [0] * LINES
        self._entries: list[Entry] = []
        self._parse()

    # -- the setup lines -------------------------------------------------------------------------
    def _setup(self) -> np.ndarray:
        return self._lines

    def _parse(self) -> None:
        """Split the setup lines into entries up to the first $000000 [A L2551]; an entry whose
        words did not change keeps its state."""
        setup = self._setup()
        self._cache = setup.tobytes()
        words = [int(v) & WORD for v in setup]
        old = {e.key: e.state for e in self._entries}
        entries: list[Entry] = []
        k = 0
        while k < LINES and words[k]:
            digit = words[k] >> 20
            if digit == 0xF:
                kind = (words[k + 1] >> 20) if k + 1 < LINES else 0x1
                method, n = 0xF0 | kind, EXTENDED_LINES.get(kind, 2)
            else:
                method, n = digit, LINES_OF[digit]
            if k + n > LINES:
                break
            ws = tuple(words[k:k + n])
            entries.append(Entry(k, ws, method, old.get((k, ws), {})))
            k += n
        self._entries = entries
        self.end = k
        self._stateful = [e for e in entries if e.stateful]
        self._lazy: list[Entry | None] = [None] * LINES
        for e in entries:
            if not e.stateful:
                self._lazy[e.last] = e
        self._busy: set[int] = set()

    def entries(self) -> list[Entry]:
        """The active entries, in table order."""
        return list(self._entries)

    # -- the servo cycle -------------------------------------------------------------------------
    def tick(self) -> None:
        """One servo cycle: re-read changed setup lines, run the entries that have memory."""
        if self._setup().tobytes() != self._cache:
            self._parse()
        for e in self._stateful:
            self._evaluate(e)

    def result(self, k: int) -> int:
        """X of line k (0-191), 24-bit unsigned."""
        e = self._lazy[k]
        if e is not None and e.first not in self._busy:
            self._busy.add(e.first)
            try:
                self._evaluate(e)
            finally:
                self._busy.discard(e.first)
        return self._res[k]

    # -- Device ----------------------------------------------------------------------------------
    def read_word(self, space: str, addr: int) -> int:
        k = addr - TABLE
        if space == "Y":
            return int(self.ivars.values[FIRST_IVAR + k]) & WORD
        return self.result(k)

    def write_word(self, space: str, addr: int, value: int) -> None:
        k = addr - TABLE
        if space == "Y":
            self.ivars.values[FIRST_IVAR + k] = float(value & WORD)
        else:
            self._res[k] = value & WORD

    # -- the methods -----------------------------------------------------------------------------
    def _x(self, addr: int) -> int:
        return self.memory.read("X", addr)

    def _y(self, addr: int) -> int:
        return self.memory.read("Y", addr)

    def _evaluate(self, e: Entry) -> None:
        w0 = e.words[0]
        src, mode, m = w0 & SOURCE, bool(w0 & MODE), e.method
        if m in (0x0, 0xC):
            out = self._incremental(src, hardware=m == 0xC and mode, extend=m == 0x0 or mode)
        elif m == 0x8:
            out = self._parallel_extension(src, mode)
        elif m in (0x1, 0x5):
            out = self._adc(e, src, mode)
        elif m in (0x2, 0x3, 0x6, 0x7, 0xF2, 0xF3):
            out = self._parallel(e, src)
        elif m == 0x4:
            out = self._time_base(e, src)
        elif m in (0x9, 0xA, 0xB):
            out = self._triggered_time_base(e, src)
        elif m == 0xD:
            out = self._exponential_filter(e, src)
        elif m == 0xE:
            out = self._sum(e)
        elif m == 0xF0:
            out = self._interpolator(e, src)
        else:
            out = 0             # $F with an unknown second-line type: not modelled
        self._res[e.last] = out & WORD

    def _incremental(self, src: int, hardware: bool, extend: bool) -> int:
        """$0 software 1/T, $C mode 0 no extension, $C mode 1 hardware 1/T: counter·32 + fraction
        [A L2578-2592]."""
        if not extend:
            return self._x(src + 1) << 5
        if self.channels is not None:
            v = self.channels.extended_position(src, 5, hardware)
            if v is not None:
                return v
        if hardware:
            return self._x(src + 1) << 5
        # another IC: fraction = "time since last count" / "time between last two counts"
        between, since = self._y(src), self._y(src + 1)
        frac = min(31, since * 32 // between) if between else 0
        return (self._x(src + 1) << 5) + frac

    def _parallel_extension(self, src: int, pmac2: bool) -> int:
        """$8: fraction from bits 19-23 of X:src (PMAC2: USER, W, V, U, T; USER the LSB) or of
        X:src+4 (PMAC(1)) [A L2584]."""
        return (self._x(src + 1) << 5) | (self._x(src if pmac2 else src + 4) >> 19) & 0x1F

    def _adc(self, e: Entry, src: int, unsigned: bool) -> int:
        """$1: high 16 bits of Y:src with the LSB at result bit 5, no rollover; $5 integrates
        (input − bias), bias in 1/256 LSB, not below 0 when unsigned [A L2634-2716]."""
        v = self._y(src) >> 8
        if not unsigned:
            v = sext(v, 16)
        if e.method == 0x1:
            return v << 5
        step = v * 256 - sext(e.words[1])
        if unsigned:
            step = max(step, 0)
        acc = e.state.get("acc", 0) + step
        e.state["acc"] = acc
        return acc >> 3

    def _parallel(self, e: Entry, src: int) -> int:
        """$2/$3 (Y, next word Y:src+1), $6/$7 (Y, next word X:src) and $F/$2, $F/$3 (byte lanes of
        consecutive Y words): `width` bits from bit `lsb`, rolled over into the result; the
        filtered forms move at most ±max change per cycle (ASSUMPTION, spec §1.6) [A L2718-2758,
        L3055-3114]."""
        width, lsb = _parallel_format(e)
        m = e.method
        if m in (0xF2, 0xF3):
            lane = 8 * min((e.words[1] >> 8) & 0xF, 2)
            data = 0
            for i in range(min(4, -(-(lsb + width) // 8))):
                data |= ((self._y(src + i) >> lane) & 0xFF) << (8 * i)
        else:
            data = self._y(src)
            if lsb + width > 24:
                data |= (self._y(src + 1) if m in (0x2, 0x3) else self._x(src)) << 24
        data = (data >> lsb) & ((1 << width) - 1)
        shift = _shift(e)
        if not e.stateful:
            return data << shift
        acc = e.state.get("acc")
        if acc is None:
            acc = data          # first cycle: take the source as it is (ASSUMPTION)
        else:
            delta = sext(data - acc, width)
            if m in (0x3, 0x7, 0xF3):
                limit = e.words[2] & WORD
                delta = max(-limit, min(limit, delta))
            acc += delta
        e.state["acc"] = acc
        return acc << shift

    def _time_base(self, e: Entry, src: int) -> int:
        """$4: 2·TBSF·(new − old) of the X source; line 1 keeps the source for the next cycle
        [A L2825-2846]."""
        new = self._x(src)
        old = e.state.get("old", new)
        e.state["old"] = new
        self._res[e.first] = new
        return 2 * e.words[1] * sext(new - old)

    def _triggered_time_base(self, e: Entry, src: int) -> int:
        """$9 frozen (result 0, capture register read every cycle), $B armed (result 0 until the
        channel's capture flag, then the method digit becomes $A with the captured position as
        time zero), $A running: 2·TBSF·(new − old) of the 1/256-count position in line 1
        [A L2847-2927]."""
        pos = self.channels.extended_position(src, 8, False) if self.channels is not None else None
        if pos is None:
            pos = (self._x(src + 1) << 8) & WORD
        self._res[e.first] = pos
        m = e.method
        if m == 0x9:
            self._x(src + 3)
            e.state["old"] = pos
            return 0
        if m == 0xB:
            if not (self._x(src) >> 11) & 1:
                return 0
            e.state["old"] = (self._x(src + 3) << 8) & WORD
            self._run(e)
        old = e.state.get("old", pos)
        e.state["old"] = pos
        return 2 * e.words[1] * sext(pos - old)

    def _run(self, e: Entry) -> None:
        """The firmware writes the running method digit $A into the armed entry's first line."""
        word = (e.words[0] & 0x0FFFFF) | 0xA00000
        self.ivars.values[FIRST_IVAR + e.first] = float(word)
        self._cache = self._setup().tobytes()
        e.words = (word, *e.words[1:])
        e.method = 0xA

    def _exponential_filter(self, e: Entry, src: int) -> int:
        """$D: Out += (K/2**23)·[In − Out] (24-bit difference, product rounded), step limited to
        ±max change; line 2 = K, line 3 = max change (the detailed text [A L2947-2949], not the
        summary table); line 1 shows the input [A L2929-2951]."""
        inp = sext(self._x(src))
        self._res[e.first] = inp & WORD
        out = e.state.get("out")
        if out is None:
            out = inp           # first cycle: start at the input (ASSUMPTION)
        else:
            step = (sext(e.words[1]) * sext(inp - out) + (1 << 22)) >> 23
            limit = e.words[2] & WORD
            out = sext(out + max(-limit, min(limit, step)))
        e.state["out"] = out
        return out

    def _sum(self, e: Entry) -> int:
        """$E: ±X(first) ± X(second) of lines at offsets bits 0-7 / 8-15; bit 18 = no second source,
        bit 19 = integrate (ASSUMPTION: result += sum) [A L2953-2975]."""
        w = e.words[0]
        total = sext(self._x(TABLE + (w & 0xFF)))
        if w & (1 << 16):
            total = -total
        if not w & (1 << 18):
            second = sext(self._x(TABLE + ((w >> 8) & 0xFF)))
            total += -second if w & (1 << 17) else second
        if w & MODE:
            total += e.state.get("acc", 0)
            e.state["acc"] = total
        return total

    def _interpolator(self, e: Entry, src: int) -> int:
        """$F/$0 high-resolution interpolator: the arctangent of the two ADCs (Y:addr sine,
        Y:addr+1 cosine, both minus the line-3 bias) gives the position in the line to 1/4096,
        the counter (4 counts per line) the whole lines [A L2977-3053]."""
        adc = e.words[1] & SOURCE
        bias = sext(e.words[2])
        s, c = sext(self._y(adc)) - bias, sext(self._y(adc + 1)) - bias
        frac = math.floor(math.atan2(s, c) / (2 * math.pi) * 4096) % 4096
        estimate = self._x(src + 1) * 1024 + 512
        return estimate + (frac - estimate + 2048) % 4096 - 2048
