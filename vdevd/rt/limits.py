"""Hard limits (switch inputs), soft limits (commanded position) and the following-error limit.

Hard limits are inputs: they act when they change or when a command moves toward an active one,
so they cost nothing per tick. Soft limits and the following-error limit are checked each tick
only while enabled on some axis.
"""

from __future__ import annotations

import numpy as np


class Limits:
    """Per-axis limit parameters and the inputs of the limit switches."""

    def __init__(self, n: int) -> None:
        self.soft_lo = np.full(n, -np.inf)
        self.soft_hi = np.full(n, np.inf)
        self.fe_limit = np.full(n, np.inf)  # inf disables
        self.limit_dec = np.full(n, np.inf)  # deceleration when a limit stops a profile
        self.in_position = np.full(n, 1.0)  # |ferr| band for IN_POSITION
        self.hard_pos = np.zeros(n, dtype=bool)
        self.hard_neg = np.zeros(n, dtype=bool)
        self.soft_enabled = False
        self.fe_enabled = False
        self._b = np.zeros(n, dtype=bool)
        self._f = np.zeros(n)

    def update_enabled(self) -> None:
        self.soft_enabled = bool(np.isfinite(self.soft_lo).any() or np.isfinite(self.soft_hi).any())
        self.fe_enabled = bool(np.isfinite(self.fe_limit).any())

    def blocked(self, axis: int, direction: float) -> bool:
        """True when an active hard limit forbids motion of `axis` in `direction`."""
        return bool((direction > 0 and self.hard_pos[axis]) or (direction < 0 and self.hard_neg[axis]))

    def soft_crossed(self, cmd_pos: np.ndarray, moving: np.ndarray) -> np.ndarray:
        """Moving axes whose commanded position is at or past a soft limit (indices)."""
        hi = np.greater_equal(cmd_pos, self.soft_hi, out=self._b)
        lo = np.less_equal(cmd_pos, self.soft_lo)
        hi |= lo
        hi &= moving
        return np.flatnonzero(hi) if hi.any() else _EMPTY

    def fe_exceeded(self, ferr: np.ndarray) -> np.ndarray:
        """Axes whose |following error| exceeds fe_limit (indices)."""
        np.abs(ferr, out=self._f)
        over = np.greater(self._f, self.fe_limit, out=self._b)
        return np.flatnonzero(over) if over.any() else _EMPTY


_EMPTY = np.zeros(0, dtype=np.intp)
