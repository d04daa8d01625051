"""What the scope records on the Turbo PMAC (issue 23 §1; docs/card-pattern.md "Scope"): the
motion core's rows of each motor, `status` the two status words `#n?` reports, word 1 in bits
24-47 and word 2 in bits 0-23 [§2.6], `outputs` the 32 JIO lines as the card drives them (the
same in every motor); `inputs` the shared default (limit and home flags)."""

from __future__ import annotations

from typing import Any

import numpy as np

from vdevd.rt.core import MotionCore
from vdevd.scope.signals import Signals, broadcast


class PmacSignals(Signals):
    @staticmethod
    def core(card: Any) -> MotionCore:
        return card.fw.motors.core

    @classmethod
    def status(cls, card: Any) -> np.ndarray:
        w1, w2 = card.fw.reports.status_words()
        return (np.asarray(w1, dtype=np.int64) << 24) | np.asarray(w2, dtype=np.int64)

    @classmethod
    def outputs(cls, card: Any) -> np.ndarray:
        return broadcast(int(card.fw.gpio.outputs()), cls.core(card).n)


SIGNALS = PmacSignals
