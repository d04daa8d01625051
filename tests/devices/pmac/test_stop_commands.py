"""`/` (stop at the end of the executing move) and `\\` (quick stop; a feed hold outside a
lookahead sequence) on a running program, without sockets [Turbo SRM `/`, `\\`, `<`, H, Q;
stop_commands.py]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
PROGRAM = ["OPEN PROG 5 CLEAR", "LINEAR ABS TA100 TS20 F10", "X10", "X20", "X30", "X40", "X50",
           "CLOSE"]


def setup(isx13: int) -> Card:
    c = Card()
    c.raw("I3=2")
    for line in ["&1#1->1000X", "#1J/", f"I5113={isx13}", *PROGRAM]:
        c.ask(line)
    return c


def ticks(seconds: float) -> int:
    return round(seconds / DT)


def running(c: Card) -> bool:
    return bool(int(c.ask("&1??")[:6], 16) & 1)


def test_slash_in_segmentation_stops_on_the_executing_moves_end_and_r_goes_on() -> None:
    """Isx13 > 0: the program stops at X10, the end of the move executing when `/` came, in the
    blend's TA: a lone move from rest reaches its corner at TA/2 + T = 1.05 s and the stop,
    centred on it, ends TA/2 later (the stop begins on the segment point before the blend's
    start, so it may end up to one 10 ms segment later); the velocity changes smoothly; R runs
    the rest."""
    c = setup(10)
    c.ask("&1B5R")
    c.tick(ticks(0.5))
    c.ask("&1/")
    trace = []
    for _ in range(ticks(0.59)):
        c.tick()
        trace.append(float(c.ask("#1P")))
    assert 9950 < trace[-1] < 10000          # 1.09 s: still decelerating onto the corner
    c.tick(ticks(0.03))
    assert c.ask("#1P") == "10000" and not running(c)
    steps = [b - a for a, b in zip(trace, trace[1:], strict=False)]
    assert min(steps) >= 0 and max(steps) <= 10 * 1000 * DT + 1  # never faster than F (±1 count)
    c.tick(ticks(1.0))
    assert c.ask("#1P") == "10000"           # stays: the program is stopped
    c.ask("&1R")
    c.tick(ticks(5.0))
    assert c.ask("#1P") == "50000" and not running(c)


def test_slash_without_segmentation_stops_on_the_executing_moves_end_q_two_moves_later() -> None:
    """Isx13 = 0: LINEAR calculates two moves ahead. At 0.5 s move 1 (X10) executes and moves 2
    and 3 are calculated: Q stops at the end of the moves calculated (X30), `/` at the end of
    the executing move (X10): the two calculated moves go back to the calculation."""
    ends = []
    for command in ("&1/", "&1Q"):
        c = setup(0)
        c.ask("&1B5R")
        c.tick(ticks(0.5))
        c.ask(command)
        c.tick(ticks(6.0))
        assert not running(c)
        ends.append(c.ask("#1P"))
    assert ends == ["10000", "30000"]


def test_slash_with_nothing_running_does_nothing() -> None:
    c = setup(10)
    assert c.raw("&1/") == b"\x06"
    assert c.raw("&1\\") == b"\x06"
    assert not running(c) and c.ask("#1P") == "0"


def test_backslash_outside_lookahead_is_a_feed_hold() -> None:
    """SRM `<`/`\\`: outside a lookahead sequence the command is an H: the motion slows to a
    stop on the path (Isx95), the program stays running, R resumes to the end."""
    c = setup(0)
    c.ask("&1B5R")
    c.tick(ticks(1.5))
    c.ask("&1\\")
    c.tick(ticks(1.0))
    held = float(c.ask("#1P"))
    c.tick(ticks(1.0))
    assert float(c.ask("#1P")) == held and running(c)
    assert 10000 < held < 30000
    c.ask("&1R")
    c.tick(ticks(6.0))
    assert c.ask("#1P") == "50000" and not running(c)


@pytest.mark.parametrize("isx13", [0, 10])
def test_slash_then_r_ends_where_the_uninterrupted_program_ends(isx13: int) -> None:
    c = setup(isx13)
    c.ask("&1B5R")
    c.tick(ticks(2.3))
    c.ask("&1/")
    c.tick(ticks(3.0))
    stopped = c.ask("#1P")
    assert stopped in ("30000", "40000", "50000") and not running(c)
    c.ask("&1R")
    c.tick(ticks(4.0))
    assert c.ask("#1P") == "50000"
