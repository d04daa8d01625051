"""EA char 5 and the capture's "encoder home event" follow the home condition the firmware sees
[S §4.3, §4.8, §3.7 Table 3-6; spec oms.md §4.2 EA, §2.8, §5.5; README "Homing", "Capture"].

In HI mode that is the home truth table (`HT a,b,i,s`, `EH a,b,i`: 1 active, 0 inactive, 2
ignored), the AND of its terms not ignored, as HI homing uses it: EA char 5 is 'H' where the
axis stands on a count where it holds, and an index capture (`CPH2`) records the exact count
where it comes true. In HS mode (the factory setting) the home condition is the switch alone:
EA char 5 follows the switch and the index capture each index pulse, as before.

The virtual encoder (README): x4 quadrature counted from the index; index pulses here every 1000
counts from 250, four counts wide; count c is at place (c - 250) mod 1000 of its period, in
quadrature state place mod 4: (A, B) = (1, 0), (1, 1), (0, 1), (0, 0).
"""

from __future__ import annotations

import struct
from collections.abc import Iterator

import numpy as np
import pytest
from vdevmaps.oms import CAPTURE_SIZE, HomeEvent, MaxkDoorbell, Mu, Shm

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd.devices.oms.encoder import first_rise_count

PERIOD, PHASE = 1000, 250
TYPES = ["stepper_encoder", "stepper_encoder", "servo", "stepper"]
AROUND = range(244, 262)  # the pulse at 250-253 and some counts either side
PHASE_A, PHASE_B = (1, 1, 0, 0), (0, 1, 1, 0)


def table_of(command: str) -> tuple[int, ...]:
    """`HT1,0,1,2` -> (1, 0, 1, 2)."""
    return tuple(int(t) for t in command[2:].split(","))


def holds(count: int, table: tuple[int, ...], switch: bool) -> bool:
    """The truth table at an encoder count with the switch as given, from its definition: each
    term not ignored at the level its entry asks for."""
    place = (count - PHASE) % PERIOD
    levels = (PHASE_A[place % 4], PHASE_B[place % 4], int(place < 4), int(switch))
    return all(t == 2 or t == level for t, level in zip(table, levels, strict=True))


def rises(path: list[int], table: tuple[int, ...], switch: bool) -> list[int]:
    """The counts of a path (one count apart) where the table comes true."""
    return [c for prev, c in zip(path, path[1:], strict=False)
            if holds(c, table, switch) and not holds(prev, table, switch)]


@pytest.fixture
def card() -> Iterator[Maxk]:
    """X a stepper with encoder (its encoder counts exactly what it steps), index pulses every
    1000 counts from 250."""
    with maxk_card(axis_types=TYPES) as maxk:
        maxk.send("AX VL2000 AC200000;")
        maxk.control("set_index", axis="X", period=PERIOD, phase=PHASE)
        assert not maxk.command_error()
        yield maxk


def move_to(maxk: Maxk, position: int) -> None:
    maxk.clear_odbr(MaxkDoorbell.DONE_X)
    maxk.send(f"AX MA{position} GO ID;")
    assert maxk.mu.wait_value(Mu.ODBR, 0, mask=MaxkDoorbell.DONE_X, timeout_s=10, equal=False) is not None
    maxk.clear_odbr(MaxkDoorbell.DONE_X)


def set_switch(maxk: Maxk, active: bool) -> None:
    maxk.control("set_home", axis="X", active=active)


def ea_home(maxk: Maxk) -> bool:
    return maxk.query("AX EA;")[4] == "H"


def take_entries(maxk: Maxk) -> list[tuple[int, int, int]]:
    """(position, axis, home-event bits) of the capture entries since the last call; the host
    removes them (removal index := insert index) [S §3.7]."""
    raw = maxk.shm.read(Shm.CAPTURE_INSERT, CAPTURE_SIZE)
    insert, removal = raw[0], raw[1]
    out = []
    while removal != insert:
        position, axis, home, _, _ = struct.unpack_from(">iBBHH", raw, 2 + 10 * removal)
        out.append((position, axis, home))
        removal = (removal + 1) % 55
    maxk.shm.write(Shm.CAPTURE_REMOVAL, bytes([insert]))
    return out


