"""The per-axis velocity profiles of a move from rest: linear (default), parabolic and S-curve
(card option `profiles`; [S §2.14, App C]; spec oms.md §5.2).

Planner tests check the phases (continuous, bounded, exactly on the goal). Card tests run a real
daemon (lockstep clock, `plant = "ideal"`: the motor position word is the rounded command) and
sample the X..Z motor position words (0x000, [S Table 3-1]) every update cycle. A move sent
between two cycles starts at the next one with t = 0 at the time it was sent, so sample k holds
the profile at k update periods. Accelerations are central second differences over h cycles:
the positions are whole counts, so one estimate is off by at most 2/(h·dt)² counts/s² from the
exact value, which it equals inside a stretch of linear acceleration (positions cubic in time).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from vdevmaps.oms import MaxkDoorbell, Shm

from tests.devices.oms.conftest import Maxk, card_config, maxk_card
from vdevd.config import ConfigError, parse
from vdevd.daemon import build_rack
from vdevd.devices.oms.params import PROFILES
from vdevd.devices.oms.profile import PLANNERS, linear, parabolic, planner, scurve
from vdevd.rt.profiles import Phase

DT = 1 / 1024  # the factory update rate [S §2.13]
NS = 1_000_000_000
# a fast axis, so that whole-count rounding is small beside the accelerations measured
VL, AC = 1_000_000, 8_000_000
D = 600_000  # long enough to cruise with every profile
TYPES = ["stepper"] * 4


# -- the planners ----------------------------------------------------------------------------------
def moving_phases(phases: list[Phase], goal: float) -> list[Phase]:
    """The phases before the hold, after checking the hold is exactly at `goal`."""
    assert phases[-1] == Phase(phases[-1].t0, math.inf, goal, 0.0, 0.0, 0.0)
    return phases[:-1]


@settings(max_examples=300, deadline=None, derandomize=True)
@given(name=st.sampled_from(["parabolic", "scurve"]), d=st.integers(-2_000_000, 2_000_000),
       vl=st.integers(2, 4_194_303), ac=st.integers(1000, 8_000_000), vb_share=st.floats(0, 0.99))
def test_parabolic_and_scurve_phases_are_continuous_bounded_and_end_on_the_goal(
        name: str, d: int, vl: int, ac: int, vb_share: float) -> None:
    """Seeded property test (STYLE §5): position, velocity and acceleration continuous from the
    VB jump to the stop from VB (S-curve: the acceleration is 0 at both ends), speed within
    [VB, VL], |acceleration| <= AC, S-curve jerk <= AC²/(VL − VB), never backwards, the last
    moving phase ending on the goal at VB, the hold exactly on it."""
    vb = math.floor(vl * vb_share)
    p0 = -7.0
    goal = p0 + d
    phases = PLANNERS[name](3.0, p0, goal, vb, vl, ac)
    moving = moving_phases(phases, goal)
    if d == 0:
        assert not moving
        return
    s, scale = math.copysign(1.0, d), max(1.0, abs(d))
    assert moving[0].t0 == 3.0 and moving[0].p0 == p0 and moving[0].v0 == s * vb
    jerk = ac * ac / (vl - vb) if vl > vb else math.inf
    for ph, nxt in zip(moving, phases[1:], strict=True):
        assert nxt.t0 == pytest.approx(ph.t0 + ph.dur, abs=1e-12 * (1 + nxt.t0))
        p, v, a = ph.end_state()
        assert abs(ph.a0) <= ac * (1 + 1e-12) and abs(a) <= ac * (1 + 1e-9)
        assert vb * (1 - 1e-9) <= s * ph.v0 <= vl * (1 + 1e-12)
        assert vb * (1 - 1e-9) - 1e-9 <= s * v <= vl * (1 + 1e-9)
        if name == "scurve":
            assert abs(ph.j) <= jerk * (1 + 1e-9)
        if nxt is phases[-1]:
            assert p == pytest.approx(goal, abs=1e-7 * scale)
            assert v == pytest.approx(s * vb, abs=1e-6 * vl)
        else:
            assert p == pytest.approx(nxt.p0, abs=1e-7 * scale)
            assert v == pytest.approx(nxt.v0, abs=1e-6 * vl)
            assert a == pytest.approx(nxt.a0, abs=1e-6 * ac)
    if name == "scurve":
        assert moving[0].a0 == 0 and moving[-1].end_state()[2] == pytest.approx(0, abs=1e-6 * ac)
    else:
        assert moving[0].a0 == s * ac  # the parabola starts at AC ...
        assert moving[-1].end_state()[2] == pytest.approx(-s * ac)  # ... and its mirror ends at AC


def test_a_parabolic_ramp_falls_from_ac_to_zero_and_takes_twice_the_linear_time() -> None:
    vb, vl, ac = 20_000.0, 220_000.0, 1_000_000.0
    up, cruise, down = moving_phases(parabolic(0.0, 0.0, 500_000, vb, vl, ac), 500_000)
    lin = linear(0.0, 0.0, 500_000, vb, vl, ac)
    assert up.dur == pytest.approx(2 * lin[0].dur) == pytest.approx(2 * (vl - vb) / ac)
    assert (up.a0, up.j) == (ac, pytest.approx(-ac / up.dur))
    assert up.end_state()[1:] == pytest.approx((vl, 0.0))
    # the ramp covers its time times the parabola's mean velocity VB + 2/3 (VL − VB)
    assert cruise.p0 == pytest.approx(up.dur * (vb + 2 / 3 * (vl - vb)))
    assert (cruise.v0, cruise.a0, cruise.j) == (vl, 0.0, 0.0)
    assert (down.a0, down.j) == (0.0, pytest.approx(-ac / down.dur))
    assert down.dur == up.dur and down.p0 == pytest.approx(500_000 - cruise.p0)


def test_a_short_parabolic_move_is_two_ramps_to_the_peak_that_covers_the_distance() -> None:
    """No cruise; the ramp by dv covers (2·dv/AC)·(VB + 2·dv/3), twice that is |d|."""
    vb, vl, ac, d = 3_000.0, 200_000.0, 1_000_000.0, -7_000
    up, down = moving_phases(parabolic(0.0, 0.0, d, vb, vl, ac), d)
    dv = (-4 * vb + math.sqrt(16 * vb**2 + 32 / 3 * ac * abs(d))) / (16 / 3)  # textbook root
    assert abs(up.end_state()[1]) == pytest.approx(vb + dv) and vb + dv < vl
    assert up.dur == down.dur == pytest.approx(2 * dv / ac)
    assert up.a0 == -ac and up.end_state()[2] == pytest.approx(0, abs=1e-6)


def test_scurve_jerk_is_ac_squared_over_vl_minus_vb_for_four_jerk_quarters() -> None:
    vb, vl, ac = 10_000.0, 210_000.0, 1_000_000.0
    phases = moving_phases(scurve(0.0, 0.0, 500_000, vb, vl, ac), 500_000)
    jerk = ac * ac / (vl - vb)
    assert [ph.j for ph in phases] == pytest.approx([jerk, -jerk, 0.0, -jerk, jerk])
    assert phases[1].a0 == pytest.approx(ac)  # the peak, at the middle of the ramp
    assert phases[0].dur + phases[1].dur == pytest.approx(2 * (vl - vb) / ac)


def test_a_short_scurve_move_keeps_the_jerk_and_peaks_lower_in_speed_and_acceleration() -> None:
    """VB = 0: |d| = 2·dv^(3/2)/sqrt(J), peak acceleration sqrt(J·dv) < AC."""
    vl, ac, d = 200_000.0, 1_000_000.0, 5_000
    jerk = ac * ac / vl
    phases = moving_phases(scurve(0.0, 0.0, d, 0.0, vl, ac), d)
    assert [ph.j for ph in phases] == pytest.approx([jerk, -jerk, -jerk, jerk])
    dv = (d * math.sqrt(jerk) / 2) ** (2 / 3)
    assert phases[2].v0 == pytest.approx(dv, rel=1e-9) and dv < vl
    assert phases[1].a0 == pytest.approx(math.sqrt(jerk * dv), rel=1e-9)
    assert phases[1].a0 < 0.8 * ac
    assert phases[-1].t0 + phases[-1].dur == pytest.approx(4 * math.sqrt(dv / jerk))


def test_scurve_with_a_larger_jerk_has_the_constant_acceleration_segments_of_seven() -> None:
    vl, ac = 200_000.0, 1_000_000.0
    phases = moving_phases(scurve(0.0, 0.0, 500_000, 0.0, vl, ac, jerk=4 * ac * ac / vl), 500_000)
    assert len(phases) == 7
    assert [ph.j == 0 for ph in phases] == [False, True, False, True, False, True, False]
    assert (phases[1].a0, phases[5].a0) == (pytest.approx(ac), pytest.approx(-ac))


def test_every_profile_the_card_option_allows_has_a_planner() -> None:
    assert set(PLANNERS) == set(PROFILES)
    with pytest.raises(ValueError, match="cubic"):
        planner("cubic")


# -- the card ---------------------------------------------------------------------------------------
@dataclass
class Trace:
    """Motor positions of axes X.. sampled every update cycle from a command on."""

    t: np.ndarray  # seconds since the command: 0 (sent), then one update period apart
    x: np.ndarray  # [axis, sample] positions
    done: list[float]  # per axis: when its done bit rose (seconds since the command)


def trace(maxk: Maxk, text: str, axes: int, cycles: int) -> Trace:
    """Send `text` and sample the first `axes` motor words and the done bits each cycle."""
    def words() -> tuple[int, ...]:
        return struct.unpack(f">{axes}i", maxk.shm.read(Shm.MOTOR_POSITION, 4 * axes))

    maxk.clear_odbr()
    start = maxk.rack.sim.now_ns()
    times, samples = [0.0], [words()]
    done = [math.nan] * axes
    maxk.send(text)
    for _ in range(cycles):
        now = maxk.step(1)
        times.append((now - start) / NS)
        samples.append(words())
        bits = maxk.odbr()
        for a in range(axes):
            if math.isnan(done[a]) and bits & MaxkDoorbell.DONE_X << a:
                done[a] = times[-1]
    return Trace(np.array(times), np.array(samples, dtype=float).T, done)


def acceleration(x: np.ndarray, h: int) -> np.ndarray:
    """Central second differences over h cycles; a[k] estimates sample k (nan where the window
    leaves the trace)."""
    a = np.full(len(x), np.nan)
    a[h:-h] = (x[2 * h:] - 2 * x[h:-h] + x[:-2 * h]) / (h * DT) ** 2
    return a


def assert_ends_on_target(tr: Trace, axis: int, target: int, t_end: float) -> None:
    """Done between one and two update cycles after the profile's end: the end is seen at the
    first cycle at or after it, and the queued `ID` sets done at the next cycle; the position
    reached the target (whole counts) and stayed."""
    done = tr.done[axis]
    assert t_end + DT - 1e-6 <= done <= t_end + 2 * DT + 1e-6, (done, t_end)
    after = tr.x[axis][tr.t >= t_end]
    assert len(after) and (after == target).all()
    assert (tr.x[axis][tr.t < t_end - 10 * DT] != target).all()  # not early


def at(seconds: float) -> int:
    """The sample index at `seconds` after the command."""
    return round(seconds / DT)


def position(phases: list[Phase], t: float) -> float:
    """The planned position at time t."""
    ph = next(ph for ph in phases if t < ph.t0 + ph.dur)
    tau = t - ph.t0
    return ph.p0 + tau * (ph.v0 + tau * (ph.a0 / 2 + ph.j * tau / 6))


def parabolic_time(d: float, vb: float, vl: float, ac: float) -> float:
    """A move that reaches VL: two parabolic ramps of 2·(VL − VB)/AC and the cruise between."""
    rise = 2 * (vl - vb) / ac
    return 2 * rise + (d - 2 * rise * (vb + 2 / 3 * (vl - vb))) / vl


def scurve_time(d: float, vb: float, vl: float, ac: float) -> float:
    """A move that reaches VL: two S ramps of 2·(VL − VB)/AC (mean speed (VB + VL)/2)."""
    rise = 2 * (vl - vb) / ac
    return 2 * rise + (d - rise * (vb + vl)) / vl


@pytest.fixture
def mixed() -> Iterator[Maxk]:
    """X parabolic, Y linear, Z S-curve, T linear (given explicitly)."""
    with maxk_card(axis_types=TYPES, plant="ideal",
                   profiles=["parabolic", "linear", "scurve", "linear"]) as maxk:
        yield maxk


def test_parabolic_move_starts_at_ac_falls_to_zero_and_ends_on_target_in_time(
        mixed: Maxk) -> None:
    tr = trace(mixed, f"AX VL{VL} VB0 AC{AC} MR{D} GO ID;", 1, 850)
    x = tr.x[0]
    rise = 2 * VL / AC  # 0.25 s: twice the linear ramp
    assert_ends_on_target(tr, 0, D, parabolic_time(D, 0, VL, AC))
    h = 8
    a, tol = acceleration(x, h), 2 / (h * DT) ** 2
    assert tol < 0.005 * AC
    assert a[h] >= 0.96 * AC  # "starts near AC": AC·(1 − h·dt/rise) at h cycles
    for k in range(h, at(rise) - h):  # a(t) = AC·(1 − t/rise): a straight fall ...
        assert a[k] == pytest.approx(AC * (1 - tr.t[k] / rise), abs=tol), k
    assert np.all(np.diff(a[h:at(rise) - h]) <= 2 * tol)  # ... decreasing throughout
    assert np.nanmax(np.abs(a)) <= AC + tol  # never beyond AC, up or down
    down = parabolic_time(D, 0, VL, AC) - rise
    for f in (0.25, 0.5, 0.75):  # the ramp down mirrors it: -AC·f at f of the ramp down
        assert a[at(down + f * rise)] == pytest.approx(-AC * f, abs=0.02 * AC)


def test_parabolic_move_with_vb_follows_the_planner_and_ends_on_target(mixed: Maxk) -> None:
    vb = 200_000
    p0 = mixed.word(Shm.MOTOR_POSITION)
    tr = trace(mixed, f"AX VL{VL} VB{vb} AC{AC} MR{D} GO ID;", 1, 850)
    assert_ends_on_target(tr, 0, p0 + D, parabolic_time(D, vb, VL, AC))
    assert tr.x[0][1] - p0 == round(vb * DT + AC * DT**2 / 2)  # the jump to VB, at AC
    phases = parabolic(0.0, p0, p0 + D, vb, VL, AC)
    model = [np.rint(position(phases, t)) for t in tr.t]
    assert np.abs(tr.x[0] - model).max() <= 1


def test_scurve_move_acceleration_rises_from_zero_to_ac_mid_ramp_with_bounded_jerk(
        mixed: Maxk) -> None:
    tr = trace(mixed, f"AZ VL{VL} VB0 AC{AC} MR{D} GO ID;", 3, 950)
    x = tr.x[2]
    rise, jerk = 2 * VL / AC, AC * AC / VL  # 0.25 s, 6.4e7 counts/s³
    assert_ends_on_target(tr, 2, D, scurve_time(D, 0, VL, AC))
    assert acceleration(x, 4)[4] <= 0.05 * AC  # starts near 0: J·4·dt is 3 % of AC
    a = acceleration(x, 8)
    peak = int(np.nanargmax(a))
    assert a[peak] == pytest.approx(AC, rel=0.03)  # less J·h·dt/3 where the ramp turns
    assert abs(peak - at(rise / 2)) <= 8  # mid-ramp
    assert abs(a[at(rise)]) <= 0.03 * AC  # back to 0 at VL
    assert np.nanmax(np.abs(a)) <= AC * 1.005
    h = 16
    a16 = acceleration(x, h)
    j = (a16[2 * h:] - a16[h:-h]) / (h * DT)  # third differences: noise <= 4/(h·dt)³
    noise = 4 / (h * DT) ** 3
    assert noise < 0.02 * jerk
    assert np.nanmax(np.abs(j)) <= jerk + noise
    assert np.nanmax(np.abs(j)) >= 0.9 * jerk


def test_linear_is_the_default_and_ramps_at_constant_ac() -> None:
    """No `profiles` option: every axis linear, as before the option existed [spec §5.2]."""
    with maxk_card(axis_types=TYPES, plant="ideal") as maxk:
        tr = trace(maxk, f"AX VL{VL} VB0 AC{AC} MR{D} GO ID;", 1, 800)
    x = tr.x[0]
    assert_ends_on_target(tr, 0, D, D / VL + VL / AC)  # |d|/VL + VL/AC [spec §5.2]
    h = 8
    a, tol = acceleration(x, h), 2 / (h * DT) ** 2
    ramp = VL / AC
    assert np.abs(a[h:at(ramp) - h] - AC).max() <= tol
    model = [np.rint(position(linear(0.0, 0.0, D, 0, VL, AC), t)) for t in tr.t]
    assert np.abs(x - model).max() <= 1


@pytest.mark.parametrize("axis", [0, 2], ids=["parabolic", "scurve"])
def test_a_short_move_peaks_below_vl_and_is_two_ramps(mixed: Maxk, axis: int) -> None:
    """|d| = 100000 is under the two full ramps (333333 counts): parabolic peaks at the dv of
    (8/3)·dv² = AC·|d|, S-curve at dv = (|d|·sqrt(J)/2)^(2/3) with the axis's J (VB = 0)."""
    d = 100_000
    if axis == 0:
        dv = math.sqrt(3 * AC * d / 8)
        t_end = 4 * dv / AC
    else:
        jerk = AC * AC / VL
        dv = (d * math.sqrt(jerk) / 2) ** (2 / 3)
        t_end = 4 * math.sqrt(dv / jerk)
    tr = trace(mixed, f"A{'XYZ'[axis]} VL{VL} VB0 AC{AC} MR{d} GO ID;", axis + 1, 420)
    assert_ends_on_target(tr, axis, d, t_end)
    x = tr.x[axis]
    v = (x[4:] - x[:-4]) / (4 * DT)  # centred on sample k + 2
    assert v.max() == pytest.approx(dv, rel=0.01) and dv < 0.6 * VL
    assert abs(int(np.argmax(v)) + 2 - at(t_end / 2)) <= 4  # one peak, no cruise
    assert np.nanmax(np.abs(acceleration(x, 8))) <= AC * 1.005


