"""`!{axis}{data}...`: the on-line altered-destination RAPID move (V1.936 [A L3232]; Turbo UM
"Altered-Destination Moves": a RAPID-mode move from an on-line command, the new destination of
a RAPID move in progress, rejected while a move of another mode runs) [README "Motion programs"]."""

from __future__ import annotations

import numpy as np

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
