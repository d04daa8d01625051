"""Application programs running on the DMC-13X8 firmware: the manual's program examples, flow,
threads, trippoints in programs, automatic subroutines (vdevd/devices/galil/threads.py,
program_commands.py; [M Ch2 Ex11-14], [M Ch3 §Limit Switch Input], spec galil.md §4.5, §5.7)."""

from __future__ import annotations

import numpy as np
import pytest
from vdevmaps.galil import InterruptStatus

from tests.devices.galil.program_rig import Rig
from vdevd.devices.galil.threads import MAX_STACK, MAX_THREADS

#: [M Ch2 Ex12] motion programs with loops: X to 1000, 2000, ... 10000, reporting each position
EX12 = """#A
DP 0
V1=1000
#Loop
PA V1
BG X
AM X
WT 500
TP X
V1=V1+1000
JP #Loop,V1<10001
EN"""

#: [M Ch2 Ex13] motion programs with trippoints
EX13 = """#B
DP 0,0
PR 30000,60000
SP 5000,5000
BGX
AD 4000
BGY
AP 6000
SP 2000,50000
AP ,50000
SP ,10000
EN"""

#: [M Ch2 Ex14] control variables: back to zero in halves (the program's PR 4000, spec §8 q.18)
EX14 = """#A;DP0
PR 4000
SP 2000
BGX
AMX
WT 500
#B
V1 = _TPX
PR -V1/2
BGX
AMX
WT 500
V1=
JP #C, V1=0
JP #B
#C
EN"""


def test_ex12_moves_to_each_position_and_reports_it() -> None:
    rig = Rig()
    assert rig.download(EX12) == b":"
    assert rig.send(b"XQ #A\r") == b":"
    out = rig.until_halted()
    assert out == b"".join(b"%010d\r\n" % (1000 * k) for k in range(1, 11))
    assert rig.value("_TPX") == 10000
    assert rig.value("V1") == 11000


def test_ex12_takes_the_moves_and_the_waits() -> None:
    """Ten moves of 1000 counts at SP 25000 with AC/DC 256000 plus ten WT 500: a little over 5 s."""
    rig = Rig()
    rig.download(EX12)
    rig.send(b"XQ #A\r")
    rig.until_halted()
    ms = rig.fw.ticks
    assert 10 * 500 < ms < 10 * 500 + 10 * 200


def test_ex13_trippoints_start_y_after_x_moved_4000_and_change_speeds_at_positions() -> None:
    rig = Rig()
    rig.download(EX13)
    rig.send(b"XQ #B\r")
    while rig.fw.threads.threads[0] is not None and rig.fw.threads.threads[0].line < 6:
        rig.samples(1)
    # BGY runs once X has moved 4000 (AD): Y starts with X near 4000
    rig.samples(1)
    x = rig.value("_RPX")
    assert 4000 <= x <= 4000 + 5000 * 0.003
    assert rig.value("_BGY") == 1
    while rig.fw.threads.threads[0] is not None and rig.fw.threads.threads[0].line < 9:
        rig.samples(1)
    rig.samples(1)
    assert rig.value("_SPY") == 50000  # changed once X passed 6000 (AP)
    assert rig.value("_RPX") >= 6000
    rig.until_halted()
    assert rig.value("_SPY") == 10000
    assert rig.value("_RPY") >= 50000


def test_ex14_halves_the_distance_to_zero_and_reports_v1() -> None:
    """Each pass moves half the way back and reports V1 (`V1=` in a program prints it). Whole
    counts: from 1 count away PR -0.5 moves nothing (PR rounds to whole counts), so the program
    loops there, as the manual's program would on a card that rounds -0.5 to 0."""
    rig = Rig()
    rig.download(EX14)
    rig.send(b"XQ #A\r")
    reported = [float(x) for x in rig.samples(15_000).split()]
    assert reported[:8] == [4000, 2000, 1000, 500, 250, 125, 63, 32]
    assert all(b <= a for a, b in zip(reported, reported[1:], strict=False))
    assert reported[-1] == 1
    assert rig.send(b"HX\r") == b":"


