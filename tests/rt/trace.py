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
