"""Compiled PLCs (PLCC 0-31) and PLCs that never end, without sockets [spec pmac.md §2.9, §2.1
X:$000006 bit 15; A L978-1002 (compiled-PLC arithmetic); README "PLCs"].

`OPEN PLCC n` takes the text a PLC takes (README assumption: the card compiles it, where PEWIN
would compile on the host); PLCC 0 scans in the foreground with PLC 0 (I5 bit 0), PLCC 1-31 in
the background with PLC 1-31 (I5 bit 1); `ENABLE PLCC`/`DISABLE PLCC` on-line and in programs;
a compiled PLC holds machine code, so `LIST PLCC` has nothing to list (ERR003).
"""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card

WATCHDOG = 1 << 15  # global status word 1 bit 15 [§2.1 X:$000006]


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    return c


def compiled(card: Card, n: int, *lines: str) -> None:
    card.ask(f"OPEN PLCC {n} CLEAR")
    for line in lines:
        card.ask(line)
    card.ask("CLOSE")


def p(card: Card, n: int) -> float:
    return float(card.fw.p[n])


def scans(card: Card, k: int) -> None:
    card.tick(k * (int(card.fw.ivars[8]) + 1))


def test_a_compiled_plc_runs_its_text_once_per_background_cycle(card: Card) -> None:
    compiled(card, 3, "P10=P10+1", "IF (P10 > 4)", "P10=0", "ENDIF")
    scans(card, 3)
    assert p(card, 10) == 0  # CLOSE leaves it disabled
    card.ask("ENABLE PLCC 3")
    scans(card, 3)
    assert p(card, 10) == 3
    scans(card, 2)
    assert p(card, 10) == 0
    card.ask("DISABLE PLCC 3")
    scans(card, 3)
    assert p(card, 10) == 0


def test_plcc_n_and_plc_n_are_separate_programs(card: Card) -> None:
    card.ask("OPEN PLC 3 CLEAR")
    card.ask("P1=P1+1")
    card.ask("CLOSE")
    compiled(card, 3, "P2=P2+10")
    assert card.ask("LIST PLC 3") == "P1=P1+1"
    card.ask("ENABLE PLC 3 ENABLE PLCC 3")
    scans(card, 2)
    assert (p(card, 1), p(card, 2)) == (2, 20)
    card.ask("DISABLE PLC 3")
    scans(card, 1)
    assert (p(card, 1), p(card, 2)) == (2, 30)


def test_i5_gates_plcc_0_with_the_foreground_and_plcc_1_31_with_the_background(card: Card) -> None:
    compiled(card, 0, "P1=P1+1")
    compiled(card, 1, "P2=P2+1")
    card.ask("ENABLE PLCC 0,1")
    for i5, expect in ((0, (0, 0)), (1, (1, 0)), (2, (0, 1)), (3, (1, 1))):
        card.fw.p[1] = card.fw.p[2] = 0
        card.ask(f"I5={i5}")
        scans(card, 1)
        assert (p(card, 1), p(card, 2)) == expect, i5


def test_compiled_plcs_cannot_be_listed(card: Card) -> None:
    compiled(card, 2, "P1=1")
    assert card.raw("LIST PLCC 2") == b"\x07ERR003\r"
    assert card.raw("OPEN PLCC 32") == b"\x07ERR003\r"
    assert card.raw("ENABLE PLCC 32") == b"\x07ERR003\r"


def test_plcs_enable_and_disable_compiled_plcs(card: Card) -> None:
    compiled(card, 5, "P5=P5+1")
    card.ask("OPEN PLC 6 CLEAR")
    card.ask("IF (P5 = 0) ENABLE PLCC 5")
    card.ask("IF (P5 > 2) DISABLE PLCC 5")
    card.ask("CLOSE ENABLE PLC 6")
    scans(card, 10)
    assert p(card, 5) == 3