def test_profiles_are_per_axis_x_parabolic_and_y_linear_in_one_card(mixed: Maxk) -> None:
    tr = trace(mixed, f"AX VL{VL} VB0 AC{AC} MR{D} GO ID; AY VB0 VL{VL} AC{AC} MR{D} GO ID;",
               2, 850)
    assert_ends_on_target(tr, 0, D, parabolic_time(D, 0, VL, AC))
    assert_ends_on_target(tr, 1, D, D / VL + VL / AC)
    ax, ay = acceleration(tr.x[0], 8), acceleration(tr.x[1], 8)
    for f in (0.25, 0.5, 0.75):  # f of the linear ramp: X has fallen, Y still at AC
        k = at(f * VL / AC)
        assert ax[k] == pytest.approx(AC * (1 - f / 2), abs=0.01 * AC)
        assert ay[k] == pytest.approx(AC, abs=0.01 * AC)


def test_a_move_started_while_the_axis_runs_is_the_trapezoid_whatever_the_profile(
        mixed: Maxk) -> None:
    """GO after JG on the parabolic axis: the core's trapezoid at AC from the jog speed to VL
    (README), not a parabolic ramp."""
    mixed.send(f"AX VL{VL} VB0 AC{AC} JG200000;")
    mixed.step(100)  # the jog ramp (25 ms) is over
    tr = trace(mixed, "AX MA400000 GO ID;", 1, 700)
    ramp = (VL - 200_000) / AC  # 0.1 s at constant AC
    h = 8
    a, tol = acceleration(tr.x[0], h), 2 / (h * DT) ** 2
    assert np.abs(a[h + 1:at(ramp) - h] - AC).max() <= tol
    assert not math.isnan(tr.done[0]) and tr.x[0][-1] == 400_000


@pytest.mark.parametrize("bad", [["linear", "cubic", "linear", "linear"], ["trapezoid"] * 4])
def test_an_unknown_profile_is_refused_when_the_card_is_built(bad: list[str]) -> None:
    with pytest.raises(ValueError, match=bad[1]):
        build_rack(card_config(profiles=bad))


def test_an_unknown_profile_is_refused_in_the_configuration_file() -> None:
    card: dict[str, object] = {"type": "oms-maxk", "name": "m", "axes": 2,
                               "profiles": ["scurve", "sine"]}
    with pytest.raises(ConfigError, match="sine"):
        parse({"card": [card]})
    assert parse({"card": [{**card, "profiles": ["scurve", "parabolic"]}]}).cards

