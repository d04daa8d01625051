"""The pure parts of the Mx4 Octavia host library (spec octavia.md §1.3, §4.1, §8.2): the unit
helpers, an RTC's argument bytes from per-axis values (split into posts of at most 57 argument
bytes, spec Q-3), the interrupt status as the card reports it, and the library's errors.

Nothing here talks to a daemon; `vdevclient.mx4` posts what `encode` returns. The layouts are
`vdevmaps.octavia`'s, shared with the daemon's card.
"""

from __future__ import annotations

import operator
import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from vdevmaps.octavia import (
    ARG_BYTES,
    BY_NAME,
    MAX_AXES,
    DspStat1,
    DspStat2,
    HostInt,
    Rtc,
    acc_from_raw,
    vel_from_raw,
)

from vdevclient.errors import VdevClientError

#: a per-axis argument: a sequence indexed by axis (index 0 = axis 1), or one value for every
#: axis of the mask
PerAxis = int | Sequence[int]

_BITS = {"B": 8, "H": 16, "I": 32, "b": 8, "h": 16, "i": 32}
#: the status block 000h..00Fh: DSPSTAT1, its eight source bytes, DSPSTAT2, its sources
STATUS_SIZE = 16
_STAT2_SOURCE = {DspStat2.ENCFLT: 0x0A, DspStat2.OFFSET: 0x0C, DspStat2.INP: 0x0D,
                 DspStat2.DSPL_INT: 0x0E, DspStat2.DSPL_ERR: 0x0F}
#: what the card's status bits mean, by register and bit number [Ch6 Tables 6-2, 6-9]
MEANING: dict[type, dict[int, str]] = {
    DspStat1: {0: "following error + halt", 1: "following error", 2: "index pulse",
               3: "position breakpoint", 4: "motion complete", 5: "probe (external) signal",
               6: "conflicting commands: the new motion command ignored",
               7: "RTC ignored: STOP (halt) in progress"},
    DspStat2: {0: "encoder fault", 2: "offset cancel finished", 3: "input-programmed interrupt",
               4: "DSPL host interrupt", 5: "DSPL program running error", 6: "5 ms interrupt"},
    HostInt: {0: "buffer breakpoint", 1: "see DSPSTAT1", 2: "ESTOP detected",
              3: "vector-change buffer overflow", 4: "reset finished",
              5: "data run-out in the ring buffer", 6: "see DSPSTAT2", 7: "NURBS buffer breakpoint"},
}
#: the report of a motion RTC the card refused [Ch7 Table 7-1; spec §3.2]
REFUSED = DspStat1.CONFLICT | DspStat1.IGNORED


# -- errors -----------------------------------------------------------------------------------------
class Mx4Error(VdevClientError):
    """A report of the card, or a card that is not there or not answering. `rtc` is the command
    the card reported on, `status` the status block read with the report (None if none was)."""

    def __init__(self, message: str, *, rtc: str | None = None,
                 status: IntStatus | None = None) -> None:
        super().__init__(message)
        self.rtc = rtc
        self.status = status

    @property
    def conflict(self) -> int:
        """Axes (bit k = axis k+1) of "conflicting commands" (DSPSTAT1 b6, 007h)."""
        return self.status.sources(DspStat1.CONFLICT) if self.status is not None else 0

    @property
    def ignored(self) -> int:
        """Axes of "RTC ignored: STOP (halt) in progress" (DSPSTAT1 b7, 008h)."""
        return self.status.sources(DspStat1.IGNORED) if self.status is not None else 0


class Mx4Timeout(Mx4Error, TimeoutError):
    """The card did not do within the time-out (card time) what the call waited for: take an RTC
    (3C2h back to 00h), echo a PARREAD, report an interrupt, finish a reset."""


def refused(rtc: str, status: IntStatus) -> Mx4Error:
    """The error of an RTC the card discarded: its DSPSTAT1 bits and their axes, named."""
    parts = [f"DSPSTAT1 {bits_text(bit)} on {axes_text(status.sources(bit))}"
             for bit in (DspStat1.CONFLICT, DspStat1.IGNORED) if status.dspstat1 & bit]
    return Mx4Error(f"{rtc}: the card discarded the command: {'; '.join(parts)}", rtc=rtc,
                    status=status)


def axes_text(mask: int) -> str:
    axes = [str(a + 1) for a in range(MAX_AXES) if mask >> a & 1]
    return ("axis " if len(axes) == 1 else "axes ") + ", ".join(axes) if axes else "no axis"


