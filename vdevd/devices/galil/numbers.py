"""Galil numbers: the 32.16 fixed-point value, its 6-byte binary form and its decimal print form.

Every DMC value is a 32-bit integer part with a 16-bit fraction (resolution 1/65536, range
-2 147 483 648 to 2 147 483 647.9999) [CR-DUMP operators]; binary commands carry it as the 6-byte
"Galil real" [M Ch5 §Command Syntax - Binary]; replies print it in decimal as PF/VF/LZ say
[M Ch5 §Interrogation Commands], spec galil.md §4.1.
"""

from __future__ import annotations

import math
from decimal import ROUND_HALF_UP, Decimal

SCALE = 65536  # 1 / resolution: 16 fraction bits
MIN_VALUE = -(2**31)
MAX_VALUE = 2**31 - 1 / SCALE
GALIL_REAL_SIZE = 6

#: reply formats (integer digits, fraction digits) of the interrogation commands (spec §4.4)
POSITION_FORMAT = (10, 0)  # PF default
VARIABLE_FORMAT = (10, 4)  # VF default
REPORT_FORMATS: dict[str, tuple[int, int]] = {
    "TP": POSITION_FORMAT, "TE": POSITION_FORMAT, "RP": POSITION_FORMAT, "TD": POSITION_FORMAT,
    "RL": POSITION_FORMAT, "TV": (7, 0), "TT": (1, 4), "SC": (3, 0), "TS": (3, 0),
}
#: the reports and the parameters whose `?` print in the position format PF [Galil command
#: reference PF: TP, TE, the `?` of DP DE IP PA PR BL FL]; the card's other position reports too
POSITION_REPORTS = frozenset(("TP", "TE", "RP", "TD", "RL"))
POSITION_PARAMS = frozenset(("PA", "PR", "BL", "FL"))


def units(value: float) -> int:
    """`value` in 1/65536 units, rounded to nearest (halves away from zero)."""
    scaled = value * SCALE  # exact: a power of two
    return int(math.copysign(math.floor(abs(scaled) + 0.5), scaled))


def fixed(value: float) -> float:
    """Round `value` to the card's resolution of 1/65536 (no range check: see MIN_VALUE, MAX_VALUE)."""
    return units(value) / SCALE


def in_range(value: float) -> bool:
    """True if `value` fits the 32.16 format once rounded."""
    return MIN_VALUE <= fixed(value) <= MAX_VALUE


def galil_real(value: float) -> bytes:
    """The 6-byte Galil real: s32 integer part then u16 fraction/65536, big-endian [M Ch5 binary].

    That is the 48-bit two's complement of value*65536, so -0.5 is FF FF FF FF 80 00 (integer
    part -1, fraction 0.5). ValueError if the value does not fit.
    """
    if not in_range(value):
        raise ValueError(f"{value} is outside the Galil real range")
    return units(value).to_bytes(GALIL_REAL_SIZE, "big", signed=True)


def from_galil_real(data: bytes) -> float:
    """The value of a 6-byte Galil real (inverse of galil_real)."""
    if len(data) != GALIL_REAL_SIZE:
        raise ValueError(f"a Galil real has {GALIL_REAL_SIZE} bytes, not {len(data)}")
    return int.from_bytes(data, "big", signed=True) / SCALE


def format_number(value: float, digits: int, frac: int, lz: bool = True) -> str:
    """`value` as the card prints it with format `digits`.`frac` (PF, VF, a command's default format).

    LZ1 (the reset default) pads the integer part with zeros to `digits` ("0000001000"), LZ0
    removes them but keeps one digit; the fraction is rounded to `frac` digits (halves away
    from zero) and printed only if `frac` > 0; negatives get '-', positives no sign; a value
    wider than `digits` prints all its digits [M Ch5 §Interrogation Commands, TP example].
    """
    if MIN_VALUE <= value <= MAX_VALUE and value == int(value):
        # a whole number (TP, TE, counts): nothing to round, so no Decimal
        whole_value = int(value)
        whole = str(abs(whole_value))
        if lz:
            whole = whole.zfill(digits)
        sign = "-" if whole_value < 0 else ""
        return sign + whole + ("." + "0" * frac if frac > 0 else "")
    return _format_decimal(value, digits, frac, lz)


def _format_decimal(value: float, digits: int, frac: int, lz: bool) -> str:
    """format_number for any value: decimal rounding, halves away from zero."""
    quantum = Decimal(1).scaleb(-frac) if frac > 0 else Decimal(1)
    rounded = Decimal(value).quantize(quantum, rounding=ROUND_HALF_UP)
    whole, _, fraction = format(abs(rounded), "f").partition(".")
    if lz:
        whole = whole.zfill(digits)
    sign = "-" if rounded < 0 else ""
    return sign + whole + ("." + fraction if frac > 0 else "")
