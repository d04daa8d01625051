"""What the scope records on the AMP-204C/208C (issue 23 §1; docs/card-pattern.md "Scope"): the
motion core's rows of axes 0..7, `status` the motion status word (APS_motion_status) and
`inputs` the motion I/O word (APS_motion_io_status) as the kernel last computed them
[M §4.8.1, §4.1.1.4], `outputs` the DO word the application wrote (the same in every axis)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vdevd.rt.core import MotionCore
from vdevd.scope.signals import Signals, broadcast


class AdlinkSignals(Signals):
    @staticmethod
    def core(card: Any) -> MotionCore:
        return card.kernel.core

    @classmethod
    def status(cls, card: Any) -> np.ndarray:
        return card.kernel.msts

    @classmethod
    def inputs(cls, card: Any) -> np.ndarray:
        return card.kernel.mio

    @classmethod
    def outputs(cls, card: Any) -> np.ndarray:
        return broadcast(int(card.kernel.do_word), cls.core(card).n)


SIGNALS = AdlinkSignals
