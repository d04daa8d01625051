"""Contour interpolation math: 2nd-order blocks (BTRATE), cubic Hermite segments (CUBIC_RATE),
the internal table's spline velocities (CUBIC_INT) and CUBIC_SCALE [Ch5 BTRATE, CUBIC_RATE,
CUBIC_SCALE, CUBIC_INT; spec octavia.md §5.4]. Positions in counts, velocities in counts/sample
(200 µs), n samples per interval. Every function is vectorised over axes: the endpoint
arguments broadcast, and results have one row per sample (or per table point).

Assumptions (the manual says only "2nd order", "cubic spline", "smooth in velocity and
continuous in acceleration"; spec Q-16..Q-18):

* 2nd order: p(t) = P_k + Δ·t/N + (V_{k+1} − V_k)·t·(t − N)/(2N), which always ends on P_{k+1}.
* Cubic: Hermite between (P_k, V_k) and (P_{k+1}, V_{k+1}) (C¹; C² when the velocities come
  from `spline_velocities`).
* Internal table: velocities of the C² cubic spline through the points, periodic when the
  table loops (the last point joins the first) and natural (zero curvature at the ends) otherwise.
* Interpolated positions are float64 (the firmware rounds them to counts); velocities are the
  derivative at each sample, not the difference of two samples.
* CUBIC_SCALE rounds Q·mult/16384 to nearest (ties towards +∞) and wraps the result to int32.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from vdevd.devices.octavia.ram import IntArray, wrap_i32

SCALE_FRAC_BITS = 14            # CUBIC_SCALE pos_mult: 1 sign, 1 integer, 14 fraction bits [Ch5]
FloatArray = npt.NDArray[np.float64]


def _samples(n: int, *args: npt.ArrayLike) -> tuple[FloatArray, list[FloatArray]]:
    """t = 1..n as a column against the broadcast endpoint arguments."""
    if n < 1:
        raise ValueError(f"an interval of {n} samples is not at least 1")
    values: list[FloatArray] = list(np.broadcast_arrays(*(np.asarray(a, dtype=np.float64)
                                                         for a in args)))
    t = np.arange(1, n + 1, dtype=np.float64).reshape((n,) + (1,) * values[0].ndim)
    return t, values


def second_order(p0: npt.ArrayLike, v0: npt.ArrayLike, p1: npt.ArrayLike, v1: npt.ArrayLike,
                 n: int) -> tuple[FloatArray, FloatArray]:
    """(positions, velocities) at t = 1..n of a 2nd-order block from (p0, v0) to (p1, v1)
    [Ch5 BTRATE; spec §5.4]: constant acceleration (v1 − v0)/n; the end velocity is v1 when the
    host data are consistent (p1 − p0 = n·(v0 + v1)/2)."""
    t, (a, va, b, vb) = _samples(n, p0, v0, p1, v1)
    dv = vb - va
    positions = a + (b - a) * t / n + dv * t * (t - n) / (2 * n)
    velocities = (b - a) / n + dv * (2 * t - n) / (2 * n)
    return positions, velocities


def hermite(p0: npt.ArrayLike, v0: npt.ArrayLike, p1: npt.ArrayLike, v1: npt.ArrayLike,
            n: int) -> tuple[FloatArray, FloatArray]:
    """(positions, velocities) at t = 1..n of the cubic Hermite segment from (p0, v0) to
    (p1, v1) [Ch5 CUBIC_RATE; spec §5.4]."""
    t, (a, va, b, vb) = _samples(n, p0, v0, p1, v1)
    s = t / n
    s2, s3 = s * s, s * s * s
    positions = ((2 * s3 - 3 * s2 + 1) * a + (s3 - 2 * s2 + s) * n * va
                 + (3 * s2 - 2 * s3) * b + (s3 - s2) * n * vb)
    slope = (6 * s2 - 6 * s) * (a - b) + (3 * s2 - 4 * s + 1) * n * va + (3 * s2 - 2 * s) * n * vb
    return positions, slope / n


def spline_velocities(points: npt.ArrayLike, n: int, *, periodic: bool) -> FloatArray:
    """Velocities at the points (rows; columns are axes) of the C² cubic spline through them,
    n samples apart [Ch5 CUBIC_INT; spec §5.4]: periodic (the last point joins the first) or
    natural. Solves v_{i−1} + 4v_i + v_{i+1} = 3(P_{i+1} − P_{i−1})/n."""
    if n < 1:
        raise ValueError(f"an interval of {n} samples is not at least 1")
    p = np.asarray(points, dtype=np.float64)
    m = len(p)
    if m < 2:
        return np.zeros_like(p)
    if periodic:
        rhs = 3.0 * (np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)) / n
        circulant = np.zeros(m)
        circulant[0] += 4.0
        circulant[1 % m] += 1.0
        circulant[-1 % m] += 1.0
        eigen = np.fft.fft(circulant).real.reshape((m,) + (1,) * (p.ndim - 1))
        return np.fft.ifft(np.fft.fft(rhs, axis=0) / eigen, axis=0).real
    rhs = np.empty_like(p)
    rhs[0] = 3.0 * (p[1] - p[0]) / n
    rhs[1:-1] = 3.0 * (p[2:] - p[:-2]) / n
    rhs[-1] = 3.0 * (p[-1] - p[-2]) / n
    diag = np.full(m, 4.0)
    diag[0] = diag[-1] = 2.0
    return _tridiagonal_ones(diag, rhs)


def _tridiagonal_ones(diag: FloatArray, rhs: FloatArray) -> FloatArray:
    """Solve the tridiagonal system with `diag` and unit off-diagonals (Thomas algorithm; a loop
    over points, vectorised over the columns of `rhs`)."""
    m = len(diag)
    upper = np.empty(m)
    x = np.empty_like(rhs)
    upper[0] = 1.0 / diag[0]
    x[0] = rhs[0] / diag[0]
    for i in range(1, m):
        pivot = diag[i] - upper[i - 1]
        upper[i] = 1.0 / pivot
        x[i] = (rhs[i] - x[i - 1]) / pivot
    for i in range(m - 2, -1, -1):
        x[i] -= upper[i] * x[i + 1]
    return x


def cubic_scale(points: npt.ArrayLike, mult: int, shift: int) -> IntArray:
    """CUBIC_SCALE applied to table positions: Q' = round(Q·mult/16384) + shift, mult an s1.14
    code (8000h..7FFFh = −2..1.99994), shift an int32 [Ch5 CUBIC_SCALE; spec §5.4]."""
    if not -0x8000 <= mult <= 0x7FFF:
        raise ValueError(f"CUBIC_SCALE multiplier {mult} is not a 16-bit two's complement value")
    if not -0x8000_0000 <= shift <= 0x7FFF_FFFF:
        raise ValueError(f"CUBIC_SCALE shift {shift} is not a 32-bit two's complement value")
    q = np.asarray(points, dtype=np.int64)
    return wrap_i32(((q * mult + (1 << SCALE_FRAC_BITS - 1)) >> SCALE_FRAC_BITS) + shift)
