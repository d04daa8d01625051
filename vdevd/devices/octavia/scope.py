"""What the scope records on the Octavia (issue 23 §1; docs/card-pattern.md "Scope"): the
motion core's rows of axes 1..8, `outputs` OUT0..31 as the host set them (bit set: ON, the same
in every axis); `status` and `inputs` the shared defaults (the core's flags, the limit and home
switches)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vdevd.rt.core import MotionCore
from vdevd.scope.signals import Signals, broadcast


class OctaviaSignals(Signals):
    @staticmethod
    def core(card: Any) -> MotionCore:
        return card.fw.core

    @classmethod
    def outputs(cls, card: Any) -> np.ndarray:
        return broadcast(card.fw.params.outputs_on & 0xFFFF_FFFF, cls.core(card).n)


SIGNALS = OctaviaSignals
