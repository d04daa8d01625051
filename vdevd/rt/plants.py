"""Plant models, vectorised over the axes of one kind: what the controller output moves.

- IDEAL: the actual position is the commanded one.
- STEPPER: the axis moves in whole steps (pulses) toward the commanded position, open loop, no
  lost steps, at most `max_rate` pulses/s (inf by default: it follows rint(cmd_pos) at once).
- SERVO: DC motor with a current amplifier: torque = amp_gain * out, clamped to +-peak_torque;
  inertia * acc = torque - viscous * vel - coulomb * sign(vel); semi-implicit Euler at dt (the
  viscous term implicit, so any damping is stable; Coulomb friction stops the motor rather than
  reversing it, so it holds a motor at rest below the friction torque).
  Units: out in DAC units, torque in counts/s^2 per unit of inertia (inertia defaults to 1).
  Defaults: amp_gain 1000 (counts/s^2 per DAC unit), inertia 1, viscous 1/s, coulomb 100
  counts/s^2 (the static friction every motor has: without it the integrator keeps a motor at
  rest creeping and hunting about the encoder count for ever, and with it the motor settles
  and stays, which lets a card at rest cost nothing: decision 0008), no peak torque;
  `default_gains` closes the loop at ~20 Hz, damping 0.7, with velocity and acceleration
  feed-forward: a 10000-count move at 50000 counts/s follows within ~2 counts and the axis
  then holds at its count.
The encoder (floor(pos * scale), frozen while lost) is sampled by the core (core.py).
"""

from __future__ import annotations

import numpy as np

from vdevd.rt.axes import PlantKind

#: default servo parameters: 1000 counts/s^2 per DAC count, 1/s viscous damping, and the
#: static friction of a real motor: 100 counts/s^2, the torque of 0.1 DAC counts
DEFAULT_AMP_GAIN = 1000.0
DEFAULT_VISCOUS = 1.0
DEFAULT_COULOMB = 100.0


def _readonly(arr: np.ndarray) -> np.ndarray:
    view = arr.view()
    view.flags.writeable = False
    return view


