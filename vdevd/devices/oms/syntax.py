"""OMS ASCII command syntax without I/O (spec oms.md §4.1; [CRM-1-1]).

A command is a two- or three-letter mnemonic (upper or lower case; some start with `#` or `?`),
an optional `[n]` task index, then its operand, which must immediately follow and ends at a
space, CR, LF or `;`. Commands without operands need no terminator (`AXRP`). `Lexer.feed` takes the
bytes as the command ring delivers them and returns the complete commands; an incomplete one at
the end waits for more bytes. An unknown mnemonic or a malformed operand is returned as a
`Command` with `error` set (the firmware raises the command-error flag for it and goes on).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

SEPARATORS = frozenset(b" \r\n;\t\0")
#: command streams whose parse a lexer remembers, and the longest it remembers (bytes)
MEMO_ENTRIES = 256
MEMO_BYTES = 256


class Operand(enum.Enum):
    """What may follow a mnemonic."""

    NONE = "none"  # nothing (a `?` is still accepted by queries such as `PS?`)
    NUMBERS = "numbers"  # signed decimals, comma separated per axis, empty to skip
    HEX = "hex"  # hexadecimal words, comma separated
    LETTERS = "letters"  # letters and signs per axis (`LMH,H`, `SVP-`, `PSO`)
    POINT = "point"  # numbers after an optional A (absolute) or R (relative) flag (`VP[1]A,5`)


class CommandError(Exception):
    """The firmware refuses a command: ODBR bit 24, no reply, nothing else changes [S §3.4.4;
    spec §4.4]. A handler raises it; the firmware flags it and parses on."""


@dataclass(frozen=True, slots=True)
class Command:
    """One command: mnemonic, task index (`VV[2]`), operand text, and an error if malformed."""

    mnemonic: str
    operand: str = ""
    index: int | None = None
    error: str = ""

    @property
    def query(self) -> bool:
        return self.operand == "?"


_NUMBER_CHARS = frozenset(b"+-.0123456789,")
_HEX_CHARS = frozenset(b"0123456789abcdefABCDEF,")
_LETTER_CHARS = frozenset(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz+-,")
_POINT_FLAGS = frozenset(b"AaRr")
#: numeric operands end at the next letter (`MR5GO`); the others must end at a separator
_ENDS_AT_A_LETTER = frozenset({Operand.NUMBERS, Operand.POINT})
_AS_SENT = frozenset({Operand.NUMBERS, Operand.HEX})


class Lexer:
    """Splits the command stream into `Command`s; `table` maps mnemonics to their operand kind."""

    def __init__(self, table: Mapping[str, Operand], memo_entries: int = MEMO_ENTRIES) -> None:
        self.table = table
        self.pending = b""
        self._three = {m for m in table if len(m) == 3}
        #: what `_split` made of up to `memo_entries` streams (a host repeats its strings,
        #: "AX RP;"): the parse depends on the bytes and the fixed table only, and a Command
        #: is immutable; 0 parses every stream afresh
        self.memo_entries = memo_entries
        self._memo: dict[bytes, tuple[tuple[Command, ...], bytes]] = {}

    def reset(self) -> None:
        self.pending = b""

    def feed(self, data: bytes) -> list[Command]:
        """The commands `data` completes, after what an earlier feed left incomplete."""
        buf = self.pending + data
        known = self._memo.get(buf)
        if known is None:
            known = self._split(buf)
            if self.memo_entries and len(buf) <= MEMO_BYTES:
                if len(self._memo) >= self.memo_entries:
                    self._memo.clear()
                self._memo[buf] = known
        commands, self.pending = known
        return list(commands)

    def _split(self, buf: bytes) -> tuple[tuple[Command, ...], bytes]:
        """The complete commands of `buf` and the incomplete rest (or, over 1024 bytes, the rest
        as one bad command)."""
        out: list[Command] = []
        i, n = 0, len(buf)
        while i < n:
            if buf[i] in SEPARATORS:
                i += 1
                continue
            cmd, end = self._one(buf, i)
            if cmd is None:  # incomplete: wait for the rest
                break
            out.append(cmd)
            i = end
        rest = buf[i:]
        if len(rest) > 1024:  # nothing valid is that long: drop it as one bad command
            out.append(Command(rest[:16].decode("latin-1"), error="command too long"))
            rest = b""
        return tuple(out), rest

    def _one(self, buf: bytes, i: int) -> tuple[Command | None, int]:
        n = len(buf)
        mnemonic = self._mnemonic(buf, i)
        if mnemonic is None:
            end = i
            while end < n and buf[end] not in SEPARATORS:
                end += 1
            if end == n:
                return None, i
            word = buf[i:end].decode("latin-1")
            return Command(word.upper(), error=f"unknown command {word!r}"), end
        j = i + len(mnemonic)
        index = None
        if j < n and buf[j] == ord("["):
            close = buf.find(b"]", j)
            if close < 0:
                return (None, i) if n - j < 8 else (Command(mnemonic, error="bad index"), n)
            text = buf[j + 1: close]
            if not text.isdigit():
                return Command(mnemonic, error="bad task index"), close + 1
            index, j = int(text), close + 1
        kind = self.table[mnemonic]
        start = j
        if j < n and buf[j] == ord("?"):
            j += 1
        elif j < n and buf[j] == ord("=") and kind is not Operand.NONE:
            j += 1  # `VO[n]=120`
            start = j
            j = _scan(buf, j, kind)
        elif kind is not Operand.NONE:
            j = _scan(buf, j, kind)
        operand = buf[start:j].decode("latin-1")
        if j == n:
            # the operand may go on in the next write (or be a longer mnemonic's start)
            return None, i
        if buf[j] not in SEPARATORS and kind is not Operand.NONE and operand and (
                kind not in _ENDS_AT_A_LETTER):
            end = j
            while end < n and buf[end] not in SEPARATORS:
                end += 1
            return Command(mnemonic, buf[start:end].decode("latin-1"), index,
                           error="malformed operand"), end
        return Command(mnemonic, operand if kind in _AS_SENT else operand.upper(), index), j

    def _mnemonic(self, buf: bytes, i: int) -> str | None:
        head = buf[i: i + 3].decode("latin-1").upper()
        if len(head) == 3 and head in self._three:
            return head
        if head[:2] in self.table:
            return head[:2]
        return None


def _scan(buf: bytes, j: int, kind: Operand) -> int:
    n = len(buf)
    if kind is Operand.POINT:
        if j < n and buf[j] in _POINT_FLAGS:
            j += 1
        kind = Operand.NUMBERS
    chars = {Operand.NUMBERS: _NUMBER_CHARS, Operand.HEX: _HEX_CHARS,
             Operand.LETTERS: _LETTER_CHARS}[kind]
    while j < n and buf[j] in chars:
        j += 1
    return j


def numbers(operand: str) -> list[float | None]:
    """`1,,-2.5` -> [1.0, None, -2.5]; ValueError if a field is not a number."""
    out: list[float | None] = []
    for field in operand.split(","):
        field = field.strip()
        out.append(None if field == "" else float(field))
    return out


def hex_words(operand: str) -> list[int | None]:
    return [None if f == "" else int(f, 16) for f in operand.split(",")]


def beyond_axes(fields: list[Any], n: int) -> bool:
    """A per-axis operand gives a value for an axis past the card's `n`: an error. Empty fields
    past it are not: EPICS writes a field for each of 8 axes whatever the card has (`KS1,,,,,,,`
    from [E-traj] L826-830)."""
    return any(f is not None and f != "" for f in fields[n:])