def walk(maxk: Maxk, counts: list[int]) -> list[int]:
    """Move X count by count along `counts`; the captured positions of encoder home events."""
    found = []
    for c in counts:
        move_to(maxk, c)
        found += [position for position, axis, home in take_entries(maxk)
                  if axis == 0 and home == HomeEvent.ENCODER_HOME]
    return found


TABLES = [
    ("HT1,0,1,2", False),  # the switch ignored: the index count alone
    ("HT2,0,1,1", True),  # phase A ignored, B inactive: places 0 and 3 of the pulse
    ("HT2,0,1,1", False),  # ... the switch term fails
    ("HT2,2,1,2", False),  # the whole pulse
    ("HT1,0,0,1", True),  # index inactive: A high B low outside the pulse
    ("HT0,1,2,0", False),  # index ignored, the switch inactive
    ("HT1,0,1,1", True),  # the factory table on the switch
    ("HT1,0,1,1", False),
]


# -- EA char 5 [spec §4.2 EA] ----------------------------------------------------------------------
@pytest.mark.parametrize(("table", "switch"), TABLES)
def test_ea_home_follows_the_table_count_by_count_in_hi_mode(card: Maxk, table: str,
                                                             switch: bool) -> None:
    card.send(f"AX HI {table};")
    set_switch(card, switch)
    for count in AROUND:
        move_to(card, count)
        assert ea_home(card) == holds(count, table_of(table), switch), count


def test_ea_home_agrees_with_where_hi_homing_stops(card: Maxk) -> None:
    """One condition: KR0 from 300 loads 0 at the first count going down where the table holds
    (253, B low in the pulse); there EA says H, one count above it N."""
    card.send("AX HI HT2,0,1,2;")
    move_to(card, 300)
    card.send("AX KR0 ID;")
    assert card.mu.wait_value(Mu.ODBR, 0, mask=MaxkDoorbell.DONE_X, timeout_s=10, equal=False) is not None
    move_to(card, 0)
    assert ea_home(card)
    move_to(card, 1)
    assert not ea_home(card)


# -- the encoder home event of the capture [S §3.7 Table 3-6] ---------------------------------------
@pytest.mark.parametrize(("table", "switch"), TABLES)
def test_index_capture_records_where_the_table_comes_true(card: Maxk, table: str,
                                                          switch: bool) -> None:
    """Count by count up through the pulse and back down: one entry at each count where the
    table comes true in the direction of travel, at that count."""
    card.send(f"AX HI {table} CPH2;")
    set_switch(card, switch)
    move_to(card, AROUND[0])
    take_entries(card)
    up, down = list(AROUND), list(reversed(AROUND))
    t = table_of(table)
    assert walk(card, up[1:]) == rises(up, t, switch)
    assert walk(card, down[1:]) == rises(down, t, switch)


@pytest.mark.parametrize(("table", "up", "down"), [
    ("HT2,2,1,2", [250, 1250], [1253, 253]),  # the first count of the pulse met
    ("HT0,0,1,2", [253, 1253], [1253, 253]),  # the pulse's last count
    ("HT1,0,1,1", [250, 1250], [1250, 250]),  # the factory table on the switch
])
def test_at_speed_the_entry_holds_the_exact_count(card: Maxk, table: str, up: list[int],
                                                  down: list[int]) -> None:
    """About 10 counts per update cycle: each entry still holds the count where the table came
    true, not where the cycle ended (one entry per pulse passed)."""
    card.send(f"AX VL10000 HI {table} CPH2;")
    set_switch(card, True)
    take_entries(card)
    move_to(card, 2000)
    assert [p for p, _, _ in take_entries(card)] == up
    move_to(card, 0)
    assert [p for p, _, _ in take_entries(card)] == down


