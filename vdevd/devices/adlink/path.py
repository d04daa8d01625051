"""Interpolation geometry of the ADLINK AMP-204C/208C [M §4.7.1, §4.7.2], spec §2.11-2.12 and Q12:
lines of 2-6 axes, 2-D and 3-D arcs and the helix/spiral, as paths parametrised by path length.

Pure geometry, no time: a path knows its `length`, its `start` and `end`, the position `at(s)` and
the unit direction `tangent_at(s)` for path lengths s in [0, length] (clamped outside). The caller
resolves relative against absolute (`OPT_RELATIVE`) and passes absolute points; angles are in
radians, as the APS API takes them [X5]. Invalid geometry raises `PathError` carrying
`ERR_ParametersInvalid` (-10) [X4].

Arcs and helices are one curve (`Arc`): with phi in [0, |angle|] the progress angle,
`P(phi) = C + r(phi)(u cos(sign*phi) + v sin(sign*phi)) + h(phi) n`, `r` and `h` linear in phi
(spec §2.12 ASSUMPTION), u = (S - C)/|S - C|, v = n x u. Its speed is `|dP/dphi| = sqrt(a^2 + r^2)`
with `a^2 = r'^2 + h'^2` constant, so the length has a closed form (a circle when r' = 0); the
conic spiral's inverse s -> phi is a table guess refined by Newton steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeAlias

import numpy as np
import numpy.typing as npt

ERR_PARAMETERS_INVALID = -10
"""`ERR_ParametersInvalid` [X4]."""

RADIUS_TOLERANCE = 1e-6
"""Relative radius mismatch a centre-end arc accepts (spec §2.12 ASSUMPTION, Q12)."""

_DEGENERATE = 1e-9
"""Relative size under which a cross product or Gram-Schmidt remainder counts as zero."""

Vector: TypeAlias = npt.NDArray[np.float64]
Lengths: TypeAlias = float | npt.ArrayLike


class PathError(ValueError):
    """Geometry the card refuses; `code` is the APS return code (-10, `ERR_ParametersInvalid`)."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.code = ERR_PARAMETERS_INVALID


def _vector(name: str, value: npt.ArrayLike, dims: int | None = None) -> Vector:
    v = np.array(value, dtype=np.float64).reshape(-1)
    if dims is not None and v.size != dims:
        raise PathError(f"{name} has {v.size} coordinates, {dims} expected")
    if not np.all(np.isfinite(v)):
        raise PathError(f"{name} is not finite")
    return v


def _finite(name: str, value: float) -> float:
    if not math.isfinite(value):
        raise PathError(f"{name} is not finite")
    return float(value)


class Line:
    """Linear interpolation of 2-6 axes [M §4.7.1]: `length = sqrt(sum dXi^2)` (spec §2.11)."""

    def __init__(self, start: npt.ArrayLike, end: npt.ArrayLike) -> None:
        self.start = _vector("start", start)
        if not 2 <= self.start.size <= 6:
            raise PathError(f"a line has 2 to 6 axes, not {self.start.size}")
        self.end = _vector("end", end, self.start.size)
        delta = self.end - self.start
        self.length = float(np.sqrt(np.dot(delta, delta)))
        self._direction = delta / self.length if self.length > 0.0 else np.zeros_like(delta)

    @property
    def dims(self) -> int:
        return self.start.size

    def at(self, s: Lengths) -> Vector:
        """Positions at path lengths s: shape (dims,) for a scalar, (len(s), dims) for an array."""
        sa = np.asarray(s, dtype=np.float64)
        if sa.ndim == 0:
            if sa >= self.length:
                return self.end.copy()
            return self.start + self._direction * max(float(sa), 0.0)
        sc = np.clip(sa, 0.0, self.length)[:, None]
        out = self.start + self._direction * sc
        out[sa >= self.length] = self.end
        return out

    def tangent_at(self, s: Lengths) -> Vector:
        """Unit direction (zero for a zero-length line)."""
        sa = np.asarray(s, dtype=np.float64)
        if sa.ndim == 0:
            return self._direction.copy()
        return np.broadcast_to(self._direction, (sa.size, self.dims)).copy()

    def rebased(self, start: npt.ArrayLike) -> Line:
        """The same command issued from another start point: same end."""
        return Line(start, self.end)


