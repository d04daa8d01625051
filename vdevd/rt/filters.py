"""The PID family: parallel PID with integrator limit, velocity and acceleration feed-forward,
offset and output limit, vectorised over axes. Cards map their vendor gains onto it."""

from __future__ import annotations

import numpy as np


class Pid:
    """out = clamp(offset + kp*e + kd*(e - e_prev) + ki*I + vff*cmd_vel + aff*cmd_acc, +-out_limit),
    with I += e each tick clamped to +-il (anti-windup). Gains are per sample, as on the cards:
    kd multiplies the difference of two successive errors, ki the running sum of errors.

    The terms live as the rows of one matrix (`terms`: e, de, I, cmd_vel, cmd_acc) so that the
    output is one multiply and one sum over all axes; `cmd_vel`/`cmd_acc` rows are where the
    profile generator writes (Axes shares them).
    """

    #: row order of `gains` and `terms`
    TERMS = ("kp", "kd", "ki", "vff", "aff")

    def __init__(self, n: int) -> None:
        self.gains = np.zeros((len(self.TERMS), n))
        self.kp, self.kd, self.ki, self.vff, self.aff = self.gains
        self.terms = np.zeros((len(self.TERMS), n))
        self.e, self.de, self.integ, self.cmd_vel, self.cmd_acc = self.terms
        self.e_prev = np.zeros(n)
        self.il = np.full(n, np.inf)
        self.offset = np.zeros(n)
        self.out_limit = np.full(n, np.inf)
        self._prod = np.zeros((len(self.TERMS), n))
        self._configure()

    PARAMS = (*TERMS, "il", "offset", "out_limit")

    def set(self, axes: slice | np.ndarray | int, **params: float) -> None:
        """Set gains and limits of some axes (use this, not the arrays: the tick skips the
        integrator limit, offset and output limit while none is in use)."""
        for key, value in params.items():
            if key not in self.PARAMS:
                raise ValueError(f"no PID parameter {key!r} (parameters: {', '.join(self.PARAMS)})")
            if key in ("il", "out_limit") and not float(value) >= 0:
                raise ValueError(f"{key} must be >= 0")
            getattr(self, key)[axes] = float(value)
        self._configure()

    def _configure(self) -> None:
        self._limit_integ = bool(np.isfinite(self.il).any())
        self._limit_out = bool(np.isfinite(self.out_limit).any())
        self._offset = bool(self.offset.any())

    def reset(self, axes: slice | np.ndarray | int) -> None:
        """Clear the integrator and derivative memory (servo on, define position)."""
        self.integ[axes] = 0.0
        self.e_prev[axes] = 0.0

    def update(self, out: np.ndarray) -> None:
        """One sample from the error already in `e`: write the controller output into `out`."""
        e, integ = self.e, self.integ
        np.subtract(e, self.e_prev, out=self.de)
        self.e_prev[:] = e
        integ += e
        if self._limit_integ:
            np.minimum(integ, self.il, out=integ)
            np.maximum(integ, -self.il, out=integ)
        np.multiply(self.gains, self.terms, out=self._prod)
        np.add.reduce(self._prod, axis=0, out=out)
        if self._offset:
            out += self.offset
        if self._limit_out:
            np.minimum(out, self.out_limit, out=out)
            np.maximum(out, -self.out_limit, out=out)
