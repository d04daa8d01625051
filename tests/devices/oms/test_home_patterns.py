"""The MAXk home truth table in HI ("Home Encoder") mode: `HT a,b,i,s` and `EH a,b,i` [S §4.3,
§4.8; spec oms.md §4.3 "Limits, home, I/O", §5.5, §8 item 15; README "Homing"].

Home is the AND of the terms not ignored (1 active, 0 inactive, 2 ignored) of phase A, phase B,
the index and the home switch; the factory table is the manual's `Home = Phase +A * Phase -B *
Index * Home Switch`. The virtual encoder: x4 quadrature [S §4.7] counted from the index; the
index pulse spans the four counts of one cycle, its first count A high B low, then A high B
high, A low B high, A low B low. Index pulses here: every 1000 counts from 250, so count c is at
place (c - 250) mod 1000 of its period, in quadrature state place mod 4.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from vdevmaps.oms import MaxkDoorbell, Mu, Shm

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd.devices.oms.encoder import first_home_count
from vdevd.nvram import NvramStore

VL, AC = 10000, 100000
PERIOD, PHASE = 1000, 250  # index pulses at ..., -750, 250, 1250, ... (places 0-3 each)
TYPES = ["stepper_encoder", "stepper_encoder", "servo", "stepper"]
POWER_UP_LOADED = 0x00010004  # running, power-up set in working memory
CHECKSUM_ERROR_FACTORY = 0x00041004  # running, archive checksum error, factory set


@pytest.fixture
def card() -> Iterator[Maxk]:
    """X, Y steppers with encoder (exact counts), Z a servo, T an open-loop stepper; X in HI
    mode with index pulses every 1000 counts from 250."""
    with maxk_card(axis_types=TYPES) as maxk:
        maxk.send(f"AA VL{VL},{VL},{VL},{VL} AC{AC},{AC},{AC},{AC}; AX HI;")
        maxk.control("set_index", axis="X", period=PERIOD, phase=PHASE)
        assert not maxk.command_error()
        yield maxk


def done_within(maxk: Maxk, timeout_s: float = 10.0) -> bool:
    return maxk.mu.wait_value(Mu.ODBR, 0, mask=MaxkDoorbell.DONE_X, timeout_s=timeout_s,
                              equal=False) is not None


def move_to(maxk: Maxk, position: int) -> None:
    """MA, GO, ID on X and wait for done (then clear it)."""
    maxk.clear_odbr(MaxkDoorbell.DONE_X)
    maxk.send(f"AX MA{position} GO ID;")
    assert done_within(maxk)
    maxk.clear_odbr(MaxkDoorbell.DONE_X)


def on_switch(maxk: Maxk, position: int) -> bool:
    """X moved to `position`: is its home switch active there (QA char 4)?"""
    move_to(maxk, position)
    return maxk.query("AX QA;")[3] == "H"


# -- the command [S §4.3, §4.8] ----------------------------------------------------------------------
def test_factory_table_is_the_manuals_default_home_logic(card: Maxk) -> None:
    """`Home = Phase +A * Phase -B * Index * Home Switch (Default)` [S §4.8]."""
    assert card.query("AX HT?;") == "=1011"
    assert card.query("AX EH?;") == "=101"


def test_ht_takes_four_entries_with_or_without_commas(card: Maxk) -> None:
    card.send("AX HT1,1,0,2; AY HT0211;")
    assert not card.command_error()
    assert card.query("AX HT?;") == "=1102"
    assert card.query("AY HT?;") == "=0211"
    assert card.query("AZ HT?;") == "=1011"


def test_eh_sets_the_encoder_entries_and_leaves_the_switch(card: Maxk) -> None:
    card.send("AX HT1,0,1,0; EH2,2,1;")
    assert not card.command_error()
    assert card.query("AX HT?;") == "=2210"
    assert card.query("AX EH?;") == "=221"


def test_ht_in_aa_mode_sets_every_axis(card: Maxk) -> None:
    card.send("AA HT0,0,1,1;")
    assert card.query("AA HT?;") == "=0011,=0011,=0011,=0011"


@pytest.mark.parametrize("text", [
    "HT1,0,1;", "HT10111;", "HT1,0,3,1;", "HT1,0,1,;", "HT-1,0,1,1;", "HT1.0,0,1,1;", "HT;",
    "HT2222;", "HT2,2,2,2;", "EH1,0,1,1;", "EH12;", "EH3,0,1;",
])
def test_a_bad_table_is_a_command_error_and_changes_nothing(card: Maxk, text: str) -> None:
    """Spec §4.4: ODBR bit 24, no reply, nothing changed; a table ignoring every term defines
    no home (README)."""
    card.send("AX " + text)
    assert card.command_error()
    assert card.query("AX HT?;") == "=1011"


def test_eh_that_would_leave_no_term_is_refused(card: Maxk) -> None:
    card.send("AX HT1,0,1,2; EH2,2,2;")
    assert card.command_error()
    assert card.query("AX HT?;") == "=1012"


# -- the home condition in HI mode [S §4.8] -----------------------------------------------------------
@pytest.mark.parametrize(("table", "home"), [
    ("HT1,0,1,1", 5250),  # the factory table: the index count (A high, B low)
    ("HT1,1,1,1", 5251),  # A high, B high: the pulse's second count
    ("HT0,1,1,1", 5252),
    ("HT0,0,1,1", 5253),
])
def test_hm_homes_on_the_pulse_count_in_the_tables_quadrant(card: Maxk, table: str,
                                                              home: int) -> None:
    """HM0 toward a switch from 5000 up: home is the count of the index pulse at 5250 whose
    quadrature state the table asks for; that count becomes 0, so the switch edge ends at
    5000 - home (on the switch there, off one count below)."""
    card.control("set_home_edge", axis="X", position=5000)
    card.send(f"AX {table} HM0 ID;")
    assert done_within(card)
    card.clear_odbr(MaxkDoorbell.DONE_X)
    assert on_switch(card, 5000 - home)
    assert not on_switch(card, 4999 - home)


@pytest.mark.parametrize(("table", "home"), [
    ("HT1,0,1,1", -5750),  # the index count, the pulse's last count met going down
    ("HT1,1,1,1", -5749),
    ("HT0,0,1,1", -5747),  # the first count of the pulse met going down
    ("EH2,0,1", -5747),  # phase A ignored: B low is places 0 and 3; going down 3 comes first
    ("HT2,2,1,1", -5747),  # both phases ignored: the first count of the pulse met
])
def test_hr_meets_the_pulse_from_above(card: Maxk, table: str, home: int) -> None:
    """HR0 toward a switch flag from -6000 to -5000 (active below -5000): the pulse at -5750
    is met from its top count; home is the first count in the direction of travel where the
    table holds, and the flag's top edge ends at -5000 - home."""
    card.control("set_home_edge", axis="X", position=-6000, width=1000)
    card.send(f"AX {table} HR0 ID;")
    assert done_within(card)
    card.clear_odbr(MaxkDoorbell.DONE_X)
    top = -5000 - home
    assert on_switch(card, top - 1)
    assert not on_switch(card, top)


