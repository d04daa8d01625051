"""ADLINK T/S-curve planner [M §4.2.3] (spec §2.5, §2.7, §2.9): the equations' times and auto-planned
peaks, Vs/Ve, on-the-fly re-plans that reverse, and seeded property tests (STYLE.md 5) for the
velocity, acceleration and S-factor/jerk bounds, exact end distance and monotonic progress.

Slack: the closed forms and the integration of a few segments round at ~1e-15 of the values; REL
covers that with margin.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vdevd.devices.adlink.profile import (
    VM_MAX_PPS,
    Plan,
    ProfilePhase,
    clamp_vm,
    plan_from,
    plan_ptp,
    plan_stop,
    plan_velocity,
    s_ramp,
    to_core_phases,
)
from vdevd.rt import MotionCore, PlantKind
from vdevd.rt.profiles import Phase, to_phases

PROPS = settings(derandomize=True, max_examples=200, deadline=None)
REL = 1e-9


def integrated_end(plan: Plan) -> tuple[float, float]:
    """(position, velocity) at the end of the segments, stepped by the core's own phases (not the
    plan's clamped `state`)."""
    a0 = plan.segs[0][2] if plan.segs else 0.0
    end = to_phases(0.0, 0.0, plan.v0, a0, plan.segs, hold=None)[-1]
    return end.p0, end.v0


def samples(plan: Plan, n: int = 400) -> list[float]:
    """n times over the plan's segments, plus every segment boundary."""
    total = sum(d for d, _, _ in plan.segs)
    ts = [total * i / n for i in range(n + 1)]
    t = 0.0
    for d, _, _ in plan.segs:
        ts.append(t)
        t += d
    return sorted(ts)


def s_factor_ramps(plan: Plan) -> list[tuple[float, float, float, float]]:
    """The S-curve velocity changes of the plan as (t1, t2, t3, peak |a|): runs of segments from zero
    acceleration back to zero acceleration."""
    ramps, run = [], []
    for d, j, a in plan.segs:
        if j == 0 and a == 0:
            continue
        run.append((d, j, a))
        if abs(a + j * d) <= 1e-9 * abs(a):
            t1, t3 = run[0][0], run[-1][0]
            t2 = run[1][0] if len(run) == 3 else 0.0
            ramps.append((t1, t2, t3, abs(run[-1][2])))
            run = []
    assert not run, "a velocity change that does not end at zero acceleration"
    return ramps


# -- the equations of spec §2.5 ----------------------------------------------------------------------


def test_t_curve_10000_at_1000_with_acc_10000_takes_10_1_s() -> None:
    plan = plan_ptp(10_000, 0, 1000, 0, 10_000, 10_000, 0)
    assert plan.segs == ((0.1, 0.0, 10_000.0), (9.9, 0.0, 0.0), (0.1, 0.0, -10_000.0))
    assert plan.duration() == pytest.approx(10.1, rel=1e-15)
    assert plan.decel_start() == pytest.approx(10.0, rel=1e-15)
    assert plan.vm == 1000 and plan.ve_reached
    assert plan.state(0.1) == pytest.approx((50.0, 1000.0, 0.0))
    assert plan.state(11.0) == (10_000, 0.0, 0.0)


def test_s_factor_1_doubles_the_acceleration_time() -> None:
    plan = plan_ptp(10_000, 0, 1000, 0, 10_000, 10_000, 1)
    t1 = 0.1  # S*dv/A: t_acc = (1+S)*dv/A = 0.2 s, pure S-curve (triangular A-T)
    assert [d for d, _, _ in plan.segs] == pytest.approx([t1, t1, 9.8, t1, t1])
    assert plan.duration() == pytest.approx(10.2)
    assert plan.segs[0][1] == pytest.approx(10_000**2 / 1000)  # J = A^2/(S*dv)
    assert plan.state(0.2)[1] == pytest.approx(1000)


