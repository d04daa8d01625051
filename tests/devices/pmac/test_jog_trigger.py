"""Jog-until-trigger (`{jog}^{c}`) and what homing PLCs read of it, without sockets [spec
pmac.md §2.5 `{jog}^{c}`, §2.6, §2.7; UM "Jog-until-trigger"; PMAC1-SRM p.241; SRM Ixx97].

The definite jogs J=, J={c}, J:{c}, J^{c} and their Mxx72 forms J=*, J:*, J^* take `^{c}`: the
move ends at the trigger + c counts if the trigger (the home search's: I7mn2/I7mn3 on the Ixx25
channel, or with Ixx97 bit 1 the warning following error) comes first, else at its end point;
the zero position stays. Home search in progress (word 1 bit 10) is set until the trigger or
the end; trigger move (word 2 bit 7) from the start to the end of the post-trigger move, left set
when no trigger came.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_online import Card

HOME_SEARCH = 1 << 10  # word 1
TRIGGER_MOVE, HOME_COMPLETE, STOPPED_ON_LIMIT = 1 << 7, 1 << 10, 1 << 11  # word 2


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.ask("M173->Y:$0000CE,0,24,S M172->L:$0000D7 M162->D:$00008B")
    c.ask("M130->Y:$0000C0,11 M145->Y:$0000C0,10 M147->Y:$0000C0,7")
    c.ask("I7012=2 I7013=0 #1J/")  # capture on HMFL1 high
    return c


def words(card: Card, motor: int = 1) -> tuple[int, int]:
    reply = card.ask(f"#{motor}?")
    return int(reply[:6], 16), int(reply[6:], 16)


def position(card: Card, motor: int = 1) -> float:
    return float(card.ask(f"#{motor}P"))


def flags(card: Card, home: bool = False, plim: bool = False, mlim: bool = False) -> None:
    """Motor 1's flag inputs as the axis world would set them."""
    mo = card.fw.motors
    level = np.zeros(mo.n, dtype=bool)
    hmfl, pl, ml = level.copy(), level.copy(), level.copy()
    hmfl[0], pl[0], ml[0] = home, plim, mlim
    mo.apply_inputs(pl, ml, hmfl, level.copy())


def run_until(card: Card, done: object, limit: int = 20000) -> None:
    for _ in range(limit):
        if done():  # type: ignore[operator]
            return
        card.tick()
    raise AssertionError("never happened")


def test_the_trigger_ends_the_move_at_trigger_plus_the_distance(card: Card) -> None:
    card.ask("#1J=10000^-50")
    card.tick(20)
    w1, w2 = words(card)
    assert w1 & HOME_SEARCH and w2 & TRIGGER_MOVE
    run_until(card, lambda: position(card) >= 2000)
    flags(card, home=True)
    trigger = int(card.ask("M173"))
    assert 2000 <= trigger < 2100
    w1, w2 = words(card)
    assert not w1 & HOME_SEARCH and w2 & TRIGGER_MOVE  # found; the post-trigger move runs
    card.tick(5000)
    assert position(card) == trigger - 50
    w1, w2 = words(card)
    assert not w2 & (TRIGGER_MOVE | HOME_COMPLETE)  # found: cleared at the end; zero unchanged
    assert card.ask("M147") == "0"


def test_without_a_trigger_the_move_ends_at_its_end_point_and_trigger_move_stays(card: Card) -> None:
    card.ask("#1J:1500^0")
    card.tick(5000)
    assert position(card) == 1500
    w1, w2 = words(card)
    assert not w1 & HOME_SEARCH
    assert w2 & TRIGGER_MOVE  # the host can tell the trigger was not found
    card.ask("#1J:100")  # the next move clears it
    assert not words(card)[1] & TRIGGER_MOVE


def test_the_mxx72_forms_and_a_trigger_already_true_at_the_start(card: Card) -> None:
    """J^*^{c}: Mxx72 counts from the actual position, what pmac_motorhome sends; a condition
    true when the move starts triggers at once (level-sensitive capture, as HM)."""
    card.ask("#1J=1000")
    card.tick(3000)
    flags(card, home=True)
    card.ask("M172=-100000000 #1J^*^250")
    card.tick(3000)
    assert position(card) == 1000 + 250
    assert int(card.ask("M173")) == 1000
    card.ask("I7012=14")  # HMFL low: ^$C as the PLCs invert it
    card.ask("M172=-5000 #1J^*^0")
    run_until(card, lambda: position(card) < 0)
    flags(card, home=False)
    card.tick(3000)
    assert position(card) == int(card.ask("M173"))


def test_j_equals_caret_returns_to_the_pre_jog_position_until_the_trigger(card: Card) -> None:
    card.ask("#1J=2000")
    card.tick(3000)
    card.ask("#1J:-1000")
    card.tick(3000)
    card.ask("#1J=^7")
    card.tick(5000)
    assert position(card) == 2000  # J=: back to where the last jog started


def test_ixx97_3_triggers_on_the_warning_following_error() -> None:
    """Ixx97 = 3: software capture, the trigger is |FE| > Ixx12 (torque-limited homing against a
    hard stop, pmac_motorhome's HSW_HSTOP); word 1 bits 2-3 show Ixx97 [SRM p.282]."""
    c = Card(plant="servo")
    c.raw("I3=2")
    c.ask("I197=3 I112=1600 I7012=2 #1J/")
    c.tick(200)
    assert int(c.ask("#1?")[:6], 16) & 0b1100 == 0b1100
    c.ask("#1J:20000^-300")
    c.tick(200)
    c.fw.motors.core.set_jammed(np.array([0]), True)  # the stage hits a hard stop
    c.tick(400)
    c.fw.motors.core.set_jammed(np.array([0]), False)
    c.tick(4000)
    w1, w2 = words(c)
    assert not w2 & TRIGGER_MOVE
    capture = c.fw.motors.homing.capture_counts[0]
    assert abs(position(c) - (capture - 300)) < 2


def test_a_limit_stop_bit_clears_when_the_next_move_starts(card: Card) -> None:
    """Word 2 bit 11 "stopped on position limit" [SRM p.283]: set by a limit stop, cleared when
    the next move starts (homing PLCs test Mxx30 after each move)."""
    card.ask("#1J+")
    card.tick(200)
    flags(card, plim=True)
    card.tick(3000)
    assert card.ask("M130") == "1"
    card.ask("#1J^-1000^0")  # away from the limit
    assert card.ask("M130") == "0"
    card.tick(3000)
    assert card.ask("M130") == "0"


def test_a_program_writes_the_home_complete_bit(card: Card) -> None:
    """pmac_motorhome clears Mxx45 before a search: the bit is RAM (README assumption)."""
    card.ask("#1HMZ")
    assert card.ask("M145") == "1"
    card.ask("M145=0")
    assert not words(card)[1] & HOME_COMPLETE
    assert position(card) == 0


def test_a_caret_without_a_definite_jog_is_err003(card: Card) -> None:
    assert card.raw("#1J+^100") == b"\x07ERR003\r"
    assert card.raw("#1J^(") == b"\x07ERR003\r"
