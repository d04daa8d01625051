"""Record mode: automatic data capture into arrays in the servo sample [M Ch6 §Teach (Record and
Play-Back)]: `RA` names up to 4 arrays, `RD` the data of each (`_TPX`, `_TEY`, `TIME` ...),
`RC n,m` records m times, every 2^n samples; `_RC` is 1 while recording, `_RD` the index of the
next element written.

The first record is taken in the sample after RC, then every 2^n samples. A negative m records
circularly into elements 0..|m|-1 until `RC 0`; m omitted (or 0) fills the smallest array.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from vdevd.devices.galil.numbers import fixed

MAX_RECORD_ARRAYS = 4  # "up to 4 for DMC-13X8" [M Ch6 §Teach]
MAX_RATE = 8  # RC n: 2^n samples, n 1..8 (spec §4.5)
NEVER = 1 << 62  # the next record's tick while not recording


@dataclass
class Recorder:
    """The record mode state of one card: what RA and RD chose and, while recording, where the
    next record goes. `next_tick` is the sample count at which the sample records (NEVER when
    not recording): the sample compares one int."""

    arrays: list[str] = field(default_factory=list)  # RA
    sources: list[str] = field(default_factory=list)  # RD, the operand texts
    next_tick: int = NEVER
    every: int = 0  # samples between records
    remaining: int = 0  # records still to take (-1: circular, until RC 0)
    length: int = 0  # the elements recorded into (circular: |m|)
    next_index: int = 0  # _RD
    targets: list[np.ndarray] = field(default_factory=list)
    readers: list[Callable[[], float]] = field(default_factory=list)

    @property
    def active(self) -> bool:
        """`_RC`: recording."""
        return self.next_tick != NEVER

    def start(self, ticks: int, rate: int, count: int, targets: list[np.ndarray],
              readers: list[Callable[[], float]]) -> None:
        """RC n,m given at sample count `ticks`: records from the next sample on."""
        self.targets, self.readers = targets, readers
        self.every = 1 << rate
        self.length = abs(count)
        self.remaining = count if count > 0 else -1
        self.next_index = 0
        self.next_tick = ticks + 1

    def stop(self) -> None:
        """RC 0, the last record taken, or RS."""
        self.next_tick = NEVER
        self.targets, self.readers = [], []

    def capture(self) -> None:
        """The record of this sample: each RD source into its RA array at `_RD`."""
        i = self.next_index
        for target, read in zip(self.targets, self.readers, strict=True):
            target[i] = fixed(read())
        i += 1
        if self.remaining < 0:
            self.next_index = i % self.length
        else:
            self.next_index = i
            self.remaining -= 1
            if not self.remaining:
                self.stop()
                return
        self.next_tick += self.every