def test_s_factor_one_half_has_equal_jerk_and_linear_zones() -> None:
    """S = t1/(t1 + t2) with t1 = t3 (the manual's "t1 = t2" read as t1 = t3)."""
    plan = plan_ptp(10_000, 0, 1000, 0, 10_000, 10_000, 0.5)
    (t1, t2, t3, peak), (u1, u2, u3, dpeak) = s_factor_ramps(plan)
    assert (t1, t2, t3) == pytest.approx((0.05, 0.05, 0.05))
    assert t1 / (t1 + t2) == pytest.approx(0.5) and peak == dpeak == 10_000
    assert plan.segs[0][1] == pytest.approx(10_000**2 / (0.5 * 1000))
    assert plan.duration() == pytest.approx(0.15 + 9.85 + 0.15)


def test_short_t_curve_lowers_vm_keeping_acc_and_dec() -> None:
    d, vs, ve, acc, dec = 100.0, 100.0, 50.0, 10_000.0, 5000.0
    plan = plan_ptp(d, vs, 1000, ve, acc, dec, 0)
    vp = math.sqrt((2 * d * acc * dec + dec * vs**2 + acc * ve**2) / (acc + dec))
    assert plan.vm == pytest.approx(vp, rel=1e-14) and vp < 1000
    assert [(j, a) for _, j, a in plan.segs] == [(0.0, acc), (0.0, -dec)]  # no cruise
    assert plan.duration() == pytest.approx((vp - vs) / acc + (vp - ve) / dec, rel=1e-14)
    assert plan.ve_reached and plan.end_velocity == ve
    assert integrated_end(plan)[0] == pytest.approx(d, rel=1e-12)


@pytest.mark.parametrize("sf", [0.1, 0.25, 0.5, 1.0])
def test_short_s_curve_peak_is_sqrt_a_d_over_1_plus_s(sf: float) -> None:
    a, d = 20_000.0, 30.0
    plan = plan_ptp(d, 0, 1e6, 0, a, a, sf)
    vp = math.sqrt(a * d / (1 + sf))
    assert plan.vm == pytest.approx(vp, rel=1e-14)
    for t1, t2, t3, peak in s_factor_ramps(plan):  # Acc, Dec and S kept, the jerk changes
        assert peak == pytest.approx(a) and t1 == pytest.approx(t3)
        assert t1 / (t1 + t2) == pytest.approx(sf)
    assert abs(plan.segs[0][1]) == pytest.approx(a * a / (sf * vp))
    assert integrated_end(plan)[0] == pytest.approx(d, rel=1e-12)


def test_ve_above_zero_ends_at_ve() -> None:
    plan = plan_ptp(5000, 0, 1000, 300, 10_000, 4000, 0.5)
    assert plan.ve_reached and plan.end_velocity == 300
    assert integrated_end(plan)[1] == pytest.approx(300)
    assert plan.state(plan.duration()) == (5000, 300, 0.0)


def test_vs_above_zero_starts_with_a_jump_to_vs() -> None:
    plan = plan_ptp(5000, 200, 1000, 0, 10_000, 10_000, 0.3)
    assert plan.v0 == 200 and plan.state(0.0) == (0.0, 200, 0.0)
    assert plan.segs[0][0] == pytest.approx(0.3 * 800 / 10_000)  # t1 over dv = Vm - Vs


def test_ve_out_of_reach_is_cut_short_and_flagged() -> None:
    """Too short to accelerate from Vs to Ve: Vm' = max(Vs, Ve), the ramp is cut at the distance
    and the move ends at a velocity step (spec §2.5 ASSUMPTION; -22 for the caller, Q7)."""
    plan = plan_ptp(10, 0, 2000, 1000, 1000, 1000, 0)
    assert not plan.ve_reached and plan.distance == 10
    assert plan.end_velocity == pytest.approx(math.sqrt(2 * 1000 * 10))
    assert plan.duration() == pytest.approx(math.sqrt(2 * 10 / 1000))
    assert integrated_end(plan)[0] == pytest.approx(10, rel=1e-12)


def test_vs_too_fast_to_slow_down_to_ve_ends_at_a_velocity_step() -> None:
    plan = plan_ptp(100, 1000, 2000, 0, 1000, 1000, 0)
    assert not plan.ve_reached and plan.vm == 1000
    assert plan.end_velocity == pytest.approx(math.sqrt(1000**2 - 2 * 1000 * 100))
    assert plan.decel_start() == 0.0


