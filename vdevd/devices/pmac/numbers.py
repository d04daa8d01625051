"""Turbo PMAC numbers: the 48-bit floating-point word, integer storage and the printed forms.

Expressions compute in IEEE doubles (expr.py); a value is quantised when it is stored: to a 48-bit
PMAC float (36-bit two's-complement mantissa, 12-bit exponent offset $800) for P, Q and floating
I-variables, or rounded to nearest and wrapped to the field for integer destinations (M-variables,
fixed registers) [A §"Turbo PMAC Mathematical Features" /, L978-1002; A L942; spec pmac.md §2.1].
Replies print values as spec pmac.md §2.4 "Number formatting" describes.
"""

from __future__ import annotations

import math
import re
import sys
from decimal import Decimal

#: Divide by zero (and TAN exactly at a pole) saturate here [A §"/" L988, §TAN L1395]
SATURATION = 2.0**47

MANTISSA_BITS = 36
EXPONENT_BITS = 12
EXPONENT_OFFSET = 0x800
#: the mantissa is the value's magnitude normalised to [1, 2) times 2**34 [EPICS-HW doubleToPMACFloat]
MANTISSA_FRACTION_BITS = MANTISSA_BITS - 2
WORD_BITS = 24
WORD_MASK = (1 << WORD_BITS) - 1

#: the largest double whose magnitude a 36-bit mantissa holds exactly
_LARGEST = math.ldexp(1 - 2.0 ** -(MANTISSA_FRACTION_BITS + 1), sys.float_info.max_exp)

_DECIMAL = re.compile(r"-?(?:\d+\.?\d*|\.\d+)", re.ASCII)
_HEX = re.compile(r"(-?)\$([0-9A-Fa-f]+)", re.ASCII)


def wrap(value: int, width: int, signed: bool) -> int:
    """`value` modulo 2**width, read back as a signed or unsigned field of that width.

    A 24-bit signed register written with +9,388,608 holds -7,388,608 [A L942].
    """
    value &= (1 << width) - 1
    if signed and value >> (width - 1):
        value -= 1 << width
    return value


def round_to_int(v: float) -> int:
    """The integer stored for `v` in an integer destination: nearest, halves toward +inf.

    "If it is then stored to an integer, it is rounded" (M1=10*2/3 -> 7) [A §"/" L982-1000].
    ASSUMPTION: halves go up (add one half, truncate toward -inf, as a two's-complement DSP does),
    so 2.5 -> 3 and -2.5 -> -2. NaN stores 0 and infinities the saturation value +-2**47.
    """
    if math.isnan(v):
        return 0
    if math.isinf(v):
        return int(math.copysign(SATURATION, v))
    low = math.floor(v)
    return low + 1 if v - low >= 0.5 else low


def pmac_float_words(v: float) -> tuple[int, int]:
    """The 48-bit PMAC float of `v` as its (X, Y) 24-bit words, X holding the high half.

    Layout [EPICS-HW doubleToPMACFloat]: bits 47-12 the 36-bit two's-complement mantissa M, bits
    11-0 the exponent E + $800, value = M * 2**(E - 34) with |M| in [2**34, 2**35) (0 is all zeros).
    The magnitude is truncated toward zero like doubleToPMACFloat (10 -> $500000000803); a
    negative value is the exact two's complement of the positive one (EPICS writes the ones'
    complement, one LSB off). NaN encodes 0; infinities the largest magnitude a double can hold.
    """
    if math.isnan(v) or v == 0:
        return 0, 0
    fraction, exponent = math.frexp(min(abs(v), _LARGEST))  # fraction in [0.5, 1)
    mantissa = math.floor(math.ldexp(fraction, MANTISSA_FRACTION_BITS + 1))
    if v < 0:
        mantissa = -mantissa
    word = (wrap(mantissa, MANTISSA_BITS, False) << EXPONENT_BITS) | (exponent - 1 + EXPONENT_OFFSET)
    return word >> WORD_BITS, word & WORD_MASK


def from_pmac_float_words(x: int, y: int) -> float:
    """The value of the PMAC float held in words X (high) and Y (low); inverse of pmac_float_words.

    Any mantissa is accepted, normalised or not. Exponents beyond a double's range saturate to
    the largest double (the PMAC float reaches 2**2047).
    """
    word = ((x & WORD_MASK) << WORD_BITS) | (y & WORD_MASK)
    mantissa = wrap(word >> EXPONENT_BITS, MANTISSA_BITS, True)
    exponent = (word & ((1 << EXPONENT_BITS) - 1)) - EXPONENT_OFFSET
    try:
        return math.ldexp(mantissa, exponent - MANTISSA_FRACTION_BITS)
    except OverflowError:
        return math.copysign(_LARGEST, mantissa)


def quantize_float(v: float) -> float:
    """`v` as a P/Q/floating I-variable stores it: 36-bit mantissa, magnitude truncated (see above).

    No saturation at 2**47: the PMAC float's exponent spans +-2048, wider than a double's, so
    only non-finite doubles need a rule: NaN stores 0, +-inf the largest representable double.
    """
    return from_pmac_float_words(*pmac_float_words(v))


def format_value(v: float) -> str:
    """A value as an on-line reply prints it [spec pmac.md §2.4 "Number formatting"].

    Integral values print without a decimal point (2, -3, 45, -135) [A L1222-1227, L1305-1313],
    other values with up to 10 significant digits, trailing zeros stripped (6.666666667) [A L997].
    ASSUMPTIONS: -0 prints 0; integral values print every digit up to 2**53 (2**47 =
    140737488355328); non-integral values of 1e10 and more print rounded to an integer (a stored
    float of 2**34 and more has no fraction bits anyway); magnitudes below 1e-10 or of 2**53 and
    more use exponent notation with 10 significant digits, C's %.10g (1.5e-11, 1e+20).
    Non-finite values print as quantize_float stores them.
    """
    if not math.isfinite(v):
        v = quantize_float(v)
    if v == 0:
        return "0"
    size = abs(v)
    if size < 1e-10 or size >= 2.0**53:
        return f"{v:.10g}"
    if v == math.floor(v) or size >= 1e10:
        return str(round_to_int(v))
    return format(Decimal(f"{v:.10g}"), "f")


def format_hex(v: float) -> str:
    """`$` and uppercase hex of the integer value, no leading zeros ($0, $78400, $C000) [spec §2.4].

    ASSUMPTION: the value is first rounded as stored into an integer (round_to_int); a negative
    value prints as its 24-bit two's complement when it fits a signed 24-bit word (-1 -> $FFFFFF),
    otherwise as a 48-bit one (-2**23 - 1 -> $FFFFFF7FFFFF).
    """
    n = round_to_int(v)
    if n < 0:
        n = wrap(n, WORD_BITS if n >= -(1 << (WORD_BITS - 1)) else 2 * WORD_BITS, False)
    return f"${n:X}"


def parse_constant(text: str) -> float:
    """A constant as written in a command: decimal (10, -2.5, .5, 1.) or hex ($78400, -$10).

    Surrounding spaces are ignored. No exponent, no unary plus (rejected as in expressions
    [A §"+" L956]); anything else raises ValueError.
    """
    text = text.strip()
    if _DECIMAL.fullmatch(text):
        return float(text)
    match = _HEX.fullmatch(text)
    if match is None:
        raise ValueError(f"not a PMAC constant: {text!r}")
    value = float(int(match[2], 16))
    return -value if match[1] else value
