"""The Turbo PMAC's DPRAM and host port as the host sees them (spec pmac.md §2.10, §2.11), and the
number formats PComm32 converts, without I/O.

The offsets, control words and interrupt bits are vdevmaps.pmac's, the map the daemon's card
serves (the client never imports the daemon).
"""

from __future__ import annotations

import math
import re
import struct
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
    ACK or an error line has none)."""
    return slot[0] != CR or slot[1] != 0 or (slot[2] | slot[3] << 8) - 1 <= len(slot) - RESP_HEAD


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
#: directives of the PComm32 preprocessor this client does not implement
UNSUPPORTED = ("include", "ifdef", "ifndef", "if", "else", "elif", "endif", "undef", "pragma", "macro")


class PreprocessError(ValueError):
    """A line the download preprocessor cannot handle; `line` is its number (1-based)."""

    def __init__(self, line: int, message: str) -> None:
        super().__init__(f"line {line}: {message}")
        self.line = line


def strip_comment(text: str) -> str:
    """`text` without a `;` or `//` comment and surrounding white space."""
    for mark in (";", "//"):
        at = text.find(mark)
        if at >= 0:
            text = text[:at]
    return text.strip()


def preprocess(source: str, macros: bool = True) -> list[tuple[int, str]]:
    """The lines PmacDownloadA sends, each with its line number in `source` (1-based): comments
    and blank lines dropped, `#define NAME value` lines taken out and (with `macros`) NAME
    replaced as a whole word in the lines after it. `#1J+`-style lines are motor commands, not
    directives. PreprocessError for the directives in UNSUPPORTED and `#define NAME(args)`."""
    names: dict[str, str] = {}
    pattern: re.Pattern[str] | None = None
    out: list[tuple[int, str]] = []
    for number, raw in enumerate(source.splitlines(), 1):
        text = strip_comment(raw)
        if not text:
            continue
        directive = _DIRECTIVE.fullmatch(text)
        if directive:
            word = directive.group(1).lower()
            if word == "define":
                definition = _DEFINE.fullmatch(directive.group(2))
                if not definition or definition.group(2).startswith("("):
                    raise PreprocessError(number, f"unsupported #define: {text!r}")
                value = definition.group(2).strip()
                if pattern is not None:  # a value may use the names defined before it
                    value = pattern.sub(lambda m: names[m.group(1)], value)
                names[definition.group(1)] = value
                ordered = sorted(names, key=len, reverse=True)
                pattern = re.compile(r"\b(" + "|".join(map(re.escape, ordered)) + r")\b")
                continue
            if word in UNSUPPORTED:
                raise PreprocessError(number, f"#{word} is not supported by this client")
        if macros and pattern is not None:
            text = pattern.sub(lambda m: names[m.group(1)], text)
        out.append((number, text))
    return out
