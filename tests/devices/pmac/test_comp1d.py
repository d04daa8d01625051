"""1-D compensation tables and backlash (vdevd/devices/pmac/comp1d.py): DEFINE COMP with one source,
DEFINE BLCOMP, DEFINE TCOMP, DELETE, LIST, I30, I51, Ixx85-Ixx87 [Turbo SRM "DEFINE COMP
(one-dimensional)", "DEFINE BLCOMP", "DEFINE TCOMP", Ixx85-Ixx87; A L1420-1432 (I30); spec §1.7]."""

from __future__ import annotations

import pytest

from tests.devices.pmac.test_online import Card

#: Mxx69, the compensation correction register, reads counts x 96 x 32 (test_online's 2-D test)
M69_SCALE = 96 * 32


def card(plant: str = "ideal") -> Card:
    c = Card(plant=plant)
    c.raw("I3=2")
    return c


def encoder(c: Card) -> int:
    """Motor 1's Servo IC counter X:$078001 (24-bit, two's complement)."""
    raw = int(c.ask("RX:$078001")[1:], 16)
    return raw - (1 << 24) if raw & 0x800000 else raw


def correction(c: Card) -> float:
    return int(c.ask("M169")) / M69_SCALE


def leadscrew(c: Card, entries: str = "160 320 480 0") -> None:
    """#1's table as a function of #2's desired position over 4000 counts: 10, 20, 30, 0 counts at
    1000, 2000, 3000, 4000."""
    c.raw("#1 DEFINE COMP 4,#2D,#1,4000")
    c.raw(entries)
    c.raw("M169->D:$000090")


# -- the leadscrew table -------------------------------------------------------------------------------
@pytest.mark.parametrize(("position", "expected"), [
    (1500, 15.0), (2500, 25.0), (3500, 15.0), (500, 5.0), (5500, 15.0), (-500, 15.0)])
def test_leadscrew_correction_interpolates_between_entries_and_rolls_over(position: int,
                                                                          expected: float) -> None:
    """Entry k at k·length/entries, 1/16 count, linear between entries, 0 at position 0 (I30 = 0),
    the source rolled over into 0..length [Turbo SRM DEFINE COMP (one-dimensional)]."""
    c = card()
    leadscrew(c)
    c.raw("I51=1")
    c.raw(f"#2J={position}")
    c.tick(2000)
    assert correction(c) == pytest.approx(expected)


def test_leadscrew_needs_i51() -> None:
    c = card()
    leadscrew(c)
    c.raw("#2J=1500")
    c.tick(2000)
    assert correction(c) == 0
    c.raw("I51=1")
    assert correction(c) == pytest.approx(15.0)


def test_leadscrew_table_shifts_the_measured_position_by_the_correction() -> None:
    """The target's loop runs at commanded + correction: its encoder moves by the interpolated
    correction while P stays in the commanded frame (README "Compensation tables")."""
    c = card(plant="servo")
    leadscrew(c)
    c.raw("#2J=1500 #1J/")
    c.tick(2000)
    base = encoder(c)
    c.raw("I51=1")
    c.tick(500)
    assert encoder(c) - base == 15
    assert abs(float(c.ask("#1P"))) <= 1
    c.raw("I51=0")
    c.tick(500)
    assert encoder(c) == base


@pytest.mark.parametrize(("i30", "at_500"), [(0, 5.0), (1, 30.0)])
def test_i30_sets_the_correction_at_zero_as_the_table_is_downloaded(i30: int, at_500: float) -> None:
    """I30 = 0: the correction at position 0 is 0; 1: the last entry is also the correction at 0.
    It acts at download only: changing it afterwards leaves the table as it is [A L1426-1432]."""
    c = card()
    c.raw(f"I30={i30}")
    leadscrew(c, "160 320 480 800")  # last entry 50 counts
    c.raw(f"I51=1 I30={1 - i30}")
    c.raw("#2J=500")
    c.tick(2000)
    assert correction(c) == pytest.approx(at_500)


def test_source_defaults_to_the_addressed_motor_and_actual_position() -> None:
    c = card()
    c.raw("#3 DEFINE COMP 2,2000")
    c.raw("320 0")
    c.raw("M369->D:$000190 I51=1 #3J=1000")
    c.tick(2000)
    assert int(c.ask("M369")) / M69_SCALE == pytest.approx(20.0)
    assert c.ask("#3 LIST COMP DEF") == "DEFINE COMP 2,#3,#3,2000"


# -- downloading, listing, deleting ---------------------------------------------------------------
def test_entries_list_as_sent_and_definitions_list_explicitly() -> None:
    c = card()
    leadscrew(c)
    c.raw("#4 DEFINE BLCOMP 3,300")
    c.raw("16 -32")
    c.raw("0")
    assert c.ask("#1 LIST COMP") == "160\r320\r480\r0"
    assert c.ask("#1 LIST COMP DEF") == "DEFINE COMP 4,#2D,#1,4000"
    assert c.ask("#4 LIST BLCOMP") == "16\r-32\r0"
    assert c.ask("#4 LIST BLCOMP DEF") == "DEFINE BLCOMP 3,300"
    assert c.ask("#4 LIST TCOMP DEF") == ""


