"""Stand-ins for the sans-I/O tests of the Servo ICs and the conversion table."""

from __future__ import annotations

import numpy as np


class FakeEncoders:
    """Encoder positions a test sets directly (counts, floats: the fraction is the sub-count)."""

    def __init__(self, n: int = 8) -> None:
        self.counts = np.zeros(n)

    def encoder(self) -> np.ndarray:
        return self.counts