@pytest.mark.parametrize(("table", "switch", "count", "homed"), [
    ("HT1,0,1,1", True, 250, True),  # the index count on the switch: the whole condition
    ("HT1,0,1,1", True, 251, False),  # A high, B high
    ("HT1,0,1,1", False, 250, False),  # the switch term
    ("HT1,0,1,0", False, 250, True),  # switch entry 0: home needs the switch inactive
    ("HT2,2,1,1", True, 253, True),  # the pulse's last count
    ("HT2,2,1,1", True, 254, False),  # one count past the pulse
    ("HT1,0,0,1", True, 250, False),  # index entry 0: not inside the pulse ...
    ("HT1,0,0,1", True, 254, True),  # ... but the next A-high-B-low count
    ("HT0,1,2,1", True, 0, True),  # place 750: state 2, A low, B high
    ("HT1,1,2,1", True, 0, False),
    ("HT2,2,2,1", True, 3, True),  # the encoder ignored: the switch alone
])
def test_an_axis_where_the_condition_holds_is_homed_where_it_stands(
        card: Maxk, table: str, switch: bool, count: int, homed: bool) -> None:
    """The home logic is an AND of levels [S §4.8]: a search that starts where every term
    holds is home at once (RP = the operand); elsewhere it runs on."""
    move_to(card, count)
    card.control("set_home", axis="X", active=switch)
    card.send(f"AX {table} HM5;")
    assert not card.command_error()
    card.step(4)
    if homed:
        assert card.query("AX RP;") == "5"
        assert card.query("AX RV;") == "0"
    else:
        assert card.query("AX RV;") != "0"
        card.send("AX KL;")