def test_malformed_definitions_and_fractional_entries_are_err003() -> None:
    c = card()
    for bad in ("#1 DEFINE COMP 0,100", "#1 DEFINE COMP 4,#2", "#1 DEFINE BLCOMP 4,#2,100",
                "#1 DEFINE TCOMP 4", "#1 DEFINE COMP 4,#40,100", "#1 DEFINE COMP 4,-100"):
        assert c.raw(bad) == b"\x07ERR003\r", bad
    c.raw("#1 DEFINE TCOMP 2,100")
    assert c.raw("1.5") == b"\x07ERR003\r"
    c.raw("3 4")
    assert c.ask("#1 LIST TCOMP") == "3\r4"


# -- ERR007: the order of the buffers [Turbo SRM; spec §1.7] ----------------------------------------
def test_comp_tables_are_defined_high_to_low_and_deleted_low_to_high_with_the_2d_ones() -> None:
    c = card()
    c.raw("#3 DEFINE COMP 2,100")
    c.raw("0 0")
    assert c.raw("#3 DEFINE COMP 2.2,#1,10,10") == b"\x07ERR007\r"   # one COMP table per motor
    assert c.raw("#4 DEFINE COMP 2.2,#1,10,10") == b"\x07ERR007\r"   # a lower motor has one
    c.raw("#2 DEFINE COMP 1.1,#1,10,10")
    c.raw("0 0 0")
    assert c.raw("#5 DEFINE COMP 2,100") == b"\x07ERR007\r"
    assert c.raw("#3 DELETE COMP") == b"\x07ERR007\r"                 # #2 (2-D) still there
    c.raw("#2 DELETE COMP")
    c.raw("#3 DELETE COMP")
    assert c.ask("#3 LIST COMP") == ""
    c.raw("#5 DEFINE COMP 2,100")
    assert c.raw("0 0") == b"\x06"


@pytest.mark.parametrize(("existing", "refused"), [
    ("#2 DEFINE BLCOMP 2,100", ("#3 DEFINE COMP 2,100", "#3 DEFINE COMP 1.1,#1,10,10",
                                "#3 DEFINE BLCOMP 2,100")),
    ("#2 DEFINE TCOMP 2,100", ("#3 DEFINE COMP 2,100", "#3 DEFINE COMP 1.1,#1,10,10",
                               "#3 DEFINE BLCOMP 2,100", "#3 DEFINE TCOMP 2,100")),
])
def test_a_table_above_refuses_the_ones_below(existing: str, refused: tuple[str, ...]) -> None:
    """DEFINE COMP is refused while a TCOMP or BLCOMP exists; BLCOMP while a TCOMP exists
    (ASSUMPTION for TCOMP/BLCOMP: the buffer order COMP, BLCOMP, TCOMP, TBUF, ROTARY, GATHER)."""
    c = card()
    c.raw(existing)
    c.raw("0 0")
    for line in refused:
        assert c.raw(line) == b"\x07ERR007\r", line
    assert c.raw("#1" + existing[2:]) == b"\x06"  # a lower-numbered motor's of the same kind


@pytest.mark.parametrize("buffer", ["GATHER", "ROTARY", "TBUF", "LOOKAHEAD"])
def test_gather_rotary_and_other_buffers_refuse_every_table(buffer: str) -> None:
    """A GATHER, ROTARY, TBUF or LOOKAHEAD buffer refuses DEFINE COMP (both forms), BLCOMP and
    TCOMP: they sit above the tables in memory [Turbo SRM; A L3139, L3183-3185]."""
    c = card()
    existing = {buffer}
    c.fw.buffer_checks.append(lambda: existing)
    for line in ("#1 DEFINE COMP 2,100", "#1 DEFINE COMP 1.1,#2,10,10", "#1 DEFINE BLCOMP 2,100",
                 "#1 DEFINE TCOMP 2,100"):
        assert c.raw(line) == b"\x07ERR007\r", line
    existing.clear()
    assert c.raw("#1 DEFINE COMP 2,100") == b"\x06"


def test_a_defined_gather_buffer_refuses_tables_until_deleted() -> None:
    """The addendum's sequence: DEFINE COMP answers ERR007 while a GATHER buffer exists, and is
    accepted after DELETE GATHER [A L3179-3190]."""
    c = card()
    c.raw("DEFINE GATHER 100")
    assert c.raw("#2 DEFINE COMP 4,1000") == b"\x07ERR007\r"
    assert c.raw("#2 DEFINE BLCOMP 4,1000") == b"\x07ERR007\r"
    assert c.raw("#2 DEFINE COMP 1.1,#1,10,10") == b"\x07ERR007\r"
    c.raw("DELETE GATHER")
    assert c.raw("#2 DEFINE COMP 4,1000") == b"\x06"


