"""The program buffer of the DMC-13X8: DL, UL, LS, its limits and their TC codes, the flash (BP
BV BN) and #AUTO (vdevd/devices/galil/program.py, flash.py; spec galil.md §1.4-1.5, §4.5)."""

from __future__ import annotations

import pytest

from tests.devices.galil.program_rig import Rig
from vdevd.devices.galil.channel import CommandChannel
from vdevd.devices.galil.program import MAX_LABELS, MAX_LINE_LENGTH, MAX_LINES

#: [M Ch2 Ex11]: the program written with the editor, lines numbered from 000
EX11 = "#A\nPR 700\nSP 2000\nBGX\nEN"


def test_dl_then_ul_gives_the_program_back_then_ctrl_z() -> None:
    rig = Rig()
    assert rig.download(EX11) == b":"
    assert rig.send(b"UL\r") == b"#A\r\nPR 700\r\nSP 2000\r\nBGX\r\nEN\r\n\x1a:"


def test_ls_numbers_the_lines_from_000_as_the_editor_does_m_ch2_ex11() -> None:
    rig = Rig()
    rig.download(EX11)
    assert rig.send(b"LS\r") == b"000 #A\r\n001 PR 700\r\n002 SP 2000\r\n003 BGX\r\n004 EN\r\n:"
    assert rig.send(b"LS 1,2\r") == b"001 PR 700\r\n002 SP 2000\r\n:"
    assert rig.send(b"LS #A,0\r") == b"000 #A\r\n:"


def test_dl_hash_appends_and_dl_label_replaces_from_the_label() -> None:
    rig = Rig()
    rig.download("#A\nEN")
    assert rig.send(b"DL#\r#B\rEN\r\\") == b":"
    assert rig.send(b"UL\r") == b"#A\r\nEN\r\n#B\r\nEN\r\n\x1a:"
    assert rig.send(b"DL#B\r#C\rMG 1\rEN\r\\") == b":"
    assert rig.send(b"UL\r") == b"#A\r\nEN\r\n#C\r\nMG 1\r\nEN\r\n\x1a:"


def _refused(rig: Rig, program: str, code: int) -> None:
    """The download answers '?' with `code`, the buffer keeps the old program, the card serves."""
    before = rig.send(b"UL\r")
    assert rig.download(program) == b"?"
    assert rig.tc() == code
    assert rig.send(b"UL\r") == before
    assert rig.send(b"MG 1+1\r") == b" 0000000002.0000\r\n:"


def test_a_line_longer_than_80_characters_is_tc_60_and_the_buffer_is_kept() -> None:
    rig = Rig()
    rig.download(EX11)
    _refused(rig, "#B\nMG \"" + "x" * MAX_LINE_LENGTH + "\"\nEN", 60)
    assert rig.value("_ED") == 1  # the line in error [DMCLIB DMCError: MG_ED]


def test_more_than_1000_lines_is_tc_60() -> None:
    _refused(Rig(), "\n".join(["WT 1"] * (MAX_LINES + 1)), 60)


def test_a_duplicate_or_bad_label_is_tc_61() -> None:
    rig = Rig()
    _refused(rig, "#A\nEN\n#A\nEN", 61)
    _refused(rig, "#TOOLONGLABEL\nEN", 61)  # 7 characters after '#' at most
    _refused(rig, "#1A\nEN", 61)


def test_more_than_254_labels_is_tc_62() -> None:
    _refused(Rig(), "\n".join(f"#L{k}" for k in range(MAX_LABELS + 1)), 62)
    rig = Rig()
    assert rig.download("\n".join(f"#L{k}" for k in range(MAX_LABELS))) == b":"


def test_binary_bytes_in_a_program_are_tc_98() -> None:
    rig = Rig()
    rig.download(EX11)
    before = rig.send(b"UL\r")
    assert rig.send(b"DL\r#B\r\xa0\x00\x00\x01\rEN\r\\") == b"?"
    assert rig.tc() == 98
    assert rig.send(b"UL\r") == before


def test_dl_while_a_program_runs_is_tc_17() -> None:
    rig = Rig()
    rig.download("#A\nJP #A")
    rig.send(b"XQ #A\r")
    assert rig.send(b"DL\r") == b"?"
    assert rig.tc() == 17
    assert rig.send(b"HX\r") == b":"
    assert rig.download("#B\nEN") == b":"


def test_dl_from_an_undefined_label_is_tc_10() -> None:
    rig = Rig()
    assert rig.send(b"DL#NONE\r") == b"?"
    assert rig.tc() == 10