def test_a_running_thread_keeps_the_card_out_of_rest_and_the_host_served() -> None:
    rig = Rig()
    rig.download("#LOOP\nV1=V1+1\nJP #LOOP")
    rig.send(b"V1=0\r")
    assert rig.fw.rest_state() is not None
    rig.send(b"XQ #LOOP\r")
    assert rig.fw.rest_state() is None
    assert rig.fw.idle_samples(100) == 0
    for _ in range(5):
        rig.samples(10)
        assert rig.send(b"MG _TPX\r") == b" 0000000000.0000\r\n:"
    assert rig.value("V1") > 0
    assert 0 <= rig.value("_XQ0") <= 2  # the line thread 0 runs
    assert rig.value("_XQ1") == -1
    assert rig.send(b"HX 0\r") == b":"
    assert rig.value("_XQ0") == -1
    assert rig.fw.rest_state() is not None


def test_lines_per_sample_is_the_sample_over_0_35_ms() -> None:
    """TM 1000: two statements per sample [M Ch4: about 0.35 ms per ASCII command]."""
    rig = Rig()
    rig.download("#LOOP\nV1=V1+1\nJP #LOOP")
    rig.send(b"V1=0;XQ #LOOP\r")
    rig.samples(300)
    assert rig.value("V1") == pytest.approx(300 * 2 / 3, abs=1)


def test_eight_threads_run_side_by_side() -> None:
    program = "\n".join(f"#T{n}\nV{n}=V{n}+1\nJP #T{n},V{n}<5\nEN" for n in range(MAX_THREADS))
    rig = Rig()
    rig.download(program)
    for n in range(MAX_THREADS):
        rig.send(f"V{n}=0;XQ #T{n},{n}\r".encode())
    assert rig.send(b"XQ #T0,8\r") == b"?"
    assert rig.tc() == 6
    rig.until_halted()
    assert [rig.value(f"V{n}") for n in range(MAX_THREADS)] == [5] * MAX_THREADS


def test_xq_on_a_running_thread_is_tc_19_and_an_undefined_label_tc_10() -> None:
    rig = Rig()
    rig.download("#A\nWT 1000\nEN")
    rig.send(b"XQ #A\r")
    assert rig.send(b"XQ #A\r") == b"?"
    assert rig.tc() == 19
    assert rig.send(b"XQ #NONE,1\r") == b"?"
    assert rig.tc() == 10


def test_xq_without_a_program_is_tc_10() -> None:
    rig = Rig()
    assert rig.send(b"XQ\r") == b"?"
    assert rig.tc() == 10


def test_a_trippoint_in_a_thread_blocks_neither_the_host_nor_other_threads() -> None:
    rig = Rig()
    rig.download("#W\nWT 100\nV1=1\nEN\n#C\nV2=V2+1\nJP #C,V2<10\nEN")
    rig.send(b"V2=0;XQ #W,0;XQ #C,1\r")
    rig.samples(20)
    assert rig.value("V2") == 10
    assert rig.send(b"V1=\r") == b"?"  # thread 0 still waits
    rig.samples(90)
    assert rig.value("V1") == 1


def test_the_command_line_trippoint_still_holds_the_interpreter() -> None:
    rig = Rig()
    assert rig.send(b"WT 5;MG 1\r") == b""
    assert rig.samples(6) == b": 0000000001.0000\r\n:"


