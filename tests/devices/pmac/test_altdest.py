"""`!{axis}{data}...`: the on-line altered-destination RAPID move (V1.936 [A L3232]; Turbo UM
"Altered-Destination Moves": a RAPID-mode move from an on-line command, the new destination of
a RAPID move in progress, rejected while a move of another mode runs) [README "Motion programs"]."""

from __future__ import annotations

import numpy as np

from tests.devices.pmac.test_cycle_runs import Twin
from tests.devices.pmac.test_online import Card
from tests.devices.pmac.test_programs import DT, card, download, trace, xy

__all__ = ["card"]

_JOG = "I122=20 I222=20 I119=1 I219=1 I120=50 I220=50 I121=0 I221=0"


def test_bang_from_an_idle_cs_is_a_rapid_move_at_jog_speed(card: Card) -> None:
    """`&1!X10Y2`: X 10000 counts at Ixx22 = 20 counts/ms with 50 ms ramps ends at 0.55 s, Y
    2000 counts at 0.15 s (a RAPID move: each motor on its jog profile) [A L3232, UM]."""
    card.ask(_JOG)
    assert card.raw("&1!X10Y2") == b"\x06"
    rows = trace(card, 2.0)
    t_x = rows[np.flatnonzero(rows[:, 1] >= 10000.0)[0], 0]
    t_y = rows[np.flatnonzero(rows[:, 2] >= 2000.0)[0], 0]
    assert abs(t_x - 0.55) < 2 * DT
    assert abs(t_y - 0.15) < 2 * DT
    assert xy(card) == (10000.0, 2000.0)
    assert not card.fw.motion.any_running()


def test_bang_names_some_axes_the_others_stay(card: Card) -> None:
    card.ask(_JOG)
    card.ask("&1!Y(1+0.5)")
    trace(card, 2.0)
    assert xy(card) == (0.0, 1500.0)


def test_bang_changes_the_destination_of_a_running_rapid_move(card: Card) -> None:
    """A program's RAPID move to X10 altered to X4 Y1 while it runs: the axes end at the new
    destination and the program goes on from there (INC X1 after it ends at X5) [UM "Use of
    Altered Destination"]."""
    card.ask(_JOG)
    download(card, 2, "RAPID ABS", "X10", "INC X1")
    card.ask("&1B2R")
    trace(card, 0.1)
    assert card.ask("&1!X4Y1") == ""
    trace(card, 5.0)
    assert xy(card) == (5000.0, 1000.0)
    assert not card.fw.motion.any_running()


def test_bang_is_refused_while_a_linear_move_runs(card: Card) -> None:
    download(card, 1, "LINEAR ABS TA50 TS0 F10", "X10")
    card.ask("&1B1R")
    trace(card, 0.1)
    assert card.raw("&1!X1") == b"\x07ERR001\r"
    trace(card, 3.0)
    assert xy(card) == (10000.0, 0.0)


def test_bang_needs_an_axis_and_a_value(card: Card) -> None:
    assert card.raw("&1!") == b"\x07ERR003\r"
    assert card.raw("&1!X") == b"\x07ERR003\r"
    assert not card.fw.motion.any_running()


def test_bang_with_no_motors_in_the_cs_is_err014(card: Card) -> None:
    assert card.raw("&2!X1") == b"\x07ERR014\r"


def _run_then_alter(card: Card, t_alter: float, command: str) -> np.ndarray:
    """`!X10` from rest, `command` after t_alter seconds; (t, X, Y) every cycle to the end."""
    card.ask(_JOG)
    card.ask("&1!X10")
    first = trace(card, t_alter)
    card.ask(command)
    return np.vstack([first, trace(card, 3.0, t0=first[-1, 0])])


def _peak(rows: np.ndarray, t_alter: float, delay: float) -> float:
    """Where X stops when the move at 20 units/s (after its 50 ms ramp from rest) breaks in
    `delay` after the command (sent at the cycle nearest t_alter), with 400 units/s²: the break
    position plus 20²/(2·400) units, in counts."""
    t_cmd = float(rows[int(round(t_alter / DT)) - 1, 0])
    return (0.5 + (t_cmd + delay - 0.05) * 20.0 + 0.5) * 1000.0


