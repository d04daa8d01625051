"""CIRCLE1/CIRCLE2 planner: arcs in the NORMAL plane, centre vector and radius forms, helical
axes, Isx13 segmentation, the TA/TS blend along the path [Turbo SRM "CIRCLE1", "CIRCLE2",
"NORMAL", "R{data}", Isx13, Isx96, Isx97; PMAC SRM p.295; blend.py]."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tests.devices.pmac.trajectory import accel, joints, move, sample, total, vec
from vdevd.devices.pmac import blend
from vdevd.devices.pmac.circle import CirclePlanner
from vdevd.devices.pmac.pieces import Piece
from vdevd.devices.pmac.planerr import CIRCLE_RADIUS_ERROR, PlanError

SEG = 0.010   # Isx13 = 10 ms
K_MINUS_1 = np.array([0.0, 0.0, -1.0])


def arc(start: np.ndarray, *moves: tuple[np.ndarray, str, dict[str, object]]) -> list[Piece]:
    pl = CirclePlanner(start)
    out: list[Piece] = []
    for target, names, params in moves:
        out += pl.add(move(target, names, **{"CIRCLE": 1, "F": 10.0, "TA": 0.1, "TS": 0.0,
                                             "SEG": SEG, **params}))
    return out + pl.flush()


def xy(pieces: list[Piece], dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ts, ps, vs = sample(pieces, dt)
    return ts, ps[:, 6:8], vs[:, 6:8]


def test_circle1_quarter_turns_clockwise_in_the_xy_plane() -> None:
    """NORMAL K-1 (default): CIRCLE1 is clockwise seen from +Z; the path keeps the radius, ends
    on the end point, and takes arc/F plus TA."""
    pieces = arc(vec(X=10), (vec(X=0, Y=-10), "XY", {"IJK": np.array([-10.0, 0, 0])}))
    _, p, _ = xy(pieces)
    r = np.hypot(p[:, 0], p[:, 1])
    assert r == pytest.approx(np.full_like(r, 10.0), abs=1e-4)
    assert np.all(p[:, 1] <= 1e-9) and np.all(p[:, 0] >= -1e-9)     # the fourth quadrant
    assert pieces[-1].end()[0][6:8] == pytest.approx([0, -10], abs=1e-12)
    assert total(pieces) == pytest.approx(np.pi * 10 / 2 / 10 + 0.1)


def test_circle2_to_the_same_point_goes_the_other_way_round() -> None:
    pieces = arc(vec(X=10), (vec(X=0, Y=-10), "XY", {"CIRCLE": 2, "IJK": np.array([-10.0, 0, 0])}))
    _, p, _ = xy(pieces)
    assert p[:, 1].max() == pytest.approx(10, abs=1e-3) and p[:, 0].min() == pytest.approx(-10, abs=1e-3)
    assert total(pieces) == pytest.approx(1.5 * np.pi * 10 / 10 + 0.1)


def test_speed_along_the_arc_is_the_feedrate_between_the_accelerations() -> None:
    pieces = arc(vec(X=10), (vec(X=-10), "XY", {"IJK": np.array([-10.0, 0, 0])}))
    ts, _, v = xy(pieces)
    speed = np.hypot(v[:, 0], v[:, 1])
    cruise = (ts > 0.11) & (ts < total(pieces) - 0.11)
    assert speed[cruise] == pytest.approx(np.full(cruise.sum(), 10.0), rel=1e-6)
    assert speed[0] == 0 and speed[-1] == pytest.approx(0, abs=1e-9)
    start = ts < 0.1    # the start ramp lies on the segment grid: F/TA exactly
    assert np.diff(speed)[start[:-1]] / 1e-3 == pytest.approx(np.full(start.sum(), 10 / 0.1), rel=1e-3)


def test_pieces_are_isx13_segments() -> None:
    pieces = arc(vec(X=10), (vec(X=-10), "XY", {"IJK": np.array([-10.0, 0, 0])}))
    assert all(p.dur == pytest.approx(SEG) for p in pieces[:-1]) and pieces[-1].dur <= SEG + 1e-12
    for pa, va, pb, vb in joints(pieces):
        assert pa == pytest.approx(pb, abs=1e-12) and va == pytest.approx(vb, abs=1e-9)


@pytest.mark.parametrize(("r", "through"), [(10.0, (10 / np.sqrt(2), 10 / np.sqrt(2) - 10)),
                                             (-10.0, (10.0, 10.0))])
def test_radius_form_positive_short_arc_negative_long_arc(r: float, through: tuple[float, float]) -> None:
    """R > 0: the arc of at most 180°; R < 0: the one of at least 180° [PMAC SRM p.295]."""
    pieces = arc(vec(X=0), (vec(X=10, Y=-10), "XY", {"R": r}))
    _, p, _ = xy(pieces)
    d = np.hypot(p[:, 0] - through[0], p[:, 1] - through[1])
    assert d.min() < 0.01
    sweep = np.pi / 2 if r > 0 else 1.5 * np.pi
    assert total(pieces) == pytest.approx(sweep * 10 / 10 + 0.1)
    assert pieces[-1].end()[0][6:8] == pytest.approx([10, -10])


def test_end_beyond_2r_is_a_spiral_within_isx96_else_a_circle_radius_error() -> None:
    """SRM Isx96 example: INC CIRCLE1 X7.072 Y7.072 R5 (distance 10.003)."""
    pieces = arc(vec(), (vec(X=7.072, Y=7.072), "XY", {"R": 5.0, "Isx96": 0.01}))
    assert pieces[-1].end()[0][6:8] == pytest.approx([7.072, 7.072])
    with pytest.raises(PlanError) as exc:
        arc(vec(), (vec(X=7.072, Y=7.072), "XY", {"R": 5.0, "Isx96": 0.001}))
    assert exc.value.bit == CIRCLE_RADIUS_ERROR
    arc(vec(), (vec(X=7.072, Y=7.072), "XY", {"R": 5.0, "Isx96": 0.0}))   # 0: no error


def test_end_on_the_start_with_a_centre_vector_is_a_full_circle() -> None:
    pieces = arc(vec(X=10), (vec(X=10), "XY", {"IJK": np.array([-10.0, 0, 0])}))
    _, p, _ = xy(pieces)
    assert p[:, 0].min() == pytest.approx(-10, abs=1e-3)
    assert total(pieces) == pytest.approx(2 * np.pi + 0.1)


def test_absolute_centre_vector_abs_r() -> None:
    """ABS(R): I J K from the XYZ origin."""
    pieces = arc(vec(X=15, Y=5), (vec(X=5, Y=-5), "XY", {"IJK": np.array([5.0, 5, 0]), "IJK_ABS": True}))
    _, p, _ = xy(pieces)
    r = np.hypot(p[:, 0] - 5, p[:, 1] - 5)
    assert r == pytest.approx(np.full_like(r, 10.0), abs=1e-4)


@pytest.mark.parametrize(("normal", "plane"), [(np.array([0.0, -1, 0]), (8, 6)),    # J-1: ZX
                                               (np.array([-1.0, 0, 0]), (7, 8))])   # I-1: YZ
def test_normal_selects_the_plane(normal: np.ndarray, plane: tuple[int, int]) -> None:
    """NORMAL J-1 circles in ZX, I-1 in YZ, clockwise with the same right-hand rule [SRM NORMAL]."""
    a, b = plane
    start, end, ijk = np.zeros(9), np.zeros(9), np.zeros(3)
    start[a], end[b], ijk[a - 6] = 10.0, -10.0, -10.0
    pl = CirclePlanner(start)
    pieces = pl.add(move(end, "XYZ", CIRCLE=1, NORMAL=normal, IJK=ijk, F=10.0, TA=0.1, SEG=SEG))
    pieces += pl.flush()
    _, ps, _ = sample(pieces)
    r = np.hypot(ps[:, a], ps[:, b])
    assert r == pytest.approx(np.full_like(r, 10.0), abs=1e-4)
    assert np.all(ps[:, b] <= 1e-9)   # clockwise from +a towards −b, as in XY


def test_helical_axes_move_linearly_in_the_same_time() -> None:
    """Z (along the normal) and A move in proportion to the arc [SRM: other axes interpolated
    linearly to finish in the same time]."""
    pieces = arc(vec(X=10), (vec(X=-10, Z=5, A=90), "XYZA", {"IJK": np.array([-10.0, 0, 0])}))
    _, ps, _ = sample(pieces)
    angle = np.unwrap(np.arctan2(ps[:, 7], ps[:, 6]))
    frac = -angle / np.pi
    assert ps[:, 8] == pytest.approx(5 * frac, abs=1e-6)
    assert ps[:, 0] == pytest.approx(90 * frac, abs=1e-4)
    assert total(pieces) == pytest.approx(np.hypot(np.pi * 10, 5) / 10 + 0.1)


def test_consecutive_arcs_blend_without_stopping() -> None:
    """An S-curve of two half circles: the speed stays F through the boundary (within 1e-4:
    the velocity vectors of the two arcs blend over TA, their curvatures opposite)."""
    pieces = arc(vec(X=0), (vec(X=20), "XY", {"IJK": np.array([10.0, 0, 0])}),
                 (vec(X=40), "XY", {"CIRCLE": 2, "IJK": np.array([10.0, 0, 0])}))
    ts, p, v = xy(pieces)
    speed = np.hypot(v[:, 0], v[:, 1])
    cruise = (ts > 0.11) & (ts < total(pieces) - 0.11)
    assert speed[cruise] == pytest.approx(np.full(cruise.sum(), 10.0), rel=1e-4)
    assert total(pieces) == pytest.approx(2 * np.pi * 10 / 10 + 0.1)
    assert p[:, 1].max() == pytest.approx(10, abs=1e-3) and p[:, 1].min() == pytest.approx(-10, abs=1e-3)


def test_isx13_zero_runs_the_move_as_a_linear_move() -> None:
    """Isx13 = 0: "CIRCLE mode moves are executed as LINEAR moves" [SRM Isx13]."""
    pieces = arc(vec(X=10), (vec(X=-10), "XY", {"IJK": np.array([-10.0, 0, 0]), "SEG": 0.0}))
    _, p, _ = xy(pieces)
    assert np.all(np.abs(p[:, 1]) < 1e-9)
    assert total(pieces) == pytest.approx(20 / 10 + 0.1)
    assert pieces[-1].end()[0][6] == -10


def test_a_short_move_takes_its_acceleration_time() -> None:
    pieces = arc(vec(X=10), (vec(X=0, Y=-10), "XY", {"IJK": np.array([-10.0, 0, 0]), "F": 1000.0,
                                                      "TA": 0.2}))
    assert total(pieces) == pytest.approx(0.4)


def test_time_specified_move_uses_tm() -> None:
    pieces = arc(vec(X=10), (vec(X=0, Y=-10), "XY", {"IJK": np.array([-10.0, 0, 0]),
                                                      "TM": 2.0}))
    assert total(pieces) == pytest.approx(2.1)


def test_s_curve_starts_with_zero_acceleration() -> None:
    pieces = arc(vec(X=10), (vec(X=-10), "XY", {"IJK": np.array([-10.0, 0, 0]), "TA": 0.2, "TS": 0.1}))
    assert accel(pieces[0], 0.0)[6:8] == pytest.approx([0, 0], abs=1e-3)   # F/TA is 50
    assert total(pieces) == pytest.approx(np.pi + 0.2)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 0.3), st.floats(0.0, 0.2), st.floats(-3, 3))
def test_blend_kernel_moves_the_full_distance(ta: float, ts: float, t: float) -> None:
    """The TA/TS kernel is a unit-area blend: before it nothing, after it all of the distance."""
    a, b = blend.widths(ta, ts)
    ta_, ts_ = (ta if ta > blend._TINY else 0.0), (ts if ts > blend._TINY else 0.0)  # ~0: none
    assert a + b == pytest.approx(max(ta_, 2 * ts_), abs=1e-9) and a >= b
    h = (a + b) / 2
    assert blend.ramp(np.array([-h - 1e-9]), a, b)[0] == pytest.approx(0, abs=1e-9)
    assert blend.ramp(np.array([h + 1.0]), a, b)[0] == pytest.approx(h + 1.0)
    rate = blend.ramp_rate(np.array([t]), a, b)[0]
    assert 0.0 <= rate <= 1.0 + 1e-12


def test_pieces_through_the_last_moves_blend_are_final_at_add() -> None:
    """Each add returns the motion up to the end of the added move's start blend (TA centred on
    its start; the next move's blend is held after it), and `begin` marks the piece where the
    added move's blend begins (the runner's look-ahead counts the move from there, one move
    ahead with Isx13 > 0 as segmented LINEAR) [README "Calculation and look-ahead"]."""
    pl = CirclePlanner(vec(X=10))
    p = {"CIRCLE": 1, "F": 10.0, "TA": 0.1, "SEG": SEG}
    first = pl.add(move(vec(X=-10), "XY", IJK=np.array([-10.0, 0, 0]), **p))
    assert total(first) == pytest.approx(0.1, abs=SEG) and pl.begin == 0   # its start blend
    second = pl.add(move(vec(X=10), "XY", IJK=np.array([10.0, 0, 0]), **p))
    assert total(first + second) == pytest.approx(np.pi + 0.1, abs=SEG)   # through its blend
    assert total(first + second[:pl.begin]) == pytest.approx(np.pi, abs=SEG)
    rest = pl.flush()
    assert total(first + second + rest) == pytest.approx(2 * np.pi + 0.1)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.5, 50), st.floats(-np.pi, np.pi), st.floats(0.05, 2 * np.pi - 0.05),
       st.sampled_from([1, 2]), st.floats(1.0, 100.0), st.floats(0.02, 0.2), st.floats(-5, 5))
def test_random_arcs_end_on_target_keep_radius_and_progress(radius: float, start_angle: float,
                                                            sweep: float, direction: int,
                                                            feed: float, ta: float,
                                                            rise: float) -> None:
    """Any IJK arc: ends exactly on its end point at rest, stays on its helix, never turns back
    (TA of at least two segments: a TA of 0 is a step of velocity the segment cubics round)."""
    assume(feed / radius <= 20)   # at most 0.2 rad per 10 ms segment (the segment cubics' error)
    sigma = -1.0 if direction == 1 else 1.0   # CIRCLE1 is clockwise seen from +Z (NORMAL K-1)
    start = vec(X=radius * np.cos(start_angle), Y=radius * np.sin(start_angle))
    end_angle = start_angle + sigma * sweep
    end = vec(X=radius * np.cos(end_angle), Y=radius * np.sin(end_angle), Z=rise)
    ijk = np.array([-start[6], -start[7], 0.0])
    pieces = arc(start, (end, "XYZ", {"CIRCLE": direction, "IJK": ijk, "F": feed, "TA": ta}))
    p, v = pieces[-1].end()
    assert p == pytest.approx(end, abs=1e-9) and v == pytest.approx(np.zeros(9), abs=1e-9)
    _, ps, _ = sample(pieces, 2e-3)
    r = np.hypot(ps[:, 6], ps[:, 7])
    assert r == pytest.approx(np.full_like(r, radius), rel=1e-3, abs=1e-3)
    turned = np.unwrap(np.arctan2(ps[:, 7], ps[:, 6])) - start_angle
    assert np.all(np.diff(sigma * turned) >= -1e-6)
    assert sigma * turned[-1] == pytest.approx(sweep, abs=1e-6)
