"""Absolute encoders with SSI [S §4.9, §4.9.1; spec oms.md §5.8].

`ECA bits,clock` on a stepper-with-encoder axis (PSE) makes its encoder an SSI absolute
encoder of 1-32 bits read at one of the eight clock rates; the card publishes its word every
update cycle at 0x3520 + 4·axis: the encoder position masked to the bit count (a position below
zero or beyond the range wraps, as the encoder's own counter does), in binary or, for Gray-code
encoders (card option `ssi_code`), Gray-coded: the card passes the word on as the encoder sends
it, and a host decodes Gray itself (E-drvMAXv `greyCode`; spec oms.md §5.8). Axes without SSI
read 0 there.
"""

from __future__ import annotations

import numpy as np

#: "31,250Hz, 62,500Hz, 125,000Hz, 250,000Hz, 500,000Hz, 1MHz, 2MHz, and 4MHz" [S §4.9]
CLOCKS = (31_250, 62_500, 125_000, 250_000, 500_000, 1_000_000, 2_000_000, 4_000_000)
MAX_BITS = 32


class Ssi:
    """The SSI configuration of every axis (bits 0: none)."""

    def __init__(self, n: int) -> None:
        self.bits = np.zeros(n, dtype=np.int64)
        self.clock = np.zeros(n, dtype=np.int64)
        self._mask = np.zeros(n, dtype=np.int64)
        self.any = False

    def configure(self, a: int, bits: int, clock: int) -> None:
        """ECA bits,clock on axis a (the caller checked the axis type and the values)."""
        self.bits[a], self.clock[a] = bits, clock
        self._mask[a] = (1 << bits) - 1
        self.any = bool(self.bits.any())

    def words(self, encoder: np.ndarray, gray: bool = False) -> np.ndarray:
        """The SSI words (as signed 32-bit values, for the big-endian int32 window), Gray-coded
        with `gray`."""
        if not self.any:
            return np.zeros(len(self.bits), dtype=np.int64)
        word = np.asarray(encoder, dtype=np.int64) & self._mask
        if gray:
            word = word ^ (word >> 1)  # within the bit count: the mask keeps the top bit's place
        return (word + 2**31) % 2**32 - 2**31
