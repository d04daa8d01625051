"""The NOTCH and LOW_PASS firmware options: one biquad per axis at the controller output
[Ch5 NOTCH, LOW_PASS; spec octavia.md §5.2, Q-25]. Ts = 200 µs.

* NOTCH: G(s) = (s² + ωn²)/(s² + (ωn/Q)s + ωn²), fn 0..1544 Hz (0 bypasses).
* LOW_PASS: G(s) = ωn²/(s² + 2ζωn·s + ωn²), ζ = 0.6, fn 0..1850 Hz; the RTC sends an index into
  the manual's frequency table (0 bypasses) [Ch5 LOW_PASS "Low Pass Filter Frequency Index"].

Assumptions: the notch quality code 00h ("~25 % bandwidth") is Q = 4 and 01h ("~10 %") is
Q = 10 (the manual's figure says Q=2); both filters are discretised with the Tustin transform
prewarped at ωn, K = ωn/tan(ωn·Ts/2), so the digital response at fn equals the analog one.
Setting a filter starts it from rest (its state is cleared).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from vdevmaps.octavia import LOW_PASS_HZ, NOTCH_MAX_HZ  # [Ch5 NOTCH, LOW_PASS table]

SAMPLE_PERIOD_S = 200e-6
NOTCH_Q = {0x00: 4.0, 0x01: 10.0}         # q code -> quality factor (ASSUMPTION, spec Q-25)
LOW_PASS_ZETA = 0.6                       # [Ch5 LOW_PASS]
LOW_PASS_MAX_HZ = LOW_PASS_HZ[-1]


class Coeffs(NamedTuple):
    """A biquad normalised to a0 = 1: y = (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²) x."""

    b0: float
    b1: float
    b2: float
    a1: float
    a2: float


def _prewarp(freq_hz: float) -> tuple[float, float]:
    """(ωn, K) of the Tustin transform prewarped at freq_hz."""
    wn = 2.0 * math.pi * freq_hz
    return wn, wn / math.tan(wn * SAMPLE_PERIOD_S / 2.0)


def notch(freq_hz: int, q: int) -> Coeffs | None:
    """NOTCH coefficients for notch frequency `freq_hz` and quality code `q`; None bypasses
    (freq 0) [Ch5 NOTCH; spec §5.2]."""
    if not 0 <= freq_hz <= NOTCH_MAX_HZ:
        raise ValueError(f"notch frequency {freq_hz} Hz is not 0..{NOTCH_MAX_HZ}")
    if q not in NOTCH_Q:
        raise ValueError(f"notch quality code {q:#04x} is not 00h or 01h")
    if freq_hz == 0:
        return None
    wn, k = _prewarp(freq_hz)
    k2, wn2, damp = k * k, wn * wn, k * wn / NOTCH_Q[q]
    a0 = k2 + damp + wn2
    return Coeffs((k2 + wn2) / a0, 2 * (wn2 - k2) / a0, (k2 + wn2) / a0,
                  2 * (wn2 - k2) / a0, (k2 - damp + wn2) / a0)


def low_pass(freq_hz: float) -> Coeffs | None:
    """LOW_PASS coefficients for cut-off `freq_hz` (0 bypasses: None) [Ch5 LOW_PASS; spec §5.2].
    DSPL's LOW_PASS gives Hz directly; the RTC's index goes through `low_pass_frequency`."""
    if not 0 <= freq_hz <= LOW_PASS_MAX_HZ:
        raise ValueError(f"low-pass frequency {freq_hz} Hz is not 0..{LOW_PASS_MAX_HZ}")
    if freq_hz == 0:
        return None
    wn, k = _prewarp(freq_hz)
    k2, wn2, damp = k * k, wn * wn, 2 * LOW_PASS_ZETA * wn * k
    a0 = k2 + damp + wn2
    return Coeffs(wn2 / a0, 2 * wn2 / a0, wn2 / a0, 2 * (wn2 - k2) / a0, (k2 - damp + wn2) / a0)


def low_pass_frequency(index: int) -> int:
    """The cut-off in Hz that a LOW_PASS RTC index (0..46) codes [Ch5 LOW_PASS table]."""
    if not 0 <= index < len(LOW_PASS_HZ):
        raise ValueError(f"low-pass index {index} is not 0..{len(LOW_PASS_HZ) - 1}")
    return LOW_PASS_HZ[index]


_IDENTITY = Coeffs(1.0, 0.0, 0.0, 0.0, 0.0)


class Biquads:
    """One biquad per axis in direct form II transposed; bypassed axes pass their input exactly."""

    def __init__(self, n: int) -> None:
        #: rows b0, b1, b2, a1, a2 and the two state rows, one column per axis
        self.coeffs = np.tile(np.array(_IDENTITY, dtype=np.float64).reshape(5, 1), (1, n))
        self.state = np.zeros((2, n))
        self.enabled = np.zeros(n, dtype=bool)
        self._y = np.zeros(n)
        self._tmp = np.zeros(n)

    @property
    def active(self) -> bool:
        """Any axis filtered (the firmware skips `apply` otherwise)."""
        return bool(self.enabled.any())

    def set(self, axis: int, coeffs: Coeffs) -> None:
        """Filter `axis` with `coeffs`, starting from rest."""
        self.coeffs[:, axis] = coeffs
        self.state[:, axis] = 0.0
        self.enabled[axis] = True

    def bypass(self, axis: int) -> None:
        """No filter on `axis` (NOTCH frequency 0, LOW_PASS index 0, the power-up default)."""
        self.coeffs[:, axis] = _IDENTITY
        self.state[:, axis] = 0.0
        self.enabled[axis] = False

    def apply(self, x: npt.NDArray[np.float64], out: npt.NDArray[np.float64]) -> None:
        """Filter one sample of every axis: `out` = F(`x`) (`out` may be `x`)."""
        c, z, y, tmp = self.coeffs, self.state, self._y, self._tmp
        np.multiply(c[0], x, out=y)
        y += z[0]
        np.multiply(c[1], x, out=z[0])
        z[0] += z[1]
        np.multiply(c[3], y, out=tmp)
        z[0] -= tmp
        np.multiply(c[2], x, out=z[1])
        np.multiply(c[4], y, out=tmp)
        z[1] -= tmp
        out[:] = y

    def response(self, axis: int, freqs_hz: npt.ArrayLike) -> npt.NDArray[np.complex128]:
        """The complex gain of `axis`' filter at `freqs_hz`."""
        b0, b1, b2, a1, a2 = self.coeffs[:, axis]
        zi = np.exp(-2j * np.pi * np.asarray(freqs_hz, dtype=np.float64) * SAMPLE_PERIOD_S)
        return (b0 + b1 * zi + b2 * zi * zi) / (1.0 + a1 * zi + a2 * zi * zi)
