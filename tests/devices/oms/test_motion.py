"""MAXk moves, loops and waits through the command ring of a real daemon (lockstep clock): the
linear profile with base velocity [S §2.14; spec oms.md §5.2], `ID` and the done flag [spec §3.4],
the stop commands flushing the queues, `LS`/`LE`, `SW`, `WT` [S §6.2; spec §4.3 "Motion"].

The axes are open-loop steppers (PSO): the step count follows the profile exactly, so times and
positions are the profile's. Times are measured in update cycles of 1/1024 s; the card starts a
queued move at the cycle after the command and sets done at the cycle after the move ended, so a
measured time is the profile's within two cycles (spec §5.2 allows ±2 ticks).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from vdevmaps.oms import MaxkDoorbell, Mu

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd.devices.oms.profile import linear
from vdevd.rt.profiles import Phase

DT = 1 / 1024  # the factory update rate [S §2.13]
NS = 1_000_000_000


@pytest.fixture
def steppers() -> Iterator[Maxk]:
    """Four open-loop stepper axes (PSO), the factory axis type [S §4.1]."""
    with maxk_card(axis_types=["stepper"] * 4) as maxk:
        yield maxk


def seconds_until(maxk: Maxk, bits: int, timeout_s: float = 20.0) -> float:
    """Simulated seconds until any of the doorbell `bits` is set (fails on time-out)."""
    start = maxk.rack.sim.now_ns()
    got = maxk.mu.wait_value(Mu.ODBR, 0, mask=bits, timeout_s=timeout_s, equal=False)
    assert got is not None, f"ODBR {bits:#x} not set within {timeout_s} s"
    return (maxk.rack.sim.now_ns() - start) / NS


def number(maxk: Maxk, text: str) -> int:
    return int(maxk.query(text + ";"))


# -- the linear profile [S §2.14; spec §5.2] -----------------------------------------------------
def test_trapezoid_takes_d_over_vl_plus_vl_over_ac_and_ends_at_the_target(steppers: Maxk) -> None:
    """VB = 0: t = |d|/VL + VL/AC, "±0 counts for point-to-point moves" [S App C; spec §5.2]."""
    steppers.send("AX VL10000 AC100000 MR50000 GO ID;")
    elapsed = seconds_until(steppers, MaxkDoorbell.DONE_X)
    assert elapsed == pytest.approx(50000 / 10000 + 10000 / 100000, abs=2 * DT)
    assert number(steppers, "AX RP") == 50000
    assert steppers.word(0x000) == 50000  # the X motor position word [S Table 3-1]


def test_velocity_during_the_cruise_is_vl(steppers: Maxk) -> None:
    steppers.send("AX VL10000 AC100000 MR50000 GO;")
    steppers.step(1024)  # 1 s: past the 0.1 s ramp, far from the end
    assert number(steppers, "AX RV") == 10000


def test_short_move_is_a_triangle_of_peak_sqrt_ac_d(steppers: Maxk) -> None:
    """|d| < VL²/AC: no cruise; t = 2·sqrt(|d|/AC), peak sqrt(AC·|d|) [spec §5.2]."""
    steppers.send("AX VL10000 AC100000 MR-400 GO ID;")
    assert seconds_until(steppers, MaxkDoorbell.DONE_X) == pytest.approx(2 * math.sqrt(400 / 100000),
                                                             abs=2 * DT)
    assert number(steppers, "AX RP") == -400
    steppers.send("AX MR400 GO;")
    steppers.step(round(math.sqrt(400 / 100000) / DT))  # the apex
    assert number(steppers, "AX RV") == pytest.approx(math.sqrt(100000 * 400), abs=100000 * DT)


def test_move_starts_at_vb_and_takes_the_base_velocity_profile_time(steppers: Maxk) -> None:
    """The velocity jumps to VB, ramps at AC to VL, cruises, ramps down to VB and stops at the
    target [S §2.14 "Velocity Base"; spec §5.2]."""
    vb, vl, ac, d = 2000, 10000, 100000, 50000
    steppers.send(f"AX VB{vb} VL{vl} AC{ac} MR{d} GO ID;")
    steppers.step(1)  # the cycle that starts the move
    first = number(steppers, "AX RV")
    assert vb <= first <= vb + ac * DT + 1  # RV is rounded to a count/s
    ramp = (vl - vb) / ac
    expected = 2 * ramp + (d - (vl * vl - vb * vb) / ac) / vl
    assert DT + seconds_until(steppers, MaxkDoorbell.DONE_X) == pytest.approx(expected, abs=2 * DT)
    assert number(steppers, "AX RP") == d
    assert number(steppers, "AX RV") == 0


def test_velocity_ramps_down_to_vb_before_the_stop(steppers: Maxk) -> None:
    vb, vl, ac, d = 2000, 10000, 100000, 20000
    steppers.send(f"AX VB{vb} VL{vl} AC{ac} MR{d} GO;")
    end = 2 * (vl - vb) / ac + (d - (vl * vl - vb * vb) / ac) / vl
    steppers.step(round((end - 0.01) / DT))  # 10 ms before the end: VB + AC·10 ms
    assert number(steppers, "AX RV") == pytest.approx(vb + ac * 0.01, abs=2 * ac * DT)


def test_short_move_with_vb_peaks_at_sqrt_vb2_plus_ac_d(steppers: Maxk) -> None:
    vb, vl, ac, d = 2000, 10000, 100000, 500
    peak = math.sqrt(vb * vb + ac * d)
    steppers.send(f"AX VB{vb} VL{vl} AC{ac} MR{d} GO ID;")
    steppers.step(round((peak - vb) / ac / DT))
    assert number(steppers, "AX RV") == pytest.approx(peak, abs=2 * ac * DT)
    seconds_until(steppers, MaxkDoorbell.DONE_X)
    assert number(steppers, "AX RP") == d


@settings(max_examples=200, deadline=None)
@given(d=st.integers(-2_000_000, 2_000_000), vl=st.integers(2, 4_194_303),
       ac=st.integers(1000, 8_000_000), vb_share=st.floats(0, 0.99))
def test_linear_profile_bounds_and_exact_end(d: int, vl: int, ac: int, vb_share: float) -> None:
    """Seeded property test of the planner: speed within [VB, VL] while moving, acceleration
    within AC, monotonic progress, the end exactly at the target (STYLE §5)."""
    vb = math.floor(vl * vb_share)
    p0 = 12.0
    phases = linear(0.0, p0, p0 + d, vb, vl, ac)
    assert phases[-1] == Phase(phases[-1].t0, math.inf, p0 + d, 0.0, 0.0, 0.0)
    moving = phases[:-1]
    assert sum(ph.dur for ph in moving) == pytest.approx(phases[-1].t0)
    for ph, nxt in zip(moving, phases[1:], strict=True):
        p, v, a = ph.end_state()
        assert abs(ph.a0) <= ac and abs(ph.v0) <= vl * (1 + 1e-12)
        assert abs(v) >= vb * (1 - 1e-9) and abs(v) <= vl * (1 + 1e-12)
        assert ph.v0 * np.sign(d) >= 0 and v * np.sign(d) >= -1e-9 * vl  # never backwards
        assert p == pytest.approx(nxt.p0, abs=1e-6 * max(1.0, abs(d)))
        if nxt.dur != math.inf:
            assert v == pytest.approx(nxt.v0, abs=1e-6 * vl)


# -- ID and the done flag [spec §3.4] -------------------------------------------------------------
def test_id_sets_done_and_the_doorbell_only_after_the_move(steppers: Maxk) -> None:
    steppers.send("AX VL10000 AC100000 MR5000 GO ID;")
    steppers.step(100)
    assert steppers.query("AX QA;")[1] == "N"
    assert not steppers.odbr() & MaxkDoorbell.DONE_X
    seconds_until(steppers, MaxkDoorbell.DONE_X)
    assert steppers.query("AX QA;")[1] == "D"
    assert number(steppers, "AX RP") == 5000


@pytest.mark.parametrize("stop", ["AX ST", "SA", "KL", "AX KS"])
def test_a_stop_flushes_the_queue_so_a_pending_id_never_fires(steppers: Maxk, stop: str) -> None:
    """ST/SA decelerate, KL/KS stop at once; each flushes the queues [spec §4.3 "Motion"]."""
    steppers.send("AX VL10000 AC100000 MR50000 GO ID MR-50000 GO ID;")
    steppers.step(512)
    steppers.send(stop + ";")
    steppers.step(512)
    assert number(steppers, "AX RV") == 0
    assert steppers.mu.wait_value(Mu.ODBR, 0, mask=MaxkDoorbell.DONE_X, timeout_s=10, equal=False) is None
    assert steppers.query("AX QA;")[1] == "N"
    assert 0 < number(steppers, "AX RP") < 10000


def test_kl_stops_at_once_st_decelerates_at_ac(steppers: Maxk) -> None:
    steppers.send("AX VL10000 AC100000 JG10000; AY VL10000 AC100000 JG10000;")
    steppers.step(512)
    x0, y0 = number(steppers, "AX RP"), number(steppers, "AY RP")
    steppers.send("AX KS; AY ST;")
    steppers.step(512)
    assert number(steppers, "AX RP") - x0 <= 10000 * DT + 1
    assert number(steppers, "AY RP") - y0 == pytest.approx(10000**2 / (2 * 100000),
                                                          abs=10000 * DT + 1)


# -- loops and waits [S §6.2; spec §4.3] ----------------------------------------------------------
def test_nested_loops_repeat_their_moves(steppers: Maxk) -> None:
    """LS#/LE nest; the queue space is reused (RQC back where it was after the loops)."""
    free = number(steppers, "AX RQC")
    steppers.send("AX VL100000 AC1000000 LS3 MR100 GO LS2 MR10 GO LE LE ID;")
    seconds_until(steppers, MaxkDoorbell.DONE_X)
    assert number(steppers, "AX RP") == 3 * (100 + 2 * 10)
    assert number(steppers, "AX RQC") == free


def test_sw_holds_the_queue_until_the_input_is_high(steppers: Maxk) -> None:
    steppers.control("set_input", bit=3, level=0)
    steppers.send("AX SW3 MR100 GO ID;")
    steppers.step(200)
    assert number(steppers, "AX RP") == 0
    steppers.control("set_input", bit=3, level=1)
    seconds_until(steppers, MaxkDoorbell.DONE_X)
    assert number(steppers, "AX RP") == 100


def test_wt_holds_the_queue_for_milliseconds_of_card_time(steppers: Maxk) -> None:
    steppers.send("AX VL100000 AC8000000 WT250 MR100 GO ID;")
    steppers.step(round(0.245 / DT))
    assert number(steppers, "AX RP") == 0
    elapsed = 0.245 + seconds_until(steppers, MaxkDoorbell.DONE_X)
    move = 2 * math.sqrt(100 / 8000000)
    assert elapsed == pytest.approx(0.25 + move, abs=3 * DT)
    assert number(steppers, "AX RP") == 100
