"""The Turbo PMAC's DPRAM and host port as the host sees them (spec pmac.md §2.10, §2.11), and the
number formats PComm32 converts, without I/O.

The offsets, control words and interrupt bits are vdevmaps.pmac's, the map the daemon's card
serves (the client never imports the daemon).
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

from vdevmaps.pmac import (
    CR,
    ERROR_FLAG,
    RESP_BUFFER,
    RESP_CONTROL,
    RESP_MAX,
    RT_MOTOR,
    RT_MOTORS,
)

#: one read takes a whole response slot: control, count, up to 255 characters and their NUL
RESP_SLOT = RESP_BUFFER - RESP_CONTROL + RESP_MAX + 1
#: the slot's head, control word and count: all there is of an ACK, an error or an empty line
RESP_HEAD = RESP_BUFFER - RESP_CONTROL


# -- the ASCII response slot -----------------------------------------------------------------------------
class Posted(NamedTuple):
    """One line the card posted in the response slot: `terminator` is CR (a data line), ACK (the
    end of the reply) or None for an error, whose number is `error`; `text` has no terminator."""

    text: bytes
    terminator: int | None
    error: int = 0


def command_bytes(line: bytes) -> bytes:
    """What the host writes from 0x0E9E: the control-character slot (0: a command line), its pad,
    then the line NUL-terminated. A 2- or 4-byte write would be a single (aligned) bus access,
    so such a block gets one more NUL."""
    data = b"\0\0" + line + b"\0"
    return data + b"\0" if len(data) in (2, 4) else data


def error_number(word: int) -> int | None:
    """The ERRnnn of a response control word (0x80 | hundreds, BCD tens and units [EPICS-VME]),
    or None when the word is not an error."""
    if not word & ERROR_FLAG:
        return None
    return (word >> 8 & 0x0F) * 100 + (word >> 4 & 0x0F) * 10 + (word & 0x0F)


def parse_slot(slot: bytes) -> Posted | None:
    """The line in a read of the response slot (0x0F40 on), or None when none is posted
    (control word 0)."""
    word = slot[0] | slot[1] << 8
    if not word:
        return None
    text = slot[4:3 + (slot[2] | slot[3] << 8)]  # the count includes the NUL
    if b"\0" in text:
        text = text[:text.index(b"\0")]
    if word & ERROR_FLAG:
        return Posted(text, None, error_number(word) or 0)
    return Posted(text, word & 0xFF)


def slot_whole(slot: bytes) -> bool:
    """A read of the response slot holds all of its line: every character of a data line (an
    ACK or an error line has none). A data line's control word is 0x000D, or 0x020D for a
    program's SEND message [PMAC1 DPRAM UM p.29]."""
    return slot[0] != CR or slot[1] not in (0, 2) or \
        (slot[2] | slot[3] << 8) - 1 <= len(slot) - RESP_HEAD


def error_text(code: int) -> bytes:
    """An error as a serial port with I6 = 1 shows it: BELL, ERRnnn, CR [UM p.384]."""
    return b"\x07ERR%03d\r" % code


# -- 48-bit values ----------------------------------------------------------------------------------------
def sign24(v: int) -> int:
    v &= 0xFFFFFF
    return v - 0x1000000 if v & 0x800000 else v


def join48(low: int, high: int) -> int:
    """A 48-bit fixed value from its two sign-extended 24-bit halves [UM p.402]."""
    return sign24(high) * (1 << 24) + (low & 0xFFFFFF)


def pmac_float(low: int, high: int) -> float:
    """The 48-bit PMAC float in two 24-bit halves: bits 47-12 the 36-bit two's-complement
    mantissa M, bits 11-0 the exponent E + $800, value M * 2**(E - 34) [EPICS-HW
    doubleToPMACFloat; vdevd/devices/pmac/numbers.py]."""
    word = (high & 0xFFFFFF) << 24 | (low & 0xFFFFFF)
    mantissa = word >> 12
    if mantissa & 1 << 35:
        mantissa -= 1 << 36
    exponent = (word & 0xFFF) - 0x800
    try:
        return math.ldexp(mantissa, exponent - 34)
    except OverflowError:
        return math.copysign(math.inf, mantissa)


