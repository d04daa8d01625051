"""Stepper position maintenance (SPM) of the DMC-13X8 [M Ch6 §Stepper Position Maintenance Mode;
spec §5.6].

`YA` step drive resolution (pulses per full step), `YB` motor resolution (full steps per
revolution), `YC` encoder resolution (counts per revolution), `YS 1` enables the monitoring,
`QS` is the error in pulses, QS = TD - TP * YA * YB / YC. When |QS| exceeds three full motor steps
(3 * YA pulses) YS becomes 2 and with OE 1 the axis stops; `YR n` is a correction move of n
pulses; once a move has completed with |QS| under the limit, YS returns to 1.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vdevd.devices.galil.motion import GalilMotion, StopCode

#: (default, lowest, highest) of YA YB YC. ASSUMPTION: the 13X8 manual gives YA up to 9999 and
#: no defaults; the defaults are its examples' full-step drive, 200-step motor, 4000-count encoder
SPM_PARAMS: dict[str, tuple[float, float, float]] = {
    "YA": (2.0, 1.0, 9999.0),
    "YB": (200.0, 1.0, 9999.0),
    "YC": (4000.0, 1.0, 2_147_483_647.0),
}
FULL_STEPS_LIMIT = 3  # QS beyond three full motor steps is an error [M Ch6 §Error Limit]
YS_ERROR = 2


class StepperMaintenance:
    """SPM of one card's axes: the resolutions, YS and the error check of every sample."""

    def __init__(self, motion: GalilMotion) -> None:
        n = motion.n
        self.motion = motion
        self.values = {k: np.full(n, d) for k, (d, _, _) in SPM_PARAMS.items()}
        self.ys = np.zeros(n, dtype=np.int64)
        #: the pulses of YR corrections: they move the motor to where the encoder says it
        #: should be, so they count in the step register but not in QS (ASSUMPTION)
        self.corrected = np.zeros(n)
        #: YS 2 "causes the automatic subroutine labeled #POSERR to be executed" [M Ch6 §SPM]
        self.on_error: Callable[[], object] | None = None

    @property
    def active(self) -> bool:
        """Whether an axis is monitored (YS 1 or 2)."""
        return bool(self.ys.any())

    def error(self) -> np.ndarray:
        """QS, in pulses: TD - TP * YA * YB / YC [M Ch6 §SPM] (TD without YR's pulses)."""
        m, v = self.motion, self.values
        return m.auxiliary() - self.corrected - m.position() * (v["YA"] * v["YB"] / v["YC"])

    def step(self) -> None:
        """The error check: |QS| over 3 * YA pulses sets YS 2 (OE 1 stops the axis); an axis
        standing with |QS| within it after an error goes back to YS 1."""
        m = self.motion
        over = np.abs(self.error()) > FULL_STEPS_LIMIT * self.values["YA"]
        trip = (self.ys == 1) & over
        if trip.any():
            self.ys[trip] = YS_ERROR
            stop = np.flatnonzero(trip & (m.values["OE"] > 0)).tolist()
            if stop:
                m.stop(stop, StopCode.OFF_ON_ERROR)
            if self.on_error is not None:
                self.on_error()
        cleared = (self.ys == YS_ERROR) & ~over & ~m.core.profile.moving
        if cleared.any():
            self.ys[cleared] = 1