def test_ve_above_vm_is_clamped_to_vm() -> None:
    plan = plan_ptp(10_000, 0, 1000, 1500, 10_000, 10_000, 0)
    assert not plan.ve_reached and plan.end_velocity == 1000 and plan.distance == 10_000


def test_distance_zero_is_an_empty_plan_at_rest() -> None:
    plan = plan_ptp(0, 100, 1000, 0, 10_000, 10_000, 0.5)
    assert plan.segs == () and plan.distance == 0 and plan.v0 == 0
    assert plan.duration() == 0 and plan.state(1.0) == (0, 0, 0)
    assert plan.phase_at(0.0) == ProfilePhase.IDLE and plan.time_at(0) == 0


def test_vs_above_vm_is_clamped_to_vm() -> None:
    plan = plan_ptp(1000, 500, 200, 0, 10_000, 10_000, 0)
    assert plan.v0 == 200 and plan.vm == 200
    assert plan.duration() == pytest.approx(200 / 10_000 / 2 + 1000 / 200)


def test_vm_zero_moves_nothing() -> None:
    plan = plan_ptp(1000, 0, 0, 0, 10_000, 10_000, 0)
    assert plan.segs == () and plan.distance == 0 and not plan.ve_reached


def test_status_phases_follow_the_profile() -> None:
    plan = plan_ptp(10_000, 0, 1000, 0, 10_000, 10_000, 0.5)
    assert plan.phase_at(0.0) == plan.phase_at(0.149) == ProfilePhase.ACC
    assert plan.phase_at(0.151) == plan.phase_at(9.99) == ProfilePhase.VM
    assert plan.phase_at(10.001) == plan.phase_at(10.149) == ProfilePhase.DEC
    assert plan.phase_at(10.151) == ProfilePhase.IDLE
    assert plan.decel_start() == pytest.approx(10.0)


def test_time_at_the_residual_deceleration_distance_is_the_decel_start() -> None:
    plan = plan_ptp(10_000, 0, 1000, 0, 10_000, 10_000, 0)
    assert plan.time_at(plan.distance - 50) == pytest.approx(plan.decel_start(), rel=1e-12)
    assert plan.time_at(5000) == pytest.approx(5.05, rel=1e-12)
    assert plan.time_at(10_000) == pytest.approx(10.1)
    assert plan.time_at(-1) == 0 and plan.time_at(20_000) == pytest.approx(10.1)


def test_clamp_vm_to_6_5_mpps_in_user_units() -> None:
    assert clamp_vm(1e7) == VM_MAX_PPS
    assert clamp_vm(-1e7, 2.0) == -VM_MAX_PPS / 2
    assert clamp_vm(1000, 0.001) == 1000


# -- on-the-fly change (spec §2.9), velocity moves and stops -----------------------------------------


def test_target_too_close_to_stop_decelerates_reverses_and_lands_exactly() -> None:
    plan = plan_from(1000, 10, 1000, 0, 10_000, 10_000, 0.5)
    stop = 1000 / 2 * 1.5 * 1000 / 10_000  # 75 past here: then 65 back
    assert plan.distance == 10 and plan.ve_reached
    assert plan.state(plan.duration()) == (10, 0.0, 0.0)
    assert integrated_end(plan) == pytest.approx((10, 0), abs=1e-9)
    assert max(plan.state(t)[0] for t in samples(plan)) == pytest.approx(stop)
    assert plan.phase_at(0.0) == ProfilePhase.DEC and plan.phase_at(0.16) == ProfilePhase.ACC
    assert plan.time_at(stop) == pytest.approx(0.15, abs=1e-5)  # at a turn: ill-conditioned
    assert plan.state(plan.time_at(stop))[0] == pytest.approx(stop, rel=1e-12)
    assert plan.time_at(10) < plan.time_at(stop)  # passed on the way out first


