"""DMC-13X8 command syntax without I/O: framing of the host byte stream, ASCII statements and their
arguments, binary commands [M Ch5 §Command Syntax - ASCII, §Command Syntax - Binary], spec galil.md
§4.1-4.2.

The interpreter feeds the bytes it received to `next_frame` until it returns None, turns each
ASCII frame into a `Statement` with `split_statement`, and runs a binary frame through
`decode_binary` and `binary_to_ascii` so that both forms take the same code path. Malformed input
raises `GalilError` with the TC code the card reports [M Ch5 §Controller Response to DATA].
"""

from __future__ import annotations

import enum
import re
from collections.abc import Mapping, Sequence, Set
from dataclasses import dataclass
from decimal import Decimal
from typing import Final, NamedTuple

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.numbers import GALIL_REAL_SIZE, from_galil_real, galil_real
from vdevd.devices.galil.params import PARAMS

# ---------------------------------------------------------------------------------------------
# Framing


class Frame(NamedTuple):
    """One command from the host: ASCII text without its terminator, or a whole binary command."""

    data: bytes
    binary: bool


CR = 0x0D
SEMICOLON = 0x3B
QUOTE = 0x22
_SKIPPED = frozenset(b"\n\0 ")  # before a command: LF of CR LF, NUL padding, spaces
_ASCII_STOPS = re.compile(rb'[\r;"]')  # the bytes an ASCII command's framing looks at
BINARY_FIELD_SIZES: Final = frozenset({0, 1, 2, 4, GALIL_REAL_SIZE})
BINARY_HEADER_SIZE = 4


def next_frame(buf: bytes) -> tuple[Frame | None, int]:
    """The next complete command at the start of `buf` and the number of bytes it used.

    ASCII ends at CR or ';' (consumed, not part of the data); a ';' inside double quotes does not
    end it (MG "a;b"), and a comment (`'text`, `REM text`) runs to the CR. LF, NUL and spaces
    before a command are consumed. A first byte 0x80-0xFF starts a binary command: the 4-byte
    header then bytes-per-field x popcount(mask) data bytes [M Ch5 §Binary Command Format]; a
    header with an invalid bytes-per-field is a frame of its 4 bytes, which decode_binary answers
    with TC 97. A bare terminator is an empty ASCII frame (the card answers ':').
    If the command is not complete: (None, bytes skipped so far).
    """
    start = 0
    while start < len(buf) and buf[start] in _SKIPPED:
        start += 1
    if start == len(buf):
        return None, start
    if buf[start] & 0x80:
        return _binary_frame(buf, start)
    return _ascii_frame(buf, start)


def _binary_frame(buf: bytes, start: int) -> tuple[Frame | None, int]:
    header_end = start + BINARY_HEADER_SIZE
    if len(buf) < header_end:
        return None, start
    width, mask = buf[start + 1], buf[start + 3]
    end = header_end + width * mask.bit_count() if width in BINARY_FIELD_SIZES else header_end
    if len(buf) < end:
        return None, start
    return Frame(bytes(buf[start:end]), True), end


def _ascii_frame(buf: bytes, start: int) -> tuple[Frame | None, int]:
    if buf.startswith((b"'", b"REM "), start):
        end = buf.find(b"\r", start)
        return (None, start) if end < 0 else (Frame(bytes(buf[start:end]), False), end + 1)
    quoted = False
    stop = _ASCII_STOPS.search(buf, start)
    while stop is not None:
        i = stop.start()
        byte = buf[i]
        if byte == CR or (byte == SEMICOLON and not quoted):
            return Frame(bytes(buf[start:i]), False), i + 1
        if byte == QUOTE:
            quoted = not quoted
        stop = _ASCII_STOPS.search(buf, i + 1)
    return None, start


# ---------------------------------------------------------------------------------------------
# ASCII statements


@dataclass(frozen=True)
class Statement:
    """An ASCII command: its name as written and its raw argument text."""

    name: str
    arg: str


LABEL = "#"  # `#NAME`: arg = NAME
ASSIGNMENT = "="  # `V1=V1+1000`: arg = the whole text, see parse_assignment
COMMENT = "'"  # `'text`: arg = text
REMARK = "REM"  # `REM text`: arg = text
#: commands written NAME[n]=... [M Ch6 §Electronic Cam]; other NAME[..]= are array elements
INDEXED_COMMANDS: Final = frozenset({"ET"})