class StepperPlant:
    """Pulse-train axes in position mode. `gen` is the pulse generator's position (floats), the
    axis position is its whole part (rint); `max_rate` limits pulses per second (inf: none)."""

    kind = PlantKind.STEPPER

    def __init__(self, n: int, dt: float, rows: np.ndarray | None = None) -> None:
        """`rows`: where the generator and the per-tick limit live, (2, n) (a motion core's
        coefficient block; its own otherwise)."""
        self.dt = dt
        self._max_rate = np.full(n, np.inf)
        self.max_rate = _readonly(self._max_rate)
        rows = np.zeros((2, n)) if rows is None else rows
        self.gen, self._lim = rows[0], rows[1]
        self._tgt = np.zeros(n)
        self._inv_dt = 1.0 / dt
        self._configure()

    def set(self, axes: slice | np.ndarray | int, max_rate: float) -> None:
        """Maximum pulse rate (pulses/s, inf: none) of some axes."""
        if not float(max_rate) > 0:
            raise ValueError("max_rate must be positive")
        self._max_rate[axes] = float(max_rate)
        self._configure()

    def set_dt(self, dt: float) -> None:
        """A new tick length (the card's period changed)."""
        self.dt, self._inv_dt = dt, 1.0 / dt
        self._configure()

    def _configure(self) -> None:
        np.multiply(self._max_rate, self.dt, out=self._lim)
        self._lim_neg = -self._lim
        self._limited = bool(np.isfinite(self._max_rate).any())

    def step(self, cmd_pos: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        """Advance one tick toward `cmd_pos`: new whole-step `pos`, `vel` = pulses of this tick/dt."""
        gen, tgt = self.gen, self._tgt
        if self._limited:
            np.rint(cmd_pos, out=tgt)
            tgt -= gen
            np.minimum(tgt, self._lim, out=tgt)
            np.maximum(tgt, self._lim_neg, out=tgt)
            gen += tgt
        else:
            np.rint(cmd_pos, out=gen)
        np.rint(gen, out=tgt)
        np.subtract(tgt, pos, out=vel)
        vel *= self._inv_dt
        pos[...] = tgt


class ServoPlant:
    """Per-axis motor and amplifier parameters (read-only views: change them with `set`, which
    recomputes the per-tick coefficients, so the tick does no division and skips what is not in
    use)."""

    kind = PlantKind.SERVO
    PARAMS = ("amp_gain", "peak_torque", "inertia", "viscous", "coulomb")

    def __init__(self, n: int, dt: float, rows: np.ndarray | None = None) -> None:
        """`rows`: where the per-tick coefficients live, (4, n): amp_gain*dt/inertia, peak
        torque*dt/inertia, the viscous damping factor, coulomb*dt/inertia (a motion core's
        coefficient block; its own otherwise)."""
        self.dt = dt
        rows = np.zeros((4, n)) if rows is None else rows
        self._gain_dt: np.ndarray = rows[0]
        self._peak_dt: np.ndarray = rows[1]
        self._damp: np.ndarray = rows[2]
        self._coul_dt: np.ndarray = rows[3]
        self._params = {
            "amp_gain": np.full(n, DEFAULT_AMP_GAIN),
            "peak_torque": np.full(n, np.inf),
            "inertia": np.ones(n),
            "viscous": np.full(n, DEFAULT_VISCOUS),
            "coulomb": np.full(n, DEFAULT_COULOMB),
        }
        for key, arr in self._params.items():
            setattr(self, key, _readonly(arr))
        self.enabled = np.ones(n, dtype=bool)
        self._dv = np.zeros(n)
        self._tmp = np.zeros(n)
        self._configure()

    # the parameter views, for type checkers (set in __init__)
    amp_gain: np.ndarray
    peak_torque: np.ndarray
    inertia: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray

    def set(self, axes: slice | np.ndarray | int, **params: float) -> None:
        """Set parameters of some axes; all positive, except coulomb (>= 0)."""
        for key, value in params.items():
            if key not in self._params:
                raise ValueError(f"no plant parameter {key!r} (parameters: {', '.join(self.PARAMS)})")
            v = float(value)
            if not (v >= 0 if key == "coulomb" else v > 0):
                raise ValueError(f"{key} must be {'>= 0' if key == 'coulomb' else 'positive'}")
            self._params[key][axes] = v
        self._configure()

    def enable(self, mask: np.ndarray) -> None:
        """Which axes this plant moves; the others keep their position with velocity 0 (axes of
        another kind on a mixed card, which their own plant then moves)."""
        self.enabled[:] = mask
        self._configure()

    def set_dt(self, dt: float) -> None:
        """A new tick length (the card's period changed)."""
        self.dt = dt
        self._configure()

    def _configure(self) -> None:
        p, dt, on = self._params, self.dt, self.enabled
        self._gain_dt[...] = p["amp_gain"] * dt / p["inertia"] * on
        self._peak_dt[...] = p["peak_torque"] * dt / p["inertia"]
        self._peak_dt_neg = -self._peak_dt
        self._damp[...] = 1.0 / (1.0 + p["viscous"] * dt / p["inertia"]) * on
        self._coul_dt[...] = p["coulomb"] * dt / p["inertia"]
        self._coul_dt_neg = -self._coul_dt
        self._clamped = bool(np.isfinite(p["peak_torque"]).any())
        self._friction = bool(p["coulomb"].any())

    def step(self, out: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        """Advance one tick with the output `out` held: velocity first (semi-implicit), then
        position. Coulomb friction slows the motor by at most its velocity (it never reverses
        it), so a motor at rest stays at rest below the friction torque."""
        dv, tmp = self._dv, self._tmp
        np.multiply(self._gain_dt, out, dv)
        if self._clamped:
            np.minimum(dv, self._peak_dt, out=dv)
            np.maximum(dv, self._peak_dt_neg, out=dv)
        np.add(vel, dv, vel)
        if self._friction:  # vel - clip(vel, -c, c): toward 0 by at most c, never past it
            np.minimum(vel, self._coul_dt, out=tmp)
            np.maximum(tmp, self._coul_dt_neg, out=tmp)
            np.subtract(vel, tmp, vel)
        np.multiply(vel, self._damp, vel)  # viscous damping taken implicitly: stable for any damping
        np.multiply(vel, self.dt, tmp)
        np.add(pos, tmp, pos)


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