def test_target_behind_stops_and_comes_back() -> None:
    plan = plan_from(500, -200, 1000, 0, 10_000, 5000, 0)
    assert plan.distance == -200 and plan.end_velocity == 0
    assert integrated_end(plan)[0] == pytest.approx(-200, rel=1e-12)
    assert plan.segs[0] == pytest.approx((0.1, 0.0, -5000))


def test_far_target_keeps_going_from_the_current_velocity() -> None:
    plan = plan_from(500, 10_000, 1000, 0, 10_000, 10_000, 0)
    assert plan.v0 == 500 and plan.segs[0] == pytest.approx((0.05, 0.0, 10_000))
    assert min(plan.state(t)[1] for t in samples(plan)) >= -1e-9


def test_lower_vm_on_the_fly_slows_down_first_with_dec() -> None:
    plan = plan_from(1000, 10_000, 400, 0, 10_000, 2000, 0)
    assert plan.segs[0] == pytest.approx((0.3, 0.0, -2000))
    assert plan.phase_at(0.0) == ProfilePhase.DEC and plan.phase_at(1.0) == ProfilePhase.VM
    assert plan.decel_start() > 1.0 and plan.distance == 10_000


def test_velocity_move_reverses_through_zero_with_dec_then_acc() -> None:
    plan = plan_velocity(500, -300, 1000, 2000, 0.3)
    assert plan.endless and plan.duration() == math.inf
    assert [a for _, _, a in plan.segs if a] == [-2000, -2000, -1000, -1000]
    assert plan.phase_at(0.1) == ProfilePhase.DEC and plan.phase_at(0.4) == ProfilePhase.ACC
    assert plan.phase_at(10) == ProfilePhase.VM and plan.state(10)[1:] == (-300, 0.0)
    s_end = plan.distance
    assert plan.state(11)[0] == pytest.approx(s_end - 300 * (11 - 0.325 - 0.39))
    assert plan.time_at(s_end - 300) == pytest.approx(0.325 + 0.39 + 1)


def test_velocity_move_from_rest_jumps_to_vs() -> None:
    plan = plan_velocity(0, -800, 1000, 1000, 0, vs=100)
    assert plan.v0 == -100 and len(plan.segs) == 1
    assert plan.segs[0] == pytest.approx((0.7, 0.0, -1000))


def test_velocity_zero_is_a_stop_that_ends() -> None:
    plan = plan_velocity(400, 0, 1000, 2000, 0)
    assert not plan.endless and plan.duration() == pytest.approx(0.2)
    assert plan.phase_at(0.3) == ProfilePhase.IDLE


def test_stop_takes_1_plus_s_times_v_over_dec() -> None:
    plan = plan_stop(-600, 3000, 0.5)
    assert plan.duration() == pytest.approx(1.5 * 600 / 3000)
    assert plan.distance == pytest.approx(-600 / 2 * 0.3)
    assert plan.decel_start() == 0 and plan.end_velocity == 0


def test_core_phases_place_the_plan_at_p0_in_the_direction_and_hold_the_target() -> None:
    plan = plan_ptp(1000, 50, 400, 0, 2000, 1000, 0.5)
    phases = to_core_phases(plan, 2.0, 5000.0, -1.0, hold=4000)
    assert phases[0].t0 == 2.0 and phases[0].p0 == 5000 and phases[0].v0 == -50
    for ph in phases[:-1]:
        s, v, a = plan.state(ph.t0 - 2.0)
        assert (ph.p0, ph.v0, ph.a0) == pytest.approx((5000 - s, -v, -a), abs=1e-9)
    assert phases[-1][1:] == (math.inf, 4000, 0.0, 0.0, 0.0)
    assert phases[-1].t0 == pytest.approx(2.0 + plan.duration())


def test_core_phases_run_on_at_the_end_velocity_without_hold() -> None:
    plan = plan_ptp(1000, 0, 400, 100, 2000, 1000, 0)
    last = to_core_phases(plan, 0.0, 10.0, 1.0, hold=None)[-1]
    assert (last.dur, last.p0, last.v0, last.a0, last.j) == (math.inf, 1010.0, 100, 0.0, 0.0)


