"""SPLINE1/SPLINE2 planners: cubic B-splines with added zero-distance end segments [Turbo UM
"Cubic Spline Mode", "Added Pieces", "Quantifying the Position Adjustment"; PMAC UM "Splined
Moves"]."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.devices.pmac.trajectory import accel, joints, move, total, vec
from vdevd.devices.pmac.pieces import Piece
from vdevd.devices.pmac.planerr import RUN_TIME_ERROR, PlanError
from vdevd.devices.pmac.spline import SplinePlanner


def run(points: list[float], times: list[float] | float, uniform: bool = True) -> list[Piece]:
    pl = SplinePlanner(vec(X=0), uniform=uniform)
    ts = times if isinstance(times, list) else [times] * len(points)
    out: list[Piece] = []
    for p, t in zip(points, ts, strict=True):
        out += pl.add(move(vec(X=p), "X", TM=t))
    return out + pl.flush()


def test_way_points_and_velocities_are_the_manuals_averages() -> None:
    """WPi = (Pi-1 + 4Pi + Pi+1)/6, Vi = (Pi+1 - Pi-1)/2T [UM]; pieces: the added start segment,
    then segment i ends at WPi."""
    pts, t = [0.0, 3.0, 4.0, 10.0, 12.0, 12.5], 0.05
    pieces = run(pts[1:], t)
    for i in range(1, len(pts) - 1):
        pos, vel = pieces[i].end()
        assert pos[6] == pytest.approx((pts[i - 1] + 4 * pts[i] + pts[i + 1]) / 6)
        assert vel[6] == pytest.approx((pts[i + 1] - pts[i - 1]) / (2 * t))


def test_position_adjustment_is_the_difference_of_distances_over_6() -> None:
    """Diffi = (Disti+1 - Disti)/6 [UM "Quantifying the Position Adjustment"]."""
    pts = [0.0, 1.0, 5.0, 6.0, 6.0]
    pieces = run(pts[1:], 0.02)
    for i in (1, 2, 3):
        dist_i, dist_next = pts[i] - pts[i - 1], pts[i + 1] - pts[i]
        assert pieces[i].end()[0][6] - pts[i] == pytest.approx((dist_next - dist_i) / 6)


def test_added_pieces_start_and_stop_with_an_s_curve() -> None:
    """n moves take n + 2 segment times; the axis leaves and arrives with zero velocity and zero
    acceleration [UM "Added Pieces"]."""
    pieces = run([1.0, 2.0, 3.0], 0.1)
    assert len(pieces) == 5 and total(pieces) == pytest.approx(0.5)
    p0, v0 = pieces[0].at(0.0)
    assert p0[6] == 0 and v0[6] == pytest.approx(0, abs=1e-9)
    assert accel(pieces[0], 0.0)[6] == pytest.approx(0, abs=1e-6)
    p1, v1 = pieces[-1].end()
    assert p1[6] == pytest.approx(3.0) and v1[6] == pytest.approx(0, abs=1e-9)
    assert accel(pieces[-1], 0.1)[6] == pytest.approx(0, abs=1e-6)


def test_the_spline_is_continuous_in_acceleration() -> None:
    pieces = run([2.0, -1.0, 5.0, 5.0, 0.0, 3.0], 0.04)
    for k, (pa, va, pb, vb) in enumerate(joints(pieces)):
        assert pa == pytest.approx(pb, abs=1e-9) and va == pytest.approx(vb, abs=1e-7)
        assert accel(pieces[k], pieces[k].dur) == pytest.approx(accel(pieces[k + 1], 0.0), abs=1e-4)


def test_spline1_stops_when_the_segment_time_changes() -> None:
    """SPLINE1: a new segment time brings the sequence to a stop and starts a new one [PMAC UM]."""
    pieces = run([1.0, 2.0, 3.0, 4.0], [0.1, 0.1, 0.05, 0.05])
    assert len(pieces) == 8   # (2 + 2) + (2 + 2)
    mid_p, mid_v = pieces[3].end()
    assert mid_p[6] == pytest.approx(2.0) and mid_v[6] == pytest.approx(0, abs=1e-9)
    assert total(pieces) == pytest.approx(4 * 0.1 + 4 * 0.05)


def test_spline2_with_equal_times_is_spline1() -> None:
    a = run([1.0, 4.0, 2.0, 7.0], 0.03)
    b = run([1.0, 4.0, 2.0, 7.0], 0.03, uniform=False)
    for x, y in zip(a, b, strict=True):
        assert x.dur == y.dur and x.coef == pytest.approx(y.coef, abs=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(-100, 100), st.floats(0.005, 0.5)), min_size=1, max_size=12))
def test_spline2_changes_time_per_segment_smoothly(segs: list[tuple[float, float]]) -> None:
    """SPLINE2: no stop at a time change; still C2, ends exactly on the last point at rest, takes
    the segment times plus the added first and last segments."""
    points = [p for p, _ in segs]
    times = [t for _, t in segs]
    pieces = run(points, times, uniform=False)
    assert len(pieces) == len(segs) + 2
    assert total(pieces) == pytest.approx(sum(times) + times[0] + times[-1])
    end_p, end_v = pieces[-1].end()
    assert end_p[6] == pytest.approx(points[-1], abs=1e-6) and end_v[6] == pytest.approx(0, abs=1e-6)
    for k, (pa, va, pb, vb) in enumerate(joints(pieces)):
        scale = 1 + float(np.max(np.abs(va)))
        assert pa[6] == pytest.approx(pb[6], abs=1e-6)
        assert va[6] == pytest.approx(vb[6], abs=1e-6 * scale)
        acc_scale = 1 + abs(float(accel(pieces[k], pieces[k].dur)[6]))
        assert accel(pieces[k], pieces[k].dur)[6] == pytest.approx(accel(pieces[k + 1], 0.0)[6],
                                                                     abs=1e-5 * acc_scale)


def test_spline1_pieces_come_one_move_behind_and_flush_gives_the_rest() -> None:
    """SPLINE1: a span is final once the next point is known (the times ahead are the segment
    time); `labels` (index, moves before the last added) mark the piece each move begins with:
    the added start segment begins move 1, span 3 + m move m [README "Calculation and
    look-ahead"]."""
    pl = SplinePlanner(vec(X=0))
    assert len(pl.add(move(vec(X=1), "X", TM=0.1))) == 1 and pl.labels == [(0, 0)]
    assert len(pl.add(move(vec(X=2), "X", TM=0.1))) == 1 and pl.labels == []
    assert len(pl.add(move(vec(X=3), "X", TM=0.1))) == 1 and pl.labels == [(0, 1)]
    assert len(pl.flush()) == 2 and pl.labels == [(0, 0)]
    assert pl.flush() == []


def test_spline2_pieces_come_two_moves_behind_and_flush_gives_the_rest() -> None:
    """SPLINE2: a span depends on the segment times two moves ahead."""
    pl = SplinePlanner(vec(X=0), uniform=False)
    assert pl.add(move(vec(X=1), "X", TM=0.1)) == []
    assert len(pl.add(move(vec(X=2), "X", TM=0.1))) == 1 and pl.labels == [(0, 1)]
    assert len(pl.add(move(vec(X=3), "X", TM=0.1))) == 1 and pl.labels == []
    assert len(pl.flush()) == 3 and pl.labels == [(0, 1), (1, 0)]
    assert pl.flush() == []


def test_zero_segment_time_is_a_run_time_error() -> None:
    with pytest.raises(PlanError) as exc:
        SplinePlanner(vec()).add(move(vec(X=1), "X", TM=0))
    assert exc.value.bit == RUN_TIME_ERROR


@pytest.mark.parametrize("uniform", [True, False])
def test_a_long_sequence_keeps_the_planner_small_and_the_path_unchanged(uniform: bool) -> None:
    """The points and knots no span still needs are dropped (`_trim`): after 500 moves the
    planner holds a few of them, and the pieces are those of the whole spline."""
    pl = SplinePlanner(vec(X=0), uniform=uniform)
    pieces = []
    for k in range(1, 501):
        pieces += pl.add(move(vec(X=float(k % 7)), "X", TM=0.1))
        assert len(pl.ctrl) <= 8 and len(pl.knots) <= 10
    pieces += pl.flush()
    assert len(pieces) == 502                     # n moves, n + 2 segments
    assert pieces[-1].end()[0][6] == pytest.approx(500 % 7)
    for pa, va, pb, vb in joints(pieces):
        assert pa[6] == pytest.approx(pb[6], abs=1e-9) and va[6] == pytest.approx(vb[6], abs=1e-6)
