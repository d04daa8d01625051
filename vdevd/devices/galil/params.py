"""Per-axis parameters of the DMC-13X8: defaults, ranges, resolution and reply format.

Ranges and defaults from spec galil.md §1.3 (Optima command reference where the 13X8 manual is
silent); formats are (integer digits, fraction digits) of the interrogation reply (`KP ?` ->
`0006.00`). Values are kept as float arrays, one element per axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Param:
    """One per-axis parameter command (`KP 10,20`, `KPX=10`, `KP ?`)."""

    default: float
    lo: float
    hi: float
    resolution: float = 0.0  # values round to a multiple of it (0: Galil fixed point, 1/65536)
    digits: int = 10
    frac: int = 0
    round_down: bool = False  # AC/DC round down to 1024 (Optima AC)
    also: tuple[float, ...] = ()  # allowed values outside lo..hi (ER -1)

    def coerce(self, value: float) -> float | None:
        """The value the card stores, or None when it is out of range (TC 6)."""
        if not math.isfinite(value):
            return None
        if value in self.also:
            return value
        if self.hi < value <= self.hi + _LSB or self.lo - _LSB <= value < self.lo:
            value = min(max(value, self.lo), self.hi)  # 9.998 in 32.16 fixed point is a hair above
        if not self.lo <= value <= self.hi:
            return None
        if self.resolution:
            q = value / self.resolution
            q = math.floor(q) if self.round_down else math.floor(q + 0.5)
            value = q * self.resolution
            if value < self.lo:
                value = self.lo
        return value


_POS = 2_147_483_647.0
_LSB = 1 / 65536  # the resolution of the card's numbers
_ACC = Param(256_000, 1024, 67_107_840, 1024, 7, 0, round_down=True)

#: every parameter command, by name (manual ch. 2 step 7-8, ch. 6; spec §1.3)
PARAMS: dict[str, Param] = {
    "KP": Param(6, 0, 1023.875, 1 / 8, 4, 2),
    "KD": Param(64, 0, 4095.875, 1 / 8, 4, 2),
    "KI": Param(0, 0, 2047.875, 1 / 128, 4, 4),
    "IL": Param(9.9982, -9.9982, 9.9982, 0, 1, 4),
    "TL": Param(9.998, 0, 9.998, 0, 1, 4),
    "OF": Param(0, -9.998, 9.998, 0, 1, 4),
    "PL": Param(0, 0, 0.9999, 0, 1, 4),
    "ER": Param(16384, 1, 32767, 1, 5, 0, also=(-1.0,)),
    "OE": Param(0, 0, 1, 1, 1, 0),
    "AC": _ACC,
    "DC": _ACC,
    "SP": Param(25_000, 0, 12_000_000, 2, 8, 0),
    "JG": Param(25_000, -12_000_000, 12_000_000, 2, 8, 0),
    "IT": Param(1, 0.004, 1, 1 / 256, 1, 4),
    "FA": Param(0, 0, 8191, 0, 4, 0),
    "FV": Param(0, 0, 8191, 0, 4, 0),
    "KS": Param(2, 0.5, 8, 1 / 32, 1, 2),
    "MT": Param(1, -2.5, 2.5, 0.5, 1, 1),
    "CE": Param(0, 0, 15, 1, 2, 0),
    "DV": Param(0, 0, 1, 1, 1, 0),
    "FL": Param(_POS, -_POS, _POS, 1, 10, 0),
    "BL": Param(-_POS, -_POS, _POS, 1, 10, 0),
    "PR": Param(0, -_POS, _POS, 1, 10, 0),
    "PA": Param(0, -_POS, _POS, 1, 10, 0),
}

#: the MT values the card accepts (1 servo, -1 reversed servo, +-2 and +-2.5 stepper; spec §5.6)
MOTOR_TYPES = (1.0, -1.0, 2.0, -2.0, 2.5, -2.5)

#: volts to DAC counts: 16-bit DAC over +-10 V, 20/65536 V per count (spec §5.1)
COUNTS_PER_VOLT = 3276.8
DAC_FULL_SCALE = 32767
