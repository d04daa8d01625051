"""Ixx27 rotary rollover of programmed ABS moves of A/B/C axes [Turbo SRM Ixx27: > 0 the shortest
way round, never more than half a revolution; < 0 (V1.937 [A L3258]) the destination's sign gives
the direction and is part of the value, every move under one revolution; INC moves unaffected]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_programs import download, trace


@pytest.fixture
def card() -> Card:
    """Motor 1 as axis A at 100 counts per degree (36000 counts per revolution)."""
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->100A #1J/ I116=1000 I117=100")
    return c


def run(card: Card, *lines: str) -> float:
    download(card, 1, "LINEAR ABS TA50 TS0 F360", *lines)
    card.ask("&1B1R")
    trace(card, 10.0)
    assert not card.fw.motion.any_running()
    return float(card.fw.reports.commanded()[0])


@pytest.mark.parametrize(("lines", "counts"), [
    (("A270",), -9000.0),            # 270 = -90: a quarter turn back, not three forward
    (("A270", "A100"), -26000.0),    # from -90 to 100: -170 is the short way (not +190)
    (("A90",), 9000.0),
    (("INC A270",), 27000.0),        # incremental: not affected
])
def test_positive_ixx27_takes_the_shortest_way(card: Card, lines: tuple[str, ...],
                                               counts: float) -> None:
    card.ask("I127=36000")
    assert run(card, *lines) == pytest.approx(counts, abs=1e-6)


@pytest.mark.parametrize(("lines", "counts"), [
    (("A270",), 27000.0),                        # positive: three quarters forward
    (("A-90",), -9000.0),                        # -90 (= 270) turning negative
    (("A-90", "A100"), 10000.0),                 # from 270 forward to 100: +190
    (("A-90", "A100", "A-350"), 1000.0),         # -350 = 10, turning negative from 100: -90
    (("A-270",), -27000.0),                      # 90 turning negative: three quarters back
    (("INC A-400",), -40000.0),
])
def test_negative_ixx27_the_sign_gives_the_direction(card: Card, lines: tuple[str, ...],
                                                     counts: float) -> None:
    card.ask("I127=-36000")
    assert run(card, *lines) == pytest.approx(counts, abs=1e-6)


def test_zero_ixx27_is_a_linear_axis(card: Card) -> None:
    assert run(card, "A270", "A-90") == pytest.approx(-9000.0, abs=1e-6)


def test_rollover_is_for_rotary_axes_only() -> None:
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->100X #1J/ I116=1000 I117=100 I127=36000")
    assert run(c, "X270") == pytest.approx(27000.0, abs=1e-6)
