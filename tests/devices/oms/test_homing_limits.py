"""MAXk homing and limits through a real daemon (lockstep clock): HM/HR/KM/KR and the home
switch polarity [S §4.3, §4.8; spec oms.md §5.5], HI (switch AND encoder index), the limit
inputs, their polarity and modes [S §4.2; spec §5.6], and what the host sees: the over-travel
doorbell bits [S §3.4.2, §3.4.5], QA [spec §4.2], the limit and home words at 0x040/0x044
(raw input levels, Tables 3-2 and 3-3).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from vdevmaps.oms import MaxkDoorbell, Mu, Shm

from tests.devices.oms.conftest import Maxk, maxk_card

DT = 1 / 1024
VL, AC = 10000, 100000
STOP = VL**2 / (2 * AC)  # counts run while ramping down from VL at AC


@pytest.fixture
def steppers() -> Iterator[Maxk]:
    with maxk_card(axis_types=["stepper"] * 3 + ["stepper_encoder"]) as maxk:
        maxk.send(f"AA VL{VL},{VL},{VL},{VL} AC{AC},{AC},{AC},{AC}; AX;")
        yield maxk


def number(maxk: Maxk, text: str) -> int:
    return int(maxk.query(text + ";"))


def qa(maxk: Maxk, axis: str = "X") -> str:
    return maxk.query(f"A{axis} QA;")


def done_within(maxk: Maxk, bits: int = MaxkDoorbell.DONE_X, timeout_s: float = 10.0) -> bool:
    return maxk.mu.wait_value(Mu.ODBR, 0, mask=bits, timeout_s=timeout_s, equal=False) is not None


# -- home switch [S §4.3, §4.8; spec §5.5] ---------------------------------------------------------
def test_hm_loads_the_operand_at_the_switch_and_ramps_to_a_stop(steppers: Maxk) -> None:
    """"the axis position counter will be reset to a selected value when the switch is
    activated. At this point the MAXk can either ramp the axis to a stop" [S §4.8]: the final
    position is the operand plus the ramp-down distance (spec §5.5)."""
    steppers.control("set_home_edge", axis="X", position=5000)
    steppers.send("AX HM100 ID;")
    assert done_within(steppers)
    assert number(steppers, "AX RP") == pytest.approx(100 + STOP, abs=VL * DT + 1)
    assert qa(steppers)[3] == "H"  # beyond the edge: on the switch
    assert steppers.shm.read32(Shm.HOME_SWITCH_STATUS) & 1 == 0  # active low: the raw level reads 0


def test_the_switch_edge_is_the_operand_after_homing(steppers: Maxk) -> None:
    steppers.control("set_home_edge", axis="X", position=5000)
    steppers.send("AX HM100 ID; AX MA100 GO MA99 GO;")
    assert done_within(steppers)
    steppers.step(200)
    assert number(steppers, "AX RP") == 99
    assert qa(steppers)[3] == "N"
    steppers.send("AX MA100 GO;")
    steppers.step(200)
    assert qa(steppers)[3] == "H"


def test_hr_homes_in_the_reverse_direction(steppers: Maxk) -> None:
    """HR: "same in the reverse direction" (spec §4.3); a switch flag from -5000 to -4000 is
    met at its upper edge."""
    steppers.control("set_home_edge", axis="X", position=-5000, width=1000)
    steppers.send("AX HR-20 ID;")
    assert done_within(steppers)
    assert number(steppers, "AX RP") == pytest.approx(-20 - STOP, abs=VL * DT + 1)
    assert qa(steppers)[0] == "M"


def test_km_stops_at_once_at_the_switch(steppers: Maxk) -> None:
    """KM/KR: home and "stop the axis immediately" [S §4.8]."""
    steppers.control("set_home_edge", axis="X", position=3000)
    steppers.send("AX KM0 ID;")
    assert done_within(steppers)
    assert 0 <= number(steppers, "AX RP") <= VL * DT + 1


def test_an_axis_on_its_switch_is_homed_where_it_stands(steppers: Maxk) -> None:
    steppers.control("set_home", axis="X", active=True)
    steppers.send("AX LP777 HM5 ID;")
    assert done_within(steppers)
    assert number(steppers, "AX RP") == 5


def test_home_switch_polarity_hh_hl(steppers: Maxk) -> None:
    """The home input is active low from the factory; HH makes the high level active [S §2.14].
    The word at 0x044 shows raw levels (X in bit 0, Table 3-3)."""
    assert steppers.shm.read32(Shm.HOME_SWITCH_STATUS) & 0xF == 0xF  # open inputs read high: no switch active
    assert qa(steppers)[3] == "N"
    steppers.control("set_home", axis="X", active=True)
    assert steppers.shm.read32(Shm.HOME_SWITCH_STATUS) & 0xF == 0xE
    assert qa(steppers)[3] == "H"
    steppers.send("AX HH;")
    assert qa(steppers)[3] == "N"  # the same low level is now inactive ...
    assert qa(steppers, "Y")[3] == "N"
    steppers.send("AY HH;")
    assert qa(steppers, "Y")[3] == "H"  # ... and Y's open (high) input active


def test_homing_that_meets_a_limit_stops_with_over_travel_and_no_done(steppers: Maxk) -> None:
    """"if a limit is hit before home, stop, flag over-travel, no done" (spec §5.5)."""
    steppers.send("AX HM0 ID;")
    steppers.step(300)
    steppers.control("set_limits", axis="X", positive=True)
    steppers.step(2)
    assert number(steppers, "AX RV") == 0
    assert steppers.odbr() & MaxkDoorbell.OVERTRAVEL_X
    assert not done_within(steppers, timeout_s=2)
    assert qa(steppers) == "PNLN"


def test_hi_homes_on_the_index_pulse_inside_the_switch(steppers: Maxk) -> None:
    """HI: home = index pulse AND home switch [S §4.8]: with index pulses every 1000 counts from
    250 and the switch from 5000 up, home is the pulse at 5250, whose count becomes the
    operand; the switch edge is then 250 counts below it."""
    steppers.control("set_index", axis="T", period=1000, phase=250)
    steppers.control("set_home_edge", axis="T", position=5000)
    steppers.send("AT HI HM0 ID;")
    assert done_within(steppers, bits=1 << 3)
    assert number(steppers, "AT RE") == pytest.approx(STOP, abs=VL * DT + 1)
    steppers.send("AT MA-250 GO;")
    steppers.step(300)
    assert qa(steppers, "T")[3] == "H"
    steppers.send("AT MA-251 GO;")
    steppers.step(100)
    assert qa(steppers, "T")[3] == "N"


def test_hs_is_switch_homing_again(steppers: Maxk) -> None:
    steppers.control("set_index", axis="T", period=1000, phase=250)
    steppers.control("set_home_edge", axis="T", position=5000)
    steppers.send("AT HI HS HM0 ID;")
    assert done_within(steppers, bits=1 << 3)
    steppers.send("AT MA0 GO;")
    steppers.step(300)
    assert qa(steppers, "T")[3] == "H"  # the switch edge is at 0, not the pulse


def test_hi_needs_an_encoder(steppers: Maxk) -> None:
    steppers.send("AX HI;")
    assert steppers.command_error()


# -- limits [S §4.2; spec §5.6] ------------------------------------------------------------------------
def test_limit_word_shows_raw_levels(steppers: Maxk) -> None:
    """Table 3-2: X..S negative in bits 0-7, positive in 8-15; the factory polarity is active
    low, so idle (pulled-up) inputs read 1 and an active switch 0."""
    assert steppers.shm.read32(Shm.LIMIT_SWITCH_STATUS) == 0x0F0F
    steppers.control("set_limits", axis="Y", positive=True)
    steppers.control("set_limits", axis="Z", negative=True)
    assert steppers.shm.read32(Shm.LIMIT_SWITCH_STATUS) == 0x0D0B
    assert int(steppers.query("QL;"), 16) == 0x0D0B


def test_hard_limit_stops_at_once_flags_over_travel_and_flushes_the_queue(steppers: Maxk) -> None:
    """Hard mode (factory): "stop without deceleration"; ODBR bit 8 + axis; QA 'L'; the queue
    flushed so the pending ID never sets done [S §3.4.2; spec §3.4]."""
    steppers.send("AX MR100000 GO ID MR-5 GO ID;")
    steppers.step(512)
    here = number(steppers, "AX RP")
    steppers.control("set_limits", axis="X", positive=True)
    steppers.step(2)
    assert number(steppers, "AX RV") == 0
    assert number(steppers, "AX RP") - here <= 2 * VL * DT + 1
    assert steppers.odbr() & MaxkDoorbell.OVERTRAVEL_X
    assert qa(steppers)[2] == "L"
    assert not done_within(steppers, timeout_s=2)
    assert number(steppers, "AX RQC") == 2559


def test_soft_limit_mode_decelerates_at_ac(steppers: Maxk) -> None:
    """LMS: "decelerate to a stop" [S §4.2]."""
    steppers.send("AX LMS JG10000;")
    steppers.step(512)
    here = number(steppers, "AX RP")
    steppers.control("set_limits", axis="X", positive=True)
    steppers.step(300)
    assert number(steppers, "AX RV") == 0
    assert number(steppers, "AX RP") - here == pytest.approx(STOP, abs=VL * DT + 1)
    assert steppers.odbr() & MaxkDoorbell.OVERTRAVEL_X


def test_limits_off_are_ignored(steppers: Maxk) -> None:
    steppers.send("AX LMF JG10000;")
    steppers.step(100)
    steppers.control("set_limits", axis="X", positive=True)
    steppers.step(100)
    assert number(steppers, "AX RV") == 10000
    assert not steppers.odbr() & MaxkDoorbell.OVERTRAVEL_X
    assert qa(steppers)[2] == "N"
    assert steppers.shm.read32(Shm.LIMIT_SWITCH_STATUS) & 0x100 == 0  # the raw level still shows


def test_motion_away_from_an_active_limit_is_allowed_toward_it_refused(steppers: Maxk) -> None:
    """"the limit condition removes any further excitation in the limit direction" [S §4.2]."""
    steppers.control("set_limits", axis="X", positive=True)
    steppers.send("AX MR-100 GO ID;")
    assert done_within(steppers)
    assert number(steppers, "AX RP") == -100
    steppers.clear_odbr()
    steppers.send("AX CA MR100 GO ID;")
    steppers.step(100)
    assert number(steppers, "AX RP") == -100
    assert steppers.odbr() & MaxkDoorbell.OVERTRAVEL_X
    assert not steppers.odbr() & MaxkDoorbell.DONE_X
    assert qa(steppers) == "PNLN"
    steppers.clear_odbr()
    steppers.send("AX JG5000 ID;")  # a jog toward it too
    steppers.step(10)
    assert steppers.odbr() & (MaxkDoorbell.OVERTRAVEL_X | MaxkDoorbell.DONE_X) == MaxkDoorbell.OVERTRAVEL_X


def test_lth_makes_the_high_level_active(steppers: Maxk) -> None:
    """LTH/LTL select the active level [S §4.2]: with LTH an open (high) input is a limit."""
    steppers.send("AX LTH;")
    assert steppers.query("AX LT?;") == "=h"
    assert qa(steppers)[2] == "L"
    steppers.send("AX MR100 GO ID;")
    steppers.step(20)
    assert number(steppers, "AX RP") == 0
    assert steppers.odbr() & MaxkDoorbell.OVERTRAVEL_X
    steppers.send("AX LTL;")
    assert qa(steppers)[2] == "N"


def test_w_axis_over_travel_sets_its_status_word_and_odbr_bit_25() -> None:
    """W and K have no ODBR bits of their own: bit 8 of the W status word (0x0CC) and ODBR bit 25
    [S §3.4.5; spec §3.1]."""
    with maxk_card(axes=10, axis_types=["stepper"] * 10) as maxk:
        maxk.send("AW VL10000 AC100000 MR100000 GO ID;")
        maxk.step(300)
        maxk.control("set_limits", axis="W", positive=True)
        maxk.step(2)
        assert maxk.odbr() & MaxkDoorbell.W_NOTIFICATION
        assert maxk.shm.read32(Shm.W_STATUS_FLAGS) & (1 << 8)
        assert not maxk.shm.read32(Shm.W_STATUS_FLAGS) & 1
        assert maxk.query("AW QA;")[2] == "L"
        assert int(maxk.query("QL;"), 16) & (1 << 24) == 0  # W positive: bit 24, active low