def test_ctrl_d_save_and_reset_take_the_compiled_plcs_too(card: Card) -> None:
    compiled(card, 4, "P4=P4+1")
    card.ask("ENABLE PLCC 4")
    card.fw.control(card.port, 0x04)  # ^D
    scans(card, 2)
    assert p(card, 4) == 0
    card.ask("SAVE")
    card.raw("$$$")
    card.raw("I3=2")
    scans(card, 2)
    assert p(card, 4) == 2  # $$$ starts every PLC with a program, compiled ones too
    card.raw("$$$***")
    card.raw("I3=2")
    card.fw.p[4] = 0
    card.ask("ENABLE PLCC 4")
    scans(card, 2)
    assert p(card, 4) == 0


@pytest.mark.parametrize("kind", ["PLC", "PLCC"])
def test_a_plc_that_loops_forever_never_holds_the_card(card: Card, kind: str) -> None:
    """A WHILE that never ends, in the foreground program (PLC 0 / PLCC 0, the real-time
    interrupt, where a real card's time runs out first): each scan ends at the ENDWHILE, so the
    card keeps serving the host, runs its motors and its other PLCs, and the watchdog (global
    status bit 15, which shuts a real card down when the background starves) stays clear."""
    card.ask(f"OPEN {kind} 0 CLEAR")
    card.ask("WHILE (1 = 1)")
    card.ask("P1=P1+1")
    card.ask("ENDWHILE")
    card.ask("CLOSE")
    card.ask("OPEN PLC 1 CLEAR P2=P2+1 CLOSE")
    card.ask(f"I5=3 ENABLE {kind} 0 ENABLE PLC 1 #1J/ #1J=500")
    scans(card, 1000)
    assert p(card, 1) == 1000 and p(card, 2) == 1000  # one loop pass a scan, PLC 1 goes on
    assert card.ask("#1P") == "500"  # the motors ran
    assert int(card.ask("???")[:6], 16) & WATCHDOG == 0
    assert card.ask("P1") == "1000"  # the host is served between scans
    card.ask(f"DISABLE {kind} 0")
    scans(card, 3)
    assert p(card, 1) == 1000


def test_send_statements_are_plc_statements_and_without_a_host_go_nowhere(card: Card) -> None:
    """SEND/SENDS/SENDP "text" (case- and space-insensitive); a firmware with no port behind it
    drops them, so the PLC never waits; DISPLAY (the display port) is not emulated: ERR003."""
    card.ask("OPEN PLC 1 CLEAR")
    card.ask('send"A" SendS "B"')
    card.ask('SEND P"C" P1=P1+1')
    assert card.raw('DISPLAY 0 "X"') == b"\x07ERR003\r"
    assert card.raw("SEND X") == b"\x07ERR003\r"
    card.ask("CLOSE ENABLE PLC 1")
    scans(card, 200)
    assert p(card, 1) == 200
    assert not card.fw.plc.messages


def test_what_homing_plcs_do_timer_waits_i_variable_writes_cmd_and_disable(card: Card) -> None:
    """pmac_motorhome's constructs in one PLC: a C.S. countdown timer set in milliseconds
    (`* 8388608/I10`, servo cycles) and waited on, I-variable writes, CMD"#1HMZ" and the PLC
    disabling itself [§2.8 Isx11; SRM p.424]."""
    card.ask("M145->Y:$0000C0,10 #1J/")
    card.ask("OPEN PLC 1 CLEAR")
    card.ask("I5111 = 20 * 8388608/I10")
    card.ask("WHILE (I5111 > 0)")
    card.ask("ENDWHILE")
    card.ask('P2 = 1 I122 = 16 CMD"#1HMZ"')
    card.ask("DISABLE PLC 1")
    card.ask("CLOSE ENABLE PLC 1")
    card.tick(42)  # 20 ms = 45.2 servo cycles
    assert p(card, 2) == 0 and card.ask("M145") == "0"
    card.tick(9)
    assert p(card, 2) == 1 and card.ask("M145") == "1" and card.ask("I122") == "16"
    assert not card.fw.plc.running
