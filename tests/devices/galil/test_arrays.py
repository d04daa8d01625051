"""Arrays and variables of the DMC-13X8 firmware (arrays.py, array_commands.py): DM, elements in
assignments and expressions, LA, DA, LV, the memory limits with their TC codes, and the QU/QD
transfers, on the firmware alone (a window, no daemon) [M Ch6 §Multiple Moves; spec §1.5, §4.5]."""

from __future__ import annotations

import pytest
from vdevmaps.galil import A16Reg

from tests.devices.galil.test_firmware import Rig
from vdevd.devices.galil.arrays import MAX_ARRAYS, MAX_ELEMENTS


def tc(rig: Rig) -> int:
    return int(rig.send(b"TC\r").split(b"\r")[0])


def mg(rig: Rig, expr: str) -> float:
    return float(rig.send(b"MG " + expr.encode() + b"\r").split(b"\r")[0])


def whole_reply(rig: Rig, line: bytes) -> bytes:
    """A reply longer than the 512-byte response FIFO: the card refills it at its samples."""
    out = rig.send(line)
    while not out.endswith((b":", b"?")):
        rig.sample()
        out += rig.receive()
    return out


def refused(rig: Rig, line: bytes) -> int:
    """Send a line that must be answered '?'; the TC code it left."""
    assert rig.send(line) == b"?"
    return tc(rig)


@pytest.fixture
def rig() -> Rig:
    return Rig()


def test_the_multiple_moves_example_fills_arrays_element_by_element(rig: Rig) -> None:
    """`DM VX [750],VY [750]`, `VX [COUNT]=N` in a loop [M Ch6 §Example - Multiple Moves]."""
    assert rig.send(b"DM VX [750],VY [750];COUNT=0;N=0\r") == b":::"
    for _ in range(5):
        assert rig.send(b"VX [COUNT]=N;VY [COUNT]=N;N=N+10;COUNT=COUNT+1\r") == b"::::"
    assert mg(rig, "VX[4]") == 40
    assert mg(rig, "VY[COUNT-1]+VX[1]") == 50
    assert mg(rig, "VX[5]") == 0  # dimensioned elements start at 0
    assert rig.send(b"VX[2]=\r") == b"0000000020.0000\r\n:"


def test_an_element_can_index_another_and_values_are_32_16_fixed_point(rig: Rig) -> None:
    rig.send(b"DM A[4]\r")
    assert rig.send(b"A[0]=3;A[3]=1/3\r") == b"::"
    assert mg(rig, "A[A[0]]*65536") == 21845  # 1/3 rounded to 1/65536


def test_la_lists_the_arrays_with_their_sizes_alphabetically(rig: Rig) -> None:
    assert rig.send(b"LA\r") == b":"
    rig.send(b"DM zeta[3],POS[16],DIF[15]\r")
    assert rig.send(b"LA\r") == b"DIF[15]\r\nPOS[16]\r\nzeta[3]\r\n:"


def test_da_deallocates_arrays_and_gives_their_space_back(rig: Rig) -> None:
    rig.send(b"DM A[100],B[200],C[300]\r")
    assert mg(rig, "_DM") == MAX_ELEMENTS - 600
    assert mg(rig, "_DA") == MAX_ARRAYS - 3
    assert rig.send(b"DA B[]\r") == b":"
    assert rig.send(b"LA\r") == b"A[100]\r\nC[300]\r\n:"
    assert mg(rig, "_DM") == MAX_ELEMENTS - 400
    assert rig.send(b"DA NOPE[]\r") == b":"  # gclib deallocates before it dimensions
    assert rig.send(b"DA *[]\r") == b":"
    assert rig.send(b"LA\r") == b":"
    assert mg(rig, "_DM") == MAX_ELEMENTS and mg(rig, "_DA") == MAX_ARRAYS
    assert rig.send(b"DM ?;DA ?\r") == b"8000\r\n:0030\r\n:"


def test_da_deallocates_variables_by_name_and_all_of_them_with_star(rig: Rig) -> None:
    rig.send(b"V1=1;V2=2;V3=3;DM A[2]\r")
    assert rig.send(b"DA V1,A[]\r") == b":"
    assert rig.send(b"LV\r") == b"V2 = 0000000002.0000\r\nV3 = 0000000003.0000\r\n:"
    assert rig.send(b"LA\r") == b":"
    assert rig.send(b"DA *\r") == b":"
    assert rig.send(b"LV\r") == b":"