def test_a_reversal_meets_the_pulse_from_the_other_side(card: Maxk) -> None:
    """Up from -600 to -200 (no pulse there), then down to -800: the pulse at -750..-747 is
    met from its top, so the table of the whole pulse comes true at -747."""
    card.send("AX HI HT2,2,1,2;")
    move_to(card, -600)
    card.send("AX CPH2;")
    move_to(card, -200)
    move_to(card, -800)
    assert [p for p, _, _ in take_entries(card)] == [-747]


def test_a_new_table_or_index_applies_to_the_next_pulse(card: Maxk) -> None:
    """Changed between two moves in the same direction: HT0,0,1,2 comes true at the pulse's
    last count; index pulses moved to 400 make it 403."""
    card.send("AX HI HT2,2,1,2 CPH2;")
    move_to(card, 100)
    card.send("AX HT0,0,1,2;")
    move_to(card, 300)
    assert [p for p, _, _ in take_entries(card)] == [253]
    card.control("set_index", axis="X", period=PERIOD, phase=400)
    move_to(card, 500)
    assert [p for p, _, _ in take_entries(card)] == [403]


def test_the_switch_coming_true_on_the_pulse_is_an_event(card: Maxk) -> None:
    """HT2,2,1,1 standing in the pulse: the switch becoming active makes the table true there
    (an entry at that count); outside the pulse it does not."""
    card.send("AX HI HT2,2,1,1 CPH2;")
    move_to(card, 251)
    take_entries(card)
    set_switch(card, True)
    card.step(1)
    assert take_entries(card) == [(251, 0, HomeEvent.ENCODER_HOME)]
    set_switch(card, False)
    card.step(1)
    assert take_entries(card) == []
    move_to(card, 260)
    set_switch(card, True)
    card.step(1)
    assert take_entries(card) == []


# -- the factory setting (HS) is what it was ----------------------------------------------------------
def test_in_hs_mode_ea_home_is_the_switch_and_capture_the_index_pulse(card: Maxk) -> None:
    """HS (factory): the home condition is the switch alone [S §4.3], whatever the table; the
    encoder's home event is its index pulse, on or off the switch."""
    card.send("AX HT2,2,1,2 CPH2;")
    move_to(card, 250)
    assert not ea_home(card)
    set_switch(card, True)
    assert ea_home(card)
    move_to(card, 300)
    assert ea_home(card)
    set_switch(card, False)
    take_entries(card)
    move_to(card, 1300)
    move_to(card, 200)
    assert [p for p, _, _ in take_entries(card)] == [1250, 1250, 250]


# -- the search against its definition ---------------------------------------------------------------
def test_first_rise_count_is_the_first_count_where_the_encoder_terms_come_true() -> None:
    """first_rise_count against a count-by-count walk over the model (seeded random periods,
    places, directions and tables): the first count met where the terms hold and did not at
    the count before it."""
    rng = np.random.default_rng(20240612)
    n = 4000
    period = rng.integers(1, 41, n).astype(float)
    place = np.floor(rng.random(n) * period)
    down = rng.random(n) < 0.5
    pattern = rng.integers(0, 3, (n, 4)).astype(np.int8)
    got = first_rise_count(place, down, period, pattern)

    def terms(p: int, row: np.ndarray) -> bool:
        levels = (PHASE_A[p % 4], PHASE_B[p % 4], int(p < 4))
        return all(t == 2 or t == level for t, level in zip(row[:3].tolist(), levels, strict=True))

    for k in range(n):
        per, step, p0 = int(period[k]), -1 if down[k] else 1, int(place[k])
        want = next((t for t in range(1, 3 * per + 2)
                     if terms((p0 + step * t) % per, pattern[k])
                     and not terms((p0 + step * (t - 1)) % per, pattern[k])), np.inf)
        assert got[k] == want, (per, p0, down[k], pattern[k])
