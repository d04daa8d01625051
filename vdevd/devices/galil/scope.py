"""What the scope records on the DMC-13X8 (issue 23 §1; docs/card-pattern.md "Scope"): the
motion core's rows (`position` is TP, the encoder; `command` RP; `error` TE), and the card's
own words: `status` the axis status word of the data record, `inputs` the axis switch byte
(limit bits are logic levels, 1 = not tripped, as TS reads them), `outputs` the output bank
OP (the same in every axis) [M Ch4 "Data Record"]."""

from __future__ import annotations

from typing import Any

import numpy as np

from vdevd.rt.core import MotionCore
from vdevd.scope.signals import Signals, broadcast


class GalilSignals(Signals):
    @staticmethod
    def core(card: Any) -> MotionCore:
        return card.firmware.motion.core

    @classmethod
    def status(cls, card: Any) -> np.ndarray:
        return card.firmware.motion.status_word()

    @classmethod
    def inputs(cls, card: Any) -> np.ndarray:
        fw = card.firmware
        return fw.motion.switches(fw.latch_inputs())

    @classmethod
    def outputs(cls, card: Any) -> np.ndarray:
        return broadcast(card.firmware.outputs, cls.core(card).n)


SIGNALS = GalilSignals
