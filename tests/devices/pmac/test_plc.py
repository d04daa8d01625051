"""PLC programs without sockets: OPEN PLC / CLOSE / CLEAR / LIST PLC, ENABLE/DISABLE PLC, ^D, I5
gating, scans every I8+1 servo cycles, IF/ELSE/ENDIF, WHILE/ENDWHILE, CMD"..." [spec pmac.md
§2.9; A L3234 (V1.936 ports), A L3235 (ERR009); README "PLCs"]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_cycle_runs import Twin
from tests.devices.pmac.test_online import Card
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.plc import CMD_QUEUE


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    return c


def download(card: Card, n: int, *lines: str) -> None:
    card.ask(f"OPEN PLC {n} CLEAR")
    for line in lines:
        card.ask(line)
    card.ask("CLOSE")


def p(card: Card, n: int) -> float:
    return float(card.fw.p[n])


# -- buffers ------------------------------------------------------------------------------------
def test_lines_go_into_the_open_buffer_and_list_back(card: Card) -> None:
    download(card, 3, "P1=P1+1", "if (p2 > 0)", "  P3 = 1", "End If")
    assert card.ask("LIST PLC 3") == "P1=P1+1\rIF (P2 > 0)\rP3 = 1\rEND IF"
    assert card.ask("LIST PLC 3,1,2") == "IF (P2 > 0)\rP3 = 1"
    assert p(card, 1) == 0  # stored, not executed


def test_an_unknown_statement_answers_err003_and_is_not_stored(card: Card) -> None:
    card.ask("OPEN PLC 1 CLEAR")
    assert card.raw("P1=P1+1") == b"\x06"
    assert card.raw("#1J+") == b"\x07ERR003\r"
    assert card.raw("P2=(3") == b"\x07ERR003\r"
    card.ask("CLOSE")
    assert card.ask("LIST PLC 1") == "P1=P1+1"


def test_close_with_an_unmatched_if_or_while_is_err009(card: Card) -> None:
    """[A L3235]: CLOSE of a buffer missing ENDIF/ENDWHILE reports ERR009."""
    card.ask("OPEN PLC 1 CLEAR")
    card.ask("WHILE (P1 < 5)")
    card.ask("IF (P2 = 1)")
    card.ask("ENDIF")
    assert card.raw("CLOSE") == b"\x07ERR009\r"
    card.ask("ENABLE PLC 1")
    card.tick(10)
    assert card.fw.plc.running is False  # a badly structured PLC does not run


def test_keywords_are_case_and_space_insensitive(card: Card) -> None:
    download(card, 1, "While (P1 < 3)", "P1 = P1 + 1", "End While", "if (P1 = 3)", "p2=7",
             "ELSE", "p2=8", "Endif")
    card.ask("ENABLE PLC 1")
    card.tick(3 * 10)
    assert (p(card, 1), p(card, 2)) == (3, 7)


def test_only_the_opening_port_enters_lines_other_ports_run_on_line(card: Card) -> None:
    """V1.936 [A L3234]: other ports keep running on-line commands; OPEN from them is refused."""
    other = PortState()
    card.ask("OPEN PLC 2")
    assert card.fw.execute(other, "P5=9").error is None
    assert p(card, 5) == 9
    assert card.fw.execute(other, "OPEN PLC 4").error == 7
    assert card.fw.execute(other, "CLOSE").error == 5
    card.ask("P5=1")   # into the buffer
    assert p(card, 5) == 9
    card.ask("CLOSE")
    assert card.ask("LIST PLC 2") == "P5=1"


def test_open_from_the_same_port_closes_the_first_buffer_and_list_plc_n_reads_any(
        card: Card) -> None:
    card.ask("OPEN PLC 1 CLEAR P1=P1+1")
    card.ask("OPEN PLC 2 CLEAR")
    card.ask("P2=P2+1")
    assert card.ask("LIST PLC 1") == "P1=P1+1"
    assert card.ask("LIST") == "P2=P2+1"
    card.ask("CLOSE ENABLE PLC 1,2")  # the rest of the CLOSE line runs on-line
    card.tick(int(card.fw.ivars[8]) + 1)
    assert (p(card, 1), p(card, 2)) == (1, 1)


def test_a_port_that_goes_away_releases_its_open_buffer(card: Card) -> None:
    gone = PortState()
    assert card.fw.execute(gone, "OPEN PLC 4 CLEAR P4=P4+1").error is None
    assert card.raw("OPEN PLC 1") == b"\x07ERR007\r"
    card.fw.plc.release(gone)
    card.ask("OPEN PLC 1 CLEAR CLOSE ENABLE PLC 4")
    card.tick(int(card.fw.ivars[8]) + 1)
    assert p(card, 4) == 1


def test_buffer_size_is_bounded(card: Card) -> None:
    from vdevd.devices.pmac.buffers import MAX_LINES
    card.ask("OPEN PLC 1 CLEAR")
    for _ in range(MAX_LINES):
        card.ask("P1=1")
    assert card.raw("P1=1") == b"\x07ERR006\r"
    card.ask("CLOSE")


def test_open_plc_number_out_of_range_and_open_prog_are_refused(card: Card) -> None:
    assert card.raw("OPEN PLC 32") == b"\x07ERR003\r"
    assert card.raw("OPEN PROG 32768") == b"\x07ERR003\r"  # PROG 1-32767 [SRM OPEN PROGRAM]
    assert card.raw("ENABLE PLC 40") == b"\x07ERR003\r"


# -- scans ----------------------------------------------------------------------------------------
def test_background_plc_increments_every_i8_plus_1_servo_cycles(card: Card) -> None:
    """PLC 1-31 scan once per background cycle, here every I8+1 servo cycles (README)."""
    download(card, 1, "P1=P1+1")
    card.tick(30)
    assert p(card, 1) == 0  # CLOSE leaves it disabled
    card.ask("ENABLE PLC 1")
    i8 = int(card.fw.ivars[8])
    card.tick(30 * (i8 + 1))
    assert p(card, 1) == 30
    card.ask("DISABLE PLC 1")
    card.tick(30)
    assert p(card, 1) == 30


def test_i5_gates_foreground_and_background(card: Card) -> None:
    download(card, 0, "P10=P10+1")
    download(card, 1, "P11=P11+1")
    card.ask("ENABLE PLC 0,1")
    period = int(card.fw.ivars[8]) + 1
    expected = {0: (0, 0), 1: (1, 0), 2: (0, 1), 3: (1, 1)}
    for i5, (fg, bg) in expected.items():
        card.fw.p[10:12] = 0
        card.ask(f"I5={i5}")
        card.tick(period)
        assert (p(card, 10), p(card, 11)) == (fg, bg), i5


def test_control_d_disables_every_plc(card: Card) -> None:
    download(card, 1, "P1=P1+1")
    download(card, 2, "P2=P2+1")
    card.ask("ENABLE PLC 1,2")
    assert card.fw.plc.running
    card.fw.control(card.port, 0x04)
    assert not card.fw.plc.running
    card.tick(20)
    assert (p(card, 1), p(card, 2)) == (0, 0)


def test_an_infinite_while_loop_ends_each_scan_and_the_card_keeps_answering(card: Card) -> None:
    download(card, 1, "WHILE (1 = 1)", "P1=P1+1", "ENDWHILE", "P2=1")
    card.ask("ENABLE PLC 1")
    period = int(card.fw.ivars[8]) + 1
    card.tick(100 * period)
    assert p(card, 1) == 100  # one pass per scan
    assert p(card, 2) == 0
    assert card.ask("P1") == "100"


def test_while_resumes_at_its_condition_and_the_program_then_restarts(card: Card) -> None:
    download(card, 1, "WHILE (P1 < 3)", "P1=P1+1", "ENDWHILE", "P2=P2+1")
    card.ask("ENABLE PLC 1")
    period = int(card.fw.ivars[8]) + 1
    card.tick(3 * period)
    assert (p(card, 1), p(card, 2)) == (3, 0)
    card.tick(period)  # the WHILE is false: on to P2 and the end
    assert p(card, 2) == 1


def test_and_or_conditions_and_single_line_if(card: Card) -> None:
    download(card, 1, "IF (P1 > 1 AND P1 < 5 OR P1 = 9) P2=P2+1", "IF ((P1 !< 5) AND (P1 != 9)) P3=P3+1")
    card.ask("ENABLE PLC 1")
    period = int(card.fw.ivars[8]) + 1
    for v in (0, 2, 5, 9):
        card.fw.p[1] = v
        card.tick(period)
    assert (p(card, 2), p(card, 3)) == (2, 1)


def test_single_line_while_runs_one_pass_per_scan(card: Card) -> None:
    download(card, 1, "WHILE (P1 < 4) P1=P1+1", "P2=P2+1")
    card.ask("ENABLE PLC 1")
    period = int(card.fw.ivars[8]) + 1
    card.tick(4 * period)
    assert (p(card, 1), p(card, 2)) == (4, 0)
    card.tick(period)
    assert (p(card, 1), p(card, 2)) == (4, 1)


def test_a_condition_continues_on_and_or_lines(card: Card) -> None:
    """`IF (a)` then `AND (b)` / `OR (c)` lines extend the condition, each joining all before it."""
    download(card, 1, "IF (P1 > 1)", "AND (P1 < 5)", "OR (P1 = 9)", "P2=P2+1", "ENDIF")
    card.ask("ENABLE PLC 1")
    period = int(card.fw.ivars[8]) + 1
    for v in (0, 2, 5, 9):
        card.fw.p[1] = v
        card.tick(period)
    assert p(card, 2) == 2


def test_and_line_not_after_an_if_is_a_structure_error(card: Card) -> None:
    card.ask("OPEN PLC 1 CLEAR")
    card.ask("P1=1")
    card.ask("AND (P1 = 1)")
    assert card.raw("CLOSE") == b"\x07ERR009\r"


def test_cmd_from_a_plc_jogs_a_motor_with_no_reply(card: Card) -> None:
    card.ask("#1J/")
    download(card, 5, "ADDRESS #2", "CMD\"J=1000\"", "DISABLE PLC 5")
    card.ask("ENABLE PLC 5")
    card.tick(4000)
    assert card.ask("#2P") == "1000"
    assert not card.fw.plc.running


def test_cmd_queue_is_bounded_a_plc_waits_for_room(card: Card) -> None:
    download(card, 1, *([f"CMD\"P{k}=P{k}+1\"" for k in range(1, CMD_QUEUE + 10)]))
    card.ask("ENABLE PLC 1")
    card.tick(int(card.fw.ivars[8]) + 1)
    assert p(card, CMD_QUEUE) == 1 and p(card, CMD_QUEUE + 1) == 0  # waits at the full queue


def test_enable_and_disable_from_a_plc(card: Card) -> None:
    download(card, 2, "P2=P2+1")
    download(card, 1, "IF (P1 = 0)", "ENABLE PLC 2", "P1=1", "ELSE", "DISABLE PLC 2", "ENDIF")
    card.ask("ENABLE PLC 1")
    period = int(card.fw.ivars[8]) + 1
    card.tick(period)
    assert card.fw.plc.plcs[2].enabled
    card.tick(period)
    assert not card.fw.plc.plcs[2].enabled


def test_a_running_plc_keeps_the_card_out_of_rest(card: Card) -> None:
    download(card, 1, "P1=P1+1")
    assert not card.fw.plc.running
    card.ask("ENABLE PLC 1")
    assert card.fw.plc.running


# -- the addendum's PLC examples [spec §2.9] -----------------------------------------------------------
def test_time_base_arming_plc_rewrites_the_method_digit(card: Card) -> None:
    """[A L2908-2927]: PLC `IF (I8008=$9F8018) I8008=$BF8018`."""
    download(card, 1, "IF (I8008=$9F8018) I8008=$BF8018")
    card.ask("I8008=$9F8018")
    card.ask("ENABLE PLC 1")
    card.tick(int(card.fw.ivars[8]) + 1)
    assert card.ask("I8008") == "$BF8018"


def test_compare_array_plc_walks_the_array(card: Card) -> None:
    """[A L720-748]: the repeatedly executed part walks P1..P50 while M116 reads 1 (here an
    M-variable pointed at a P-variable stands in for the compare flag)."""
    card.ask("M116->L:$006C80")   # P3200 stands in for the compare-status flag
    card.ask("M103->L:$006C81")   # P3201 for the compare register
    card.ask("M111->L:$006C82")
    for k in range(1, 51):
        card.fw.p[k] = 10.0 * k
    card.ask("P100=1 P101=0 P3200=1")
    download(card, 1, "WHILE (P100<51) ; Loop until 50 points completed",
             "IF (M116=1)   ; Reached last compare position?", "P100=P100+1",
             "M103=P101+P(P100)", "M111=0", "M111=1", "ENDIF", "ENDWHILE")
    card.ask("ENABLE PLC 1")
    card.tick(60 * (int(card.fw.ivars[8]) + 1))
    assert p(card, 100) == 51
    assert p(card, 3202) == 1


def test_jio_reset_plc_sets_the_output_directions_once(card: Card) -> None:
    """[A L543]: I/O00-31 are inputs at power-up; 'usually PLC 1 acting as a reset PLC, scanning
    through once' makes the outputs (M32 byte direction, M33 buffer direction) and disables
    itself."""
    card.ask("M32->X:$078400,0,8 M33->Y:$070800,0")
    download(card, 1, "M32=255", "M33=1", "P1=P1+1", "DISABLE PLC 1")
    card.ask("ENABLE PLC 1")
    card.tick(10 * (int(card.fw.ivars[8]) + 1))
    mem = card.fw.memory
    assert mem.read("X", 0x078400) & 0xFF == 0xFF and mem.read("Y", 0x070800) & 1
    assert p(card, 1) == 1  # one scan
    assert not card.fw.plc.running


def test_save_keeps_plcs_and_power_on_reset_starts_every_plc_with_a_program(card: Card) -> None:
    download(card, 2, "P2=P2+1")
    card.raw("$$$")
    card.raw("I3=2")
    assert card.ask("LIST PLC 2") == ""  # not saved: gone
    download(card, 1, "P1=P1+1")
    card.ask("SAVE")
    card.raw("$$$")
    card.raw("I3=2")
    card.tick(int(card.fw.ivars[8]) + 1)
    assert p(card, 1) == 1
    card.raw("$$$***")
    card.raw("I3=2")
    assert card.ask("LIST PLC 1") == ""


def test_a_card_with_a_plc_is_not_at_rest_and_batches_run_it_as_one_by_one() -> None:
    """Decision 0008: a scanning PLC is work; batched cycles count as cycles one by one."""
    twin = Twin(True, "servo")
    twin.send("OPEN PLC 1 CLEAR")
    twin.send("P1=P1+1")
    twin.send("IF (P1 > 50) CMD\"#1J=200\"")
    twin.send("CLOSE")
    for c in twin.cards:
        assert c.rest_state() is not None
    twin.send("ENABLE PLC 1")
    for c in twin.cards:
        assert c.rest_state() is None
    for n in [1, 2, 3, 5, 64, 200, 400]:
        twin.tick(n)
        twin.same()
    assert twin.cards[0].fw.p[1] == twin.cards[1].fw.p[1] > 50
    twin.send("DISABLE PLC 1")
    twin.tick(3000)
    for c in twin.cards:
        assert c.rest_state() is not None
