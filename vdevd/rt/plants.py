"""Plant models, vectorised over the axes of one kind: what the controller output moves.

- IDEAL: the actual position is the commanded one.
- STEPPER: the axis moves in whole steps to the commanded position (open loop, no lost steps).
- SERVO: DC motor with a current amplifier: torque = amp_gain * out, clamped to +-peak_torque;
  inertia * acc = torque - viscous * vel - coulomb * sign(vel); semi-implicit Euler at dt
  (the viscous term implicit, so any damping is stable).
  Units: out in DAC counts, torque per unit inertia in counts/s^2 (inertia defaults to 1).
"""

from __future__ import annotations

import numpy as np

from vdevd.rt.axes import PlantKind

#: default servo parameters: 1000 counts/s^2 per DAC count, 1/s viscous damping
DEFAULT_AMP_GAIN = 1000.0
DEFAULT_VISCOUS = 1.0


class ServoPlant:
    """Per-axis motor and amplifier parameters. Change them with `set`, which recomputes the
    per-tick coefficients (so the tick does no division and skips what is not in use)."""

    kind = PlantKind.SERVO
    PARAMS = ("amp_gain", "peak_torque", "inertia", "viscous", "coulomb")

    def __init__(self, n: int, dt: float) -> None:
        self.dt = dt
        self.amp_gain = np.full(n, DEFAULT_AMP_GAIN)
        self.peak_torque = np.full(n, np.inf)
        self.inertia = np.ones(n)
        self.viscous = np.full(n, DEFAULT_VISCOUS)
        self.coulomb = np.zeros(n)
        self._acc = np.zeros(n)
        self._tmp = np.zeros(n)
        self._configure()

    def set(self, axes: slice | np.ndarray | int, **params: float) -> None:
        for key, value in params.items():
            if key not in self.PARAMS:
                raise ValueError(f"no plant parameter {key!r} (parameters: {', '.join(self.PARAMS)})")
            if key != "coulomb" and not float(value) > 0:
                raise ValueError(f"{key} must be positive")
            getattr(self, key)[axes] = float(value)
        self._configure()

    def _configure(self) -> None:
        self._gain_dt = self.amp_gain * self.dt / self.inertia
        self._peak_dt = self.peak_torque * self.dt / self.inertia
        self._damp = 1.0 / (1.0 + self.viscous * self.dt / self.inertia)
        self._coul_dt = self.coulomb * self.dt / self.inertia
        self._clamped = bool(np.isfinite(self.peak_torque).any())
        self._friction = bool(self.coulomb.any())

    def step(self, out: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        """Advance one tick: velocity from torque (semi-implicit), then position."""
        dv, tmp = self._acc, self._tmp
        np.multiply(self._gain_dt, out, out=dv)
        if self._clamped:
            np.minimum(dv, self._peak_dt, out=dv)
            np.maximum(dv, -self._peak_dt, out=dv)
        if self._friction:
            np.sign(vel, out=tmp)
            tmp *= self._coul_dt
            dv -= tmp
        vel += dv
        vel *= self._damp  # viscous damping taken implicitly: stable for any damping
        np.multiply(vel, self.dt, out=tmp)
        pos += tmp


def default_gains(dt: float, amp_gain: float = DEFAULT_AMP_GAIN,
                  viscous: float = DEFAULT_VISCOUS) -> dict[str, float]:
    """PID gains that close the default servo plant at ~20 Hz, damping 0.7, with feed-forward.

    kp*amp_gain = wn^2; kd*amp_gain*dt = 2*zeta*wn (kd acts on the per-sample difference);
    aff cancels the inertia and vff the viscous damping, so tracking error stays small.
    """
    wn, zeta = 2 * np.pi * 20.0, 0.7
    kp = wn * wn / amp_gain
    return {
        "kp": kp,
        "kd": 2 * zeta * wn / (amp_gain * dt),
        "ki": kp * dt / 0.2,
        "vff": viscous / amp_gain,
        "aff": 1.0 / amp_gain,
    }
