"""Run a motion core and record its commanded trajectory, for the invariant checks."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vdevd.rt import MotionCore


def record(core: MotionCore, max_ticks: int, until: Callable[[MotionCore], bool]) -> np.ndarray:
    """cmd_pos of every tick (row 0 is the state before the first tick) until `until` holds."""
    rows = [core.axes.cmd_pos.copy()]
    for _ in range(max_ticks):
        core.tick()
        rows.append(core.axes.cmd_pos.copy())
        if until(core):
            break
    return np.array(rows)


def idle(core: MotionCore) -> bool:
    return not core.profile.moving.any()


def check_bounds(trace: np.ndarray, dt: float, vmax: np.ndarray | None, amax: np.ndarray,
                 jmax: np.ndarray | None = None) -> None:
    """Finite-difference velocity, acceleration (and jerk) within the limits, per axis."""
    scale = np.abs(trace).max() + 1.0
    vel = np.diff(trace, axis=0) / dt
    acc = np.diff(vel, axis=0) / dt
    eps = 1e-12 * scale  # float rounding of positions
    if vmax is not None:
        assert (np.abs(vel) <= vmax * (1 + 1e-9) + eps / dt).all(), np.abs(vel).max(axis=0)
    assert (np.abs(acc) <= amax * (1 + 1e-6) + 4 * eps / dt**2).all(), np.abs(acc).max(axis=0)
    if jmax is not None:
        jerk = np.diff(acc, axis=0) / dt
        assert (np.abs(jerk) <= jmax * (1 + 1e-6) + 8 * eps / dt**3).all(), np.abs(jerk).max(axis=0)
