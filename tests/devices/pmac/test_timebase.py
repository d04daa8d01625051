"""The feed-rate override `%` slewing at Isx94, without sockets [spec pmac.md §2.2 Isx94 (SRM
p.191: factory 1644, 0 to 100 % in about a second), §2.8 X:$002000 host-commanded and X:$002002
present time base, in I10 units]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card

I10 = 3_713_707


@pytest.fixture
def card() -> Card:
    c = Card()
    c.raw("I3=2")
    c.ask("M5100->X:$002000,0,24,S M5102->X:$002002,0,24,S M5202->X:$002102,0,24,S")
    return c


def present(card: Card, m: int = 5102) -> int:
    return int(card.ask(f"M{m}"))


def test_the_present_time_base_slews_at_isx94_per_servo_cycle(card: Card) -> None:
    card.ask("&1%50")
    assert int(card.ask("M5100")) == round(I10 * 0.5)  # commanded at once
    assert present(card) == I10
    card.tick(1000)
    assert present(card) == I10 - 1000 * 1644
    card.tick(1130)  # 1856854 / 1644 = 1129.5 cycles in all
    assert present(card) == round(I10 * 0.5)
    assert card.ask("&1%") == "50"
    assert present(card, 5202) == I10  # C.S. 2 untouched


def test_a_new_override_slews_from_where_the_last_one_had_got(card: Card) -> None:
    card.ask("&1%0")
    card.tick(500)
    card.ask("&1%100")
    card.tick(200)
    assert present(card) == I10 - 500 * 1644 + 200 * 1644


def test_isx94_sets_the_rate_and_0_takes_the_value_at_once(card: Card) -> None:
    card.ask("I5194=16440")
    card.ask("&1%20")
    card.tick(100)
    assert present(card) == I10 - 100 * 16440
    card.tick(200)
    assert present(card) == round(I10 * 0.2)
    card.ask("I5194=0")
    card.ask("&1%70")
    assert present(card) == round(I10 * 0.7)


def test_writing_the_commanded_time_base_slews_too(card: Card) -> None:
    """X:$002000 written by a program or the host is the `%` command [§2.8]."""
    card.ask(f"M5100={I10 // 4}")
    assert card.ask("&1%") == "25"
    card.tick(10)
    assert present(card) == I10 - 10 * 1644
