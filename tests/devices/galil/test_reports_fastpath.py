"""The firmware's quick paths give what the general ones give: a whole number prints without
Decimal (numbers.format_number), the framing of a command FIFO content is remembered (card.py),
and a report formats its axes from one list (interpreter.py)."""

from __future__ import annotations

from hypothesis import example, given
from hypothesis import strategies as st

from tests.devices.galil.conftest import Dmc
from vdevd.devices.galil import syntax
from vdevd.devices.galil.firmware import _next_frame
from vdevd.devices.galil.numbers import MAX_VALUE, MIN_VALUE, _format_decimal, format_number

FORMATS = {"digits": st.integers(1, 12), "frac": st.integers(0, 4), "lz": st.booleans()}


@given(value=st.integers(MIN_VALUE, int(MAX_VALUE)), as_float=st.booleans(), **FORMATS)
@example(value=0, as_float=True, digits=10, frac=0, lz=True)
@example(value=MIN_VALUE, as_float=True, digits=10, frac=4, lz=False)
def test_a_whole_number_prints_as_decimal_rounding_prints_it(
        value: int, as_float: bool, digits: int, frac: int, lz: bool) -> None:
    number = float(value) if as_float else value
    assert format_number(number, digits, frac, lz) == _format_decimal(number, digits, frac, lz)


@given(value=st.floats(-3e9, 3e9) | st.sampled_from([-0.0, 0.5, -0.5, 2.5, MAX_VALUE, 1e15]),
       **FORMATS)
def test_any_number_prints_as_decimal_rounding_prints_it(
        value: float, digits: int, frac: int, lz: bool) -> None:
    assert format_number(value, digits, frac, lz) == _format_decimal(value, digits, frac, lz)


@given(stream=st.binary(max_size=24) | st.sampled_from(
    [b"TPX\r", b"\nTPX\r", b"MG \"a;b\";BG\r", b"'TP;X\r", b"REM a;b\rTP", b"TP", b"\xd9\x00\x00\x01"]))
def test_the_remembered_framing_is_next_frames(stream: bytes) -> None:
    assert _next_frame(stream) == syntax.next_frame(stream)
    assert _next_frame(stream) == syntax.next_frame(stream)  # now remembered


def test_a_polled_report_follows_the_card(dmc: Dmc) -> None:
    """The same lines again and again while what they report changes: position, sign, width,
    LZ, echo, an error in between."""
    assert [dmc.cmd("TPX") for _ in range(3)] == ["0000000000"] * 3
    dmc.cmd("DP -1000,20,,7")
    assert dmc.cmd("TPX") == "-0000001000"
    assert dmc.cmd("TP") == "-0000001000,0000000020,0000000000,0000000007"
    assert dmc.cmd("TP WY") == "0000000020,0000000007"  # axis order, not the letters' order
    assert dmc.cmd("TPX;TPY") == "-0000001000\r\n:0000000020"
    assert dmc.refused("TPQ") == 4
    dmc.cmd("LZ 1")
    assert dmc.cmd("TP") == "-1000,20,0,7"
    assert dmc.cmd("TPX") == "-1000"
    dmc.cmd("LZ 0")
    assert dmc.cmd("MG _TPX") == "-0000001000.0000"
    assert dmc.cmd("TPX") == "-0000001000"
    dmc.cmd("EO 1")
    assert dmc.command("TPX") == (0, "TPX\r-0000001000\r\n:")
    dmc.cmd("EO 0")
    assert dmc.cmd("TPX") == "-0000001000"