# -- the reporting buffers, Turbo layout ------------------------------------------------------------
_RT_RECORD = struct.Struct("<12i")


@dataclass(frozen=True)
class MotorReport:
    """One motor's record of the real-time buffer ($06001D + 12(n-1)): status words 1 and 2
    (24 bits), following error, position bias and actual position (1/(Ixx08*32) count), filtered
    velocity (1/(Ixx09*32) count per servo cycle), the DAC register (16-bit value in bits 8-23)."""

    status1: int
    status2: int
    following_error: int
    bias: int
    actual: int
    velocity: int
    dac: int

    @property
    def commanded(self) -> int:
        """Commanded position: actual + following error (1/(Ixx08*32) count)."""
        return self.actual + self.following_error


def motor_report(record: bytes, offset: int = 0) -> MotorReport:
    """Decode a 48-byte motor record of the real-time buffer."""
    w = _RT_RECORD.unpack_from(record, offset)
    return MotorReport(w[3] & 0xFFFFFF, w[4] & 0xFFFFFF, join48(w[0], w[1]), join48(w[5], w[6]),
                       join48(w[10], w[11]), w[7], w[2])


def realtime_motor(motor: int) -> int:
    """Host offset of motor n's (1-based) record in the real-time buffer."""
    return RT_MOTORS + (motor - 1) * RT_MOTOR


# -- PmacDownloadA's preprocessing --------------------------------------------------------------------------
_DIRECTIVE = re.compile(r"#\s*([A-Za-z]+)\b\s*(.*)")
_DEFINE = re.compile(r"([A-Za-z_]\w*)\s*(.*)")
_NAME = re.compile(r"[A-Za-z_]\w*")
_INCLUDE = re.compile(r'"([^"]+)"|<([^>]+)>')
#: directives of the PComm32 preprocessor this client does not implement
UNSUPPORTED = ("if", "elif", "pragma", "macro")
#: how deep #include may nest, and how many lines a download may have in all (bounded input)
MAX_INCLUDE_DEPTH = 16
MAX_LINES = 200_000


class PreprocessError(ValueError):
    """A line the download preprocessor cannot handle; `line` is its number (1-based), `file`
    the file it is in ("" for the downloaded text itself)."""

    def __init__(self, line: int, message: str, file: str = "") -> None:
        super().__init__(f"{file + ':' if file else ''}line {line}: {message}")
        self.line = line
        self.file = file


class SourceLine(NamedTuple):
    """A line PmacDownloadA sends: its number in its file (1-based), its text, the file ("" the
    downloaded text itself, else the #include's name as written)."""

    number: int
    text: str
    file: str = ""


def strip_comment(text: str) -> str:
    """`text` without a `;` or `//` comment and surrounding white space."""
    for mark in (";", "//"):
        at = text.find(mark)
        if at >= 0:
            text = text[:at]
    return text.strip()