def test_jump_to_a_missing_label_ends_the_thread_with_tc_10() -> None:
    rig = Rig()
    rig.download("#A\nV1=1\nJP #NONE\nV1=2\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.tc() == 10
    assert rig.value("V1") == 1
    assert rig.value("_ED") == 2
    assert rig.send(b"MG 5\r") == b" 0000000005.0000\r\n:"


def test_js_deeper_than_16_is_tc_12() -> None:
    rig = Rig()
    rig.download("#A\nN=0\n#R\nN=N+1\nJS #R\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.tc() == 12
    assert rig.value("N") == MAX_STACK + 1


def test_js_returns_with_en_and_zs_clears_the_stack() -> None:
    rig = Rig()
    rig.download("#A\nJS #S\nMG \"BACK\"\nJS #Z\nMG \"NOT\"\nEN\n#S\nMG \"SUB\"\nEN\n#Z\nZS\nEN")
    rig.send(b"XQ #A\r")
    assert rig.until_halted() == b"SUB\r\nBACK\r\n"


def test_js_with_a_false_condition_does_not_call() -> None:
    rig = Rig()
    rig.download("#A\nV1=0\nJS #S,V1=1\nEN\n#S\nV1=9\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.value("V1") == 0


@pytest.mark.parametrize(("v1", "out"), [(1, b"ONE\r\nIN\r\nEND\r\n"), (2, b"TWO\r\nEND\r\n"),
                                         (3, b"OTHER\r\nEND\r\n")])
def test_if_else_endif_nest(v1: int, out: bytes) -> None:
    rig = Rig()
    rig.download("\n".join([
        "#A", "IF (V1=1)", "MG \"ONE\"", "IF (V1<2);MG \"IN\";ELSE;MG \"NO\";ENDIF", "ELSE",
        "IF (V1=2)", "MG \"TWO\"", "ELSE", "MG \"OTHER\"", "ENDIF", "ENDIF", "MG \"END\"", "EN"]))
    rig.send(f"V1={v1};XQ #A\r".encode())
    assert rig.until_halted() == out


def test_a_variable_named_like_if_is_no_if() -> None:
    rig = Rig()
    rig.download("#A\nIF 0\nIFLAG=1\nELSE\nIFLAG=2\nENDIF\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.value("IFLAG") == 2


def test_if_without_endif_is_tc_63() -> None:
    rig = Rig()
    rig.download("#A\nIF 0\nMG 1\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.tc() == 63


def test_a_refused_statement_runs_cmderr_in_thread_0_and_en_returns_after_it() -> None:
    rig = Rig()
    rig.download("#A\nKP 5000\nMG \"NEXT\"\nEN\n#CMDERR\nMG \"ERR\",_TC\nEN")
    rig.send(b"XQ #A\r")
    assert rig.until_halted() == b"ERR 0000000006.0000\r\nNEXT\r\n"


def test_cmderr_ends_the_thread_with_zs_then_en() -> None:
    rig = Rig()
    rig.download("#A\nKP 5000\nMG \"NEXT\"\nEN\n#CMDERR\nZS0\nEN")
    rig.send(b"XQ #A\r")
    assert rig.until_halted() == b""


def test_a_refused_statement_of_another_thread_ends_it() -> None:
    rig = Rig()
    rig.download("#A\nKP 5000\nMG \"NEXT\"\nEN\n#CMDERR\nMG \"ERR\"\nEN")
    rig.send(b"XQ #A,3\r")
    assert rig.until_halted() == b""
    assert rig.tc() == 6


def test_comments_and_semicolons_in_programs() -> None:
    rig = Rig()
    rig.download("#A;V1=1;'a comment; V1=2\nNO nothing here\nREM the end\nV2=V1+1 ;EN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.value("V1") == 1
    assert rig.value("V2") == 2


def test_st_from_the_host_halts_programs_and_ab1_does_not() -> None:
    rig = Rig()
    rig.download("#A\nJP #A")
    rig.send(b"XQ #A\r")
    rig.send(b"AB1\r")
    assert rig.fw.threads.active
    rig.send(b"ST X\r")
    assert rig.fw.threads.active
    rig.send(b"ST\r")
    assert not rig.fw.threads.active
    rig.send(b"XQ #A\r")
    rig.send(b"AB\r")
    assert not rig.fw.threads.active


def test_tb_bit_7_while_a_program_runs() -> None:
    rig = Rig()
    rig.download("#A\nWT 10\nEN")
    rig.send(b"XQ #A\r")
    assert int(rig.value("_TB")) & 0x80
    rig.until_halted()
    assert not int(rig.value("_TB")) & 0x80


def test_mg_waits_while_the_response_fifo_is_full() -> None:
    """A program's messages wait for the host: the card holds a bounded amount."""
    rig = Rig()
    rig.download("#A\nMG \"0123456789\"\nJP #A")
    rig.send(b"XQ #A\r")
    for _ in range(500):
        rig.now_ns = (rig.fw.ticks + 1) * 1_000_000
        rig.fw.step()
    assert len(rig.fw.pending_output) < 600
    assert rig.fw.threads.active


def test_in_waits_for_the_host_to_set_the_variable() -> None:
    rig = Rig()
    rig.download("#A\nIN \"SPEED?\",VAL\nSP VAL\nEN")
    rig.send(b"VAL=1;XQ #A\r")
    assert rig.samples(10) == b"SPEED?\r\n"
    assert rig.fw.threads.active
    rig.send(b"VAL=1234\r")
    rig.until_halted()
    assert rig.value("_SPX") == 1234


def test_program_messages_carry_bit_7_unless_cw2() -> None:
    """The host tells a program's messages from replies by bit 7 (CW1, the default)."""
    rig = Rig()
    rig.download("#A\nMG \"HI\"\nEN")
    rig.send(b"XQ #A\r")
    rig.samples(3)
    assert rig.receive(raw=True) == b""
    rig.send(b"XQ #A\r")
    for _ in range(3):
        rig.now_ns = (rig.fw.ticks + 1) * 1_000_000
        rig.fw.step()
    assert rig.receive(raw=True) == bytes(b | 0x80 for b in b"HI\r\n")
    rig.send(b"CW 2;XQ #A\r")
    for _ in range(3):
        rig.now_ns = (rig.fw.ticks + 1) * 1_000_000
        rig.fw.step()
    assert rig.receive(raw=True) == b"HI\r\n"


def test_a_bare_number_from_the_host_answers_in_without_a_reply() -> None:
    """DMCCommand expects no ':' for "numeric IN replies" [DMCLIB]."""
    rig = Rig()
    rig.download("#A\nIN \"N?\",VAL\nSP VAL\nEN")
    rig.send(b"XQ #A\r")
    assert rig.samples(5) == b"N?\r\n"
    assert rig.send(b"2500\r") == b""
    rig.until_halted()
    assert rig.value("_SPX") == 2500
    assert rig.send(b"2500\r") == b"?"  # no IN waits: not a command


def test_in_is_only_valid_in_thread_0() -> None:
    rig = Rig()
    rig.download("#A\nIN \"N?\",VAL\nEN")
    rig.send(b"XQ #A,1\r")
    rig.until_halted()
    assert rig.tc() == 71


def test_a_program_ending_posts_interrupt_db_when_ei_bit_13_is_set() -> None:
    rig = Rig()
    rig.download("#A\nWT 2\nEN\n#B\nJP #B")
    rig.send(f"EI {1 << 13};XQ #A;XQ #B,1\r".encode())
    assert rig.fw.bus.pending_interrupts == ()
    rig.samples(5)
    assert rig.fw.bus.pending_interrupts == (InterruptStatus.PROGRAM_STOPPED,)
    rig.send(b"HX 1\r")  # halted by the host: no DB
    assert rig.fw.bus.pending_interrupts == (InterruptStatus.PROGRAM_STOPPED,)


def test_tr_traces_the_lines() -> None:
    rig = Rig()
    rig.download("#A\nV1=1\nEN")
    rig.send(b"TR1;XQ #A\r")
    assert rig.until_halted() == b"000 #A\r\n001 V1=1\r\n002 EN\r\n"


# -- trippoints in programs -----------------------------------------------------------------------
def test_ai_waits_for_an_input_level() -> None:
    rig = Rig()
    rig.download("#A\nAI -3\nV1=1\nEN")
    rig.send(b"XQ #A\r")
    rig.samples(10)
    assert rig.fw.threads.active
    rig.fw.set_input(3, 0)
    rig.until_halted()
    assert rig.value("V1") == 1


def test_mf_and_mr_wait_for_the_encoder_to_pass() -> None:
    rig = Rig()
    rig.download("#A\nJG 5000\nBGX\nMF 1000\nV1=_TPX\nJG -5000\nST X\nAMX\nBGX\nMR 500\nV2=_TPX\nSTX\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert 1000 <= rig.value("V1") < 1000 + 5000 * 0.003
    assert 500 - 5000 * 0.003 < rig.value("V2") <= 500


def test_as_waits_until_at_speed() -> None:
    rig = Rig()
    rig.download("#A\nJG 25600\nAC 256000\nBGX\nASX\nV1=TIME\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert rig.value("V1") == pytest.approx(100, abs=3)  # 25600 / 256000 s = 100 samples


def test_as_after_the_move_ended_does_not_wait() -> None:
    rig = Rig()
    rig.download("#A\nPR 100\nBGX\nAMX\nASX\nV1=1\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted(1000)
    assert rig.value("V1") == 1


def test_ar_waits_for_distances_from_the_last_ar() -> None:
    rig = Rig()
    rig.download("#A\nJG 10000\nBGX\nAR 1000\nV1=_RPX\nAR 1000\nV2=_RPX\nSTX\nEN")
    rig.send(b"XQ #A\r")
    rig.until_halted()
    assert 1000 <= rig.value("V1") < 1050
    assert 2000 <= rig.value("V2") < 2050


# -- automatic subroutines ------------------------------------------------------------------------
def test_limswi_runs_in_thread_0_when_a_limit_switch_trips_m_ch3() -> None:
    rig = Rig()
    rig.download("#A\nJP #A\n#LIMSWI\nMG \"LIMIT\"\nRE")
    rig.send(b"XQ #A\r")
    rig.samples(5)
    rig.fw.set_limits(np.array([True, False, False, False]), np.zeros(4, dtype=bool))
    assert rig.samples(5) == b"LIMIT\r\n"
    assert rig.fw.threads.active  # RE went back to the loop


def test_limswi_needs_a_running_thread_0() -> None:
    rig = Rig()
    rig.download("#A\nEN\n#LIMSWI\nMG \"LIMIT\"\nRE")
    rig.fw.set_limits(np.array([True, False, False, False]), np.zeros(4, dtype=bool))
    assert rig.samples(5) == b""


def test_poserr_runs_when_the_error_exceeds_er() -> None:
    rig = Rig(plant="servo")
    rig.download("#A\nJP #A\n#POSERR\nMG \"POSERR\"\nRE")
    rig.send(b"ER 5;KP 1;KD 0;PR 100000;SP 100000;BG X;XQ #A\r")
    out = rig.samples(300)
    assert b"POSERR\r\n" in out


def test_inint_runs_on_an_input_chosen_with_ii_and_ri_arms_it_again() -> None:
    rig = Rig()
    rig.download("#A\nII 2\n#L\nJP #L\n#ININT\nN=N+1\nRI")
    rig.send(b"N=0;XQ #A\r")
    rig.samples(3)
    rig.fw.set_input(2, 0)
    rig.samples(5)
    assert rig.value("N") == 1
    rig.fw.set_input(2, 1)
    rig.fw.set_input(2, 0)
    rig.samples(5)
    assert rig.value("N") == 2
    rig.fw.set_input(1, 1)
    rig.fw.set_input(1, 0)  # not chosen
    rig.samples(5)
    assert rig.value("N") == 2


def test_ri1_restores_the_interrupted_trippoint() -> None:
    rig = Rig()
    rig.download("#A\nII 1\nWT 100\nV1=TIME\nEN\n#ININT\nRI1")
    rig.send(b"XQ #A\r")
    rig.samples(10)
    rig.fw.set_input(1, 0)
    rig.until_halted()
    assert rig.value("V1") >= 100


def test_mctime_runs_when_mc_waits_longer_than_tw() -> None:
    rig = Rig()
    rig.download("#A\nTW 50\nJG 1000\nBGX\nMCX\nMG \"AFTER\"\nEN\n#MCTIME\nMG \"MCTIME\"\nRE1")
    rig.send(b"XQ #A\r")
    assert rig.until_halted(500) == b"MCTIME\r\nAFTER\r\n"
    assert rig.value("_SCX") == 99


def test_re_outside_an_automatic_subroutine_is_refused() -> None:
    rig = Rig()
    rig.download("#A\nRE\nMG 1\nEN")
    rig.send(b"XQ #A\r")
    assert rig.until_halted() == b""
    assert rig.tc() == 8


# -- the manual's chapter 4 and 6 program examples ------------------------------------------------
def _started(rig: Rig, axis: str, limit: int = 10_000) -> int:
    """Samples until the axis moves; the sample count then."""
    for _ in range(limit):
        if rig.value(f"_BG{axis}"):
            return rig.fw.ticks
        rig.samples(1)
    raise AssertionError(f"{axis} never started")


def test_ch4_user_interrupt_when_at_speed() -> None:
    """[M Ch4 §Setting up Interrupts, 2)]: #I PR 1000; SP 5000; BGX; ASX; UI1; EN: F1 once X
    has reached 5000 counts/s (AC 256000: about 20 ms)."""
    rig = Rig()
    rig.download("#I\nPR 1000\nSP 5000\nBGX\nASX\nUI1\nEN")
    rig.send(b"EI 2,,255;XQ #I\r")
    for _ in range(100):
        rig.samples(1)
        if rig.fw.bus.pending_interrupts:
            break
    assert rig.fw.bus.pending_interrupts == (InterruptStatus.USER + 1,)
    assert rig.fw.ticks == pytest.approx(5000 / 256000 * 1000, abs=3)


def test_ch6_fig_6_1_moves_start_20_ms_apart() -> None:
    """[M Ch6 §Independent Axis Positioning]: BG X, WT 20, BG Y, WT 20, BG Z."""
    rig = Rig()
    rig.download("#A\nPR 2000,500,100\nSP 15000,10000,5000\nAC 500000,500000,500000\n"
                 "DC 500000,500000,500000\nBG X\nWT 20\nBG Y\nWT 20\nBG Z\nEN")
    rig.send(b"XQ #A\r")
    x = _started(rig, "X")
    y = _started(rig, "Y")
    z = _started(rig, "Z")
    assert y - x == pytest.approx(20, abs=2)
    assert z - y == pytest.approx(20, abs=2)
    rig.samples(300)
    assert [rig.value(f"_RP{a}") for a in "XYZ"] == [2000, 500, 100]


def test_ch6_jog_x_then_z_once_x_is_at_speed() -> None:
    """[M Ch6 §Example - Jog in X only]: AS X, then BG Z (AC 20000 rounds down to 19456)."""
    rig = Rig()
    rig.download("#A\nAC 20000,,20000\nDC 20000,,20000\nJG 50000,,-25000\nBG X\nAS X\nBG Z\nEN")
    rig.send(b"XQ #A\r")
    z = _started(rig, "Z")
    assert z == pytest.approx(50000 / 19456 * 1000, abs=4)  # BG at the next sample, AS polled
    assert rig.value("_TVX") >= 0  # X keeps jogging
    assert rig.value("_BGX") == 1


def test_ch6_joystick_jogging_follows_the_analog_input() -> None:
    """[M Ch6 §Example - Joystick Jogging]: 10 V is 50000 counts/s."""
    rig = Rig()
    rig.download("#JOY\nJG0\nBGX\n#B\nV1 =@AN[1]\nVEL=V1*50000/10\nJG VEL\nJP #B")
    rig.fw.analog[0] = 5.0
    rig.send(b"XQ #JOY\r")
    rig.samples(200)
    assert rig.value("_JGX") == pytest.approx(25000, abs=2)
    rig.fw.analog[0] = -2.0
    rig.samples(50)
    assert rig.value("_JGX") == pytest.approx(-10000, abs=2)
    assert rig.send(b"ST\r") == b":"
    assert not rig.fw.threads.active


#: [M Ch6 §SPM, Example: Error Correction], one statement per line as the listing's comments
#: show them; without `KS16`, outside KS's range 0.5-8 (spec §1.3), which the card refuses
SPM_EXAMPLE = """#SETUP
OE1; 'SET THE PROFILER TO STOP AXIS UPON ERROR
MT-2,-2,-2,-2; 'MOTOR TYPE SET TO STEPPER
YA2; 'STEP RESOLUTION OF THE DRIVE
YB200; 'MOTOR RESOLUTION (FULL STEPS PER REVOLUTION)
YC4000; 'ENCODER RESOLUTION (COUNTS PER REVOLUTION)
SHX; 'ENABLE AXIS
WT100; 'ALLOW SLIGHT SETTLE TIME
YS1; 'ENABLE SPM MODE
#MOTION 'PERFORM MOTION
SP512; 'SET THE SPEED
PR1000; 'PREPARE MODE OF MOTION
BGX; 'BEGIN MOTION
#LOOP;JP#LOOP; 'KEEP THREAD ZERO ALIVE FOR #POSERR TO RUN IN
#POSERR; 'AUTOMATIC SUBROUTINE IS CALLED WHEN YS=2
WT100; 'WAIT HELPS USER SEE THE CORRECTION
spsave=_SPX; 'SAVE CURRENT SPEED SETTING
JP#RETURN,_YSX<>2;'RETURN TO THREAD ZERO IF INVALID ERROR
SP64; 'SET SLOW SPEED SETTING FOR CORRECTION
MG"ERROR= ",_QSX
YRX=_QSX; 'ELSE, ERROR IS VALID, USE QS FOR CORRECTION
MCX; 'WAIT FOR MOTION TO COMPLETE
MG"CORRECTED, ERROR NOW= ",_QSX
WT100; 'WAIT HELPS USER SEE THE CORRECTION
#RETURN
SPX=spsave; 'RETURN THE SPEED TO PREVIOUS SETTING
RE0; 'RETURN FROM #POSERR"""


def test_ch6_spm_error_correction_runs_poserr_when_ys_becomes_2() -> None:
    rig = Rig("stepper")
    rig.fw.motion.core.set_encoder_scale(0, 10.0)  # 4000 counts per 400 pulses (YA 2 x YB 200)
    assert rig.download(SPM_EXAMPLE) == b":"
    rig.send(b"XQ #SETUP\r")
    rig.samples(400)
    assert rig.value("_YSX") == 1
    rig.fw.motion.core.slip_encoder(0, 100)  # 10 pulses: over three full steps
    out = rig.samples(3000).decode()
    assert out.startswith("ERROR=  0000000010.0000\r\nCORRECTED, ERROR NOW=  0000000000.0000")
    assert rig.value("_YSX") == 1
    assert rig.value("_SPX") == 512  # #RETURN restored the speed
    assert rig.fw.threads.threads[0] is not None and not rig.fw.threads.threads[0].stack  # RE0
