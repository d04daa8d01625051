"""M-variables: definitions pointing at memory and their bit-field reads and writes.

`M{n}->{type}:{address}[,{offset}[,{width}[,{format}]]]` [spec pmac.md §2.3; addendum L153-158,
L712-800]. Types: `X:`/`Y:` bit fields of one 24-bit word (width 1-24, format U unsigned (the
default) or S signed), `D:` 48-bit fixed point (X:Y), `L:` 48-bit floating point, `F:` 32-bit
IEEE float and `DP:` 32-bit fixed point in the DPRAM (Y word = low 16 bits, X word = high 16 bits),
`*` self-referenced (the value is kept in the definition). A value stored into an integer field is
rounded to nearest and wrapped to the field's width [A L942, L982].
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass

from vdevd.devices.pmac.memory import TOP, Memory
from vdevd.devices.pmac.numbers import round_to_int, wrap

COUNT = 8192

_DEF = re.compile(
    r"\s*(?:(?P<self>\*)|(?P<kind>DP|[XYDLF])\s*:\s*(?P<addr>\$[0-9A-F]+|\d+)"
    r"(?:\s*,\s*(?P<offset>\d+)(?:\s*,\s*(?P<width>\d+)(?:\s*,\s*(?P<fmt>[US]))?)?)?)",
    re.IGNORECASE,
)


class MDefError(ValueError):
    """A definition the card rejects (ERR003)."""


@dataclass(frozen=True)
class MDef:
    """One M-variable definition; kind "" means undefined (reads 0, writes are lost)."""

    kind: str = ""
    addr: int = 0
    offset: int = 0
    width: int = 1
    signed: bool = False

    def text(self) -> str:
        """The definition as `M{n}->` reports it."""
        if self.kind == "*":
            return "*"
        if not self.kind:
            return "*"
        if self.kind in "XY":
            tail = f",{self.offset}" if self.width == 1 else \
                f",{self.offset},{self.width}" + (",S" if self.signed else ",U")
            return f"{self.kind}:${self.addr:06X}{tail}"
        return f"{self.kind}:${self.addr:06X}"


def parse_definition(text: str, pos: int = 0) -> tuple[MDef, int]:
    """Parse a definition at text[pos:]; return it and the index after it. MDefError if bad."""
    m = _DEF.match(text, pos)
    if m is None:
        raise MDefError(f"bad M-variable definition {text[pos:]!r}")
    if m["self"]:
        return MDef("*"), m.end()
    kind = m["kind"].upper()
    a = m["addr"]
    addr = int(a[1:], 16) if a.startswith("$") else int(a)
    if addr > TOP:
        raise MDefError(f"address ${addr:X} outside memory")
    offset = int(m["offset"] or 0)
    width = int(m["width"] or (1 if kind in "XY" else 48))
    signed = (m["fmt"] or "U").upper() == "S"
    if kind in "XY":
        if not (0 <= offset <= 23 and 1 <= width <= 24 and offset + width <= 24):
            raise MDefError(f"bit field {offset},{width} does not fit a 24-bit word")
    elif m["offset"] is not None:
        raise MDefError(f"{kind}: takes no bit field")
    return MDef(kind, addr, offset, width, signed), m.end()


class MVars:
    """The card's 8192 M-variable definitions and the values of self-referenced ones."""

    def __init__(self, memory: Memory) -> None:
        self.memory = memory
        self.defs: list[MDef] = [MDef()] * COUNT
        self.own: dict[int, float] = {}

    def define(self, n: int, d: MDef) -> None:
        self.defs[n] = d
        self.own.pop(n, None)

    def clear(self) -> None:
        self.defs = [MDef()] * COUNT
        self.own.clear()

    def read(self, n: int) -> float:
        d, mem = self.defs[n], self.memory
        match d.kind:
            case "X" | "Y":
                v = (mem.read(d.kind, d.addr) >> d.offset) & ((1 << d.width) - 1)
                return float(v - (1 << d.width) if d.signed and v >> (d.width - 1) else v)
            case "D":
                return float(mem.read_fixed(d.addr))
            case "L":
                return mem.read_float(d.addr)
            case "F":
                return float(struct.unpack("<f", struct.pack("<I", self._dpram32(d.addr)))[0])
            case "DP":
                v = self._dpram32(d.addr)
                return float(v - (1 << 32) if v >> 31 else v)
            case "*":
                return self.own.get(n, 0.0)
        return 0.0

    def write(self, n: int, value: float) -> None:
        d, mem = self.defs[n], self.memory
        match d.kind:
            case "X" | "Y":
                field = wrap(round_to_int(value), d.width, signed=False)
                mask = ((1 << d.width) - 1) << d.offset
                word = (mem.read(d.kind, d.addr) & ~mask) | (field << d.offset)
                mem.write(d.kind, d.addr, word)
            case "D":
                mem.write_fixed(d.addr, round_to_int(value))
            case "L":
                mem.write_float(d.addr, value)
            case "F":
                f = value if math.isfinite(value) else 0.0
                raw = struct.unpack("<I", struct.pack("<f", max(min(f, 3.4e38), -3.4e38)))[0]
                self._set_dpram32(d.addr, raw)
            case "DP":
                self._set_dpram32(d.addr, wrap(round_to_int(value), 32, signed=False))
            case "*":
                self.own[n] = float(round_to_int(value))

    def _dpram32(self, addr: int) -> int:
        mem = self.memory
        return (mem.read("Y", addr) & 0xFFFF) | (mem.read("X", addr) & 0xFFFF) << 16

    def _set_dpram32(self, addr: int, raw: int) -> None:
        self.memory.write("Y", addr, raw & 0xFFFF)
        self.memory.write("X", addr, raw >> 16)

    def image(self) -> dict[str, str]:
        """The definitions that differ from undefined, for SAVE."""
        return {str(n): d.text() for n, d in enumerate(self.defs) if d.kind}

    def restore(self, image: dict[str, str]) -> None:
        self.clear()
        for n, text in image.items():
            self.define(int(n), parse_definition(text)[0])