def test_lv_lists_every_variable_in_the_variable_format(rig: Rig) -> None:
    assert rig.send(b"speed=-12.5;ZEBRA=37;APPLE=60\r") == b":::"
    assert rig.send(b"LV\r") == (b"APPLE = 0000000060.0000\r\nZEBRA = 0000000037.0000\r\n"
                                 b"speed = -0000000012.5000\r\n:")
    rig.send(b"LZ 1\r")
    assert rig.send(b"LV\r") == b"APPLE = 60.0000\r\nZEBRA = 37.0000\r\nspeed = -12.5000\r\n:"


def test_more_than_30_arrays_is_tc_67_and_nothing_changes(rig: Rig) -> None:
    names = [f"A{i}" for i in range(MAX_ARRAYS)]
    assert rig.send(("DM " + ",".join(f"{n}[2]" for n in names) + "\r").encode()) == b":"
    assert refused(rig, b"DM EXTRA[1]\r") == 67
    assert len(rig.send(b"LA\r").split(b"\r\n")) == MAX_ARRAYS + 1
    assert rig.send(b"DM A0[2]\r") == b":"  # the same array again is no new one


def test_more_than_8000_elements_is_tc_66_and_a_line_applies_whole_or_not_at_all(rig: Rig) -> None:
    assert rig.send(b"DM BIG[7000]\r") == b":"
    assert refused(rig, b"DM SMALL[10],REST[1001]\r") == 66
    assert rig.send(b"LA\r") == b"BIG[7000]\r\n:"
    assert rig.send(b"DM REST[1000]\r") == b":"
    assert mg(rig, "_DM") == 0
    assert refused(rig, b"DM ONE[1]\r") == 66


@pytest.mark.parametrize(("line", "code"), [
    (b"DM A[0]\r", 6),  # no elements
    (b"DM A[8001]\r", 6),
    (b"DM A[2.5]\r", 6),
    (b"DM LONGNAME9[2]\r", 9),  # names up to 8 characters
    (b"DM A\r", 55),
    (b"DM A[]\r", 50),
])
def test_a_bad_dimension_is_refused_with_the_card_s_code(rig: Rig, line: bytes, code: int) -> None:
    assert refused(rig, line) == code
    assert rig.send(b"LA\r") == b":"


def test_dm_of_an_existing_array_keeps_it_or_refuses_another_size(rig: Rig) -> None:
    rig.send(b"DM A[3];A[1]=5\r")
    assert rig.send(b"DM A[3]\r") == b":"
    assert mg(rig, "A[1]") == 5
    assert refused(rig, b"DM A[4]\r") == 57
    assert rig.send(b"LA\r") == b"A[3]\r\n:"


def test_an_index_outside_the_array_is_tc_56_and_the_card_keeps_serving(rig: Rig) -> None:
    rig.send(b"DM A[10]\r")
    assert refused(rig, b"A[10]=1\r") == 56
    assert refused(rig, b"A[-1]=1\r") == 56
    assert refused(rig, b"MG A[10]\r") == 56
    assert refused(rig, b"MG A[1.5]\r") == 56
    assert refused(rig, b"MG NONE[0]\r") == 57  # no such array
    assert refused(rig, b"NONE[0]=1\r") == 57
    assert rig.send(b"TPX\r") == b"0000000000\r\n:"
    assert rig.send(b"QU A[],,,1\r") == b",".join([b"0000000000.0000"] * 10) + b"\r\n:"


def test_a_failed_element_assignment_changes_nothing(rig: Rig) -> None:
    rig.send(b"DM A[2];A[0]=7\r")
    assert refused(rig, b"A[0]=1/0\r") == 6
    assert mg(rig, "A[0]") == 7


def test_too_many_variables_is_tc_67(rig: Rig) -> None:
    for i in range(0, 254, 50):
        line = ";".join(f"V{j}={j}" for j in range(i, min(i + 50, 254)))
        assert rig.send(line.encode() + b"\r") == b":" * min(50, 254 - i)
    assert refused(rig, b"LAST=1\r") == 67
    assert rig.send(b"V0=5\r") == b":"  # an existing one can still change
    assert refused(rig, b"TOOLONGNM=1\r") == 9