# -- status, SAVE, reset --------------------------------------------------------------------------
def test_global_status_bit_14_with_a_table_and_i51() -> None:
    c = card()
    c.raw("#2 DEFINE BLCOMP 2,100")
    c.raw("0 0")
    assert not int(c.ask("???")[:6], 16) & (1 << 14)
    c.raw("I51=1")
    assert int(c.ask("???")[:6], 16) & (1 << 14)
    c.raw("#2 DELETE BLCOMP")
    assert not int(c.ask("???")[:6], 16) & (1 << 14)


def test_save_keeps_the_tables_as_downloaded_and_factory_reset_clears_them() -> None:
    c = card()
    c.raw("I30=1")
    leadscrew(c, "160 320 480 800")
    c.raw("#2 DEFINE TCOMP 2,100")
    c.raw("7 8")
    c.raw("SAVE")
    c.raw("$$$")
    c.raw("I3=2")
    c.raw("I51=1 M169->D:$000090 #2J=500")  # I30 is 0 again: the table keeps its wrapped zero
    c.tick(2000)
    assert correction(c) == pytest.approx(30.0)
    assert c.ask("#2 LIST TCOMP") == "7\r8"
    c.raw("$$$***")
    c.raw("I3=2")
    assert c.ask("#1 LIST COMP") == "" and c.ask("#2 LIST TCOMP") == ""


# -- backlash (Ixx85, Ixx86, Ixx87) -----------------------------------------------------------------
def test_backlash_is_taken_up_at_ixx85_on_reversal_and_released_going_positive() -> None:
    """Moving negative the commanded position loses Ixx86 (1/16 count), taken up at Ixx85 per cycle
    once the reversal exceeds Ixx87; moving positive again it is given back. P stays in the
    commanded frame [Turbo SRM Ixx85-Ixx87, UM "Backlash Compensation"]."""
    c = card(plant="servo")
    c.raw("I185=16 I186=160")   # 1 count per cycle, 10 counts
    c.raw("#1J=1000")
    c.tick(3000)
    assert encoder(c) == 1000
    c.raw("#1J=500")
    c.tick(3000)
    assert encoder(c) == 490
    assert abs(float(c.ask("#1P")) - 500) <= 1
    c.raw("#1J=800")
    c.tick(3000)
    assert encoder(c) == 800


def test_backlash_takeup_rate_and_hysteresis() -> None:
    c = card(plant="ideal")
    c.raw("I185=32 I186=160 I187=160")  # 2 counts per cycle, 10 counts, 10 counts of hysteresis
    c.raw("#1J=1000")
    c.tick(3000)
    bl = c.fw.comp1d
    c.raw("#1J=995")                    # a reversal of 5 counts: within the hysteresis
    c.tick(3000)
    assert bl.taken[0] == 0
    c.raw("#1J=900")
    taken = []
    for _ in range(2000):
        c.tick()
        taken.append(bl.taken[0])
        if taken[-1] == -10:
            break
    assert taken[-1] == -10
    steps = [b - a for a, b in zip([0.0, *taken], taken, strict=False) if b != a]
    assert steps == [-2.0] * 5         # Ixx85 = 32: 2 counts per cycle
    assert not bl.busy(c.fw.reports.commanded())   # taken up: nothing left to do at rest


def test_backlash_table_adds_to_ixx86_at_the_nominal_position_with_i51() -> None:
    c = card(plant="ideal")
    c.raw("I185=1000 I186=160")
    c.raw("#1 DEFINE BLCOMP 2,2000")
    c.raw("320 0")                      # +20 counts at 1000
    c.raw("#1J=1500")
    c.tick(3000)
    c.raw("#1J=1000")
    c.tick(3000)
    assert c.fw.comp1d.taken[0] == -10
    c.raw("I51=1")
    c.tick(10)
    assert c.fw.comp1d.taken[0] == -30


def test_no_backlash_without_ixx85() -> None:
    c = card(plant="servo")
    c.raw("I186=160")
    c.raw("#1J=1000")
    c.tick(3000)
    c.raw("#1J=500")
    c.tick(3000)
    assert encoder(c) == 500


# -- rest (decision 0008) -------------------------------------------------------------------------
def test_tables_at_rest_cost_nothing_and_backlash_takeup_is_work() -> None:
    """A card holding a leadscrew table and taken-up backlash rests once its motors settle (the
    correction depends on positions only); while backlash is taken up it does not; resting and
    cycle-by-cycle cards end alike."""
    from tests.devices.pmac.test_cycle_runs import Twin

    twin = Twin(True, "servo")
    for line in ("#1 DEFINE COMP 4,#2D,#1,4000", "160 320 480 0", "I51=1 I185=1 I186=160",
                 "#2J=1500 #1J=1000"):
        twin.send(line)
    twin.tick(6000)
    twin.same()
    fast = twin.cards[0]
    assert fast.rest_state() is not None
    twin.send("#1J=900")
    twin.tick(2000)                                  # the move is over, 10 counts take 160 cycles
    twin.same()
    skipped = fast.quiet_skipped
    twin.tick(3000)
    twin.same()
    assert fast.quiet_skipped > skipped              # at rest again, table and backlash held
    assert fast.fw.comp1d.taken[0] == -10
    core = fast.fw.motors.core
    assert core.axes.encoder[0] + core.encoder_slip[0] == 900 + 15 - 10  # the stage's true count