def bits_text(flags: DspStat1 | DspStat2 | HostInt) -> str:
    """`HostInt.STAT1|ESTOP` as "b1 STAT1 (see DSPSTAT1), b2 ESTOP (ESTOP detected)"."""
    kind, meaning = type(flags), MEANING[type(flags)]
    return ", ".join(f"b{b} {kind(1 << b).name or '?'} ({meaning.get(b, 'unused')})"
                     for b in range(8) if int(flags) >> b & 1) or "none"


# -- the interrupt status [Ch6 Table 6-2, Handling Interrupts] ---------------------------------------
@dataclass(frozen=True)
class IntStatus:
    """The card's interrupt registers: HOSTINT1 (1FFEh; None when not read: a read of it ends the
    interrupt) and the status block 000h..00Fh (`raw`): DSPSTAT1, the source byte of each of its
    types (bit k = axis k+1; the probe's is the EXT code), DSPSTAT2 and its sources."""

    raw: bytes
    hostint: HostInt | None = None

    @property
    def dspstat1(self) -> DspStat1:
        return DspStat1(self.raw[0])

    @property
    def dspstat2(self) -> DspStat2:
        return DspStat2(self.raw[9] & 0x7D)

    def sources(self, bit: DspStat1 | DspStat2) -> int:
        """The source byte of one DSPSTAT1 type (001h + its bit number) or DSPSTAT2 type."""
        return self.raw[source_offset(bit)]


def source_offset(bit: DspStat1 | DspStat2) -> int:
    """The address of the source byte of one interrupt type [Table 6-2]; ValueError for a type
    with none (DSPSTAT2 b6, the 5 ms interrupt) or several bits."""
    if isinstance(bit, DspStat1) and int(bit).bit_count() == 1:
        return int(bit).bit_length()  # b0 -> 001h ... b7 -> 008h
    if isinstance(bit, DspStat2) and bit in _STAT2_SOURCE:
        return _STAT2_SOURCE[bit]
    raise ValueError(f"{bit!r} is not one interrupt type with a source byte")


def source_or_none(bit: DspStat1 | DspStat2) -> int | None:
    """`source_offset`, None for a type without a source byte."""
    return int(bit).bit_length() if isinstance(bit, DspStat1) else _STAT2_SOURCE.get(bit)


def cleared(status: bytes, stat1: int, stat2: int, sources: int | bool) -> bytearray:
    """The status block 000h..00Fh after the host acknowledged the DSPSTAT1 types `stat1` and the
    DSPSTAT2 types `stat2`: with `sources` True their source bytes are zeroed and their type bits
    cleared; with an axis mask only those axes' source bits go, and a type bit only once its
    source byte is empty; with False only the type bits go [Ch6 Handling Interrupts]."""
    out = bytearray(status)
    types: list[DspStat1 | DspStat2] = [DspStat1(1 << b) for b in range(8) if stat1 >> b & 1]
    types += [DspStat2(1 << b) for b in range(8) if stat2 >> b & 1]
    for bit in types:
        at = 0 if isinstance(bit, DspStat1) else 9
        offset = source_or_none(bit)
        if offset is not None and sources is not False:
            out[offset] &= 0 if sources is True else ~int(sources) & 0xFF
            if out[offset] and sources is not True:
                continue  # other axes of this type still to be handled
        out[at] &= ~int(bit) & 0xFF
    return out


# -- units [Ch5 State Variables; spec §1.3, §8.2] ------------------------------------------------------
def acc_to_raw(acc: float) -> int:
    """An acceleration in counts/sample^2 (sample = 200 us) as the 1.15 word: round(a * 2^15)."""
    raw = round(acc * 32768)
    if not 0 <= raw <= 0xFFFF:
        raise ValueError(f"acceleration {acc} outside 0 .. 1.99997 counts/sample^2")
    return raw


def raw_to_acc(raw: int) -> float:
    return acc_from_raw(raw)


def vel_to_raw(vel: float) -> int:
    """A velocity in counts/sample as the 16.16 word (signed): round(v * 2^16), |v| < 256."""
    raw = round(vel * 65536)
    if not -0xFFFFFF <= raw <= 0xFFFFFF:
        raise ValueError(f"velocity {vel} outside +-255.99998 counts/sample")
    return raw


def raw_to_vel(raw: int) -> float:
    """A velocity word (25-bit two's complement 16.16; a negative int as well) in counts/sample."""
    return vel_from_raw(raw & 0xFFFFFFFF)


def ratio_to_raw(ratio: float, bits: int = 7) -> int:
    """A gear or cam ratio as the 1.8.7 word: round(r * 2^bits), -256 .. 255.99 (spec Q-5);
    `bits` 12 for a card whose `gear_ratio_bits` is 12 (the manual's GEAR examples: 2000h = 2.0;
    cam ratios are always 1.8.7)."""
    raw = round(ratio * (1 << bits))
    if not -0x8000 <= raw <= 0x7FFF:
        raise ValueError(f"ratio {ratio} outside the signed 16-bit word at {bits} fraction bits")
    return raw


