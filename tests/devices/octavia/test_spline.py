"""Contour interpolation: 2nd-order blocks, Hermite segments, the internal table's spline and
CUBIC_SCALE [Ch5 BTRATE, CUBIC_RATE, CUBIC_SCALE, CUBIC_INT; spec octavia.md §5.4]."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vdevd.devices.octavia.spline import cubic_scale, hermite, second_order, spline_velocities

POSITION = st.integers(-2**31, 2**31 - 1)
VELOCITY = st.floats(-255.99, 255.99)
BLOCK = st.sampled_from([25, 50, 75, 100])        # BTRATE m = 0..3: 5..20 ms [Ch5 BTRATE]
CIRCLE_RATE = 400                                 # 16 points at 80 ms [Ch5 CUBIC_RATE]


def circle(points: int, radius: float = 2500) -> np.ndarray:
    angle = 2 * np.pi * np.arange(points) / points
    return np.round(radius * np.stack([np.cos(angle), np.sin(angle)], axis=1))


def curvature(p0: np.ndarray, v0: np.ndarray, p1: np.ndarray, v1: np.ndarray, n: int,
              at_end: bool) -> np.ndarray:
    """The second derivative of a Hermite segment at its start or end (counts/sample²)."""
    if at_end:
        return (-6 * (p1 - p0) + 2 * n * v0 + 4 * n * v1) / n**2
    return (6 * (p1 - p0) - 4 * n * v0 - 2 * n * v1) / n**2


# --- 2nd order ---

@settings(derandomize=True, max_examples=200, deadline=None)
@given(p0=POSITION, v0=VELOCITY, v1=VELOCITY, n=BLOCK)
def test_second_order_with_consistent_data_is_constant_acceleration(p0: int, v0: float, v1: float,
                                                                    n: int) -> None:
    p1 = p0 + n * (v0 + v1) / 2
    pos, vel = second_order(p0, v0, p1, v1, n)
    # float64 near 2^31 resolves 2.4e-7 counts: tolerances are a few of those
    assert pos[-1] == pytest.approx(p1, abs=1e-5) and vel[-1] == pytest.approx(v1, abs=1e-6)
    path = np.concatenate([[p0], pos])
    accel = np.diff(path, 2)
    assert accel == pytest.approx(np.full(n - 1, (v1 - v0) / n), abs=1e-5)
    assert np.diff(path)[0] == pytest.approx(v0 + (v1 - v0) / (2 * n), abs=1e-5)  # v0 at t = 0
    assert vel == pytest.approx(v0 + (v1 - v0) * np.arange(1, n + 1) / n, abs=1e-6)


@settings(derandomize=True, max_examples=200, deadline=None)
@given(p0=POSITION, p1=POSITION, v0=VELOCITY, v1=VELOCITY, n=BLOCK)
def test_second_order_always_ends_exactly_on_the_next_point(p0: int, p1: int, v0: float, v1: float,
                                                           n: int) -> None:
    pos, _ = second_order(p0, v0, p1, v1, n)
    assert pos[-1] == p1 and len(pos) == n


def test_second_order_is_vectorised_over_axes() -> None:
    p0, v0 = np.array([0, 100, -40]), np.array([0.0, 2.0, -1.0])
    p1, v1 = np.array([250, 100, -90]), np.array([10.0, -2.0, -1.0])
    pos, vel = second_order(p0, v0, p1, v1, 50)
    assert pos.shape == vel.shape == (50, 3)
    for axis in range(3):
        one, _ = second_order(p0[axis], v0[axis], p1[axis], v1[axis], 50)
        assert np.array_equal(pos[:, axis], one)
    assert pos[-1].tolist() == [250, 100, -90]


# --- Hermite (ring-buffer cubic) ---

@settings(derandomize=True, max_examples=200, deadline=None)
@given(p0=POSITION, p1=POSITION, v0=VELOCITY, v1=VELOCITY, n=st.integers(5, 511))
def test_hermite_ends_on_the_next_point_with_both_end_velocities(p0: int, p1: int, v0: float,
                                                                v1: float, n: int) -> None:
    pos, vel = hermite(p0, v0, p1, v1, n)
    assert pos[-1] == p1 and vel[-1] == pytest.approx(v1, abs=1e-6)
    _, back = hermite(p1, -v1, p0, -v0, n)          # the same curve backwards ends with −v0
    assert back[-1] == pytest.approx(-v0, abs=1e-6)
    # for a cubic, the central difference is the derivative plus a sixth of the (constant) jerk
    jerk = (12 * (p0 - p1) + 6 * n * (v0 + v1)) / n**3
    central = (pos[2:] - pos[:-2]) / 2
    tol = 1e-5 * max(1.0, max(abs(p0), abs(p1)) / 1e6)
    assert central == pytest.approx(vel[1:-1] + jerk / 6, abs=tol)


def test_hermite_with_matching_velocities_is_a_straight_line() -> None:
    pos, vel = hermite(1000, 2.5, 2000, 2.5, 400)
    assert pos == pytest.approx(1000 + 2.5 * np.arange(1, 401), abs=1e-9)
    assert vel == pytest.approx(np.full(400, 2.5), abs=1e-12)


# --- internal table: spline velocities ---

def test_circle_of_cubic_rate_matches_the_manual_points() -> None:
    points = circle(16)
    assert points[0].tolist() == [2500, 0] and points[1].tolist() == [2310, 957]
    assert points[15].tolist() == [2310, -957]
    assert points[1].tolist() == [0x906, 0x3BD] and int(points[15][1]) & 0xFFFFFFFF == 0xFFFFFC43


def run_loop(points: np.ndarray, vel: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The closed path through `points` (last to first included), sample by sample."""
    segments = [hermite(points[k], vel[k], points[(k + 1) % len(points)], vel[(k + 1) % len(points)], n)
                for k in range(len(points))]
    return np.concatenate([s[0] for s in segments]), np.concatenate([s[1] for s in segments])


