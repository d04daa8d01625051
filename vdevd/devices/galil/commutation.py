"""Sinusoidal commutation setup of the DMC-13X8 [M Ch2 Step 5, Step 7b; spec §5.8].

`BA axes` makes axes sinusoidally commutated: each takes a second DAC, the highest axes not
commutated, lowest commutated axis with the lowest of them (BAXZ on a DMC-1348: X with Y's DAC,
Z with W's), and the card has one standard axis fewer for each; the highest axis can never be
commutated. `BM` magnetic cycle (counts), `BI` first of three Hall inputs, `BB` Hall offset
(degrees), `BC` calibration at the next Hall transition, `BZ v` drive to the zero phase (v > 0
ends motor off, v < 0 servo here; `_BZx` the counts to the zero phase), `BS v,t` the setup test.
The two phase outputs are u*sin(theta) and u*sin(theta + 120 deg), theta the electrical angle
360 * (position - zero) / BM (spec §5.8). No motor physics: see the README.
"""

from __future__ import annotations

import numpy as np

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.motion import GalilMotion

PHASE_SHIFT = 2 * np.pi / 3  # the second DAC leads by 120 degrees (spec §5.8)


class Commutation:
    """BA axes, their second DACs, magnetic cycles, Hall inputs and zero phases."""

    def __init__(self, motion: GalilMotion) -> None:
        n = motion.n
        self.motion = motion
        self.sinusoidal = np.zeros(n, dtype=bool)
        self.second_dac = np.full(n, -1, dtype=np.int64)  # per BA axis: the axis of its phase B
        self.cycle = np.zeros(n)  # BM
        self.hall = np.zeros(n, dtype=np.int64)  # BI: first Hall input, 0 none
        self.hall_offset = np.zeros(n)  # BB
        self.zero = np.zeros(n)  # the position of the zero phase
        self.phased = np.zeros(n, dtype=bool)  # BZ/BC done (or Halls give an estimate)
        self.calibrate = np.zeros(n, dtype=bool)  # BC armed

    @property
    def standard_axes(self) -> int:
        """The axes left for standard control (BAX on a 1348: 3, a DMC-1338)."""
        return self.motion.n - int(self.sinusoidal.sum())

    def freed(self) -> np.ndarray:
        """The axes whose DAC is a second phase (not available for standard control)."""
        return self.second_dac[self.sinusoidal]

    def select(self, axes: list[int]) -> None:
        """BA: `axes` become sinusoidal (the others standard) [M Ch2 Step 5]."""
        n, k = self.motion.n, len(axes)
        others = [a for a in range(n) if a not in axes]
        if n - 1 in axes or 2 * k > n:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, "no DAC left for the second phase")
        dacs = sorted(others)[len(others) - k:]
        if any(self.motion.moving(a) for a in axes + dacs):
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        self.sinusoidal[:] = False
        self.second_dac[:] = -1
        self.sinusoidal[axes] = True
        self.second_dac[sorted(axes)] = dacs
        if dacs:
            self.motion.motor_off(dacs)  # their DACs now drive a second phase

    def require(self, axes: list[int]) -> None:
        """BM BI BB BC BZ BS on an axis not made brushless by BA: TC 110 [spec §4.3]."""
        if not all(self.sinusoidal[a] for a in axes):
            raise GalilError(TC.NOT_BRUSHLESS)

    def angle(self) -> np.ndarray:
        """theta, radians, per axis (0 where BM is 0)."""
        bm = np.where(self.cycle != 0, self.cycle, np.inf)
        return 2 * np.pi * (self.motion.position() - self.zero) / bm

    def phases(self) -> np.ndarray:
        """(2, n) volts: phase A and phase B of each BA axis (0 elsewhere) from its command."""
        u = self.motion.torque() * self.sinusoidal
        theta = self.angle()
        return np.stack([u * np.sin(theta), u * np.sin(theta + PHASE_SHIFT)])

    def to_zero(self) -> np.ndarray:
        """_BZx: the counts from the present position to the nearest zero phase."""
        bm = np.where(self.cycle != 0, self.cycle, 1.0)
        d = np.mod(self.zero - self.motion.position(), bm)
        return np.where((self.cycle != 0) & self.sinusoidal, np.where(d > bm / 2, d - bm, d), 0.0)

    def zero_here(self, axes: list[int], volts: float) -> None:
        """BZ: the motor is driven to a zero phase; here it is defined at the present position
        (no motor physics), then motor off (volts > 0) or servo here (volts < 0)."""
        m = self.motion
        self.zero[axes] = m.position()[axes]
        self.phased[axes] = True
        if volts > 0:
            m.motor_off(axes)
        else:
            m.servo_here(axes)