def test_bang_breaks_into_a_rapid_move_after_ixx92_and_blends(card: Card) -> None:
    """At 0.2 s X cruises at 20 units/s (at 3.5); `!X6` breaks in at 0.21 s (Ixx92 = 10 ms,
    X at 3.7) and goes on at speed to a stop at 6: 0.09 s at 20 units/s, 0.05 s ramp: the
    move ends at 0.35 s, never turning back, its speed never above Ixx22 [UM
    "Altered-Destination Moves"]."""
    rows = _run_then_alter(card, 0.2, "&1!X6")
    end = rows[np.flatnonzero(rows[:, 1] >= 6000.0)[0], 0]
    assert abs(end - 0.35) < 2 * DT
    assert xy(card) == (6000.0, 0.0)
    step = np.diff(rows[:, 1])
    assert (step >= -1e-9).all()
    assert step.max() <= 20.0 * DT * 1000 + 1e-6


def test_bang_behind_the_axis_stops_then_comes_back(card: Card) -> None:
    """`!X3` at 0.2 s: the break at 0.21 s (X 3.7 at 20 units/s) cannot stop before 3, so X
    stops at 3.7 + 20²/(2·400) = 4.2 and comes back to 3, ending at 0.21 + 0.05 + 0.11 s."""
    rows = _run_then_alter(card, 0.2, "&1!X3")
    assert abs(rows[:, 1].max() - _peak(rows, 0.2, 0.010)) < 0.01
    assert abs(_peak(rows, 0.2, 0.010) - 4200.0) < 3.0
    assert xy(card) == (3000.0, 0.0)
    back = rows[np.flatnonzero(rows[:, 1] == rows[:, 1].max())[0]:, :]
    end = back[np.flatnonzero(back[:, 1] <= 3000.0)[0], 0]
    assert abs(end - 0.37) < 2 * DT


def test_ixx92_delays_the_break(card: Card) -> None:
    """I192 = 60 ms: the break comes at 0.26 s (X 4.7), so X stops at 5.2 before coming back."""
    card.ask("I192=60")
    rows = _run_then_alter(card, 0.2, "&1!X3")
    assert abs(rows[:, 1].max() - _peak(rows, 0.2, 0.060)) < 0.01
    assert abs(_peak(rows, 0.2, 0.060) - 5200.0) < 3.0
    assert xy(card) == (3000.0, 0.0)


def test_bang_after_the_move_ends_starts_from_rest_there(card: Card) -> None:
    """A rotary buffer's last RAPID move done, the program waits for lines: `!X2` moves from the
    end point, the same end as if sent during the move [UM "Use of Altered Destination"]."""
    card.ask(_JOG)
    card.ask("&1 DEFINE ROT 100 &1B0")
    card.ask("OPEN ROT")
    card.ask("RAPID X1")
    card.ask("CLOSE")
    card.ask("&1R")
    card.tick(2000)
    assert xy(card) == (1000.0, 0.0)
    assert card.fw.motion.any_running()   # waiting for rotary lines
    assert card.raw("&1!X2") == b"\x06"
    card.tick(2000)
    assert xy(card) == (2000.0, 0.0)


def test_a_bang_move_is_not_at_rest_and_batches_match_cycles_one_by_one() -> None:
    """Decision 0008: a card running a `!` move works at every cycle (batched and cycle-by-cycle
    runs end alike, a new destination in the middle included) and rests once it is over."""
    twin = Twin(True, "servo")
    for line in ("&1#1->1000X", "#1J/", "I122=20 I119=1 I120=50 I121=0", "&1!X2"):
        twin.send(line)
    fast = twin.cards[0]
    assert fast.rest_state() is None
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 6:
        twin.tick(n)
        twin.same()
    twin.send("&1!X1")
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 6:
        twin.tick(n)
        twin.same()
    twin.tick(2000)
    twin.same()
    assert not fast.fw.motion.active
    assert fast.rest_state() is not None
