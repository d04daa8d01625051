"""Manual chapter 5 "Command Syntax - Binary": a 4-byte header (command number 80-FF, bytes per
field 0/1/2/4/6, coordinated 0/1, axis mask) and big-endian data fields, sent with
DMCBinaryCommand; the card answers ':' or '?' like an ASCII command."""

from __future__ import annotations

import pytest
from vdevclient import galil

from tests.devices.galil.conftest import Dmc


def test_manual_example_a7_is_pr_1000_none_minus_500(dmc: Dmc) -> None:
    """"the command PR 1000,, -500 would be A7 02 00 05 03 E8 FE 0C"; the field left out keeps
    its previous value [M Ch5 §Command Syntax - ASCII]."""
    dmc.cmd("PR 0,7,0")
    assert dmc.binary("A7 02 00 05 03 E8 FE 0C") == (galil.DMCNOERROR, ":")
    assert dmc.cmd("PR ?,?,?") == "0000001000,0000000007,-0000000500"


def test_manual_example_a1_is_st_xyzs(dmc: Dmc) -> None:
    """"The command ST XYZS would be A1 00 01 07": X, Y and Z stop, W keeps moving."""
    dmc.cmd("JG 1000,1000,1000,1000;BG")
    dmc.step(0.05)
    assert dmc.binary("A1 00 01 07") == (galil.DMCNOERROR, ":")
    dmc.cmd("AM XYZ")
    assert dmc.values("SC") == [4, 4, 4, 0]  # ST for X, Y, Z; W still running (spec §4.4)
    dmc.cmd("ST W;AM W")


@pytest.mark.parametrize(("header", "ascii_query", "reply"), [
    ("81 01 00 0F 01 02 03 04", "KP ?,?,?,?", "0001.00,0002.00,0003.00,0004.00"),  # one byte per field
    ("81 02 00 02 00 64", "KP ,?", "0100.00"),  # one word
    ("92 04 00 01 00 01 86 A0", "SP ?", "00100000"),  # one long word: SP 100000
    ("97 04 00 09 FF FF FF FF 00 00 30 39", "TP XW", "-0000000001,0000012345"),  # DP -1,,,12345
])
def test_field_widths_1_2_4_bytes(dmc: Dmc, header: str, ascii_query: str, reply: str) -> None:
    """"Byte 2 specifies the # of bytes in each field as 0,1,2,4"; byte 4 the axes."""
    assert dmc.binary(header) == (galil.DMCNOERROR, ":")
    assert dmc.cmd(ascii_query) == reply


def test_galil_real_format_6_bytes(dmc: Dmc) -> None:
    """"06 Galil real format (4 bytes integer and 2 bytes fraction)": TL 1.5 on X."""
    assert dmc.binary("8A 06 00 01 00 00 00 01 80 00") == (galil.DMCNOERROR, ":")
    assert dmc.value("TL ?") == 1.5


def test_binary_bg_and_tp(dmc: Dmc) -> None:
    """BG is A0 (no data fields); TP is D9 and answers like TP."""
    dmc.cmd("PR 321")
    assert dmc.binary("A0 00 00 01") == (galil.DMCNOERROR, ":")
    dmc.cmd("AM X")
    dmc.step(0.2)
    rc, reply = dmc.binary("D8 00 00 01")  # RP
    assert (rc, reply) == (galil.DMCNOERROR, "0000000321\r\n:")


@pytest.mark.parametrize("opcode", ["80", "9B", "AB", "E2", "FF"])
def test_reserved_command_number_is_refused_with_tc_99(dmc: Dmc, opcode: str) -> None:
    """Numbers the binary command table marks "reserved": '?' and TC 99 "Bad binary command
    number"; the card keeps working."""
    rc, reply = dmc.binary(f"{opcode} 00 00 01")
    assert (rc, reply) == (galil.DMCERROR_COMMAND, "?")
    assert dmc.cmd("TC1") == "99 Bad binary command number"
    assert dmc.cmd("TPX") == "0000000000"


@pytest.mark.parametrize("header", ["A7 03 00 00", "A7 05 00 00", "A7 02 02 00"])
def test_bad_format_or_coordinated_byte_is_refused_with_tc_97(dmc: Dmc, header: str) -> None:
    """Byte 2 must be 0, 1, 2, 4 or 6 and byte 3 0 or 1: else '?' and TC 97 "Bad binary command
    format"."""
    rc, reply = dmc.binary(header)
    assert (rc, reply) == (galil.DMCERROR_COMMAND, "?")
    assert dmc.cmd("TC1") == "97 Bad binary command format"
    assert dmc.cmd("TPX") == "0000000000"


def test_binary_and_ascii_commands_mix_on_one_channel(dmc: Dmc) -> None:
    assert dmc.binary("81 02 00 01 00 0A") == (galil.DMCNOERROR, ":")
    assert dmc.cmd("KP ?") == "0010.00"
    assert dmc.binary("83 02 00 01 00 32") == (galil.DMCNOERROR, ":")
    assert dmc.cmd("KD ?") == "0050.00"
