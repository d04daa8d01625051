"""A servo axis settles after a stop: the card's commanded position is whole counts, so every
way a motion can end (ST, SA, KL, a soft or hard limit, a home search's ramp-down or KM, the end
of a contour) leaves the loop holding a whole count, and the encoder comes to rest on it instead
of hunting one count around a fraction [S §2.13, §2.14; spec oms.md §5.2-5.3; README "Motion"].

The card (a daemon of its own, lockstep clock) has four servo axes on the simulated motor of
vdevd/devices/oms/servo.py, at the factory gains and 1024 Hz.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from vdevmaps.oms import MaxkDoorbell, Shm

from tests.devices.oms.conftest import Maxk, maxk_card

HZ = 1024
JOG = 5000  # counts/s: at the factory AC, ST ramps down over 6.25 counts
WATCH = 512  # update cycles watched, one at a time, once the loop had time to settle


@pytest.fixture
def servo() -> Iterator[Maxk]:
    with maxk_card() as maxk:
        yield maxk


def snapshot(maxk: Maxk, axis: int = 0) -> tuple[int, int, int]:
    """(motor, encoder, DAC) of an axis X..S from the words the card writes every cycle."""
    return (maxk.word(Shm.MOTOR_POSITION + 4 * axis), maxk.word(Shm.ENCODER_POSITION + 4 * axis),
            maxk.word(Shm.DAC + 4 * axis))


def assert_settled(maxk: Maxk, axis: int = 0) -> int:
    """Let the loop settle for a second, then watch the axis cycle by cycle: motor, encoder and
    DAC stay constant, the encoder on the motor position, RP = RE. Returns the position."""
    maxk.step(HZ)
    seen = set()
    for _ in range(WATCH):
        maxk.step(1)
        seen.add(snapshot(maxk, axis))
    assert len(seen) == 1, f"the loop hunts: {sorted(seen)}"
    ((motor, encoder, dac),) = seen
    assert encoder == motor
    assert dac == 0
    letter = "XYZT"[axis]
    assert maxk.query(f"A{letter} RP;") == maxk.query(f"A{letter} RE;") == str(motor)
    return motor


def jog_then(maxk: Maxk, stop: str) -> None:
    """X jogs at JOG for 700 cycles (to a position between counts), then `stop` is sent."""
    maxk.send(f"AX JG{JOG};")
    maxk.step(700)
    maxk.send(stop)


# -- every kind of stop ----------------------------------------------------------------------------
@pytest.mark.parametrize("stop", ["AX ST;", "SA;", "AA SI1;", "AX JG0;", "KL;", "AX KS;"])
def test_jg_then_a_stop_command_settles_on_a_whole_count(servo: Maxk, stop: str) -> None:
    jog_then(servo, stop)
    assert assert_settled(servo) > 0
    assert servo.query("AX RV;") == "0"


@pytest.mark.parametrize("mode", ["LMS", "LMH"])
def test_a_limit_stop_settles_on_a_whole_count(servo: Maxk, mode: str) -> None:
    """LMS decelerates at AC, LMH stops within the cycle [S §4.2]; either ends between counts."""
    servo.send(f"AX {mode};")
    jog_then(servo, "")
    servo.control("set_limits", axis="X", positive=True)
    assert_settled(servo)
    assert servo.query("AX QA;")[2] == "L"


@pytest.mark.parametrize("search", ["HM0", "KM0"])
def test_a_home_search_settles_on_a_whole_count(servo: Maxk, search: str) -> None:
    """HM ramps down past the switch, KM stops within the cycle [S §4.8]."""
    servo.send(f"AX VL{JOG};")
    servo.control("set_home_edge", axis="X", position=1234.5)
    servo.send(f"AX {search} ID;")
    servo.step(HZ)
    assert servo.odbr() & MaxkDoorbell.DONE_X
    assert_settled(servo)


def test_a_contour_ending_between_counts_settles_on_whole_counts(servo: Maxk) -> None:
    """An arc ends where the circle takes it; the card holds the whole counts there."""
    servo.send("AA; VV5000; VA100000; VP1000,0; VC1000,500,77; VE;")
    servo.step(3 * HZ)
    x, y = assert_settled(servo, 0), assert_settled(servo, 1)
    assert (x, y) == (1487, 388)  # (1000, 500) + 500·(sin 77°, −cos 77°), rounded


# -- done flags and ID around a stop -----------------------------------------------------------------
def test_st_of_a_move_settles_and_its_queued_id_never_fires(servo: Maxk) -> None:
    """ST flushes the queue [spec §4.3]: holding the whole count raises no done flag."""
    servo.send(f"AX VL{JOG}; MR100000; GO; ID;")
    servo.step(700)
    servo.send("AX ST;")
    assert_settled(servo)
    assert servo.odbr() & MaxkDoorbell.DONE_X == 0
    assert servo.query("AX QA;")[1] == "N"


def test_a_move_after_a_stop_runs_from_the_whole_count_and_sets_done(servo: Maxk) -> None:
    jog_then(servo, "AX ST;")
    here = assert_settled(servo)
    servo.send("AX MR1000; GO; ID;")
    servo.step(HZ)
    assert servo.odbr() & MaxkDoorbell.DONE_X
    assert servo.query("AX QA;")[1] == "D"
    assert assert_settled(servo) == here + 1000