AXIS_LETTERS: Final = "XYZW"
AXIS_ALIASES: Final = "ABCDEFGH"  # A-D are X-W [M "Using This Manual"]; E-H are axes 5-8
MAX_NAME_LENGTH = 8  # variable and array names [CR-DUMP "[,]"]
_ASSIGNMENT_LHS = re.compile(r"([A-Za-z][A-Za-z0-9]*) *(\[)?")
_COMMAND_AXIS_ASSIGN = re.compile(rf"[A-Z]{{2}}[{AXIS_LETTERS}{AXIS_ALIASES}]+ *=")
#: the per-axis commands: `<cmd>N=` is the command for the virtual axis N (`PRN=1000`, `KPN=1`
#: refused), not a variable of that name [M Ch6 §Virtual Axis]
AXIS_ASSIGN_COMMANDS: Final = frozenset(PARAMS) | frozenset(
    ("DP", "DE", "IP", "GA", "GR", "GM", "EM", "EG", "EQ", "YA", "YB", "YC", "YS", "YR", "BM",
     "BI", "BB", "BZ", "BS", "AF", "CD", "OC"))
_COMMAND_N_ASSIGN = re.compile(r"([A-Z]{2})N *=")


def split_statement(text: str) -> Statement:
    """Split one ASCII frame into command name and argument [M Ch5 §Command Syntax - ASCII].

    A command is two upper-case letters; the spaces between name and argument are dropped
    ("PR 1000,,-500" -> PR, "1000,,-500"; "KPX=10" -> KP, "X=10"). Also: labels (#), comments
    (' and REM), two control characters (^R^V = "\\x12\\x16") and variable or array assignments
    ("V1=V1+1000", "spx=100", "VX [COUNT]=N": name "=", arg the whole text). A name followed by
    '=' is an assignment unless it is two upper-case letters and axis letters ("ACYH=400000"),
    a per-axis command and N, the virtual axis ("PRN=100": PR, "N=100"), or an INDEXED_COMMANDS
    entry ("ET[1]=40,20"). Anything else, lower-case commands included,
    is TC 1 [M Ch5 §Controller Response to DATA]. Empty text is Statement("", "").
    """
    text = text.lstrip(" ")
    if not text:
        return Statement("", "")
    if text[0] == LABEL:
        return Statement(LABEL, text[1:])
    if text[0] == COMMENT:
        return Statement(COMMENT, text[1:])
    if text == REMARK or text.startswith(REMARK + " "):
        return Statement(REMARK, text[len(REMARK):].lstrip(" "))
    if len(text) >= 2 and text[0] < " " and text[1] < " ":
        return Statement(text[:2], text[2:])
    if _is_assignment(text):
        return Statement(ASSIGNMENT, text)
    if len(text) >= 2 and "A" <= text[0] <= "Z" and "A" <= text[1] <= "Z":
        return Statement(text[:2], text[2:].lstrip(" "))
    raise GalilError(TC.UNRECOGNIZED_COMMAND, repr(text))


def _is_assignment(text: str) -> bool:
    lhs = _ASSIGNMENT_LHS.match(text)
    if lhs is None:
        return False
    name, bracket = lhs.group(1), lhs.group(2)
    if bracket:
        return name not in INDEXED_COMMANDS
    if text[lhs.end():].lstrip(" ")[:1] != "=":
        return False
    virtual = _COMMAND_N_ASSIGN.match(text)
    if virtual is not None and virtual.group(1) in AXIS_ASSIGN_COMMANDS:
        return False
    return not _COMMAND_AXIS_ASSIGN.match(text)


def parse_assignment(text: str) -> tuple[str, str | None, str]:
    """`NAME=expr` or `NAME[index]=expr` -> (NAME, index text or None, value text).

    Spaces around the parts are removed ("V1 = _TPX" -> ("V1", None, "_TPX")); an empty value
    ("V1=") asks the card to print the variable [M Ch2 Ex14]. A name longer than 8 characters or
    text that is no assignment: TC 9; an unclosed '[': TC 55.
    """
    lhs = _ASSIGNMENT_LHS.match(text.lstrip(" "))
    if lhs is None:
        raise GalilError(TC.VARIABLE_ERROR, repr(text))
    rest = text.lstrip(" ")[lhs.end():]
    name, index = lhs.group(1), None
    if len(name) > MAX_NAME_LENGTH:
        raise GalilError(TC.VARIABLE_ERROR, f"{name!r} is longer than {MAX_NAME_LENGTH} characters")
    if lhs.group(2):
        close = _closing_bracket(rest)
        index, rest = rest[:close].strip(" "), rest[close + 1:]
    rest = rest.lstrip(" ")
    if not rest.startswith("="):
        raise GalilError(TC.VARIABLE_ERROR, repr(text))
    return name, index, rest[1:].strip(" ")