class _Preprocessor:
    """The state of one download's preprocessing: the #define table, the #ifdef stack per file."""

    def __init__(self, macros: bool, include: Callable[[str, str], tuple[str, str]] | None) -> None:
        self.macros = macros
        self.include = include
        self.names: dict[str, str] = {}
        self.pattern: re.Pattern[str] | None = None
        self.out: list[SourceLine] = []
        self.opened: list[str] = []  # the files being read, outermost first (cycles)

    def substitute(self, text: str) -> str:
        return self.pattern.sub(lambda m: self.names[m.group(1)], text) if self.pattern else text

    def _names_changed(self) -> None:
        ordered = sorted(self.names, key=len, reverse=True)
        self.pattern = (re.compile(r"\b(" + "|".join(map(re.escape, ordered)) + r")\b")
                        if ordered else None)

    def run(self, source: str, file: str, where: str) -> None:
        """Preprocess `source` (`file` its name as an error names it, `where` its resolved
        place for the includes it makes)."""
        active: list[bool] = []  # one entry per open #ifdef: whether its branch is taken
        for number, raw in enumerate(source.splitlines(), 1):
            def fail(message: str, number: int = number) -> PreprocessError:
                return PreprocessError(number, message, file)
            text = strip_comment(raw)
            if not text:
                continue
            directive = _DIRECTIVE.fullmatch(text)
            word = directive.group(1).lower() if directive else ""
            if directive and word in ("ifdef", "ifndef", "else", "endif"):
                arg = directive.group(2).strip()
                if word in ("ifdef", "ifndef"):
                    if not _NAME.fullmatch(arg):
                        raise fail(f"#{word} needs a name: {text!r}")
                    taken = (arg in self.names) == (word == "ifdef")
                    active.append(taken and all(active))
                elif not active:
                    raise fail(f"#{word} without #ifdef")
                elif word == "else":
                    outer = all(active[:-1])
                    active[-1] = outer and not active[-1]
                else:
                    active.pop()
                continue
            if not all(active):
                continue  # a branch not taken
            if directive and word == "define":
                definition = _DEFINE.fullmatch(directive.group(2))
                if not definition or definition.group(2).startswith("("):
                    raise fail(f"unsupported #define: {text!r}")
                self.names[definition.group(1)] = self.substitute(definition.group(2).strip())
                self._names_changed()
                continue
            if directive and word == "undef":
                self.names.pop(directive.group(2).strip(), None)
                self._names_changed()
                continue
            if directive and word == "include":
                self._include(directive.group(2).strip(), fail, where)
                continue
            if directive and word in UNSUPPORTED:
                raise fail(f"#{word} is not supported by this client")
            if len(self.out) >= MAX_LINES:
                raise fail(f"more than {MAX_LINES} lines")
            self.out.append(SourceLine(number, self.substitute(text) if self.macros else text,
                                       file))
        if active:
            raise PreprocessError(len(source.splitlines()), "#ifdef without #endif", file)

    def _include(self, arg: str, fail: Callable[[str], PreprocessError], where: str) -> None:
        named = _INCLUDE.fullmatch(arg)
        if not named:
            raise fail(f"#include needs \"file\" or <file>: {arg!r}")
        name = named.group(1) or named.group(2)
        if self.include is None:
            raise fail(f"#include {name!r}: no file to include from (lines from getproc)")
        if len(self.opened) >= MAX_INCLUDE_DEPTH:
            raise fail(f"#include nested deeper than {MAX_INCLUDE_DEPTH}")
        try:
            text, place = self.include(name, where)
        except OSError as exc:
            raise fail(f"#include {name!r}: {exc.strerror or exc}") from None
        if place in self.opened:
            raise fail(f"#include {name!r} includes itself")
        self.opened.append(place)
        try:
            self.run(text, name, place)
        finally:
            self.opened.pop()


def preprocess(source: str, macros: bool = True,
               include: Callable[[str, str], tuple[str, str]] | None = None,
               where: str = "") -> list[SourceLine]:
    """The lines PmacDownloadA sends, as PComm32's preprocessor makes them: comments and blank
    lines dropped; `#define NAME value` taken out and (with `macros`) NAME replaced as a whole
    word in the lines after it; `#undef NAME`; `#ifdef`/`#ifndef`/`#else`/`#endif` (nested)
    keeping the lines of the branches taken; `#include "file"` (or `<file>`) read through
    `include(name, where) -> (text, place)` (`where`: the including file's place) and
    preprocessed in line, with the same #define table, at most MAX_INCLUDE_DEPTH deep, a
    file including itself refused. `#1J+`-style lines are motor commands, not directives.
    PreprocessError for `#if`, `#elif`, `#pragma`, `#macro` and `#define NAME(args)`."""
    state = _Preprocessor(macros, include)
    if where:
        state.opened.append(where)
    state.run(source, "", where)
    return state.out