@pytest.mark.parametrize("sf", [5e-324, 2.2e-311, 5.2e-213, 1e-12])
@pytest.mark.parametrize("v0", [-2.2e-311, 0.0, 1e-200, 1.0])
def test_tiny_s_factors_and_velocity_changes_give_finite_plans_within_bounds(sf: float, v0: float) -> None:
    """An S so small that the jerk would overflow is the T-curve; the tags say ACC/DEC where
    rounding leaves the velocity at the end of a stop at about -1e-16."""
    for plan in (plan_velocity(v0, 251.0, 1.0, 1.0, sf), plan_ptp(1.0, v0, 1.0, 0.0, 1.0, 1.0, sf),
                 plan_from(v0, 1.0, 1.0, 0.0, 1.0, 1.0, sf), plan_stop(v0, 1.0, sf)):
        check_bounds(plan, max(abs(v0), 251.0), 1.0, 1.0, 0.0)
        assert all(math.isfinite(j) and math.isfinite(a) for _, j, a in plan.segs)
        if plan.segs and not plan.endless:
            assert plan.phase_at(plan.decel_start() * (1 - 1e-9)) != ProfilePhase.DEC or (
                plan.decel_start() == 0)


def test_a_plan_built_by_hand_gets_its_phases_from_velocity_and_acceleration() -> None:
    plan = Plan(((1.0, 0.0, 2.0), (1.0, 0.0, 0.0), (1.0, 0.0, -2.0)), 0.0, 4.0)
    assert plan.tags == (ProfilePhase.ACC, ProfilePhase.VM, ProfilePhase.DEC)
    assert plan.decel_start() == 2.0 and plan.time_at(2.0) == pytest.approx(1.5)


@pytest.mark.parametrize(("start", "goal", "vs", "ve", "sf"), [
    (1234, 101_234, 0, 0, 0.0), (1234, -48_766, 300, 0, 0.5), (0, 1777, 100, 50, 1.0), (5, 4, 0, 0, 0.3)])
def test_the_motion_core_runs_a_ptp_plan_to_the_exact_count(start: int, goal: int, vs: float,
                                                            ve: float, sf: float) -> None:
    """Through MotionCore.move_planned (a card's own profile shape): the commanded position ends
    exactly on the target count, the first tick starts at Vs, no tick is faster than Vm."""
    dt, vm = 1e-3, 20_000.0
    core = MotionCore(1, 1_000_000, PlantKind.IDEAL)
    core.servo_on(slice(None))
    core.set_position(0, start)

    def planner(t: float, p: float, v: float, target: float) -> list[Phase]:
        sign = 1.0 if target >= p else -1.0
        plan = plan_ptp(abs(target - p), vs, vm, ve, 200_000, 100_000, sf)
        return to_core_phases(plan, t, p, sign, hold=target)

    core.move_planned(0, goal, planner, dec=100_000)
    trace = [float(core.axes.cmd_pos[0])]
    while core.profile.moving.any() and len(trace) < 100_000:
        core.tick()
        trace.append(float(core.axes.cmd_pos[0]))
    assert trace[-1] == goal
    steps = [abs(b - a) for a, b in zip(trace, trace[1:], strict=False)]
    assert max(steps) <= vm * dt * (1 + 1e-9)
    if abs(goal - start) > vm * dt:
        assert steps[0] >= vs * dt * (1 - 1e-9)


def test_s_ramp_zero_factor_is_one_segment() -> None:
    assert s_ramp(0, 100, 1000, 0) == [(0.1, 0.0, 1000)]
    assert s_ramp(100, 100, 1000, 0.5) == []


# -- properties (seeded) -----------------------------------------------------------------------------

SPEEDS = st.floats(1.0, 1e6)
#: S = 0 or at least 1e-6, velocities 0 or at least 1e-3 in magnitude, so that every S-curve ramp
#: has measurable t1 and t2 to check S on (tinier ones: test_tiny_s_factors_and_velocity_changes_...)
FACTORS = st.one_of(st.sampled_from([0.0, 0.25, 0.5, 1.0]), st.floats(1e-6, 1.0))


