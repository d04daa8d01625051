"""Group motion and the seven continuous-interpolation transitions [M §4.7.3], spec §2.13, against a
stand-in trapezoid profile (`stub_profile`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.devices.adlink.stub_profile import StubPlan, plan_ptp, plan_stop
from vdevd.devices.adlink.group import (
    ERR_COMMAND_IN_PROCESS,
    QUEUE_DEPTH,
    Group,
    PlanFactory,
    Transition,
)
from vdevd.devices.adlink.path import ERR_PARAMETERS_INVALID, arc2_ca, line

VM, ACC = 1000.0, 10000.0  # a 1000-long line: 0.1 s up (50), 0.9 s at VM, 0.1 s down (50)


def factory(vs: float = 0.0, vm: float = VM, ve: float = 0.0, acc: float = ACC) -> PlanFactory:
    def make(distance: float, v0: float | None) -> StubPlan:
        return plan_ptp(distance, vs if v0 is None else v0, vm, ve, acc, acc, 0.0)

    return make


def plan_of(distance: float) -> StubPlan:
    return plan_ptp(distance, 0.0, VM, 0.0, ACC, ACC, 0.0)


def group() -> Group:
    g = Group((0, 1), plan_stop=plan_stop)
    g.sd_dec = ACC
    return g


def moving_x(g: Group) -> None:
    assert g.submit(line([0, 0], [1000, 0]), factory(), Transition.BUFFERED, 0.0, 0.0) == 0


def run(g: Group, t0: float, t1: float, dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    times = np.arange(t0, t1, dt)
    pts = [g.positions(float(t)) for t in times]
    keep = [i for i, p in enumerate(pts) if p is not None]
    return times[keep], np.array([pts[i] for i in keep])


def test_idle_group_has_no_positions_and_done_flag() -> None:
    g = group()
    assert g.positions(0.0) is None
    assert g.flags(0.0).done and not g.flags(0.0).moving


def test_single_line_phases_then_exact_end_once_then_idle() -> None:
    g = group()
    assert g.submit(line([0, 0], [600, 800]), factory(), Transition.ABORT_BLEND, 0.0, 0.0) == 0
    assert g.flags(0.05).accelerating and g.flags(0.5).constant and g.flags(1.05).decelerating
    pos = g.positions(0.5)
    assert pos is not None and np.allclose(pos, [0.6 * 450, 0.8 * 450])
    assert np.array_equal(g.positions(2.0), [600.0, 800.0])
    assert g.positions(2.1) is None
    assert g.flags(2.1).done


def test_buffered_runs_the_exact_path_through_the_corner_and_stops_there_when_ve_is_0() -> None:
    g = group()
    moving_x(g)
    assert g.submit(line([1000, 0], [1000, 1000]), factory(), Transition.BUFFERED, 0.0, 0.3) == 0
    times, pts = run(g, 0.0, 2.5)
    on_path = (pts[:, 1] == 0.0) | (pts[:, 0] == 1000.0)
    assert on_path.all()
    corner = plan_of(1000.0).duration()
    g2 = group()
    moving_x(g2)
    g2.submit(line([1000, 0], [1000, 1000]), factory(), Transition.BUFFERED, 0.0, 0.3)
    assert np.array_equal(g2.positions(corner), [1000.0, 0.0])
    vel = g2.velocity(corner)
    assert vel is not None and np.allclose(vel, 0.0)
    assert not any(g2.flags(t).blending for t in np.arange(0, 2.3, 0.01))
    assert np.array_equal(pts[-1], [1000.0, 1000.0])


def test_blend_on_deceleration_starts_the_next_segment_when_the_previous_decelerates() -> None:
    g = group()
    moving_x(g)
    assert g.submit(line([1000, 0], [1000, 1000]), factory(), Transition.BLEND_DEC_EVENT, 0.0, 0.2) == 0
    td = plan_of(1000.0).decel_start()  # 1.0 s
    before = g.positions(td - 1e-6)
    assert before is not None and before[1] == 0.0 and not g.flags(td - 1e-6).blending
    after = g.positions(td + 1e-3)
    assert after is not None and after[1] > 0.0 and g.flags(td + 1e-3).blending
    assert g.flags(td + 0.05).blending
    assert not g.flags(td + 0.1 + 1e-6).blending  # the first segment has ended
    assert np.array_equal(g.positions(5.0), [1000.0, 1000.0])


@pytest.mark.parametrize(
    ("mode", "para"), [(Transition.BLEND_RES_DIST, 100.0), (Transition.BLEND_RES_DIST_PERCENT, 10.0)]
)
def test_residual_distance_blend_of_a_1000_line_starts_at_900(mode: Transition, para: float) -> None:
    g = group()
    moving_x(g)
    assert g.submit(line([1000, 0], [1000, 1000]), factory(), mode, para, 0.1) == 0
    tb = plan_of(1000.0).time_at(900.0)
    assert g.positions(tb - 1e-6)[1] == 0.0  # type: ignore[index]
    p = g.positions(tb + 1e-4)
    assert p is not None and p[1] > 0.0 and p[0] == pytest.approx(900.0, abs=0.2)
    assert g.flags(tb + 1e-4).blending
    assert np.array_equal(g.positions(5.0), [1000.0, 1000.0])


def test_a_blend_behind_a_finished_zero_length_command_starts_then_not_in_the_past() -> None:
    """The blend follows the previous command; when that one (zero length) has already ended,
    the next starts at its end, not at a trigger time computed on an older overlapping run."""
    def chain() -> Group:
        g = group()
        moving_x(g)
        assert g.submit(line([1000, 0], [1000, 0]), factory(), Transition.BLEND_DEC_EVENT, 0.0, 0.1) == 0
        assert g.submit(line([1000, 0], [0, 0]), factory(), Transition.BLEND_RES_DIST_PERCENT, 50.0, 0.1) == 0
        return g

    _, pts = run(chain(), 0.0, 3.0)
    assert (np.abs(np.diff(pts[:, 0])) <= 2 * VM * 1e-3 + 1e-9).all()  # no jump
    g, td = chain(), plan_of(1000.0).decel_start()
    assert g.positions(td - 1e-3) is not None and not g.flags(td - 1e-3).blending
    assert g.flags(td + 1e-3).blending


def test_blend_superposes_the_remaining_and_the_new_displacements() -> None:
    g = group()
    moving_x(g)
    g.submit(line([1000, 0], [1000, 1000]), factory(), Transition.BLEND_RES_DIST, 100.0, 0.0)
    first = plan_of(1000.0)
    second = plan_of(1000.0)
    tb = first.time_at(900.0)
    for t in (tb + 0.01, tb + 0.05, first.duration()):
        p = g.positions(t)
        assert p is not None
        assert p[0] == pytest.approx(first.state(t)[0])
        assert p[1] == pytest.approx(second.state(t - tb)[0])


def test_abort_stop_decelerates_then_goes_to_the_target_relative_to_the_receive_point() -> None:
    g = group()
    moving_x(g)
    received = g.positions(0.5)
    assert received is not None
    target = received + [0.0, 500.0]  # relative (0, 500) from E1'
    assert g.submit(line(received, target), factory(), Transition.ABORT_STOP, 0.0, 0.5) == 0
    assert g.queued == 1
    stop_time = VM / ACC
    s2 = received + [VM * VM / (2 * ACC), 0.0]
    assert np.allclose(g.positions(0.5 + stop_time), s2)
    assert g.positions(0.5 + stop_time * 0.5)[1] == 0.0  # type: ignore[index]
    _, pts = run(g, 0.5 + stop_time, 3.0)
    assert np.array_equal(pts[-1], target)
    assert np.allclose(pts[:, 0] - s2[0], -(pts[:, 1] / 500.0) * (s2[0] - target[0]))  # straight S2 -> E2


def test_abort_force_is_jump_free_with_a_velocity_step() -> None:
    g = group()
    moving_x(g)
    here = g.positions(0.5)
    assert here is not None
    v_before = g.velocity(0.5)
    assert g.submit(line(here, here + [0, 800]), factory(), Transition.ABORT_FORCE, 0.0, 0.5) == 0
    assert np.array_equal(g.positions(0.5), here)
    p = g.positions(0.5 + 1e-4)
    assert p is not None and np.linalg.norm(p - here) < 0.11
    v_after = g.velocity(0.5)
    assert v_before is not None and v_after is not None
    assert np.allclose(v_before, [VM, 0]) and np.allclose(v_after, [0, VM])  # speed kept, direction steps
    assert g.queued == 0
    assert np.array_equal(g.positions(3.0), here + [0, 800])


def test_abort_blend_overlaps_the_old_stop_and_the_new_command_and_ends_at_the_target() -> None:
    g = group()
    moving_x(g)
    g.submit(line([1000, 0], [1000, 1000]), factory(), Transition.BUFFERED, 0.0, 0.1)
    here = g.positions(0.5)
    assert here is not None
    end = np.array([500.0, 300.0])
    assert g.submit(line(here, end), factory(), Transition.ABORT_BLEND, 0.0, 0.5) == 0
    assert g.queued == 0
    assert g.flags(0.55).blending
    vel = g.velocity(0.5)
    assert vel is not None and np.allclose(vel, [VM, 0.0])  # no slow-down at the switch
    _, pts = run(g, 0.5, 3.0)
    assert np.max(np.linalg.norm(np.diff(pts, axis=0), axis=1)) < 1.01 * VM * 1e-3 * math.sqrt(2)
    assert np.array_equal(pts[-1], end)


def test_queue_overflow_is_refused_with_minus_15() -> None:
    g = group()
    moving_x(g)
    for i in range(QUEUE_DEPTH):
        start, end = [1000, 10 * i], [1000, 10 * (i + 1)]
        assert g.submit(line(start, end), factory(), Transition.BUFFERED, 0.0, 0.1) == 0
    assert g.queued == QUEUE_DEPTH
    extra = line([1000, 100], [0, 100])
    assert g.submit(extra, factory(), Transition.BUFFERED, 0.0, 0.1) == ERR_COMMAND_IN_PROCESS == -15
    assert np.array_equal(g.target, [1000, 100])
    assert np.array_equal(g.positions(60.0), [1000, 100])


def test_mismatched_dimension_start_mode_or_parameter_is_refused_with_minus_10() -> None:
    g = group()
    moving_x(g)
    assert g.submit(line([1000, 0, 0], [0, 0, 0]), factory(), Transition.BUFFERED, 0.0, 0.1) == -10
    assert g.submit(line([999, 0], [0, 0]), factory(), Transition.BUFFERED, 0.0, 0.1) == -10
    assert g.submit(line([1000, 0], [0, 0]), factory(), 7, 0.0, 0.1) == ERR_PARAMETERS_INVALID
    assert g.submit(line([1000, 0], [0, 0]), factory(), Transition.BLEND_RES_DIST_PERCENT, 101.0, 0.1) == -10
    assert g.submit(line([1000, 0], [0, 0]), factory(), Transition.BLEND_RES_DIST, -1.0, 0.1) == -10
    assert g.queued == 0


def test_stop_decelerates_along_an_arc_and_clears_the_buffer() -> None:
    g = group()
    arc = arc2_ca([1000, 0], [0, 0], math.pi)
    assert g.submit(arc, factory(), Transition.BUFFERED, 0.0, 0.0) == 0
    g.submit(line(arc.end, [0, 0]), factory(), Transition.BUFFERED, 0.0, 0.0)
    g.stop(0.5, ACC, 0.0)
    assert g.queued == 0
    assert g.flags(0.55).decelerating
    _, pts = run(g, 0.5, 1.0)
    assert np.allclose(np.linalg.norm(pts, axis=1), 1000.0)
    assert arc.at(450.0 + 50.0) == pytest.approx(pts[-1])
    assert g.positions(1.1) is None


def test_abort_freezes_at_the_last_output_position() -> None:
    g = group()
    moving_x(g)
    here = g.positions(0.5)
    g.abort()
    assert np.array_equal(g.positions(0.6), here)
    assert g.positions(0.7) is None and g.flags(0.7).done


def test_events_happen_at_their_times_whatever_the_tick_rate() -> None:
    def sample(dt: float) -> np.ndarray:
        g = group()
        moving_x(g)
        g.submit(line([1000, 0], [1000, 1000]), factory(), Transition.BLEND_DEC_EVENT, 0.0, 0.0)
        g.submit(line([1000, 1000], [0, 1000]), factory(), Transition.BLEND_RES_DIST_PERCENT, 30.0, 0.0)
        for t in np.arange(0.0, 1.7, dt):
            g.positions(float(t))
        p = g.positions(1.7)
        assert p is not None
        return p

    assert np.allclose(sample(1e-3), sample(0.37), atol=1e-9)


def test_transition_from_option_bits() -> None:
    assert Transition.from_option(0x6001) is Transition.BLEND_RES_DIST_PERCENT
    assert Transition.from_option(0x0001) is Transition.ABORT_BLEND


QUEUED = [
    Transition.BUFFERED,
    Transition.BLEND_DEC_EVENT,
    Transition.BLEND_RES_DIST,
    Transition.BLEND_RES_DIST_PERCENT,
]


@settings(derandomize=True, max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(-500, 500),
            st.floats(-500, 500),
            st.sampled_from(QUEUED),
            st.floats(0, 100),
        ),
        min_size=1,
        max_size=5,
    )
)
def test_queued_chains_are_continuous_bounded_and_end_exactly(
    moves: list[tuple[float, float, Transition, float]],
) -> None:
    g = group()
    here = np.zeros(2)
    for dx, dy, mode, para in moves:
        end = here + [dx, dy]
        assert g.submit(line(here, end), factory(), mode, para, 0.0) == 0
        here = end
    dt = 1e-3
    _, pts = run(g, 0.0, 10.0, dt)
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert steps.max(initial=0.0) <= len(moves) * VM * dt * (1 + 1e-9)  # 100 % residue: all overlap
    assert np.array_equal(pts[-1], here)
    assert g.positions(10.0) is None
