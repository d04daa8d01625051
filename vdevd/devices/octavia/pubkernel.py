"""The Octavia's state windows (ACTPOS, ACTVEL, ERROR) published in one compiled call (decision
0011's pattern, issue 18): `Firmware.publish` after every batch of samples, ~5 us of numpy calls
on 8-element rows, here ~1 us.

`publish_py` does what the numpy path of `Firmware.publish` does (kept as the reference, and the
fallback without numba or with VDEVD_JIT=0), with the same IEEE operations: the three rows as the
card's counts (encoder; rint(vel * TS * ACTVEL_SCALE); rint(ferr)) into `pub` (3, n) int64, and
with `store` those rows into both banks of the DPR as little-endian int32 words, wrapping beyond
2^31 as numpy's int64 -> int32 store does. tests/devices/octavia/test_publish_kernel.py compares
the DPR both ways.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np
from vdevmaps.octavia import BANK2, DPR_SIZE, Dpr

from vdevd.rt import kernel

#: where bank 1's ACTPOS, ACTVEL and ERROR rows start (four int32 words a row; bank 2 +800h)
STATE = int(Dpr.ACTPOS)
BANK = BANK2


def publish_py(encoder: Any, vel: Any, ferr: Any, pub: Any, mem: Any, n: int, ts: float,
               scale: float, store: bool) -> None:
    """The rows of `Firmware.publish` into `pub`, and with `store` into the DPR `mem` (uint8)."""
    for i in range(n):
        pub[0, i] = encoder[i]
        pub[1, i] = np.int64(np.rint(vel[i] * ts * scale))
        pub[2, i] = np.int64(np.rint(ferr[i]))
    if not store:
        return
    for r in range(3):
        for i in range(n):
            at = STATE + 16 * r + 4 * i if i < 4 else STATE + BANK + 16 * r + 4 * (i - 4)
            word = pub[r, i] & 0xFFFFFFFF
            mem[at] = word & 0xFF
            mem[at + 1] = (word >> 8) & 0xFF
            mem[at + 2] = (word >> 16) & 0xFF
            mem[at + 3] = (word >> 24) & 0xFF


Publish = Callable[[Any, Any, Any, Any, Any, int, float, float, bool], None]


@cache
def compiled() -> Publish | None:
    """`publish_py` compiled, or None (no numba, VDEVD_JIT=0, or compiling failed: logged)."""
    state = np.zeros((11, 1))
    probe = (np.zeros(1, dtype=np.int64), state[0], state[1], np.zeros((3, 1), dtype=np.int64),
             np.zeros(DPR_SIZE, dtype=np.uint8), 1, 2e-4, 208.0, False)
    return kernel._jit(publish_py, probe, "the Octavia's compiled publish",
                       "it publishes with numpy")