class Arc:
    """Arc or helix/spiral [M §4.7.2]; built by `arc2_ca`, `arc2_ce`, `arc3_ca`, `arc3_ce`,
    `spiral_ca`, `spiral_ce`, which validate the parameters."""

    _TABLE = 129

    def __init__(
        self,
        start: Vector,
        centre: Vector,
        u: Vector,
        v: Vector,
        n: Vector,
        angle: float,
        final_radius: float,
        height: float,
        end: Vector | None,
        remake: Callable[[Vector], Arc],
    ) -> None:
        if angle == 0.0:
            raise PathError("zero arc angle")
        self.start = start
        self.centre = centre
        self.angle = angle
        self._u, self._v, self._n = u, v, n
        self._sign = 1.0 if angle > 0 else -1.0
        self._span = abs(angle)
        self.radius = float(np.linalg.norm(start - centre))
        self.final_radius = final_radius
        self.height = height
        self._k = (final_radius - self.radius) / self._span  # r'
        self._h = height / self._span  # h'
        self._a2 = self._k * self._k + self._h * self._h
        # Below the radius tolerance the radius change is a rounding blend (centre-end arcs, Q12):
        # the mean radius gives the length, and phi is proportional to s.
        self._conic = abs(final_radius - self.radius) > RADIUS_TOLERANCE * max(self.radius, final_radius)
        if self._conic:
            self.length = float(self._arc_length(self._span))
            grid = np.linspace(0.0, self._span, self._TABLE)
            self._phi_grid = grid
            self._s_grid = np.asarray(self._arc_length(grid))
        else:
            mean = 0.5 * (self.radius + final_radius)
            self._speed = math.sqrt(self._a2 + mean * mean)
            self.length = self._speed * self._span
        self.end = self._point(np.asarray(self._span, dtype=np.float64)) if end is None else end
        self._remake = remake

    @property
    def dims(self) -> int:
        return self.start.size

    def _arc_length(self, phi: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Closed form of the integral of sqrt(a^2 + r(phi)^2) from 0 (conic spirals, r' != 0)."""
        a2 = self._a2

        def primitive(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
            root = np.sqrt(a2 + x * x)
            return np.asarray(0.5 * (x * root + a2 * np.arcsinh(x / math.sqrt(a2))))

        x = self.radius + self._k * np.asarray(phi, dtype=np.float64)
        return np.asarray((primitive(x) - primitive(np.asarray(self.radius))) / self._k)

    def _phi(self, s: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        sc = np.clip(s, 0.0, self.length)
        if not self._conic:
            return sc / self._speed
        phi = np.interp(sc, self._s_grid, self._phi_grid)
        if sc.ndim == 0:
            return np.asarray(self._phi_scalar(float(sc), float(phi)))
        for _ in range(3):  # Newton on s(phi) - s; ds/dphi = sqrt(a^2 + r^2) > 0
            r = self.radius + self._k * phi
            phi = phi - (self._arc_length(phi) - sc) / np.sqrt(self._a2 + r * r)
        return np.clip(phi, 0.0, self._span)

    def _phi_scalar(self, s: float, phi: float) -> float:
        """`_phi` for one s in plain floats (the per-tick case)."""
        a2, k, r0 = self._a2, self._k, self.radius
        a = math.sqrt(a2)
        f0 = 0.5 * (r0 * math.sqrt(a2 + r0 * r0) + a2 * math.asinh(r0 / a))
        for _ in range(3):
            r = r0 + k * phi
            root = math.sqrt(a2 + r * r)
            phi -= ((0.5 * (r * root + a2 * math.asinh(r / a)) - f0) / k - s) / root
        return min(max(phi, 0.0), self._span)

    def _point(self, phi: npt.NDArray[np.float64]) -> Vector:
        psi = self._sign * phi
        r = self.radius + self._k * phi
        h = self._h * phi
        if phi.ndim == 0:
            return self.centre + r * (self._u * math.cos(psi) + self._v * math.sin(psi)) + h * self._n
        c, sn = np.cos(psi)[:, None], np.sin(psi)[:, None]
        return self.centre + r[:, None] * (self._u * c + self._v * sn) + h[:, None] * self._n

    def at(self, s: Lengths) -> Vector:
        """Positions at path lengths s; `end` exactly from s >= length."""
        sa = np.asarray(s, dtype=np.float64)
        out = self._point(self._phi(sa))
        if sa.ndim == 0:
            return self.end.copy() if sa >= self.length else out
        out[sa >= self.length] = self.end
        return out

    def tangent_at(self, s: Lengths) -> Vector:
        """Unit direction of motion: dP/dphi / |dP/dphi|."""
        sa = np.asarray(s, dtype=np.float64)
        phi = self._phi(sa)
        psi = self._sign * phi
        r = self.radius + self._k * phi
        c, sn = np.cos(psi), np.sin(psi)
        if sa.ndim:
            c, sn, r = c[:, None], sn[:, None], r[:, None]
        radial = self._u * c + self._v * sn
        along = self._sign * (self._v * c - self._u * sn)
        d = self._k * radial + r * along + self._h * self._n
        return np.asarray(d / np.sqrt(self._a2 + r * r))

    def rebased(self, start: npt.ArrayLike) -> Arc:
        """The same command (centre, angle or end, normal, Dir) issued from another start point."""
        return self._remake(_vector("start", start, self.dims))


Path: TypeAlias = Line | Arc


def line(start: npt.ArrayLike, end: npt.ArrayLike) -> Line:
    """`APS_line` [M §4.7.1]."""
    return Line(start, end)


def _radial(start: Vector, centre: Vector) -> tuple[Vector, float]:
    d = start - centre
    r = float(np.linalg.norm(d))
    if r == 0.0:
        raise PathError("the start point is the centre")
    return d / r, r


def _ccw(u: Vector) -> Vector:
    """+90 degrees about +Z of the (axis 0, axis 1) plane (spec §2.12 ASSUMPTION)."""
    return np.array([-u[1], u[0]])


def _laps(theta: float, direction: int) -> float:
    """`Angle = theta + Dir * 2 pi` [M §4.7.2.1]."""
    return theta + int(direction) * 2.0 * math.pi


def _check_radius(r0: float, re: float) -> None:
    if abs(re - r0) > RADIUS_TOLERANCE * r0:
        raise PathError(f"end radius {re} differs from start radius {r0}")


def _corrected_normal(normal: npt.ArrayLike, u: Vector) -> Vector:
    """Gram-Schmidt against u = (S - C)/|S - C| [M §4.7.2.1, Fig 4-28]."""
    n = _vector("normal", normal, 3)
    size = float(np.linalg.norm(n))
    if size == 0.0:
        raise PathError("zero normal vector")
    n = n - np.dot(n, u) * u
    rest = float(np.linalg.norm(n))
    if rest <= _DEGENERATE * size:
        raise PathError("normal vector parallel to the start radius")
    return n / rest


def arc2_ca(start: npt.ArrayLike, centre: npt.ArrayLike, angle: float) -> Arc:
    """`APS_arc2_ca` [M §4.7.2.2]: positive angle counter-clockwise from axis 0 toward axis 1."""
    s, c = _vector("start", start, 2), _vector("centre", centre, 2)
    angle = _finite("angle", angle)
    u, r = _radial(s, c)
    return Arc(s, c, u, _ccw(u), np.zeros(2), angle, r, 0.0, None, lambda p: arc2_ca(p, c, angle))


def arc2_ce(start: npt.ArrayLike, centre: npt.ArrayLike, end: npt.ArrayLike, direction: int) -> Arc:
    """`APS_arc2_ce` [M §4.7.2.2]: theta is the CCW angle S -> E in (0, 2 pi), 180 degrees
    included (ADLINK's contour sample drives half circles, G20); the end is exact."""
    s, c, e = _vector("start", start, 2), _vector("centre", centre, 2), _vector("end", end, 2)
    u, r = _radial(s, c)
    w = e - c
    re = float(np.linalg.norm(w))
    _check_radius(r, re)
    theta = math.atan2(float(u[0] * w[1] - u[1] * w[0]), float(np.dot(u, w)))
    if theta < 0.0:
        theta += 2.0 * math.pi
    if theta <= _DEGENERATE or theta >= 2.0 * math.pi - _DEGENERATE:
        raise PathError("centre-end arc cannot be a full circle")
    return Arc(
        s, c, u, _ccw(u), np.zeros(2), _laps(theta, direction), re, 0.0, e,
        lambda p: arc2_ce(p, c, e, direction),
    )  # fmt: skip


def arc3_ca(start: npt.ArrayLike, centre: npt.ArrayLike, normal: npt.ArrayLike, angle: float) -> Arc:
    """`APS_arc3_ca` [M §4.7.2.1]: right-hand rule about the corrected normal, laps beyond 2 pi."""
    return spiral_ca(start, centre, normal, angle, 0.0, None)


def arc3_ce(start: npt.ArrayLike, centre: npt.ArrayLike, end: npt.ArrayLike, direction: int) -> Arc:
    """`APS_arc3_ce` [M §4.7.2.1]: normal (S - C) x (E - C), theta in (0, pi); 0 and 180 degrees
    refused (no normal); the end is exact."""
    s, c, e = _vector("start", start, 3), _vector("centre", centre, 3), _vector("end", end, 3)
    u, r = _radial(s, c)
    w = e - c
    re = float(np.linalg.norm(w))
    _check_radius(r, re)
    cross = np.cross(s - c, w)
    size = float(np.linalg.norm(cross))
    if size <= _DEGENERATE * r * re:
        raise PathError("centre-end arc of 0 or 180 degrees has no normal")
    n = cross / size
    theta = math.atan2(size, float(np.dot(s - c, w)))
    return Arc(
        s, c, u, np.cross(n, u), n, _laps(theta, direction), re, 0.0, e,
        lambda p: arc3_ce(p, c, e, direction),
    )  # fmt: skip


def spiral_ca(
    start: npt.ArrayLike,
    centre: npt.ArrayLike,
    normal: npt.ArrayLike,
    angle: float,
    delta_h: float,
    final_r: float | None,
) -> Arc:
    """`APS_spiral_ca` [M §4.7.2.3]: angle projected on the start plane, height DeltaH along the
    corrected normal, radius linear from |S - C| to FinalR (None: the start radius, an arc)."""
    s, c = _vector("start", start, 3), _vector("centre", centre, 3)
    angle, delta_h = _finite("angle", angle), _finite("DeltaH", delta_h)
    u, r = _radial(s, c)
    n = _corrected_normal(normal, u)
    rf = r if final_r is None else _finite("FinalR", final_r)
    if rf < 0.0:
        raise PathError("negative final radius")
    return Arc(
        s, c, u, np.cross(n, u), n, angle, rf, delta_h, None,
        lambda p: spiral_ca(p, c, normal, angle, delta_h, final_r),
    )  # fmt: skip


def spiral_ce(
    start: npt.ArrayLike, centre: npt.ArrayLike, normal: npt.ArrayLike, end: npt.ArrayLike, direction: int
) -> Arc:
    """`APS_spiral_ce` [M §4.7.2.3]: DeltaH = (E - C).n, FinalR = distance of E from the axis,
    theta the angle S -> E about n in [0, 2 pi) (0 when E is on the axis); the end is exact."""
    s, c, e = _vector("start", start, 3), _vector("centre", centre, 3), _vector("end", end, 3)
    u, r = _radial(s, c)
    n = _corrected_normal(normal, u)
    v = np.cross(n, u)
    w = e - c
    height = float(np.dot(w, n))
    planar = w - height * n
    rf = float(np.linalg.norm(planar))
    theta = 0.0
    if rf > _DEGENERATE * r:
        theta = math.atan2(float(np.dot(planar, v)), float(np.dot(planar, u)))
        if theta < 0.0:
            theta += 2.0 * math.pi
        if theta <= _DEGENERATE or theta >= 2.0 * math.pi - _DEGENERATE:
            theta = 0.0  # E above the start point: whole laps only
    return Arc(
        s, c, u, v, n, _laps(theta, direction), rf, height, e,
        lambda p: spiral_ce(p, c, normal, e, direction),
    )  # fmt: skip