def test_qu_uploads_a_range_with_cr_or_comma_between_the_values(rig: Rig) -> None:
    rig.send(b"DM A[5];A[0]=1;A[1]=-2.5;A[2]=3;A[3]=4;A[4]=5\r")
    assert rig.send(b"QU A[],1,2,1\r") == b"-0000000002.5000,0000000003.0000\r\n:"
    assert rig.send(b"QU A[],3\r") == b"0000000004.0000\r0000000005.0000\r\n:"
    rig.send(b"LZ 1\r")
    assert rig.send(b"QU A[]\r") == b"1.0000\r-2.5000\r3.0000\r4.0000\r5.0000\r\n:"


@pytest.mark.parametrize(("line", "code"), [
    (b"QU B[]\r", 82),  # no such array
    (b"QU A[],3,1\r", 56),  # backwards
    (b"QU A[],0,5\r", 56),  # past the end
    (b"QU A[],0,4,2\r", 6),  # delimiter 0 or 1
    (b"QU A\r", 55),
    (b"QD B[]\r1,2\\", 82),  # the data of a refused QD is read and dropped
    (b"QD A[],-1,2\r1\r2\r\x1a", 56),
    (b"QD A[],0,9,1\r5\\", 1),
])
def test_a_bad_transfer_is_refused_and_the_card_keeps_serving(rig: Rig, line: bytes, code: int) -> None:
    rig.send(b"DM A[5]\r")
    assert refused(rig, line) == code
    assert rig.send(b"A[0]=9;MG A[0]\r") == b": 0000000009.0000\r\n:"


def test_qd_downloads_numbers_separated_by_commas_cr_or_lf_until_a_backslash(rig: Rig) -> None:
    rig.send(b"DM A[6]\r")
    assert rig.send(b"QD A[]\r1,-2.5\r\n3\n.25, 5 \\") == b":"
    assert rig.send(b"QU A[],,,1\r") == (b"0000000001.0000,-0000000002.5000,0000000003.0000,"
                                        b"0000000000.2500,0000000005.0000,0000000000.0000\r\n:")
    assert rig.send(b"QD A[],4,5\r7,8\x1a") == b":"  # the DMC library ends the data with ^Z
    assert rig.send(b"QU A[],3,5,1\r") == b"0000000000.2500,0000000007.0000,0000000008.0000\r\n:"


def test_qd_data_may_arrive_in_pieces_across_samples(rig: Rig) -> None:
    rig.send(b"DM A[3]\r")
    assert rig.send(b"QD A[]\r10,2") == b""  # no answer before the data ends
    rig.sample()
    assert rig.send(b"0,30") == b""
    rig.sample()
    assert rig.send(b"\\TPX\r") == b":0000000000\r\n:"
    assert rig.send(b"QU A[],,,1\r") == b"0000000010.0000,0000000020.0000,0000000030.0000\r\n:"


def test_qd_with_more_values_than_the_range_keeps_those_that_fit_and_answers_tc_56(rig: Rig) -> None:
    rig.send(b"DM A[2]\r")
    assert rig.send(b"QD A[]\r1,2,3\\") == b"?"
    assert tc(rig) == 56
    assert rig.send(b"QU A[],,,1\r") == b"0000000001.0000,0000000002.0000\r\n:"


def test_qd_with_a_bad_number_answers_tc_83_after_the_data(rig: Rig) -> None:
    rig.send(b"DM A[3]\r")
    assert rig.send(b"QD A[]\r1,X2,3\\") == b"?"
    assert tc(rig) == 83
    assert rig.send(b"QU A[],,,1\r") == b"0000000001.0000,0000000003.0000,0000000000.0000\r\n:"


def test_clearing_the_fifos_ends_a_qd_that_never_ends(rig: Rig) -> None:
    rig.send(b"DM A[3]\r")
    assert rig.send(b"QD A[]\r1,2") == b""
    for b in (1, 0x80, 1, 0x80):  # [M Ch4 §Clearing FIFO Buffer]
        rig.bus.write(A16Reg.CONTROL, b)
    assert rig.send(b"MG A[0]\r") == b" 0000000001.0000\r\n:"


def test_rs_erases_the_arrays(rig: Rig) -> None:
    rig.send(b"DM A[3]\r")
    assert rig.send(b"RS\r") == b":"
    assert rig.send(b"LA\r") == b":"
    assert mg(rig, "_DM") == MAX_ELEMENTS