def _closing_bracket(text: str) -> int:
    """Index of the ']' that closes a '[' just before `text`; TC 55 if none."""
    depth = 1
    for i in range(len(text)):
        if text[i] == "[":
            depth += 1
        elif text[i] == "]":
            depth -= 1
            if depth == 0:
                return i
    raise GalilError(TC.MISSING_BRACKET, repr(text))


# ---------------------------------------------------------------------------------------------
# Arguments


class Query(enum.Enum):
    """A `?` field: interrogate the current value [M Ch5 §Interrogating Current Commanded Values]."""

    QUERY = "?"


QUERY: Final = Query.QUERY
#: one comma field: expression text, QUERY, or None when empty (keep the previous value)
Field = str | Query | None
MAX_AXES = 8


def parse_fields(arg: str, n_axes: int = MAX_AXES) -> list[Field]:
    """Comma-separated fields in X,Y,Z,W(,E..H) order [M Ch5 §Command Syntax - ASCII].

    "1000,,-500" -> ["1000", None, "-500"]; " ,?" -> [None, QUERY]; spaces around a field are
    dropped; the text stays an expression for expr.evaluate; "" -> []. More than `n_axes`
    fields: TC 4 "Operand error" (the card has no "too many fields" code; TC 50 means too few).
    """
    if not arg.strip(" "):
        return []
    fields: list[Field] = []
    for text in arg.split(","):
        text = text.strip(" ")
        fields.append(None if not text else QUERY if text == "?" else text)
    if len(fields) > n_axes:
        raise GalilError(TC.OPERAND_ERROR, f"{len(fields)} fields for {n_axes} axes")
    return fields


def axis_index(letter: str, n_axes: int) -> int:
    """Axis number of X,Y,Z,W or A-H [M "Using This Manual"]; TC 4 unknown, TC 90 not on this card."""
    index = -1 if len(letter) != 1 else max(AXIS_LETTERS.find(letter), AXIS_ALIASES.find(letter))
    if index < 0:
        raise GalilError(TC.OPERAND_ERROR, f"{letter!r} is not an axis")
    if index >= n_axes:
        raise GalilError(TC.ONLY_ABCD_VALID, f"axis {letter} on a {n_axes}-axis card")
    return index


_AXIS_ASSIGN = re.compile(rf" *([{AXIS_LETTERS}{AXIS_ALIASES}]+|\*) *=(.*)", re.DOTALL)


def parse_axis_assign(arg: str, n_axes: int = MAX_AXES) -> tuple[list[int], str] | None:
    """The single-axis form "X=1000", "YH=400000", "*=10" (all axes) [M Ch2 Ex1, M Ch5].

    -> (sorted axis numbers, value text), or None if `arg` is not of that form; an axis the card
    does not have is TC 90.
    """
    match = _AXIS_ASSIGN.fullmatch(arg)
    if match is None:
        return None
    letters, value = match.group(1), match.group(2).strip(" ")
    if letters == "*":
        return list(range(n_axes)), value
    return sorted({axis_index(letter, n_axes) for letter in letters}), value


@dataclass(frozen=True)
class AxisSet:
    """The axes of an action command (BG XZ) and the coordinate systems S and T [M Ch5]."""

    axes: tuple[int, ...]
    s: bool = False
    t: bool = False


def parse_axes(arg: str, n_axes: int) -> AxisSet:
    """Axis letters without commas ("XZ", "TW", "XYZS"); none at all means every axis [M Ch5].

    Spaces are ignored. A letter that is no axis nor S/T is TC 4 "Operand error"; an axis the
    card does not have is TC 90 "Only A B C D valid operand".
    """
    letters = arg.replace(" ", "")
    if not letters:
        return AxisSet(tuple(range(n_axes)))
    axes = {axis_index(letter, n_axes) for letter in letters if letter not in "ST"}
    return AxisSet(tuple(sorted(axes)), s="S" in letters, t="T" in letters)


