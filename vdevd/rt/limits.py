"""Hard limits (switch inputs), soft limits (commanded position) and the following-error limit.

Hard limits are inputs: they act when they change (a moving axis heading into an active switch
decelerates with `limit_dec`) and when a command would move toward an active one (refused), so they
cost nothing per tick. Soft limits act at command time: a move or jog heading past a soft limit is
planned to stop exactly at it (the last whole count inside), so the tick never checks them. The
following-error limit costs three ufunc calls per tick while enabled on some axis.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from vdevd.rt.axes import AxisFlag


class Limits:
    """Per-axis limit parameters and the inputs of the limit switches.

    soft_lo/soft_hi: soft limits on the commanded position (-inf/inf disable), read by the next
    motion command; limit_dec: deceleration when a hard limit stops a profile (inf: the command's
    own deceleration); in_position: |ferr| band of IN_POSITION; fe_limit: |following error|
    limit in counts, 0 disables (read-only: change it with `set_fe_limit`).
    """

    def __init__(self, n: int, fe_over: np.ndarray | None = None) -> None:
        """`fe_over`: where the limit the tick compares with lives, (n,) (a row of a motion
        core's coefficient block; its own otherwise)."""
        self.soft_lo = np.full(n, -np.inf)
        self.soft_hi = np.full(n, np.inf)
        self._fe_limit = np.zeros(n)
        self.fe_limit = self._fe_limit.view()
        self.fe_limit.flags.writeable = False
        self._fe_over = np.zeros(n) if fe_over is None else fe_over  # what the tick compares with
        self._fe_over[:] = np.inf
        self.limit_dec = np.full(n, np.inf)
        self.in_position = np.full(n, 1.0)
        self.hard_pos = np.zeros(n, dtype=bool)
        self.hard_neg = np.zeros(n, dtype=bool)
        self.fe_enabled = False
        self._over = np.zeros(n, dtype=bool)
        self._none = bytes(n)
        self._abs = np.zeros(n)

    def set_fe_limit(self, axes: slice | np.ndarray | int, limit: ArrayLike) -> None:
        """Following-error limit of some axes in counts (0 or inf disables)."""
        values = np.asarray(limit, dtype=float)
        if not (values >= 0).all():
            raise ValueError("fe_limit must be >= 0")
        self._fe_limit[axes] = values
        self._fe_over[:] = np.where(self._fe_limit > 0, self._fe_limit, np.inf)
        self.fe_enabled = bool(np.isfinite(self._fe_over).any())

    def blocked(self, axis: int, direction: float) -> bool:
        """True when an active hard limit forbids motion of `axis` in `direction`."""
        return bool((direction > 0 and self.hard_pos[axis]) or (direction < 0 and self.hard_neg[axis]))

    def soft_target(self, axis: int, here: float, target: float) -> tuple[float, int]:
        """Where a motion from `here` toward `target` may go, and the soft-limit bit it hits
        (0 if none). A result equal to `here` with a bit set means the motion is refused."""
        hi, lo = float(self.soft_hi[axis]), float(self.soft_lo[axis])
        if target > here and target > hi:
            return max(here, float(math.floor(hi))), int(AxisFlag.SOFT_LIMIT_POS)
        if target < here and target < lo:
            return min(here, float(math.ceil(lo))), int(AxisFlag.SOFT_LIMIT_NEG)
        return target, 0

    def fe_exceeded(self, ferr: np.ndarray) -> np.ndarray | None:
        """Bool mask of the axes whose |following error| exceeds fe_limit, None when none does."""
        over = self._over
        np.abs(ferr, self._abs)
        np.greater(self._abs, self._fe_over, over)
        return over if over.tobytes() != self._none else None