def test_hs_mode_ignores_the_table(card: Maxk) -> None:
    """HS: the switch alone [S §4.8]; a table asking for an inactive switch does not apply."""
    card.control("set_home_edge", axis="X", position=5000)
    card.send("AX HT2,2,2,0 HS HM0 ID;")
    assert done_within(card)
    card.clear_odbr(MaxkDoorbell.DONE_X)
    assert on_switch(card, 0)
    assert not on_switch(card, -1)


# -- the virtual encoder's home logic, against its definition ------------------------------------------
def test_first_home_count_is_the_first_count_where_the_encoder_terms_hold() -> None:
    """first_home_count against a count-by-count walk over the model: place p of the index
    period, quadrature state p mod 4 = (A, B) in (1,0) (1,1) (0,1) (0,0), index for p < 4
    (seeded random periods, places, directions and tables)."""
    rng = np.random.default_rng(20240611)
    n = 4000
    period = rng.integers(1, 41, n).astype(float)
    place = np.floor(rng.random(n) * period)
    down = rng.random(n) < 0.5
    pattern = rng.integers(0, 3, (n, 4)).astype(np.int8)
    got = first_home_count(place, down, period, pattern)
    phase_a, phase_b = (1, 1, 0, 0), (0, 1, 1, 0)

    def holds(p: int, row: np.ndarray) -> bool:
        levels = (phase_a[p % 4], phase_b[p % 4], int(p < 4))
        return all(t == 2 or t == level for t, level in zip(row[:3].tolist(), levels, strict=True))

    for k in range(n):
        per, step = int(period[k]), -1 if down[k] else 1
        want = next((t for t in range(2 * per)
                     if holds((int(place[k]) + step * t) % per, pattern[k])), np.inf)
        assert got[k] == want, (per, place[k], down[k], pattern[k])


# -- stored with APP, reset by RDF [S §2.14; README "APP, RDF, RDP"] ------------------------------------
def test_app_stores_the_tables_and_a_power_cycle_loads_them(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX HT1,1,1,1; AY EH2,0,1; APP; AZ HT0,0,1,1;")
        assert not maxk.command_error()
    image = NvramStore(tmp_path).load("maxk0")
    assert image is not None and image["format"] == 2
    assert image["home_pattern"] == ["1111", "2011", "1011", "1011"]
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.query("AA HT?;") == "=1111,=2011,=1011,=1011"  # Z's change was not stored


def test_the_stored_table_homes_after_a_power_cycle(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX HI HT1,1,1,1; APP;")
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send(f"AX VL{VL} AC{AC};")
        maxk.control("set_index", axis="X", period=PERIOD, phase=PHASE)
        move_to(maxk, 251)  # the pulse's A-high-B-high count
        maxk.control("set_home", axis="X", active=True)
        maxk.send("AX HM5;")
        maxk.step(4)
        assert maxk.query("AX RP;") == "5"


def test_rdf_restores_the_factory_table_and_rdp_the_stored_one(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX HT0,0,1,1; APP; AY HT2,2,1,1; RDF;")
        assert maxk.query("AA HT?;") == "=1011,=1011,=1011,=1011"
        maxk.send("RDP;")
        assert not maxk.command_error()
        assert maxk.query("AA HT?;") == "=0011,=1011,=1011,=1011"


def test_an_image_without_tables_loads_with_the_factory_table(tmp_path: Path) -> None:
    """A format-2 image as APP wrote it before the tables were stored still loads; what it
    lacks takes its factory value."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AZ KP25; APP;")
    store = NvramStore(tmp_path)
    image = store.load("maxk0")
    assert image is not None
    del image["home_pattern"]
    store.save("maxk0", image)
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == POWER_UP_LOADED
        assert maxk.query("AZ ?KP;") == "25.00"
        assert maxk.query("AA HT?;") == "=1011,=1011,=1011,=1011"


def test_a_bad_stored_table_sets_the_archive_aside(tmp_path: Path) -> None:
    """Tables HT refuses (all ignored, too short, not text) are an image no command makes: the
    archive is bad (issue 22 §4; a checksum error, the factory set loaded), kept as .corrupt."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AA HT0,0,1,1; APP;")
    store = NvramStore(tmp_path)
    image = store.load("maxk0")
    assert image is not None
    image["home_pattern"] = ["2222", "13", 7, "0111"]
    store.save("maxk0", image)
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == CHECKSUM_ERROR_FACTORY
        assert maxk.query("AA HT?;") == "=1011,=1011,=1011,=1011"
    assert (tmp_path / "maxk0.nvram.corrupt").exists()
