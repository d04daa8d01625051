"""PMAC numbers: 48-bit float words, integer storage, printed forms (vdevd/devices/pmac/numbers.py)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vdevd.devices.pmac.numbers import (
    SATURATION,
    format_hex,
    format_value,
    from_pmac_float_words,
    parse_constant,
    pmac_float_words,
    quantize_float,
    round_to_int,
    wrap,
)

finite = st.floats(min_value=-1e300, max_value=1e300)


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (2.0, "2"),
        (-3.0, "-3"),
        (45.0, "45"),
        (-135.0, "-135"),
        (7.0, "7"),
        (10 * 2 / 3, "6.666666667"),  # P1=10*2/3 [A L997]
        (0.5, "0.5"),
        (-0.375, "-0.375"),
        (0.1, "0.1"),
        (2.302585092994046, "2.302585093"),
        (1.234e-5, "0.00001234"),
        (1e-10, "0.0000000001"),
        (1000000.0, "1000000"),
    ],
)
def test_format_value_integers_bare_others_with_10_significant_digits(value: float, text: str) -> None:
    assert format_value(value) == text


def test_minus_zero_prints_zero() -> None:
    assert format_value(-0.0) == "0"


def test_divide_by_zero_saturation_prints_as_an_integer() -> None:
    assert format_value(SATURATION) == "140737488355328"
    assert format_value(-SATURATION) == "-140737488355328"


def test_tiny_and_huge_values_use_exponent_notation() -> None:
    assert format_value(1.5e-11) == "1.5e-11"
    assert format_value(1e20) == "1e+20"


def test_non_integral_values_of_1e10_and_more_print_rounded_to_an_integer() -> None:
    assert format_value(12345678901.5) == "12345678902"


def test_quantized_value_prints_like_the_double() -> None:
    assert format_value(quantize_float(10 * 2 / 3)) == "6.666666667"
    assert format_value(quantize_float(0.1)) == "0.1"


@pytest.mark.parametrize(
    ("value", "text"),
    [(0, "$0"), (0x78400, "$78400"), (0xC000, "$C000"), (0xF4, "$F4"), (0xFF, "$FF"),
     (2**40, "$10000000000")],
)
def test_format_hex_is_uppercase_without_leading_zeros(value: float, text: str) -> None:
    assert format_hex(value) == text


def test_format_hex_negative_is_24_bit_twos_complement_when_it_fits_else_48_bit() -> None:
    assert format_hex(-1) == "$FFFFFF"
    assert format_hex(-(2**23)) == "$800000"
    assert format_hex(-(2**23) - 1) == "$FFFFFF7FFFFF"


def test_format_hex_rounds_a_fraction_first() -> None:
    assert format_hex(15.6) == "$10"


@pytest.mark.parametrize(
    ("text", "value"),
    [("10", 10.0), ("-2.5", -2.5), (".5", 0.5), ("1.", 1.0), ("$78400", 0x78400), ("$c000", 0xC000),
     ("-$10", -16.0), (" 7 ", 7.0)],
)
def test_parse_constant_reads_decimal_and_hex(text: str, value: float) -> None:
    assert parse_constant(text) == value


@pytest.mark.parametrize("text", ["", "+5", "1e3", "$", "$G", "1.2.3", "P1", "0x10", "- 5", "."])
def test_parse_constant_rejects_anything_else(text: str) -> None:
    with pytest.raises(ValueError):
        parse_constant(text)


def test_storing_into_an_integer_rounds_to_nearest() -> None:
    assert round_to_int(10 * 2 / 3) == 7  # M1=10*2/3 [A L999]
    assert round_to_int(-10 * 2 / 3) == -7
    assert round_to_int(2.4) == 2


def test_round_to_int_halves_go_up() -> None:
    assert round_to_int(2.5) == 3
    assert round_to_int(-2.5) == -2
    assert round_to_int(0.49999999999999994) == 0


def test_round_to_int_of_non_finite_values() -> None:
    assert round_to_int(math.nan) == 0
    assert round_to_int(math.inf) == 2**47
    assert round_to_int(-math.inf) == -(2**47)


def test_24_bit_signed_register_wraps_one_million_past_rollover() -> None:
    assert wrap(9_388_608, 24, True) == -7_388_608  # [A L942]


def test_wrap_unsigned_and_in_range_values() -> None:
    assert wrap(-1, 24, False) == 0xFFFFFF
    assert wrap(8_388_607, 24, True) == 8_388_607
    assert wrap(-8_388_608, 24, True) == -8_388_608
    assert wrap(0x1_000_005, 24, False) == 5


@pytest.mark.parametrize(
    ("value", "x", "y"),
    [
        (10.0, 0x500000, 0x000803),  # EPICS pmac test harness: 10 -> $500000000803
        (0.295599839124, 0x4BAC6E, 0x59B7FE),  # -> $4bac6e59b7fe (magnitude truncated)
        (1.2955998341, 0x52EB1B, 0x910800),  # -> $52eb1b910800
        (1.0, 0x400000, 0x000800),
        (0.5, 0x400000, 0x0007FF),
        (-10.0, 0xB00000, 0x000803),  # exact two's complement (EPICS: ones' complement $AFFFFFFFF803)
        (0.0, 0, 0),
    ],
)
def test_pmac_float_words_known_encodings(value: float, x: int, y: int) -> None:
    assert pmac_float_words(value) == (x, y)


@pytest.mark.parametrize(
    "value", [1.0, -1.0, 0.0, 0.5, 1e6, -3.75, 2.0**40, 2.0**47, -(2.0**47), 2.0**-40, -0.375]
)
def test_pmac_float_words_round_trip_exactly(value: float) -> None:
    assert from_pmac_float_words(*pmac_float_words(value)) == value


def test_epics_ones_complement_negative_decodes_one_lsb_past_the_value() -> None:
    value = from_pmac_float_words(0xAFFFFF, 0xFFF803)
    assert value == pytest.approx(-10.0, abs=1e-9)
    assert format_value(value) == "-10"


def test_words_are_24_bit() -> None:
    x, y = pmac_float_words(-1e300)
    assert 0 <= x <= 0xFFFFFF and 0 <= y <= 0xFFFFFF


def test_quantize_keeps_a_35_bit_magnitude() -> None:
    assert quantize_float(2.0**35 - 1) == 2.0**35 - 1
    assert quantize_float(2.0**35 + 1) == 2.0**35
    assert quantize_float(-(2.0**35 + 1)) == -(2.0**35)


def test_quantize_of_non_finite_values() -> None:
    assert quantize_float(math.nan) == 0.0
    assert quantize_float(math.inf) == -quantize_float(-math.inf) > 1e308


def test_decoding_an_exponent_beyond_a_double_saturates() -> None:
    assert from_pmac_float_words(0x400000, 0x000FFF) > 1e308
    assert from_pmac_float_words(0xC00000, 0x000FFF) < -1e308


@given(finite)
def test_quantize_is_idempotent_and_within_one_mantissa_lsb(value: float) -> None:
    stored = quantize_float(value)
    assert quantize_float(stored) == stored
    assert abs(stored) <= abs(value)
    assert abs(value - stored) <= abs(value) * 2.0**-34


@given(finite)
def test_format_value_reads_back_within_10_significant_digits(value: float) -> None:
    text = format_value(value)
    assert float(text) == pytest.approx(value, rel=5e-10, abs=0.5 if abs(value) >= 1e10 else 0)
