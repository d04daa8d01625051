"""What drives an axis of the kernel, and the shape of a kernel unit (kernel.py)."""

from __future__ import annotations

from typing import Protocol

# axis modes
IDLE, PTP, VEL, HOME, JOG, UNIT, STOPPING = 0, 1, 2, 3, 4, 5, 6


class Unit(Protocol):
    """A part of the kernel with its own per-cycle work (interpolation, gearing, trigger, ...):
    `before_motion(t)` before the motion core's tick to time t (s), `after_motion(t)` after it,
    `busy()` while a tick moves it on (no rest), `reset()` at power-up. It may also define
    `stop_axis(axis, code, immediate)` (the kernel stops an axis it drives) and `image()`/
    `restore(image)` for what it keeps in flash, `publish()` to write its part of the status
    block (the kernel's `publish` calls it after every cycle batch and command), and
    `motion_only()`: True when a cycle's `before_motion` and `after_motion` would change nothing
    the last cycle of a run (runs.py) does not set again (default: not `busy()`)."""

    def before_motion(self, t: float) -> None: ...
    def after_motion(self, t: float) -> None: ...
    def busy(self) -> bool: ...
    def reset(self) -> None: ...
