"""What the scope records on the OMS MAXk (issue 23 §1; docs/card-pattern.md "Scope"): the
motion core's rows of each axis, `outputs` the 16 I/O lines' levels (bit n = IOn, the same in
every axis) [S §4.6]; `status` and `inputs` the shared defaults (the core's flags, the limit
and home switches)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vdevd.rt.core import MotionCore
from vdevd.scope.signals import Signals, broadcast


class MaxkSignals(Signals):
    @staticmethod
    def core(card: Any) -> MotionCore:
        return card.fw.motion.core

    @classmethod
    def outputs(cls, card: Any) -> np.ndarray:
        return broadcast(int(card.fw.gpio_levels()), cls.core(card).n)


SIGNALS = MaxkSignals