def signed(limit: float) -> st.SearchStrategy[float]:
    return st.one_of(st.just(0.0), st.floats(1e-3, limit), st.floats(-limit, -1e-3))


@st.composite
def ptp_moves(draw: st.DrawFn) -> dict[str, float]:
    vm = draw(SPEEDS)
    return {
        "distance": draw(st.one_of(st.sampled_from([0.0, 1.0, 2.0]), st.floats(1e-3, 1e7))),
        "vs": draw(st.one_of(st.just(0.0), st.floats(1e-3, 1.5 * vm))),
        "vm": vm,
        "ve": draw(st.one_of(st.just(0.0), st.floats(1e-3, 1.5 * vm))),
        "acc": draw(st.floats(vm / 10, 100 * vm)),
        "dec": draw(st.floats(vm / 10, 100 * vm)),
        "sf": draw(FACTORS),
    }


def check_bounds(plan: Plan, vmax: float, acc: float, dec: float, sf: float) -> None:
    """|v| <= vmax; a within acc while speeding up and dec while slowing down; S kept in every
    complete velocity change (t1 = t3, t1/(t1+t2) = S, peak acc or dec) so |jerk|*t1 <= peak."""
    for d, _, _ in plan.segs:
        assert 0 < d < math.inf
    for t in samples(plan):
        _, v, a = plan.state(t)
        assert abs(v) <= vmax * (1 + REL)
        limit = acc if plan.phase_at(t) == ProfilePhase.ACC else dec
        assert abs(a) <= max(acc, dec) * (1 + REL)
        if plan.phase_at(t) != ProfilePhase.IDLE:
            assert abs(a) <= limit * (1 + REL)
    if sf > 0:
        ramps = s_factor_ramps(plan) if plan.ve_reached else []
        for t1, t2, t3, peak in ramps:
            assert t1 == pytest.approx(t3, rel=1e-9)
            assert t1 / (t1 + t2) == pytest.approx(sf, rel=1e-9, abs=1e-12)
            assert min(abs(peak - acc), abs(peak - dec)) <= 1e-9 * peak
    for d, j, a in plan.segs:
        assert abs(a + j * d) <= max(acc, dec) * (1 + REL)


@PROPS
@given(m=ptp_moves())
def test_ptp_ends_exactly_within_bounds_with_monotonic_progress(m: dict[str, float]) -> None:
    plan = plan_ptp(**m)
    d, vm, ve = m["distance"], m["vm"], m["ve"]
    assert plan.distance == d and plan.v0 == (min(m["vs"], vm) if d > 0 else 0)
    end, v_end = integrated_end(plan)
    assert end == pytest.approx(d, rel=REL, abs=1e-12)
    assert plan.state(plan.duration()) == (d, plan.end_velocity, 0.0)
    check_bounds(plan, vm, m["acc"], m["dec"], m["sf"])
    last = -math.inf
    for t in samples(plan):
        s, v, _ = plan.state(t)
        assert v >= -REL * vm and s <= d * (1 + REL)
        assert s >= last - REL * d
        last = s
        if d > 0 and 0 < s < d:  # the time of a distance gives that distance back
            assert plan.state(plan.time_at(s))[0] == pytest.approx(s, rel=1e-7, abs=1e-9)
    if plan.ve_reached:
        assert plan.end_velocity == ve and v_end == pytest.approx(ve, rel=1e-7, abs=1e-6 * vm)
    elif d > 0:
        assert ve > vm or plan.vm == max(min(m["vs"], vm), min(ve, vm))
    assert plan.decel_start() <= plan.duration()
    if plan.segs and plan.decel_start() > 0:
        assert plan.phase_at(plan.decel_start() * (1 - 1e-9)) != ProfilePhase.DEC