def test_the_fifo_clear_sequence_ends_a_download_in_progress() -> None:
    rig = Rig()
    rig.send(b"DL\r#A\r")
    rig.fw.host_cleared()
    assert rig.send(b"MG 3\r") == b" 0000000003.0000\r\n:"


def test_ed_is_not_emulated() -> None:
    rig = Rig()
    assert rig.send(b"ED\r") == b"?"
    assert rig.tc() == 1


def test_program_commands_from_the_host_are_tc_2() -> None:
    rig = Rig()
    for cmd in (b"JP #A\r", b"JS #A\r", b"EN\r", b"RE\r", b"RI\r", b"IF 1\r", b"ZS\r"):
        assert rig.send(cmd) == b"?"
        assert rig.tc() == 2


# -- flash [spec §1.4-1.5] ---------------------------------------------------------------------------
def test_bp_bv_bn_burn_and_a_new_power_up_restores_them() -> None:
    rig = Rig()
    rig.download(EX11)
    assert rig.send(b"V1=123;KP 12,13;BP;BV;BN\r") == b":::::"
    after = Rig(flash=rig.flash)
    assert after.send(b"UL\r") == b"#A\r\nPR 700\r\nSP 2000\r\nBGX\r\nEN\r\n\x1a:"
    assert after.value("V1") == 123
    assert after.send(b"KP ?,?\r") == b"0012.00,0013.00\r\n:"


def test_bn_while_a_program_runs_is_tc_17() -> None:
    rig = Rig()
    rig.download("#A\nJP #A")
    rig.send(b"XQ #A\r")
    assert rig.send(b"BN\r") == b"?"
    assert rig.tc() == 17
    assert rig.send(b"BP\r") == b":"


def test_a_program_not_burned_is_gone_at_power_up() -> None:
    rig = Rig()
    rig.download(EX11)
    after = Rig(flash=rig.flash)
    assert after.send(b"UL\r") == b"\x1a:"


def test_bn_burns_the_motor_off_state_m_ch2_step_7b_e() -> None:
    """"it is highly recommended that the motor off command be given before executing the BN
    command. In this case the motor will be disabled upon power up or reset"."""
    rig = Rig()
    rig.send(b"MO X;BN\r")
    assert Rig(flash=rig.flash).value("_MOX") == 1


def test_master_reset_erases_programs_variables_and_the_flash() -> None:
    rig = Rig()
    rig.download(EX11)
    rig.send(b"V1=5;BP;BV\r")
    assert rig.send(b"\x12\x13\r") == b":"
    assert rig.send(b"UL\r") == b"\x1a:"
    assert rig.send(b"V1=\r") == b"?"
    assert Rig(flash=rig.flash).send(b"UL\r") == b"\x1a:"


def test_rs_restores_the_burned_program_and_variables() -> None:
    rig = Rig()
    rig.download(EX11)
    rig.send(b"V1=7;BP;BV\r")
    rig.download("#B\nEN")
    rig.send(b"V1=8\r")
    assert rig.send(b"RS\r") == b":"
    assert rig.send(b"UL\r").startswith(b"#A\r\n")
    assert rig.value("V1") == 7


@pytest.mark.parametrize("image", [
    {"format": "something else", "programs": ["#A"]},
    {"format": "vdevd-galil-dmc13x8-flash", "programs": [123], "variables": "x",
     "parameters": {"values": {"KP": ["a"]}}},
    {"format": "vdevd-galil-dmc13x8-flash", "programs": ["#A", "#A"]},
])
def test_a_foreign_or_corrupt_image_leaves_the_defaults(image: dict[str, object]) -> None:
    rig = Rig(flash=image)
    assert rig.send(b"UL\r") == b"\x1a:"
    assert rig.send(b"KP ?\r") == b"0006.00\r\n:"


def test_auto_runs_at_power_up_when_the_burned_program_has_it() -> None:
    rig = Rig()
    rig.download("#AUTO\nV1=42\nMG \"UP\"\nEN")
    rig.send(b"BP\r")
    after = Rig(flash=rig.flash)
    assert after.fw.threads.active
    assert after.until_halted() == b"UP\r\n"
    assert after.value("V1") == 42


