"""Position feedback through the encoder conversion table: Ixx03 [A L2445-2551, L336-365].

A motor's loop reads its position from the conversion-table result Ixx03 points at (X:$3501+k,
24 bits in 1/32 count). With the factory Ixx03 ($3501 + n − 1, the 1/T entry of the motor's own
encoder) that is the motor's encoder, and nothing is done. Pointed elsewhere (an MLDT entry, a
parallel or filtered entry, another channel) the motor's feedback becomes that result: the
24-bit result is extended across its rollovers as the firmware does, and the motion core sees
its encoder offset so that it reads the result (to the nearest count), one servo cycle late
(the table is processed after the motors here). Ixx04 (a separate velocity feedback) is not
modelled: the loop uses Ixx03 for both.
"""

from __future__ import annotations

import numpy as np

from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.memory import Memory

TABLE = 0x3501
WRAP = 1 << 24


def _signed24(v: int) -> int:
    return v - WRAP if v & 0x800000 else v


class FeedbackSelect:
    """Which motors take their position from a conversion-table result other than their own."""

    def __init__(self, memory: Memory, ivars: IVars) -> None:
        self.memory = memory
        self.ivars = ivars
        n = ivars.motors
        self.defaults = np.array([ivars.defaults[100 * (m + 1) + 3] for m in range(n)])
        self.source = np.zeros(n, dtype=np.int64)  # the Ixx03 each motor tracks (0: own encoder)
        self.last = np.zeros(n, dtype=np.int64)  # the last 24-bit result read
        self.position = np.zeros(n)  # the extended result, counts
        #: whether a motor tracks another result (`source` not all 0): looked at every cycle
        self.active = False

    def reset(self) -> None:
        self.source[:] = 0
        self.active = False

    def refresh(self, encoder: np.ndarray) -> None:
        """Ixx03 may have changed: motors that now read another result start from where their
        encoder is, so switching the source does not jump the motor."""
        wanted = np.rint(self.ivars.motor(3)).astype(np.int64)
        wanted[wanted == self.defaults] = 0
        for m in np.flatnonzero(wanted != self.source):
            self.source[m] = wanted[m]
            if wanted[m]:
                self.last[m] = self._read(int(wanted[m]))
                self.position[m] = encoder[m]
        self.active = bool(np.count_nonzero(self.source))

    def _read(self, addr: int) -> int:
        return _signed24(self.memory.read("X", addr))

    def offsets(self) -> np.ndarray:
        """Extend each tracked result by its change since the last cycle (24-bit rollover) and
        return, per motor, the result in counts (NaN for motors on their own encoder)."""
        out = np.full(len(self.source), np.nan)
        for m in np.flatnonzero(self.source):
            now = self._read(int(self.source[m]))
            step = (now - int(self.last[m]) + WRAP // 2) % WRAP - WRAP // 2
            self.last[m] = now
            self.position[m] += step / 32
            out[m] = self.position[m]
        return out
