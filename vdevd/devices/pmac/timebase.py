"""The coordinate systems' time base: the feed-rate override `%` slewing at Isx94 [spec pmac.md
§2.2 Isx94/Isx95 (SRM p.191), §2.7 "Delta-time per servo cycle = I10·%/100", §2.8 X:$002000 /
X:$002002].

`%{v}` sets the host-commanded time base (X:$002000 + $100(s−1), I10·v/100); the present time
base (X:$002002 ...), which motion runs on, moves toward it by Isx94 units (2^-23 ms per servo
cycle, the unit of I10) each servo cycle: with the factory 1644 and I10 = 3,713,707 from 0 to
100 % in about 2259 cycles, one second [SRM p.191]. In closed form from the cycle of the
command, so a card at rest does no work for it (decision 0008).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vdevd.devices.pmac.ivars import IVars

CS_COUNT = 16


class TimeBase:
    """The present feed-rate override of C.S. 1-16, slewing toward the commanded one."""

    def __init__(self, ivars: IVars, clock: Callable[[], int]) -> None:
        self.ivars = ivars
        self.clock = clock
        self.reset()

    def reset(self) -> None:
        """Power-up: 100 % commanded and present."""
        self._start = np.full(CS_COUNT, 100.0)
        self._target = np.full(CS_COUNT, 100.0)
        self._at = np.zeros(CS_COUNT, dtype=np.int64)

    def command(self, cs: int, percent: float) -> None:
        """`%{v}` of C.S. `cs` (0-based): the present value starts to slew toward it."""
        self._start[cs] = self.present(cs)
        self._target[cs] = percent
        self._at[cs] = self.clock()

    def rate(self, cs: int) -> float:
        """Percent per servo cycle: Isx94 / I10 x 100; Isx94 = 0 takes the new value at once
        (README assumption)."""
        i10 = float(self.ivars.values[10])
        i94 = float(self.ivars.values[5000 + 100 * (cs + 1) + 94])
        return i94 / i10 * 100 if i94 > 0 and i10 > 0 else float("inf")

    def present(self, cs: int) -> float:
        """The present override, percent (what X:$002002 holds in I10 units)."""
        start, target = float(self._start[cs]), float(self._target[cs])
        if start == target:
            return target
        rate = self.rate(cs)
        step = rate * (self.clock() - int(self._at[cs])) if rate != float("inf") else rate
        if step >= abs(target - start):
            self._start[cs] = target
            return target
        return start + step if target > start else start - step