# ---------------------------------------------------------------------------------------------
# Binary commands

#: command number -> name [M Ch5 §Binary command table]; 0xB3 is CR (the manual's "a3" is a
#: typo, 0xA3 is HM); 0xB5 "LE, VE" decodes as LE; reserved numbers are absent
BINARY_OPCODES: Final[dict[int, str]] = {
    0x81: "KP", 0x82: "KI", 0x83: "KD", 0x84: "DV", 0x85: "AF", 0x86: "KF", 0x87: "PL",
    0x88: "ER", 0x89: "IL", 0x8A: "TL", 0x8B: "MT", 0x8C: "CE", 0x8D: "OE", 0x8E: "FL",
    0x8F: "BL", 0x90: "AC", 0x91: "DC", 0x92: "SP", 0x93: "IT", 0x94: "FA", 0x95: "FV",
    0x96: "GR", 0x97: "DP", 0x98: "DE", 0x99: "OF", 0x9A: "GM",
    0xA0: "BG", 0xA1: "ST", 0xA2: "AB", 0xA3: "HM", 0xA4: "FE", 0xA5: "FI", 0xA6: "PA",
    0xA7: "PR", 0xA8: "JG", 0xA9: "MO", 0xAA: "SH",
    0xB0: "LM", 0xB1: "LI", 0xB2: "VP", 0xB3: "CR", 0xB4: "TN", 0xB5: "LE", 0xB6: "VT",
    0xB7: "VA", 0xB8: "VD", 0xB9: "VS", 0xBA: "VR",
    0xBD: "CM", 0xBE: "CD", 0xBF: "DT", 0xC0: "ET", 0xC1: "EM", 0xC2: "EP", 0xC3: "EG",
    0xC4: "EB", 0xC5: "EQ", 0xC6: "EC",
    0xC8: "AM", 0xC9: "MC", 0xCA: "TW", 0xCB: "MF", 0xCC: "MR", 0xCD: "AD", 0xCE: "AP",
    0xCF: "AR", 0xD0: "AS", 0xD1: "AI", 0xD2: "AT", 0xD3: "WT", 0xD4: "WC",
    0xD8: "RP", 0xD9: "TP", 0xDA: "TE", 0xDB: "TD", 0xDC: "TV", 0xDD: "RL", 0xDE: "TT",
    0xDF: "TS", 0xE0: "TI", 0xE1: "SC",
    0xE5: "TM", 0xE6: "CN", 0xE7: "LZ", 0xE8: "OP", 0xE9: "OB", 0xEA: "SB", 0xEB: "CB",
    0xEC: "II", 0xED: "EI", 0xEE: "AL",
}  # fmt: skip
#: name -> command number (VE shares 0xB5 with LE)
BINARY_NUMBERS: Final[dict[str, int]] = {name: op for op, name in BINARY_OPCODES.items()} | {"VE": 0xB5}
#: mask bit -> axis letter when a command has no data fields
BINARY_AXIS_LETTERS: Final = "XYZWEFGH"


@dataclass(frozen=True)
class BinaryCommand:
    """A decoded binary command [M Ch5 §Binary Command Format].

    `mask` selects axes (no data fields: BG, ST XYZS) or data fields (PR 1000,,-500); `values`
    are the fields' values in mask-bit order; `width` is the bytes per field (0 = none).
    """

    name: str
    coordinated: bool
    mask: int
    values: tuple[float, ...]
    width: int = 0


