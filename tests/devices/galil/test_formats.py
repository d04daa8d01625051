"""PF and VF, the position and variable formats [M Ch5 §Interrogation Commands; spec §4.4;
the Galil command reference's PF/VF, README "Assumptions"]."""

from __future__ import annotations

import pytest

from tests.devices.galil.test_firmware import Rig
from vdevd.devices.galil.formats import NumberFormat, parse_format


def test_pf_formats_tp_in_decimal_hex_and_saturates_like_the_manuals_example() -> None:
    """DP21; TPX 0000000021; PF4 0021; PF-4 $0015; PF2 and a position over 99: 99."""
    rig = Rig()
    assert rig.send(b"DP 21;TPX\r") == b":0000000021\r\n:"
    assert rig.send(b"PF 4;TPX\r") == b":0021\r\n:"
    assert rig.send(b"PF -4;TPX\r") == b":$0015\r\n:"
    assert rig.send(b"PF 5.2;TPX\r") == b":00021.00\r\n:"
    assert rig.send(b"PF-5.2;TPX\r") == b":$00015.00\r\n:"
    assert rig.send(b"DP 121;PF 2;TPX\r") == b"::99\r\n:"


def test_negative_positions_in_hex_are_twos_complement_and_saturate_at_the_signed_range() -> None:
    rig = Rig()
    assert rig.send(b"DP -5,5;PF-4.2;TPXY\r") == b"::$FFFB.00,$0005.00\r\n:"
    assert rig.send(b"DP 5000,-40000;PF-3;TPXY\r") == b"::$7FF,$800\r\n:"
    assert rig.send(b"PF-4;TPY\r") == b":$8000\r\n:"
    assert rig.send(b"DP -1234;PF 3;TPX\r") == b"::-999\r\n:"


def test_pf_applies_to_every_position_report_and_position_query() -> None:
    rig = Rig()
    rig.send(b"DP 21,,,;PA 300;PR 7;PF-4\r")
    for cmd, reply in ((b"TPX", b"$0015"), (b"RPX", b"$0015"), (b"TEX", b"$0000"),
                       (b"TDX", b"$0000"), (b"RLX", b"$0000"), (b"DP ?", b"$0015"),
                       (b"PA ?", b"$0015"), (b"PR ?", b"$0007"), (b"FL ?", b"$7FFF"),
                       (b"BL ?", b"$8000"), (b"IP ?", b"$0015"), (b"DE ?", b"$0000")):
        assert rig.send(cmd + b"\r") == reply + b"\r\n:", cmd
    assert rig.send(b"KP ?;TVX\r") == b"0006.00\r\n:0000000\r\n:"  # not positions: their formats


def test_vf_formats_variables_elements_and_mg_as_the_manuals_example() -> None:
    """V1=10; V1= 0000000010.0000; VF2.2 10.00; VF-2.2 $0A.00; VF1 9 (overflow)."""
    rig = Rig()
    assert rig.send(b"V1=10;V1=\r") == b":0000000010.0000\r\n:"
    assert rig.send(b"VF2.2;V1=\r") == b":10.00\r\n:"
    assert rig.send(b"VF-2.2;V1=\r") == b":$0A.00\r\n:"
    assert rig.send(b"VF1;V1=\r") == b":9\r\n:"
    assert rig.send(b"VF 3.1;V2=-2.25;V2=;MG V2,V1\r") == b"::-002.3\r\n:-002.3 010.0\r\n:"
    assert rig.send(b"VF-4.1;MG -3\r") == b":$FFFD.0\r\n:"  # hex: no sign column
    assert rig.send(b"DM A[2];A[1]=-1;A[1]=;LV\r") == b"::$FFFF.0\r\n:V1 = $000A.0\r\nV2 = $FFFD.C\r\n:"
    assert rig.send(b"QU A[],0,1,1\r") == b"$0000.0,$FFFF.0\r\n:"
    assert rig.send(b"TPX\r") == b"0000000000\r\n:"  # positions keep PF


def test_lz1_removes_leading_zeros_in_both_bases() -> None:
    rig = Rig()
    assert rig.send(b"LZ 1;DP 21;PF 5.2;TPX\r") == b":::21.00\r\n:"
    assert rig.send(b"PF-6;TPX\r") == b":$15\r\n:"
    assert rig.send(b"DP -1;TPX\r") == b":$FFFFFF\r\n:"
    assert rig.send(b"VF 6.1;V1=3;V1=\r") == b"::3.0\r\n:"
    assert rig.send(b"LZ 0;V1=\r") == b":000003.0\r\n:"


def test_pf_and_vf_queries_and_operands_give_m() -> None:
    rig = Rig()
    assert rig.send(b"PF ?;VF ?\r") == b"10\r\n:10\r\n:"
    assert rig.send(b"PF -4.2;VF 3.1;PF ?;VF ?\r") == b"::-04\r\n:03\r\n:"
    assert rig.send(b"VF 10.4;MG _PF,_VF\r") == b":-0000000004.0000 0000000010.0000\r\n:"


@pytest.mark.parametrize("bad", [b"PF 11", b"PF -9", b"PF 2.5", b"VF 4.12", b"VF x", b"VF -0.2"])
def test_a_format_out_of_range_is_tc6_and_changes_nothing(bad: bytes) -> None:
    rig = Rig()
    assert rig.send(b"PF 4;VF 2.2\r") == b"::"
    assert rig.send(bad + b"\r") == b"?"
    assert rig.send(b"TC\r") == b"006\r\n:"
    assert rig.send(b"TPX;V1=1;V1=\r") == b"0000\r\n::01.00\r\n:"


def test_rs_restores_the_default_formats() -> None:
    rig = Rig()
    assert rig.send(b"PF-4;VF 2.1;RS;PF ?;VF ?;TPX\r") == b":::10\r\n:10\r\n:0000000000\r\n:"


def test_formats_round_fractions_and_print_hex_fractions_as_the_fixed_point_value() -> None:
    assert NumberFormat(10, 4).text(-3.25) == "-0000000003.2500"
    assert NumberFormat(1, 2).text(9.999) == "9.99"  # rounds past the format: saturates
    assert NumberFormat(1, 2).text(9.994) == "9.99"
    assert NumberFormat(-4, 2).text(-5.5) == "$FFFA.80"
    assert NumberFormat(-4, 4).text(0.5) == "$0000.8000"
    assert parse_format("5.2") == NumberFormat(5, 2)
    assert parse_format("-8") == NumberFormat(-8, 0)
    assert parse_format("10.4") == NumberFormat(10, 4)