def raw_to_ratio(raw: int, bits: int = 7) -> float:
    return _signed(raw, 16) / (1 << bits)


def volts_to_dac(volts: float) -> int:
    """A DAC output in volts as DDAC's word: round(v / 10 * 32767), 7FFFh = +10 V [Ch5 DDAC]."""
    raw = round(volts / 10 * 32767)
    if not -0x8000 <= raw <= 0x7FFF:
        raise ValueError(f"{volts} V outside +-10 V")
    return raw


def dac_to_volts(raw: int) -> float:
    return _signed(raw, 16) * 10 / 32767


def i32(value: int) -> int:
    """A 32-bit DPR word as a signed int: two's complement patterns (FFFFE0C0h) taken too."""
    return value - (1 << 32) if 1 << 31 <= value < 1 << 32 else value


def i16(value: int) -> int:
    return value - (1 << 16) if 1 << 15 <= value < 1 << 16 else value


def _signed(value: int, bits: int) -> int:
    value &= (1 << bits) - 1
    return value - (1 << bits) if value >> (bits - 1) else value


# -- RTC encoding [Ch6 Real-Time Commands; spec §4.1] ---------------------------------------------------
@dataclass(frozen=True)
class Post:
    """One RTC as written to the DPR: the code for 3C2h, the argument bytes from 3C3h, and the
    data a table load stages at 120h first [Ch5 LOAD_CAM_TABLE ...]."""

    name: str
    code: int
    args: bytes
    stage: bytes = b""


def encode(name: str, head: Mapping[str, Any] | None = None, **per_axis: PerAxis) -> list[Post]:
    """The posts of RTC `name`: the `head` fields, and for a multi-axis RTC one group per bit of
    its axis mask (the head field the layout names: `n`, or `m` for the slaves of CAM/GEAR), in
    increasing axis order, each group's fields taken from `per_axis` (a sequence indexed by axis
    from 0 for axis 1, or one value for all). A list longer than the 57-byte window is split by
    axes into several posts (spec Q-3); every post of one call starts within one sample of the
    first. Signed fields take a two's complement pattern too (FFAA0000h as well as -5636096)."""
    layout = _LAYOUTS.get(name) or _layout(name)
    if head is None:  # (read, never changed: not copied)
        head = {}
    if head.keys() != layout.head_names or per_axis.keys() != layout.group_names:
        raise TypeError(f"{name} takes {sorted(layout.head_names)} and per axis "
                        f"{sorted(layout.group_names)}, not {sorted(head)} and {sorted(per_axis)}")
    rtc = layout.rtc
    if rtc.mask is None:
        return [Post(name, rtc.code, layout.pack(head, []))]
    mask = head[rtc.mask]
    if not 0 <= mask <= 0xFF:
        raise ValueError(f"{name}: mask {mask:#x} outside 00h..FFh")
    axes = _AXES_OF[mask] if type(mask) is int else [a for a in range(MAX_AXES) if mask >> a & 1]
    columns = tuple(zip(layout.group_order, layout.group_values(per_axis), strict=True))
    per_post = layout.per_post
    if 0 < per_post >= len(axes):  # one post (the usual case): its mask is the mask given
        # the values in DPR order, straight: one value for every axis (an int) as it is, an int
        # of a list as it is, anything else through _axis_value
        values = list(layout.head_values(head))
        append = values.append
        for a in axes:
            for f, v in columns:
                if type(v) is int:
                    append(v)
                elif type(v) is list and a < len(v) and type(v[a]) is int:
                    append(v[a])
                else:
                    append(_axis_value(name, f, v, a))
        return [Post(name, rtc.code, layout.pack_values(values, len(axes), head))]
    rows = [[v if type(v) is int else _axis_value(name, f, v, a) for f, v in columns]
            for a in axes]
    return [Post(name, rtc.code, layout.pack({**head, rtc.mask: sum(1 << a for a in axes[i:i + per_post])},
                                             rows[i:i + per_post]))
            for i in range(0, max(len(axes), 1), per_post)]


