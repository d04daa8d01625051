"""The Turbo PMAC's servo filter: the shared motion core's PID with PMAC's integrator hold
[spec pmac.md §2.7, PMAC1-UM p.108]. The gain mapping from Ixx30-Ixx35 is in motors.py."""

from __future__ import annotations

import numpy as np

from vdevd.rt import Pid


class PmacPid(Pid):
    """The core's PID with PMAC's integrator hold [§2.7]: the error is not integrated while the
    output is saturated at Ixx69, nor (Ixx34 = 1, `hold_moving`) while the commanded velocity is
    not zero. Costs nothing while no motor has an integral gain (`integrating`)."""

    def __init__(self, n: int, terms: np.ndarray) -> None:
        super().__init__(n, terms)
        self.hold_moving = np.zeros(n, dtype=bool)
        self.integrating = False
        self._hold = np.zeros(n, dtype=bool)
        self._sat = np.zeros(n, dtype=bool)
        self._abs = np.zeros(n)

    def update(self, out: np.ndarray) -> None:
        if self.integrating:  # `out` still holds the previous output here
            hold, sat = self._hold, self._sat
            np.not_equal(self.cmd_vel, 0.0, out=hold)
            hold &= self.hold_moving
            np.abs(out, out=self._abs)
            np.greater_equal(self._abs, self.out_limit, out=sat)
            hold |= sat
            hold &= self.ki_on  # the others do not integrate at all
            self.integ -= self.e * hold  # the parent adds e back: no net integration
        super().update(out)
