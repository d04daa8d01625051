"""Galil numbers: decimal print formats, the 6-byte Galil real, 1/65536 rounding
(vdevd/devices/galil/numbers.py)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vdevd.devices.galil.numbers import (
    MAX_VALUE,
    MIN_VALUE,
    fixed,
    format_number,
    from_galil_real,
    galil_real,
    in_range,
)


@pytest.mark.parametrize(
    ("value", "digits", "frac", "text"),
    [
        (0, 10, 0, "0000000000"),  # TP X at reset [M Ch5 §Interrogation Commands]
        (-1000, 10, 0, "-0000001000"),
        (100, 4, 2, "0100.00"),  # KD ? [OPT-CR 125]
        (149504, 7, 0, "0149504"),  # AC ? [OPT-CR 24]
        (7, 4, 0, "0007"),  # KI ? [OPT-CR 126]
        (9.998, 1, 4, "9.9980"),
        (12345678901, 10, 0, "12345678901"),
    ],
)
def test_lz1_pads_the_integer_part_with_zeros(value: float, digits: int, frac: int, text: str) -> None:
    assert format_number(value, digits, frac) == text


@pytest.mark.parametrize(
    ("value", "digits", "frac", "text"),
    [(1000, 10, 0, "1000"), (0, 10, 0, "0"), (-5, 10, 4, "-5.0000"), (0.25, 10, 4, "0.2500")],
)
def test_lz0_removes_leading_zeros_but_keeps_one_digit(
    value: float, digits: int, frac: int, text: str
) -> None:
    assert format_number(value, digits, frac, lz=False) == text


def test_fraction_rounds_halves_away_from_zero() -> None:
    assert format_number(2.5, 4, 0) == "0003"
    assert format_number(-2.5, 4, 0) == "-0003"
    assert format_number(0.125, 1, 2) == "0.13"


def test_a_negative_value_that_rounds_to_zero_prints_without_sign() -> None:
    assert format_number(-0.4, 4, 0) == "0000"


def test_galil_real_is_integer_part_then_fraction_big_endian() -> None:
    assert galil_real(1000) == bytes.fromhex("000003E8 0000")
    assert galil_real(1.5) == bytes.fromhex("00000001 8000")
    assert galil_real(-0.5) == bytes.fromhex("FFFFFFFF 8000")  # integer part -1, fraction .5
    assert galil_real(-1000) == bytes.fromhex("FFFFFC18 0000")


def test_galil_real_refuses_values_outside_32_16() -> None:
    with pytest.raises(ValueError):
        galil_real(2**31)
    with pytest.raises(ValueError):
        from_galil_real(b"\0" * 5)


@given(st.integers(min_value=-(2**47), max_value=2**47 - 1))
def test_galil_real_round_trips_every_32_16_value(raw: int) -> None:
    value = raw / 65536
    assert from_galil_real(galil_real(value)) == value


def test_fixed_rounds_to_1_over_65536() -> None:
    assert fixed(1 / 3) == 21845 / 65536
    assert fixed(0.5 / 65536) == 1 / 65536
    assert fixed(-0.5 / 65536) == -1 / 65536
    assert fixed(0.4 / 65536) == 0


def test_range_is_that_of_the_32_16_format() -> None:
    assert in_range(MAX_VALUE) and in_range(MIN_VALUE)
    assert not in_range(2147483648) and not in_range(-2147483649)