def test_16_point_circle_is_a_closed_periodic_c2_path_of_1_28_s() -> None:
    points = circle(16)
    vel = spline_velocities(points, CIRCLE_RATE, periodic=True)
    pos, speed = run_loop(points, vel, CIRCLE_RATE)
    assert len(pos) * 200e-6 == pytest.approx(1.28)                 # 16 × 80 ms [Ch5 CUBIC_RATE]
    assert pos[-1].tolist() == [2500, 0]                            # closes on p1
    for k in range(16):                                             # C² at every joint, p16→p1 too
        before = curvature(points[k - 1], vel[k - 1], points[k], vel[k], CIRCLE_RATE, at_end=True)
        after = curvature(points[k], vel[k], points[(k + 1) % 16], vel[(k + 1) % 16], CIRCLE_RATE,
                          at_end=False)
        assert before == pytest.approx(after, abs=1e-9)
    radius = np.hypot(pos[:, 0], pos[:, 1])
    assert radius.min() > 2499 and radius.max() < 2501              # a natural spline: 2481..2528
    tangential = 2 * math.pi * 2500 / 6400                          # counts/sample
    assert np.hypot(speed[:, 0], speed[:, 1]) == pytest.approx(np.full(6400, tangential), rel=0.002)


def test_natural_spline_does_not_close_the_circle_smoothly() -> None:
    points = circle(16)
    vel = spline_velocities(points, CIRCLE_RATE, periodic=False)
    before = curvature(points[15], vel[15], points[0], vel[0], CIRCLE_RATE, at_end=True)
    after = curvature(points[0], vel[0], points[1], vel[1], CIRCLE_RATE, at_end=False)
    assert np.abs(before - after).max() > 1e-4
    assert np.abs(curvature(points[0], vel[0], points[1], vel[1], CIRCLE_RATE, at_end=False)).max() \
        < 1e-12                                                     # natural: no curvature at the ends


@settings(derandomize=True, max_examples=100, deadline=None)
@given(points=st.lists(st.integers(-10**6, 10**6), min_size=2, max_size=60),
       n=st.integers(5, 511), periodic=st.booleans())
def test_spline_velocities_solve_the_c2_equations(points: list[int], n: int, periodic: bool) -> None:
    p = np.array(points, dtype=float)
    v = spline_velocities(p, n, periodic=periodic)
    scale = max(1.0, np.abs(p).max() / n)
    if periodic:
        left = np.roll(v, 1) + 4 * v + np.roll(v, -1)
        assert left == pytest.approx(3 * (np.roll(p, -1) - np.roll(p, 1)) / n, abs=1e-9 * scale)
    else:
        assert 2 * v[0] + v[1] == pytest.approx(3 * (p[1] - p[0]) / n, abs=1e-9 * scale)
        assert v[-2] + 2 * v[-1] == pytest.approx(3 * (p[-1] - p[-2]) / n, abs=1e-9 * scale)
        inner = v[:-2] + 4 * v[1:-1] + v[2:]
        assert inner == pytest.approx(3 * (p[2:] - p[:-2]) / n, abs=1e-9 * scale)


def test_spline_velocities_of_a_line_are_its_slope_per_sample_per_axis() -> None:
    points = np.stack([np.arange(10) * 800.0, np.full(10, -5.0)], axis=1)
    v = spline_velocities(points, 400, periodic=False)
    assert v.shape == (10, 2)
    assert v[:, 0] == pytest.approx(np.full(10, 2.0)) and v[:, 1] == pytest.approx(np.zeros(10))
    assert spline_velocities(points[:1], 400, periodic=True).tolist() == [[0.0, 0.0]]


# --- CUBIC_SCALE ---

def test_cubic_scale_manual_example_halves_the_points() -> None:
    points = circle(16)[:, 1].astype(np.int64)
    assert cubic_scale(points, 0x2000, 0)[:3].tolist() == [0, 479, 884]   # 957·0.5 → 478.5 → 479
    assert cubic_scale([-957], 0x2000, 0).tolist() == [-478]              # ties towards +∞


def test_cubic_scale_multiplier_is_s1_14_and_shift_moves_the_origin() -> None:
    assert cubic_scale([1000, -1000], 0x4000, 0).tolist() == [1000, -1000]       # 1.0
    assert cubic_scale([1000], -0x8000, 0).tolist() == [-2000]                   # −2.0
    assert cubic_scale([1000], 0x6000, -250).tolist() == [1250]                  # 1.5, shift
    assert cubic_scale([2**31 - 1], 0x4000, 1).tolist() == [-2**31]              # rolls over
    with pytest.raises(ValueError):
        cubic_scale([1], 0x8000, 0)
    with pytest.raises(ValueError):
        cubic_scale([1], 0x4000, 2**31)


def test_intervals_below_one_sample_are_rejected() -> None:
    with pytest.raises(ValueError):
        second_order(0, 0, 1, 0, 0)
    with pytest.raises(ValueError):
        spline_velocities([0, 1, 2], 0, periodic=True)