def decode_binary(frame: bytes) -> BinaryCommand:
    """Decode one binary frame (from next_frame).

    Unknown or reserved command number: TC 99 "Bad binary command number"; bytes per field not
    0/1/2/4/6, coordinated byte not 0/1 or a length that does not match the header: TC 97 "Bad
    binary command format". Data are big-endian two's complement; 6 bytes is a Galil real.
    """
    if len(frame) < BINARY_HEADER_SIZE:
        raise GalilError(TC.BAD_BINARY_FORMAT, f"{len(frame)}-byte header")
    opcode, width, coordinated, mask = frame[:BINARY_HEADER_SIZE]
    name = BINARY_OPCODES.get(opcode)
    if name is None:
        raise GalilError(TC.BAD_BINARY_NUMBER, f"0x{opcode:02X}")
    if width not in BINARY_FIELD_SIZES or coordinated > 1:
        raise GalilError(TC.BAD_BINARY_FORMAT, frame[:BINARY_HEADER_SIZE].hex(" "))
    data = frame[BINARY_HEADER_SIZE:]
    if len(data) != width * mask.bit_count():
        raise GalilError(TC.BAD_BINARY_FORMAT, f"{len(data)} data bytes for header {frame[:4].hex(' ')}")
    chunks = [data[i:i + width] for i in range(0, len(data), width)] if width else []
    values = tuple(_decode_value(chunk) for chunk in chunks)
    return BinaryCommand(name, bool(coordinated), mask, values, width)


def _decode_value(chunk: bytes) -> float:
    if len(chunk) == GALIL_REAL_SIZE:
        return from_galil_real(chunk)
    return float(int.from_bytes(chunk, "big", signed=True))


def encode_binary(
    name: str,
    fields: Mapping[int, float] | Sequence[float | None] | Set[int] = (),
    width: int = 0,
    coordinated: bool = False,
) -> bytes:
    """A binary command for the host side [M Ch5 §Binary Command Format].

    `fields` is {field number: value}, a list with None for a skipped field ([1000, None, -500]
    is PR 1000,,-500), or with `width` 0 a set of axis numbers ({0, 1, 2} with coordinated=True
    is ST XYZS). ValueError for an unknown name, a bad width or a value the width cannot carry.
    """
    opcode = BINARY_NUMBERS.get(name.upper())
    if opcode is None:
        raise ValueError(f"{name!r} has no binary command number")
    if width not in BINARY_FIELD_SIZES:
        raise ValueError(f"bytes per field must be one of {sorted(BINARY_FIELD_SIZES)}, not {width}")
    by_field = _by_field(fields)
    if isinstance(fields, Set) and width:
        raise ValueError("a set of axes carries no data: use width 0")
    mask = 0
    for field in by_field:
        if not 0 <= field < MAX_AXES:
            raise ValueError(f"field {field} is outside 0..{MAX_AXES - 1}")
        mask |= 1 << field
    data = b"".join(_encode_value(by_field[field], width) for field in sorted(by_field)) if width else b""
    return bytes((opcode, width, int(coordinated), mask)) + data


def _by_field(fields: Mapping[int, float] | Sequence[float | None] | Set[int]) -> dict[int, float]:
    if isinstance(fields, Mapping):
        return dict(fields)
    if isinstance(fields, Set):
        return dict.fromkeys(fields, 0.0)
    return {i: value for i, value in enumerate(fields) if value is not None}


def _encode_value(value: float, width: int) -> bytes:
    if width == GALIL_REAL_SIZE:
        return galil_real(value)
    if value != int(value):
        raise ValueError(f"{value} is not an integer: use width {GALIL_REAL_SIZE}")
    try:
        return int(value).to_bytes(width, "big", signed=True)
    except OverflowError:
        raise ValueError(f"{value} does not fit {width} bytes") from None


def binary_to_ascii(cmd: BinaryCommand) -> str:
    """The ASCII statement equivalent to a binary command, for the one interpreter code path.

    With no data fields the mask bits are axis letters X,Y,Z,W,E,F,G,H and the coordinated flag
    adds S ("ST XYZS"; "BG" when none: all axes) [M Ch5 ST XYZS example]; with data fields the
    mask selects comma fields ("PR 1000,,-500") and the coordinated flag is not used (the manual
    gives it no meaning there: "S is not active for PR"). Numbers print exactly, no exponent.
    """
    if not cmd.values:
        letters = "".join(letter for bit, letter in enumerate(BINARY_AXIS_LETTERS) if cmd.mask >> bit & 1)
        letters += "S" if cmd.coordinated else ""
        return f"{cmd.name} {letters}" if letters else cmd.name
    texts: list[str] = []
    values = iter(cmd.values)
    for bit in range(cmd.mask.bit_length()):
        texts.append(_ascii_number(next(values)) if cmd.mask >> bit & 1 else "")
    return f"{cmd.name} {','.join(texts)}"


def _ascii_number(value: float) -> str:
    return format(Decimal(value).normalize(), "f")