@pytest.mark.parametrize(("command", "code"), [
    (b"LS 7\r", 11), (b"LS 1,2,3\r", 4), (b"LS #NONE\r", 10), (b"XQ A\r", 11), (b"XQ #A,-1\r", 6),
    (b"HX 9\r", 6), (b"II 9\r", 6), (b"II 3,2\r", 6), (b"TW 40000\r", 6), (b"TR 2\r", 6),
    (b"CW 3\r", 6), (b"AI 9\r", 6), (b"AD\r", 50), (b"AP ?\r", 51),
])
def test_bad_program_commands_answer_their_tc_and_change_nothing(command: bytes, code: int) -> None:
    rig = Rig()
    rig.download(EX11)
    assert rig.send(command) == b"?"
    assert rig.tc() == code
    assert rig.send(b"UL\r") == b"#A\r\nPR 700\r\nSP 2000\r\nBGX\r\nEN\r\n\x1a:"
    assert not rig.fw.threads.active


def test_bv_burns_the_arrays_with_the_variables() -> None:
    rig = Rig()
    rig.send(b"DM POS[3];POS[0]=5;POS[2]=-7;BV\r")
    after = Rig(flash=rig.flash)
    assert after.value("POS[0]") == 5
    assert after.value("POS[2]") == -7
    rig.send(b"DA POS[];RS\r")
    assert rig.value("POS[2]") == -7


def test_dl_over_an_ethernet_connection_takes_the_program_from_it() -> None:
    """The Ethernet command channel takes DL's lines from its own input, as the FIFO does."""
    rig = Rig()
    channel = CommandChannel(rig.fw)
    assert channel.receive(b"DL\r#A\rV1=3\r") == b""
    assert rig.send(b"MG 1\r") == b" 0000000001.0000\r\n:"  # the FIFO is not in the download
    assert channel.receive(b"EN\r\\") == b":"
    assert channel.receive(b"UL\r") == b"#A\r\nV1=3\r\nEN\r\n\x1a:"
    assert channel.receive(b"DL\r#A\r#A\r\\TC\r") == b"?061\r\n:"


def test_ctrl_l_ctrl_k_locks_the_program_against_ul_ls_and_tr() -> None:
    """^L^K password,1 with the password PW set (Galil command reference; README): UL, LS and TR
    are TC 106 "Privilege violation" while locked, the program still runs; a wrong password
    neither locks nor unlocks; ^R^S erases the password and the lock."""
    rig = Rig()
    rig.download(EX11)
    assert rig.send(b"PW abc,abd\r") == b"?" and rig.tc() == 6  # the two must match
    assert rig.send(b"PW abc,abc\r") == b":"
    assert rig.send(b"\x0c\x0bxyz,1\r") == b"?" and rig.tc() == 106
    assert rig.value("_LK") == 0
    assert rig.send(b"\x0c\x0babc,1\r") == b":"
    assert rig.value("_LK") == 1
    for line in (b"UL\r", b"LS\r", b"TR1\r", b"PW q,q\r"):
        assert rig.send(line) == b"?" and rig.tc() == 106, line
    assert rig.send(b"XQ #A\r") == b":"  # a locked program runs
    rig.until_halted()
    assert rig.send(b"\x0c\x0babc,0\r") == b":"
    assert rig.send(b"UL\r").endswith(b"\x1a:")
    rig.send(b"\x0c\x0babc,1\r")
    assert rig.send(b"\x12\x13\r") == b":"  # ^R^S
    assert rig.value("_LK") == 0 and rig.send(b"LS\r") == b":"


def test_at_waits_from_its_reference_and_at_minus_n_moves_it() -> None:
    """AT (the Galil command reference's example): AT 0 sets the reference, AT 50 and AT 100
    wait 50 and 100 ms from it, AT -150 waits 150 ms and makes that the reference, AT 80 then
    ends 230 ms after the first AT 0. TIME counts samples (1 ms at TM 1000)."""
    rig = Rig()
    rig.download("#A\nAT 0\nt0=TIME\nAT 50\nt1=TIME\nAT 100\nt2=TIME\nAT -150\nt3=TIME\n"
                 "AT 80\nt4=TIME\nEN")
    assert rig.send(b"XQ #A\r") == b":"
    rig.until_halted()
    t = [round(rig.value(f"t{k}")) for k in range(5)]
    assert t[1] - t[0] in (49, 50)  # t0 is read in the sample after AT 0's (or in it)
    assert [t[2] - t[1], t[3] - t[2], t[4] - t[3]] == [50, 50, 80]


def test_at_holds_the_command_line_and_rejects_a_bad_time() -> None:
    rig = Rig()
    assert rig.send(b"AT 0;AT -20;AT 20\r") == b":"  # AT -20 holds the command line
    assert rig.samples(19) == b""
    assert rig.samples(1) == b":"  # 20 ms: the reference moves there
    assert rig.samples(19) == b""
    assert rig.samples(1) == b":"  # AT 20: 40 ms from the first AT 0
    assert rig.send(b"AT 2.5\r") == b"?" and rig.tc() == 6
