"""The modes in which the card computes axes' commanded positions itself every sample: gearing,
ECAM, contour (manual ch. 6), beside stepper position maintenance and the commutation setup.

`Follow` owns their state for one motion firmware (a new one at RS) and hooks itself into the
sample (`GalilMotion.before_tick`) only while one of them has work: a card with none engaged
ticks as before and may rest (decision 0008); one with any engaged is not at rest
(`GalilMotion.engaged`).
"""

from __future__ import annotations

import numpy as np
from vdevmaps.galil import AxisStatus

from vdevd.devices.galil.commutation import Commutation
from vdevd.devices.galil.contour import Contour
from vdevd.devices.galil.ecam import Ecam
from vdevd.devices.galil.gearing import Gearing
from vdevd.devices.galil.motion import GalilMotion
from vdevd.devices.galil.spm import StepperMaintenance
from vdevd.devices.galil.virtual import VirtualAxis


class Follow:
    """Gearing, ECAM, contour, SPM and commutation of one card's motion."""

    def __init__(self, motion: GalilMotion, virtual: VirtualAxis | None = None) -> None:
        self.motion = motion
        self.gearing = Gearing(motion, virtual)
        self.ecam = Ecam(motion, virtual)
        self.ecam.on_redefine = self.gearing.redefined
        self.contour = Contour(motion)
        self.spm = StepperMaintenance(motion)
        self.commutation = Commutation(motion)

    def refresh(self) -> None:
        """After a command or a sample: hook the sample while a mode has work."""
        engaged = self.gearing.active or self.ecam.active or self.contour.on
        self.motion.engaged = engaged
        self.motion.before_tick = self.step if engaged or self.spm.active else None

    def step(self) -> None:
        """Before a sample's motion: the contour point, the cam slaves, the gear followers."""
        if self.contour.on:
            self.contour.step()
        if self.ecam.active:
            self.ecam.step()
        if self.gearing.active:
            self.gearing.step()
        if self.spm.active:
            self.spm.step()
        self.refresh()

    def stopped(self, axes: list[int]) -> None:
        """ST on `axes`: gearing disengages in standard mode [M Ch6 §Electronic Gearing]; the
        contour axes leave contour mode (ASSUMPTION)."""
        self.gearing.stopped(axes)
        if self.contour.on and set(axes) & set(self.contour.idx.tolist()):
            self.contour.leave()
        self.refresh()

    def status_bits(self) -> np.ndarray:
        """Bits of the axis status word these modes set: 6, contour mode [M Ch4 §Explanation of
        Status Information]."""
        bits = np.zeros(self.motion.n, dtype=np.int64)
        if self.contour.on:
            bits[self.contour.idx] |= int(AxisStatus.CONTOUR)
        return bits

    def aborted(self) -> None:
        """AB or the abort input: gearing, ECAM and contour end at once (ASSUMPTION: the
        manual names ST and limit switches only)."""
        self.gearing.disengage(list(range(self.motion.n)))
        self.ecam.release_all()
        self.contour.leave(None)
        self.refresh()