@PROPS
@given(m=ptp_moves())
def test_ptp_takes_the_time_of_its_peak_and_lowers_vm_only_when_short(m: dict[str, float]) -> None:
    """Time = ramps of (1+S)*dv/A + cruise at the peak; a lowered peak has no cruise and is the
    closed form Vm'^2 = (2*D*Acc*Dec/(1+S) + Dec*Vs^2 + Acc*Ve^2)/(Acc + Dec)."""
    plan = plan_ptp(**m)
    if not plan.ve_reached or m["distance"] == 0:
        return
    d, vs, ve, acc, dec, k = m["distance"], m["vs"], m["ve"], m["acc"], m["dec"], 1 + m["sf"]
    vs, vp = min(vs, m["vm"]), plan.vm
    ramps = k * (abs(vp - vs) / acc + (vp - ve) / dec)
    travel = k * ((vp * vp - vs * vs) / (2 * acc) + (vp * vp - ve * ve) / (2 * dec))
    assert plan.duration() == pytest.approx(ramps + max(0.0, d - travel) / vp, rel=1e-7)
    if vp < m["vm"]:
        closed = math.sqrt((2 * d * acc * dec / k + dec * vs * vs + acc * ve * ve) / (acc + dec))
        assert vp == pytest.approx(max(closed, vs, ve), rel=1e-9)
        assert all(j or a or d < 1e-12 for d, j, a in plan.segs)  # no cruise (but a rounding)


@st.composite
def replans(draw: st.DrawFn) -> dict[str, float]:
    vm = draw(SPEEDS)
    return {
        "v0": draw(signed(2 * vm)),
        "distance": draw(st.one_of(st.sampled_from([0.0, 1.0, -1.0]), st.floats(-1e6, 1e6))),
        "vm": vm,
        "ve": draw(st.one_of(st.just(0.0), st.floats(1e-3, 1.5 * vm))),
        "acc": draw(st.floats(vm / 10, 100 * vm)),
        "dec": draw(st.floats(vm / 10, 100 * vm)),
        "sf": draw(FACTORS),
    }


@PROPS
@given(m=replans())
def test_replan_from_any_velocity_reaches_the_target_exactly_within_bounds(m: dict[str, float]) -> None:
    plan = plan_from(**m)
    d, v0, vm = m["distance"], m["v0"], m["vm"]
    assert plan.distance == d and plan.v0 == v0 and plan.state(0)[1] == v0
    end, v_end = integrated_end(plan)
    scale = max(abs(d), v0 * v0 / m["dec"], 1.0)
    assert end == pytest.approx(d, abs=REL * scale)
    assert plan.state(plan.duration())[0] == d
    check_bounds(plan, max(abs(v0), vm), m["acc"], m["dec"], m["sf"])
    velocities = [plan.state(t)[1] for t in samples(plan)]
    tol = REL * max(abs(v0), vm)
    signs = [v > tol for v in velocities if abs(v) > tol]
    assert sum(a != b for a, b in zip(signs, signs[1:], strict=False)) <= 1  # one reversal at most
    stop = (1 + m["sf"]) * v0 * v0 / (2 * m["dec"])
    if v0 * d > 0 and abs(d) >= stop * (1 + 1e-9):
        assert all(v * d >= -tol for v in velocities)  # no stop on the way
    if plan.ve_reached:
        assert abs(plan.end_velocity) == min(m["ve"], vm)
        assert abs(v_end) == pytest.approx(min(m["ve"], vm), rel=1e-7, abs=1e-6 * max(abs(v0), vm))


@PROPS
@given(v0=signed(1e6), v1=signed(1e6), acc=st.floats(1.0, 1e7),
       dec=st.floats(1.0, 1e7), sf=FACTORS)
def test_velocity_moves_end_at_the_velocity_asked_within_bounds(v0: float, v1: float, acc: float,
                                                                dec: float, sf: float) -> None:
    plan = plan_velocity(v0, v1, acc, dec, sf)
    assert plan.endless == (v1 != 0) and plan.end_velocity == v1
    assert integrated_end(plan)[1] == pytest.approx(v1, abs=1e-9 * max(abs(v0), abs(v1), 1.0))
    check_bounds(plan, max(abs(v0), abs(v1)), acc, dec, sf)
    lo, hi = min(v0, v1), max(v0, v1)
    tol = REL * max(abs(v0), abs(v1), 1.0)
    for t in samples(plan):
        assert lo - tol <= plan.state(t)[1] <= hi + tol  # monotonic from v0 to v1