class _Layout:
    """An RTC's layout made ready to pack fast: its fields' order and their struct codes."""

    def __init__(self, rtc: Rtc) -> None:
        self.rtc = rtc
        self.head_order = [n for n, _ in rtc.head]
        self.group_order = [n for n, _ in rtc.group]
        self.head_names = frozenset(self.head_order)
        #: a mapping's head (group) values in DPR order, as a tuple (C-level itemgetters)
        self.head_values = _getter(self.head_order)
        self.group_values = _getter(self.group_order)
        self.group_names = frozenset(self.group_order) if rtc.mask is not None else frozenset()
        self.per_post = (ARG_BYTES - rtc.head_size) // rtc.group_size if rtc.group else 0
        self._codes = [c for _, c in rtc.head] + [c for _, c in rtc.group] * MAX_AXES
        #: (position, 2^(bits-1), 2^bits) of the signed fields among `_codes`
        self._signed = [(i, _HALF[c], _WRAP[c]) for i, c in enumerate(self._codes) if c in _WRAP]
        self._structs: dict[int, struct.Struct] = {}

    def pack(self, head: Mapping[str, Any], rows: list[list[Any]]) -> bytes:
        """The head and `rows` (one list of group values per group) as the DPR's bytes, signed
        fields taking two's complement patterns; a value that does not fit is a ValueError."""
        return self.pack_values([head[n] for n in self.head_order] + [v for row in rows for v in row],
                                len(rows), head)

    def pack_values(self, values: list[Any], k: int, head: Mapping[str, Any]) -> bytes:
        """`pack` of the head's values then `k` groups' in DPR order (`values`); `head` names
        the fields in the error."""
        packer = self._structs.get(k)
        if packer is None:
            packer = self._structs[k] = struct.Struct("<" + "".join(
                self._codes[:len(self.head_order) + k * len(self.group_order)]))
        n = len(values)
        given = values
        for i, half, wrap in self._signed:  # signed fields take a two's complement pattern too
            if i >= n:
                break
            v = values[i]
            if half <= v < wrap:
                if values is given:
                    values = list(given)
                values[i] = v - wrap
        try:
            return packer.pack(*values)
        except struct.error:
            g, h = len(self.group_order), len(self.head_order)
            raise self._unfit(head, [given[i:i + g] for i in range(h, n, g)] if g else []) from None

    def _unfit(self, head: Mapping[str, Any], rows: list[list[Any]]) -> ValueError:
        fields = list(head.items()) + [(f, v) for row in rows for f, v in zip(self.group_order, row,
                                                                               strict=True)]
        codes = dict(self.rtc.head) | dict(self.rtc.group)
        for f, v in fields:
            c = codes[f]
            if c in _BITS:
                bits = _BITS[c]
                low = -(1 << (bits - 1)) if c.islower() else 0
                if not isinstance(v, int) or not low <= v < 1 << bits:
                    return ValueError(f"{self.rtc.name}: {f} = {v} does not fit "
                                      f"{'a signed' if c.islower() else 'an unsigned'} {bits}-bit field")
        return ValueError(f"{self.rtc.name}: the values {fields} do not fit its layout")


def _getter(names: list[str]) -> Callable[[Mapping[str, Any]], tuple[Any, ...]]:
    """A mapping's values of `names`, in order, as a tuple."""
    if len(names) == 1:
        one = names[0]
        return lambda d: (d[one],)
    if not names:
        return lambda d: ()
    return operator.itemgetter(*names)


_WRAP = {c: 1 << b for c, b in _BITS.items() if c.islower()}
_HALF = {c: 1 << (b - 1) for c, b in _BITS.items() if c.islower()}
_LAYOUTS: dict[str, _Layout] = {}
#: mask -> its axes (0-based, increasing)
_AXES_OF = [[a for a in range(MAX_AXES) if mask >> a & 1] for mask in range(0x100)]


def _layout(name: str) -> _Layout:
    layout = _LAYOUTS.get(name)
    if layout is None:
        layout = _LAYOUTS[name] = _Layout(BY_NAME[name])
    return layout


def encode_list(name: str, items: Sequence[Mapping[str, Any]]) -> list[Post]:
    """The posts of a counted list (CHANGE_VAR): `items` are the groups' fields, at most as many
    per post as fit the window (eight 7-byte pairs: exactly 57 bytes)."""
    layout = _layout(name)
    rtc = layout.rtc
    if rtc.count is None:
        raise ValueError(f"{name} takes no counted list")
    rows = [[item[f] for f in layout.group_order] for item in items]
    per_post = layout.per_post
    return [Post(name, rtc.code, layout.pack({rtc.count: len(rows[i:i + per_post])}, rows[i:i + per_post]))
            for i in range(0, max(len(rows), 1), per_post)]


def _axis_value(name: str, field: str, values: PerAxis, axis: int) -> int:
    if isinstance(values, int):
        return values
    if axis >= len(values):
        raise ValueError(f"{name}: {field} has no value for axis {axis + 1} "
                         f"({len(values)} values, index 0 = axis 1)")
    return int(values[axis])
