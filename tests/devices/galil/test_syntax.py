"""DMC-13X8 command syntax: framing, statements, arguments, binary commands
(vdevd/devices/galil/syntax.py; manual ch. 5 "Command Syntax - ASCII" and "- Binary")."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.syntax import (
    BINARY_OPCODES,
    QUERY,
    AxisSet,
    BinaryCommand,
    Frame,
    Statement,
    binary_to_ascii,
    decode_binary,
    encode_binary,
    next_frame,
    parse_assignment,
    parse_axes,
    parse_axis_assign,
    parse_fields,
    split_statement,
)

PR_1000_0_M500 = bytes.fromhex("A7 02 00 05 03 E8 FE 0C")  # [M Ch5 §Binary Command Format]
ST_XYZS = bytes.fromhex("A1 00 01 07")


def frames(stream: bytes) -> tuple[list[Frame], bytes]:
    """Every complete frame of `stream` and the bytes left over."""
    out: list[Frame] = []
    while True:
        frame, used = next_frame(stream)
        stream = stream[used:]
        if frame is None:
            return out, stream
        out.append(frame)


def frames_fed_in_pieces(stream: bytes, cuts: list[int]) -> list[Frame]:
    """The frames a reader gets when `stream` arrives in pieces cut at `cuts`."""
    out: list[Frame] = []
    buf = b""
    for start, end in zip([0, *cuts], [*cuts, len(stream)], strict=True):
        buf += stream[start:end]
        got, buf = frames(buf)
        out += got
    return out


def error_code(fn: Callable[..., object], *args: object) -> int:
    with pytest.raises(GalilError) as info:
        fn(*args)
    return info.value.code


# -- framing -----------------------------------------------------------------------------------


def test_cr_and_semicolon_end_a_command_and_are_consumed() -> None:
    assert next_frame(b"PR 4000\r") == (Frame(b"PR 4000", False), 8)
    assert frames(b"#A;DP0\r")[0] == [Frame(b"#A", False), Frame(b"DP0", False)]  # [M Ch2 Ex14]


def test_lf_nul_and_spaces_before_a_command_are_skipped() -> None:
    got, rest = frames(b"TP X\r\n\0  BG X\r\n")
    assert got == [Frame(b"TP X", False), Frame(b"BG X", False)]
    assert rest == b""


def test_an_incomplete_command_uses_only_the_skipped_bytes() -> None:
    assert next_frame(b"PR 10") == (None, 0)
    assert next_frame(b"\n PR 10") == (None, 2)
    assert next_frame(b"\n\0") == (None, 2)
    assert next_frame(b"") == (None, 0)


def test_a_semicolon_inside_double_quotes_does_not_end_the_command() -> None:
    assert frames(b'MG "a;b";BG\r')[0] == [Frame(b'MG "a;b"', False), Frame(b"BG", False)]


def test_a_cr_inside_double_quotes_still_ends_the_command() -> None:
    assert frames(b'MG "ab\rBG\r')[0] == [Frame(b'MG "ab', False), Frame(b"BG", False)]


def test_a_comment_runs_to_the_end_of_the_line() -> None:
    got, _ = frames(b"SH;'servo here; all axes\rREM a \"; b\rBG\r")
    assert got == [Frame(b"SH", False), Frame(b"'servo here; all axes", False),
                   Frame(b'REM a "; b', False), Frame(b"BG", False)]


def test_a_bare_terminator_is_an_empty_command() -> None:
    assert frames(b"\r;")[0] == [Frame(b"", False), Frame(b"", False)]


def test_control_r_control_v_is_an_ascii_frame() -> None:
    assert next_frame(b"\x12\x16\r") == (Frame(b"\x12\x16", False), 3)


def test_a_byte_with_the_high_bit_starts_a_binary_command() -> None:
    assert next_frame(PR_1000_0_M500 + b"BG\r") == (Frame(PR_1000_0_M500, True), 8)
    assert next_frame(ST_XYZS) == (Frame(ST_XYZS, True), 4)
    assert next_frame(b"\r\n" + ST_XYZS)[0] == Frame(b"", False)
    assert next_frame(b"\n" + ST_XYZS) == (Frame(ST_XYZS, True), 5)


@pytest.mark.parametrize("cut", range(1, len(PR_1000_0_M500)))
def test_an_incomplete_binary_command_uses_no_bytes(cut: int) -> None:
    assert next_frame(PR_1000_0_M500[:cut]) == (None, 0)


def test_a_binary_header_with_a_bad_field_size_is_a_frame_of_four_bytes() -> None:
    bad = bytes.fromhex("A7 03 00 05") + b"BG\r"
    frame, used = next_frame(bad)
    assert (frame, used) == (Frame(bad[:4], True), 4)
    assert error_code(decode_binary, bad[:4]) == TC.BAD_BINARY_FORMAT


def test_binary_and_ascii_mix_in_one_stream() -> None:
    got, rest = frames(b"SP 2000\r" + PR_1000_0_M500 + b"BG X;" + ST_XYZS + b"TP")
    assert got == [Frame(b"SP 2000", False), Frame(PR_1000_0_M500, True), Frame(b"BG X", False),
                   Frame(ST_XYZS, True)]
    assert rest == b"TP"


STREAM = b'#A;DP0\r\nPR 4000;SP 2000\rBGX\r' + PR_1000_0_M500 + b'MG "x;y"\r' + ST_XYZS + b"\x12\x16\r"


@given(st.lists(st.integers(min_value=1, max_value=len(STREAM) - 1), unique=True).map(sorted))
def test_a_stream_cut_anywhere_gives_the_same_frames(cuts: list[int]) -> None:
    assert frames_fed_in_pieces(STREAM, cuts) == frames(STREAM)[0]


def test_a_stream_fed_one_byte_at_a_time_gives_the_same_frames() -> None:
    assert frames_fed_in_pieces(STREAM, list(range(1, len(STREAM)))) == frames(STREAM)[0]


# -- statements --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "statement"),
    [
        ("PR 1000,,-500", Statement("PR", "1000,,-500")),
        ("PR 4000", Statement("PR", "4000")),
        ("BGX", Statement("BG", "X")),
        ("BG", Statement("BG", "")),
        ("KPX=10", Statement("KP", "X=10")),
        ("KP*=10", Statement("KP", "*=10")),
        ("ACYH=400000", Statement("AC", "YH=400000")),
        ("KP, 20", Statement("KP", ", 20")),
        ("JP #Loop,V1<10001", Statement("JP", "#Loop,V1<10001")),
        ("JP #C, V1=0", Statement("JP", "#C, V1=0")),
        ("ET[1]=40,20", Statement("ET", "[1]=40,20")),
        ('MG "DONE"', Statement("MG", '"DONE"')),
        ("#LOOP2", Statement("#", "LOOP2")),
        ("\x12\x16", Statement("\x12\x16", "")),
        ("'set the gains", Statement("'", "set the gains")),
        ("REM set the gains", Statement("REM", "set the gains")),
        ("", Statement("", "")),
        ("  SH", Statement("SH", "")),
    ],
)
def test_split_statement_gives_the_command_name_and_its_argument(text: str, statement: Statement) -> None:
    assert split_statement(text) == statement


@pytest.mark.parametrize(
    "text", ["V1=V1+1000", "V1=", "V1 = _TPX", "spx=100", "spsave=_SPX", "COUNT=0", "POS[C]=V4",
             "VX [COUNT]=N", "T=0", "kpx=10"],
)
def test_variable_and_array_assignments_are_named_equals(text: str) -> None:
    assert split_statement(text) == Statement("=", text)


@pytest.mark.parametrize("text", ["bg", "bgX", "Bg", "tp x", "V1", "1V", "%", "\x12"])
def test_lower_case_or_malformed_commands_are_unrecognized(text: str) -> None:
    assert error_code(split_statement, text) == TC.UNRECOGNIZED_COMMAND


# -- fields ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("arg", "fields"),
    [  # PR forms of [M Ch5 §Command Syntax - ASCII]
        ("1000", ["1000"]),
        (",2000", [None, "2000"]),
        (",,3000", [None, None, "3000"]),
        (",,,4000", [None, None, None, "4000"]),
        ("2000, 4000,6000, 8000", ["2000", "4000", "6000", "8000"]),
        (",8000,,9000", [None, "8000", None, "9000"]),
        ("?,?, ?,?", [QUERY, QUERY, QUERY, QUERY]),
        (",?", [None, QUERY]),
        (" ,?", [None, QUERY]),
        ("1000,,-500", ["1000", None, "-500"]),
        ("-V1/2", ["-V1/2"]),
        ("VX[COUNT],VY[COUNT]", ["VX[COUNT]", "VY[COUNT]"]),
        ("", []),
        ("  ", []),
    ],
)
def test_parse_fields_keeps_expression_text_per_axis(arg: str, fields: list[object]) -> None:
    assert parse_fields(arg) == fields


@pytest.mark.parametrize(
    ("text", "fields"),
    [  # [M Ch2 Example 1]
        ("KP10,10,10,10", ["10", "10", "10", "10"]),
        ("KP, 20", [None, "20"]),
        ("KP,,10", [None, None, "10"]),
        ("KP ?,?,?,?", [QUERY, QUERY, QUERY, QUERY]),
        ("KP ,,?", [None, None, QUERY]),
    ],
)
def test_manual_gain_forms_give_fields(text: str, fields: list[object]) -> None:
    statement = split_statement(text)
    assert statement.name == "KP"
    assert parse_axis_assign(statement.arg, 4) is None
    assert parse_fields(statement.arg, 4) == fields


def test_more_fields_than_axes_is_an_operand_error() -> None:
    assert error_code(parse_fields, "1,2,3,4,5", 4) == TC.OPERAND_ERROR
    assert len(parse_fields("1,2,3,4,5,6,7,8")) == 8


@pytest.mark.parametrize(
    ("text", "axes", "value"),
    [  # [M Ch2 Example 1], [M Ch5], [M Ch6]
        ("KP*=10", [0, 1, 2, 3], "10"),
        ("KPX=10", [0], "10"),
        ("KPA=10", [0], "10"),
        ("KPZ=10", [2], "10"),
        ("KPD=10", [3], "10"),
        ("PRX=1000", [0], "1000"),
        ("ACY=200000", [1], "200000"),
        ("JGZ=4000", [2], "4000"),
        ("ER*=1000", [0, 1, 2, 3], "1000"),
    ],
)
def test_single_axis_forms_name_the_axes(text: str, axes: list[int], value: str) -> None:
    assert parse_axis_assign(split_statement(text).arg, 4) == (axes, value)


def test_axis_assign_takes_several_letters_and_axes_e_to_h() -> None:
    assert parse_axis_assign("YH=400000") == ([1, 7], "400000")
    assert parse_axis_assign("*=10", 8) == (list(range(8)), "10")
    assert parse_axis_assign("X = 5") == ([0], "5")


def test_axis_assign_for_an_axis_the_card_lacks_is_tc_90() -> None:
    assert error_code(parse_axis_assign, "E=10", 4) == TC.ONLY_ABCD_VALID


@pytest.mark.parametrize("arg", ["1000", ",20", "?", "[1]=40,20", "Q=5", ""])
def test_axis_assign_is_none_for_other_arguments(arg: str) -> None:
    assert parse_axis_assign(arg) is None


# -- action axes -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("arg", "axis_set"),
    [  # [M Ch5 §Command Syntax - ASCII, §Coordinated Motion with more than 1 axis]
        ("X", AxisSet((0,))),
        ("Y", AxisSet((1,))),
        ("XYZW", AxisSet((0, 1, 2, 3))),
        ("YW", AxisSet((1, 3))),
        ("", AxisSet((0, 1, 2, 3))),
        ("S", AxisSet((), s=True)),
        ("TW", AxisSet((3,), t=True)),
        ("XYZS", AxisSet((0, 1, 2), s=True)),
        ("X Z", AxisSet((0, 2))),
        ("ZX", AxisSet((0, 2))),
        ("AC", AxisSet((0, 2))),
    ],
)
def test_parse_axes_reads_axis_letters_and_coordinate_systems(arg: str, axis_set: AxisSet) -> None:
    assert parse_axes(arg, 4) == axis_set


def test_parse_axes_rejects_unknown_letters_and_absent_axes() -> None:
    assert error_code(parse_axes, "XQ", 4) == TC.OPERAND_ERROR
    assert error_code(parse_axes, "x", 4) == TC.OPERAND_ERROR
    assert error_code(parse_axes, "E", 4) == TC.ONLY_ABCD_VALID
    assert error_code(parse_axes, "Y", 1) == TC.ONLY_ABCD_VALID
    assert parse_axes("EH", 8) == AxisSet((4, 7))


# -- assignments -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "parts"),
    [
        ("V1=V1+1000", ("V1", None, "V1+1000")),  # [M Ch2 Ex12]
        ("V1=", ("V1", None, "")),  # print the value [M Ch2 Ex14]
        ("V1 = _TPX", ("V1", None, "_TPX")),
        ("A[3]=5", ("A", "3", "5")),
        ("VX [COUNT]=N", ("VX", "COUNT", "N")),  # [M Ch6 §Multiple Moves]
        ("A[B[1]]=3", ("A", "B[1]", "3")),
        ("spx=100", ("spx", None, "100")),
        ("V3=-955*@SIN[V2]+V1", ("V3", None, "-955*@SIN[V2]+V1")),
    ],
)
def test_parse_assignment_gives_name_index_and_value(text: str, parts: tuple[str, str | None, str]) -> None:
    assert parse_assignment(text) == parts


def test_parse_assignment_errors() -> None:
    assert error_code(parse_assignment, "A[3=5") == TC.MISSING_BRACKET
    assert error_code(parse_assignment, "LONGNAME9=1") == TC.VARIABLE_ERROR
    assert error_code(parse_assignment, "V1") == TC.VARIABLE_ERROR
    assert error_code(parse_assignment, "1=2") == TC.VARIABLE_ERROR


# -- binary ------------------------------------------------------------------------------------


def test_manual_pr_example_decodes_to_pr_1000_comma_comma_minus_500() -> None:
    cmd = decode_binary(PR_1000_0_M500)
    assert cmd == BinaryCommand("PR", False, 0b101, (1000.0, -500.0), 2)
    assert binary_to_ascii(cmd) == "PR 1000,,-500"


def test_manual_st_example_decodes_to_st_xyzs() -> None:
    cmd = decode_binary(ST_XYZS)
    assert cmd == BinaryCommand("ST", True, 0b111, (), 0)
    assert binary_to_ascii(cmd) == "ST XYZS"


def test_encode_binary_reproduces_the_manual_examples() -> None:
    assert encode_binary("PR", [1000, None, -500], 2) == PR_1000_0_M500
    assert encode_binary("PR", {0: 1000, 2: -500}, 2) == PR_1000_0_M500
    assert encode_binary("ST", {0, 1, 2}, coordinated=True) == ST_XYZS


def test_the_opcode_table_is_the_manuals() -> None:
    assert len(BINARY_OPCODES) == 91
    assert BINARY_OPCODES[0xB3] == "CR"  # printed "a3" in the manual, which is HM
    assert BINARY_OPCODES[0xA3] == "HM"
    assert BINARY_OPCODES[0xB5] == "LE"
    assert (BINARY_OPCODES[0x81], BINARY_OPCODES[0xEE]) == ("KP", "AL")
    assert len(set(BINARY_OPCODES.values())) == len(BINARY_OPCODES)


def test_ve_shares_its_number_with_le() -> None:
    assert encode_binary("VE") == bytes.fromhex("B5 00 00 00")
    assert binary_to_ascii(decode_binary(encode_binary("VE"))) == "LE"


#: bytes per field -> the smallest and largest value it carries (a Galil real: a fraction)
WIDTH_VALUES: dict[int, list[float]] = {
    1: [-128, 127], 2: [-32768, 32767], 4: [-(2**31), 2**31 - 1], 6: [-0.25, 1234.5],
}


@pytest.mark.parametrize("opcode", sorted(BINARY_OPCODES))
@pytest.mark.parametrize("width", [1, 2, 4, 6])
def test_every_opcode_round_trips_with_every_field_size(opcode: int, width: int) -> None:
    name = BINARY_OPCODES[opcode]
    low, high = WIDTH_VALUES[width]
    frame = encode_binary(name, {1: low, 3: high}, width)
    assert frame[0] == opcode
    assert next_frame(frame) == (Frame(frame, True), len(frame))
    cmd = decode_binary(frame)
    assert cmd == BinaryCommand(name, False, 0b1010, (low, high), width)
    assert encode_binary(cmd.name, dict(zip((1, 3), cmd.values, strict=True)), cmd.width) == frame


@pytest.mark.parametrize("opcode", sorted(BINARY_OPCODES))
def test_every_opcode_round_trips_as_an_axis_command(opcode: int) -> None:
    name = BINARY_OPCODES[opcode]
    frame = encode_binary(name, {0, 3}, coordinated=True)
    cmd = decode_binary(frame)
    assert cmd == BinaryCommand(name, True, 0b1001, (), 0)
    assert binary_to_ascii(cmd) == f"{name} XWS"


@pytest.mark.parametrize(
    ("frame", "text"),
    [
        (encode_binary("BG"), "BG"),
        (encode_binary("BG", set(), coordinated=True), "BG S"),
        (encode_binary("SH", set(range(8))), "SH XYZWEFGH"),
        (encode_binary("AB", [1], 1), "AB 1"),
        (encode_binary("GR", [1.5, None, -0.25], 6), "GR 1.5,,-0.25"),
        (encode_binary("SP", {7: 2000}, 4), "SP ,,,,,,,2000"),
        (encode_binary("KP", [1 / 65536], 6), "KP 0.0000152587890625"),
        (encode_binary("WT", [500], 2), "WT 500"),
    ],
)
def test_binary_to_ascii_gives_the_equivalent_statement(frame: bytes, text: str) -> None:
    assert binary_to_ascii(decode_binary(frame)) == text


def test_binary_commands_run_through_the_ascii_parsers() -> None:
    statement = split_statement(binary_to_ascii(decode_binary(PR_1000_0_M500)))
    assert statement == Statement("PR", "1000,,-500")
    assert parse_fields(statement.arg, 4) == ["1000", None, "-500"]
    statement = split_statement(binary_to_ascii(decode_binary(ST_XYZS)))
    assert parse_axes(statement.arg, 4) == AxisSet((0, 1, 2), s=True)


@pytest.mark.parametrize("opcode", [0x80, 0x9B, 0x9F, 0xAB, 0xAF, 0xBB, 0xBC, 0xC7, 0xD5, 0xD7, 0xE2,
                                    0xE4, 0xEF, 0xFF])
def test_a_reserved_command_number_is_tc_99(opcode: int) -> None:
    assert error_code(decode_binary, bytes([opcode, 0, 0, 0])) == TC.BAD_BINARY_NUMBER


@pytest.mark.parametrize(
    "frame",
    [
        bytes.fromhex("A7 03 00 01 00 00 00"),  # 3 bytes per field
        bytes.fromhex("A7 08 00 00"),
        bytes.fromhex("A1 00 02 07"),  # coordinated byte 2
        bytes.fromhex("A7 02 00 05 03 E8"),  # one field short
        bytes.fromhex("A7 02 00 05 03 E8 FE 0C 00"),  # one byte too many
        bytes.fromhex("A7 02 00"),  # short header
    ],
)
def test_a_malformed_binary_command_is_tc_97(frame: bytes) -> None:
    assert error_code(decode_binary, frame) == TC.BAD_BINARY_FORMAT


def test_encode_binary_refuses_what_the_format_cannot_carry() -> None:
    with pytest.raises(ValueError):
        encode_binary("XX")
    with pytest.raises(ValueError):
        encode_binary("PR", [1000], 3)
    with pytest.raises(ValueError):
        encode_binary("PR", [1000], 1)
    with pytest.raises(ValueError):
        encode_binary("PR", [0.5], 4)
    with pytest.raises(ValueError):
        encode_binary("PR", {8: 1}, 4)
    with pytest.raises(ValueError):
        encode_binary("ST", {0, 1}, 2)
