"""Interpolation geometry [M §4.7.1-4.7.2], spec §2.11-2.12: lengths, exact ends, the Dir lap table,
Gram-Schmidt normal correction, refusals, and path-length parametrisation checked numerically."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vdevd.devices.adlink.path import (
    ERR_PARAMETERS_INVALID,
    Arc,
    Line,
    PathError,
    arc2_ca,
    arc2_ce,
    arc3_ca,
    arc3_ce,
    line,
    spiral_ca,
    spiral_ce,
)

PROPS = settings(derandomize=True, max_examples=40, deadline=None)


def polyline_length(path: Line | Arc, n: int = 20001) -> float:
    pts = path.at(np.linspace(0.0, path.length, n))
    return float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))


def test_line_length_is_the_euclidean_norm_over_six_axes() -> None:
    p = line([0, 0, 0, 0, 0, 0], [1, 2, 3, 4, 5, 6])
    assert p.length == pytest.approx(math.sqrt(91))
    assert np.allclose(p.at(p.length / 2), [0.5, 1, 1.5, 2, 2.5, 3])


def test_line_end_is_exact_and_at_is_vectorised() -> None:
    end = [0.1 + 0.2, 1 / 3]
    p = line([0.7, -0.3], end)
    assert np.array_equal(p.at(p.length), np.array(end))
    pts = p.at([0.0, p.length / 3, p.length, 2 * p.length])
    assert pts.shape == (4, 2)
    assert np.array_equal(pts[2], np.array(end)) and np.array_equal(pts[3], np.array(end))
    assert np.array_equal(pts[0], p.start)


def test_line_tangent_is_unit_direction() -> None:
    p = line([0, 0], [3, 4])
    assert np.allclose(p.tangent_at(1.0), [0.6, 0.8])
    assert p.tangent_at([0.0, 5.0]).shape == (2, 2)


@pytest.mark.parametrize("dims", [1, 7])
def test_line_needs_2_to_6_axes(dims: int) -> None:
    with pytest.raises(PathError) as err:
        line([0] * dims, [1] * dims)
    assert err.value.code == ERR_PARAMETERS_INVALID == -10


def test_path_error_is_a_value_error() -> None:
    with pytest.raises(ValueError):
        line([0, 0], [1, float("nan")])


def test_quarter_circle_length_is_r_pi_over_2() -> None:
    p = arc2_ca([2, 0], [0, 0], math.pi / 2)
    assert p.length == pytest.approx(math.pi)
    assert np.allclose(p.end, [0, 2], atol=1e-12)
    assert np.allclose(p.at(p.length / 2), [math.sqrt(2), math.sqrt(2)])


def test_2d_positive_angle_is_counter_clockwise_from_axis0_toward_axis1() -> None:
    p = arc2_ca([1, 0], [0, 0], 0.1)
    assert p.at(0.05)[1] > 0
    assert np.allclose(p.tangent_at(0.0), [0, 1])
    assert arc2_ca([1, 0], [0, 0], -0.1).at(0.05)[1] < 0


@pytest.mark.parametrize(("direction", "degrees"), [(0, 30), (1, 390), (2, 750), (-1, -330), (-2, -690)])
def test_dir_lap_table_for_theta_30_degrees(direction: int, degrees: float) -> None:
    c = np.array([1.0, 2.0, 3.0])
    s = c + [5.0, 0.0, 0.0]
    e = c + 5.0 * np.array([math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0])
    p = arc3_ce(s, c, e, direction)
    assert math.degrees(p.angle) == pytest.approx(degrees)
    assert p.length == pytest.approx(5.0 * math.radians(abs(degrees)))
    assert np.array_equal(p.at(p.length), e)
    assert np.array_equal(p.end, e)
    q = arc2_ce(s[:2], c[:2], e[:2], direction)
    assert math.degrees(q.angle) == pytest.approx(degrees)
    assert np.array_equal(q.end, e[:2])


def test_3d_centre_end_normal_is_start_cross_end_about_the_centre() -> None:
    p = arc3_ce([0, 1, 0], [0, 0, 0], [0, 0, 1], 0)  # (S-C) x (E-C) = +X
    mid = p.at(p.length / 2)
    assert np.allclose(mid, [0, math.sqrt(0.5), math.sqrt(0.5)])
    q = arc3_ce([0, 1, 0], [0, 0, 0], [0, 0, 1], -1)  # 270 degrees the other way
    assert q.length == pytest.approx(1.5 * math.pi)
    assert np.allclose(q.at(q.length / 3), [0, 0, -1], atol=1e-12)  # -90 degrees about +X


@pytest.mark.parametrize("end", [[1, 0, 0], [-1, 0, 0]])
def test_3d_centre_end_refuses_0_and_180_degrees(end: list[float]) -> None:
    with pytest.raises(PathError):
        arc3_ce([1, 0, 0], [0, 0, 0], end, 1)


def test_2d_centre_end_accepts_a_half_circle_and_refuses_a_full_one() -> None:
    p = arc2_ce([1, 0], [0, 0], [-1, 0], 0)
    assert p.length == pytest.approx(math.pi)
    assert np.allclose(p.at(p.length / 2), [0, 1])
    with pytest.raises(PathError):
        arc2_ce([1, 0], [0, 0], [1, 0], 0)


def test_centre_end_radius_tolerance_is_1e_6_relative() -> None:
    arc2_ce([1000, 0], [0, 0], [0, 1000 * (1 + 0.9e-6)], 0)
    with pytest.raises(PathError) as err:
        arc2_ce([1000, 0], [0, 0], [0, 1000 * (1 + 1.1e-6)], 0)
    assert err.value.code == -10


def test_centre_end_radius_rounding_is_blended_so_the_path_reaches_the_end_continuously() -> None:
    e = np.array([0.0, 1000 * (1 + 0.9e-6)])
    p = arc2_ce([1000, 0], [0, 0], e, 0)
    just_before = p.at(p.length * (1 - 1e-12))
    assert np.linalg.norm(just_before - e) < 1e-6


def test_gram_schmidt_corrects_a_normal_not_orthogonal_to_the_start_radius() -> None:
    # normal (1, 0, 1) with S - C along +X: corrected to +Z, so the arc lies in the XY plane
    p = arc3_ca([2, 0, 0], [0, 0, 0], [1, 0, 1], math.pi / 2)
    assert np.allclose(p.end, [0, 2, 0], atol=1e-12)
    assert np.allclose(p.at(np.linspace(0, p.length, 7))[:, 2], 0.0)
    assert p.length == pytest.approx(math.pi)


def test_normal_parallel_to_the_start_radius_is_refused() -> None:
    with pytest.raises(PathError):
        arc3_ca([2, 0, 0], [0, 0, 0], [3, 0, 0], 1.0)
    with pytest.raises(PathError):
        arc3_ca([2, 0, 0], [0, 0, 0], [0, 0, 0], 1.0)


def test_start_on_the_centre_and_zero_angle_are_refused() -> None:
    with pytest.raises(PathError):
        arc2_ca([1, 1], [1, 1], 1.0)
    with pytest.raises(PathError):
        arc2_ca([1, 0], [0, 0], 0.0)


def test_arc3_multiple_laps_end_where_they_started() -> None:
    p = arc3_ca([1, 0, 0], [0, 0, 0], [0, 0, 1], 4 * math.pi)
    assert p.length == pytest.approx(4 * math.pi)
    assert np.allclose(p.end, [1, 0, 0], atol=1e-12)


def test_helix_length_closed_form() -> None:
    # two laps of radius 3 rising 8: length = 2 * sqrt((2 pi 3)^2 + 4^2)
    p = spiral_ca([3, 0, 0], [0, 0, 0], [0, 0, 1], 4 * math.pi, 8.0, 3.0)
    assert p.length == pytest.approx(2 * math.hypot(6 * math.pi, 4.0))
    assert np.allclose(p.end, [3, 0, 8], atol=1e-12)
    assert np.allclose(p.at(p.length / 4), [-3, 0, 2], atol=1e-12)


def test_conic_spiral_length_matches_numerical_integration_and_s_is_path_length() -> None:
    p = spiral_ca([1, 0, 0], [0, 0, 0], [0, 0, 1], 3 * math.pi, 2.0, 4.0)
    assert p.length == pytest.approx(polyline_length(p), rel=1e-7)
    pts = p.at(np.linspace(0, p.length, 2001))
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert np.allclose(steps, p.length / 2000, rtol=1e-4)
    assert np.allclose(p.end, [-4, 0, 2], atol=1e-12)


def test_spiral_to_the_centre_reaches_zero_radius() -> None:
    p = spiral_ca([2, 0, 0], [0, 0, 0], [0, 0, 1], 2 * math.pi, 0.0, 0.0)
    assert np.allclose(p.end, [0, 0, 0], atol=1e-12)
    assert p.length == pytest.approx(polyline_length(p), rel=1e-6)


def test_spiral_centre_end_derives_height_final_radius_and_theta_and_ends_exactly() -> None:
    e = np.array([0.0, 2.0, 5.0])
    p = spiral_ce([1, 0, 0], [0, 0, 0], [0, 0, 1], e, 1)
    assert p.angle == pytest.approx(math.pi / 2 + 2 * math.pi)
    assert p.height == pytest.approx(5.0) and p.final_radius == pytest.approx(2.0)
    assert np.array_equal(p.at(p.length + 1.0), e)
    assert np.linalg.norm(p.at(p.length * (1 - 1e-12)) - e) < 1e-9
    with pytest.raises(PathError):
        spiral_ce([1, 0, 0], [0, 0, 0], [0, 0, 1], [1, 0, 5], 0)  # straight up: zero angle
    assert spiral_ce([1, 0, 0], [0, 0, 0], [0, 0, 1], [1, 0, 5], 1).length == pytest.approx(
        math.hypot(2 * math.pi, 5)
    )


def test_rebased_keeps_the_command_and_moves_the_start() -> None:
    assert np.array_equal(line([0, 0], [5, 5]).rebased([1, 0]).start, [1, 0])
    p = arc2_ca([1, 0], [0, 0], math.pi / 2).rebased([0, 1])
    assert np.allclose(p.end, [-1, 0])
    with pytest.raises(PathError):
        arc2_ce([1, 0], [0, 0], [0, 1], 0).rebased([2, 0])


@PROPS
@given(
    st.floats(0.5, 50),
    st.floats(-20.0, 20.0).filter(lambda a: abs(a) > 0.05),
    st.floats(-10, 10),
    st.floats(0.0, 50),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.1, 1)),
)
def test_spiral_invariants(r0: float, angle: float, dh: float, rf: float, normal: tuple[float, ...]) -> None:
    c = np.array([1.0, -2.0, 0.5])
    p = spiral_ca(c + [r0, 0, 0], c, normal, angle, dh, rf)
    assert p.length == pytest.approx(polyline_length(p, 4001), rel=1e-4)
    s = np.linspace(0.0, p.length, 401)
    t = p.tangent_at(s)
    assert np.allclose(np.linalg.norm(t, axis=1), 1.0)
    ds = 1e-6 * p.length
    mid = s[1:-1]
    numeric = (p.at(mid + ds) - p.at(mid - ds)) / (2 * ds)
    assert np.allclose(numeric, t[1:-1], atol=1e-4)
    assert np.array_equal(p.at(0.0), p.start)


def test_scalar_and_vectorised_evaluation_agree_on_a_conic_spiral() -> None:
    p = spiral_ca([1, 0, 0], [0, 0, 0], [0, 0, 1], 30.0, 5.0, 40.0)
    s = np.linspace(0.0, p.length, 257)
    one_by_one = np.array([p.at(float(x)) for x in s])
    assert np.allclose(p.at(s), one_by_one, rtol=0, atol=1e-9)
    assert np.allclose(p.tangent_at(s), np.array([p.tangent_at(float(x)) for x in s]), atol=1e-12)
