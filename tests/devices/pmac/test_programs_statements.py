"""Motion-program statements beyond moves, without sockets: SEND/SENDS/SENDP, BLOCKSTART/BLOCKSTOP,
PAUSE PLC/RESUME PLC (on-line, in PLCs and in programs), move until trigger `{axis}{data}^{data}`
[Turbo SRM SEND, BLOCKSTART, BLOCKSTOP, PAUSE PLC, RESUME PLC, "{axis}{data}^{data}"; UM
"Move-Until-Trigger"; README "Motion programs", "PLCs"]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_jog_trigger import TRIGGER_MOVE, flags, run_until
from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_programs import cs_words, download, running, xy

RUNTIME_ERROR = 1 << 22


@pytest.fixture
def card() -> Card:
    """As test_programs.py's: motors 1 and 2 as X and Y at 1000 counts per unit, ideal plant;
    motor 1 captures on its home flag (I7012 = 2) as test_jog_trigger.py's."""
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->1000X &1#2->1000Y #1J/#2J/")
    c.ask("I116=1000 I216=1000 I117=100 I217=100")
    c.ask("I7012=2 I7013=0 M173->Y:$0000CE,0,24,S")
    return c


def plc(card: Card, n: int, *lines: str) -> None:
    assert card.ask(f"OPEN PLC {n} CLEAR") == ""
    for line in lines:
        assert card.raw(line) == b"\x06", line
    assert card.raw("CLOSE") == b"\x06"


# -- SEND ---------------------------------------------------------------------------------------------
def test_send_and_sendp_from_a_program_post_when_calculated(card: Card) -> None:
    """A program's SEND goes out as a PLC's does (to the response port "", SENDP to the host
    port "P", SENDS to the serial port "S") when the calculation reaches it: the SEND after
    the first move is calculated at R (the look-ahead), the one after the DWELL only once the
    dwell is over [UM "When No Calculation Ahead"]."""
    got: list[tuple[str, str]] = []
    card.fw.plc.on_message = lambda port, text: got.append((port, text)) is None
    download(card, 2, "LINEAR ABS TA100 TS0 F10", "X1", 'SEND"AT ONE"', "DWELL200",
             'SENDP"DONE" SENDS"SERIAL"')
    card.ask("&1B2R")
    card.tick()
    assert got == [("", "AT ONE")]
    card.tick(int(0.25 / 442.71e-6))   # the move takes 0.2 s; the dwell to 0.4 s
    assert got == [("", "AT ONE")]
    card.tick(int(0.2 / 442.71e-6))
    assert got == [("", "AT ONE"), ("P", "DONE"), ("S", "SERIAL")]


def test_a_full_message_queue_holds_the_calculation(card: Card) -> None:
    """No port takes the messages: the 65th SEND waits (plc.py MESSAGE_QUEUE = 64), and the
    statement after it is not calculated."""
    card.fw.plc.on_message = lambda port, text: False
    download(card, 2, "P1=0", "WHILE (P1 < 70)", 'SEND"M"', "P1=P1+1", "ENDWHILE", "P2=1")
    card.ask("&1B2R")
    card.tick(200)
    assert card.fw.p[1] == 64 and card.fw.p[2] == 0
    assert running(card)
    card.fw.plc.on_message = lambda port, text: True
    card.tick(200)
    assert card.fw.p[1] == 70 and card.fw.p[2] == 1


# -- BLOCKSTART / BLOCKSTOP ---------------------------------------------------------------------------
def test_one_step_runs_the_whole_block(card: Card) -> None:
    """S runs one move; between BLOCKSTART and BLOCKSTOP it runs all of them [SRM BLOCKSTART]."""
    download(card, 3, "LINEAR INC TA100 TS0 F10", "X1", "BLOCKSTART", "X1", "X1", "BLOCKSTOP",
             "X1", "X1")
    card.ask("&1B3S")
    card.tick(int(1.0 / 442.71e-6))
    assert not running(card) and xy(card)[0] == 1000.0
    card.ask("&1S")
    card.tick(int(1.0 / 442.71e-6))
    assert not running(card) and xy(card)[0] == 3000.0
    card.ask("&1S")
    card.tick(int(1.0 / 442.71e-6))
    assert not running(card) and xy(card)[0] == 4000.0


