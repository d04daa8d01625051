"""Software travel limits (card option `travel_limits`): the MAXk's "Software (soft) over-travel"
power-up parameter, factory disabled [S §2.14; spec oms.md §1.4, §5.6]. No mnemonic is known,
so the card option sets them (README). A motion heading past one stops at it and is a limit
stop: over-travel (ODBR bit 8 + axis), QA 'L', the axis's queue flushed; motion back is allowed.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from vdevmaps.oms import MaxkDoorbell

from tests.devices.oms.conftest import Maxk, card_config, maxk_card
from vdevd.daemon import build_rack

LOW, HIGH = -1000, 5000
HZ = 1024


@pytest.fixture
def card() -> Iterator[Maxk]:
    """X limited to -1000..5000, the other axes free; X fast enough to end its moves in 1 s."""
    with maxk_card(travel_limits=[[LOW, HIGH], [], [], []]) as c:
        c.send("AA; VL20000,20000,20000,20000; AC200000,200000,200000,200000;")
        yield c


def x(card: Maxk) -> int:
    return card.word(0)


@pytest.mark.parametrize("command", [
    "AX MA8000 GO ID; MR-100 GO;",  # the MR is queued behind: the limit stop flushes it
    "AX MR6000 GO ID; MR-100 GO;",
    "AX JG20000;",  # JG does not hold the queue (README)
])
def test_a_motion_past_the_high_limit_stops_at_it_as_a_limit_stop(card: Maxk,
                                                                  command: str) -> None:
    card.send(command)
    card.step(HZ)
    assert x(card) == HIGH
    assert card.odbr() & (MaxkDoorbell.OVERTRAVEL_X | MaxkDoorbell.DONE_X) == MaxkDoorbell.OVERTRAVEL_X
    assert card.query("AX QA;") == "PNLN"
    assert card.query("AX RQC;") == "2559"


def test_a_motion_inside_the_limits_is_not_touched(card: Maxk) -> None:
    card.send("AX MA4999 GO ID;")
    card.step(HZ)
    assert x(card) == 4999
    assert card.odbr() & (MaxkDoorbell.OVERTRAVEL_X | MaxkDoorbell.DONE_X) == MaxkDoorbell.DONE_X
    assert card.query("AX QA;") == "PDNN"


def test_at_the_limit_a_motion_further_is_refused_and_one_back_runs(card: Maxk) -> None:
    card.send("AX JG-20000;")
    card.step(HZ)
    assert x(card) == LOW and card.query("AX QA;") == "MNLN"
    card.clear_odbr()
    card.send("AX MR-1 GO;")
    card.step(10)
    assert x(card) == LOW and card.odbr() & MaxkDoorbell.OVERTRAVEL_X
    card.clear_odbr()
    card.send("AX MR500 GO ID;")
    card.step(HZ)
    assert x(card) == LOW + 500
    assert card.odbr() & (MaxkDoorbell.OVERTRAVEL_X | MaxkDoorbell.DONE_X) == MaxkDoorbell.DONE_X
    assert card.query("AX QA;") == "PDNN"


def test_the_other_axes_have_none(card: Maxk) -> None:
    card.send("AY MA20000 GO;")
    card.step(2 * HZ)
    assert card.word(4) == 20000 and not card.odbr() & (MaxkDoorbell.OVERTRAVEL_X << 1)


def test_a_contour_stops_inside_the_limit_with_over_travel(card: Maxk) -> None:
    """The path stops where it is in the last cycle before it would cross (at 4000 counts/s
    of path, within 4 counts of it); a contour back from there runs."""
    card.send("AA; VV4000; VA20000; VP8000,4000; VE;")
    card.step(3 * HZ)
    assert HIGH - 5 <= x(card) <= HIGH and card.word(4) == pytest.approx(x(card) / 2, abs=1)
    assert card.odbr() & (MaxkDoorbell.OVERTRAVEL_X | MaxkDoorbell.DONE_X) == MaxkDoorbell.OVERTRAVEL_X
    assert card.query("AX QA;") == "PNLN"
    card.clear_odbr()
    card.send("AA; VV4000; VA20000; VP0,0; VE;")
    card.step(3 * HZ)
    assert (x(card), card.word(4)) == (0, 0) and not card.odbr() & MaxkDoorbell.OVERTRAVEL_X
    assert card.query("AX QA;") == "MNNN"


def test_the_factory_setting_has_none() -> None:
    with maxk_card() as card:
        card.send("AX VL200000; MA3000000 GO;")
        card.step(20 * HZ)
        assert x(card) == 3_000_000 and not card.odbr() & MaxkDoorbell.OVERTRAVEL_X


@pytest.mark.parametrize("bad", [
    [[5000, -1000], [], [], []],  # low above high
    [[0, 1.5], [], [], []],  # not whole counts
    [[0], [], [], []],  # not a pair
    [[0, 2**31], [], [], []],  # beyond the position range
    [[0, 100], [], []],  # three entries for four axes
])
def test_bad_travel_limits_are_refused_when_the_card_is_built(bad: list[object]) -> None:
    with pytest.raises(ValueError, match="travel_limits"):
        build_rack(card_config(travel_limits=bad))
