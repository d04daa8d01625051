"""The Turbo PMAC's DPRAM and host port as the host sees them (spec pmac.md §2.10, §2.11), and the
number formats PComm32 converts, without I/O.

The client runs on machines without the daemon, so the offsets are duplicated here from the card's
modules: `vdevd/devices/pmac/dpram.py` (DPRAM layout, ASCII handshake, reporting buffers) and
`vdevd/devices/pmac/hostport.py` (host port and interrupt controller). Keep them in step.
"""

from __future__ import annotations

import enum
import math
import re
import struct
from dataclasses import dataclass
from typing import NamedTuple

CARD_TYPE = "pmac-turbo"
DPRAM, HOST, LINE = "dpram", "host", "inta"

# -- DPRAM (vdevd/devices/pmac/dpram.py) ---------------------------------------------------------------
DPRAM_SIZE = 0x4000  # 8k x 16 [UM p.402]
BASE = 0x060000  # PMAC address of host offset 0: A <-> 4 (A - BASE)
CMD_CONTROL, CMD_CHAR, CMD_BUFFER, CMD_MAX = 0x0E9C, 0x0E9E, 0x0EA0, 160
RESP_CONTROL, RESP_COUNT, RESP_BUFFER, RESP_MAX = 0x0F40, 0x0F42, 0x0F44, 255
#: one read takes a whole response slot: control, count, up to 255 characters and their NUL
RESP_SLOT = RESP_BUFFER - RESP_CONTROL + RESP_MAX + 1
#: the slot's head, control word and count: all there is of an ACK, an error or an empty line
RESP_HEAD = RESP_BUFFER - RESP_CONTROL
CR, ACK, BELL = 0x0D, 0x06, 0x07

# -- host port and interrupt controller (vdevd/devices/pmac/hostport.py) ----------------------------
HOST_SIZE = 16
IR_STATUS, IR_MASK = 8, 9  # status (write 1 to clear), enable mask


class HostIrq(enum.IntFlag):
    """Interrupt controller bits IR0-IR7 (ASSUMPTION of spec §2.11, the card's README)."""

    IN_POSITION = 1 << 0
    BUFFER_REQUEST = 1 << 1
    FATAL_FOLLOWING_ERROR = 1 << 2
    WARNING_FOLLOWING_ERROR = 1 << 3
    ASCII_READY = 1 << 4
    COMPARE_EQU1 = 1 << 5
    COMPARE_EQU5 = 1 << 6
    DPRAM = 1 << 7


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
    if not word & 0x8000:
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
    if word & 0x8000:
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


# -- the reporting buffers, Turbo layout (vdevd/devices/pmac/dpram.py) ---------------------------
RT_HOST_BUSY, RT_READY, RT_MASK = 0x006A, 0x006E, 0x0070  # X:$06001A, X:$06001B, L:$06001C
RT_TIMER, RT_MOTORS, RT_MOTOR = 0x006C, 0x0074, 48  # Y:$06001B; $06001D + 12 words per motor
BG_CS_COUNT, BG_HOST_BUSY, BG_READY = 0x0674, 0x0676, 0x067A  # Y:$06019D, X:$06019D, X:$06019E
BG_TIMER, BG_STATUS = 0x0678, 0x0688  # Y:$06019E; L:$0601A2 global status
READY = 0x8000  # bit 15 of a data-ready (or host-busy) word
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