def test_r_runs_through_a_block_as_through_any_lines(card: Card) -> None:
    download(card, 3, "LINEAR INC TA100 TS0 F10", "BLOCKSTART", "X1", "BLOCKSTOP", "X1")
    card.ask("&1B3R")
    card.tick(int(1.0 / 442.71e-6))
    assert not running(card) and xy(card)[0] == 2000.0


# -- PAUSE PLC / RESUME PLC ---------------------------------------------------------------------------
def test_a_paused_plc_resumes_where_it_stopped_and_enable_restarts_it(card: Card) -> None:
    """PLC 2 pauses itself after P1=P1+1: RESUME goes on with P2=P2+1 (then from the top, to the
    PAUSE again); ENABLE starts it from the top [SRM PAUSE PLC, RESUME PLC, ENABLE PLC]."""
    plc(card, 2, "P1=P1+1", "PAUSE PLC 2", "P2=P2+1")
    card.ask("ENABLE PLC 2")
    card.tick(30)
    assert (card.fw.p[1], card.fw.p[2]) == (1, 0)
    card.ask("RESUME PLC 2")
    card.tick(30)
    assert (card.fw.p[1], card.fw.p[2]) == (2, 1)
    card.ask("ENABLE PLC 2")
    card.tick(30)
    assert (card.fw.p[1], card.fw.p[2]) == (3, 1)


def test_pause_and_resume_on_line_and_from_a_motion_program(card: Card) -> None:
    plc(card, 3, "P3=P3+1")
    card.ask("ENABLE PLC 3")
    card.tick(30)
    assert card.fw.p[3] > 0
    card.ask("PAUSE PLC 3")
    held = card.fw.p[3]
    card.tick(30)
    assert card.fw.p[3] == held
    card.ask("RESUME PLC 3")
    card.tick(30)
    assert card.fw.p[3] > held
    download(card, 4, "PAUSE PLC 3", "DWELL100", "P5=P3", "RESUME PLC 3")
    card.ask("&1B4R")
    card.tick(5)
    held = card.fw.p[3]
    card.tick(int(0.15 / 442.71e-6))
    assert card.fw.p[5] == held
    card.tick(30)
    assert card.fw.p[3] > held


def test_pause_plc_checks_its_numbers(card: Card) -> None:
    assert card.raw("PAUSE PLC 32") == b"\x07ERR003\r"
    assert card.raw("OPEN PROG 4 CLEAR") == b"\x06"
    assert card.raw("RESUME PLC 40") == b"\x07ERR003\r"
    assert card.raw("CLOSE") == b"\x06"


# -- move until trigger ----------------------------------------------------------------------------------
def test_move_until_trigger_ends_at_the_trigger_plus_the_distance(card: Card) -> None:
    """X10^-0.05: motor 1 moves toward X = 10 (10000 counts) and, at its home-flag trigger,
    ends 50 counts back from it (−0.05 units × 1000); the program goes on from there (X: 1
    more, INC) [SRM "{axis}{data}^{data}"]."""
    download(card, 5, "RAPID ABS X10^-0.05", "INC LINEAR TA100 TS0 F10 X1")
    card.ask("&1B5R")
    card.tick(20)
    assert int(card.ask("#1?")[6:], 16) & TRIGGER_MOVE
    run_until(card, lambda: xy(card)[0] >= 2000)
    flags(card, home=True)
    trigger = int(card.ask("M173"))
    assert 2000 <= trigger < 2100
    run_until(card, lambda: not running(card))
    assert xy(card)[0] == trigger - 50 + 1000
    assert not cs_words(card)[1] & RUNTIME_ERROR


def test_move_until_trigger_without_a_trigger_ends_at_the_end_point(card: Card) -> None:
    download(card, 5, "X1.5^0")
    card.ask("&1B5R")
    run_until(card, lambda: not running(card))
    assert xy(card) == (1500.0, 0.0)
    assert int(card.ask("#1?")[6:], 16) & TRIGGER_MOVE   # no trigger came


def test_move_until_trigger_takes_a_distance_for_each_axis(card: Card) -> None:
    assert card.raw("OPEN PROG 5 CLEAR") == b"\x06"
    assert card.raw("X1^0 Y1") == b"\x07ERR003\r"
    assert card.raw("X1^0 Y1^0") == b"\x06"
    assert card.raw("CLOSE") == b"\x06"
