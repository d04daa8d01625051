"""Daemon-side helpers over the MAXk register maps, which live in `vdevmaps.oms` (shared with
`vdevclient.maxk`): numpy word indices of the per-axis fields of the shared memory [S Table 3-1;
spec §2.2] and the packing of the limit and home status words [S Tables 3-2, 3-3].
"""

from __future__ import annotations

import numpy as np
from vdevmaps.oms import Shm


def _word_index(x_to_s: int, w_k: int) -> np.ndarray:
    """Word indices (offset / 4) of a per-axis field: 8 words from x_to_s, then 2 from w_k."""
    return np.array([x_to_s // 4 + i for i in range(8)] + [w_k // 4, w_k // 4 + 1])


#: per-axis word indices, X..K, into the shared window viewed as big-endian int32
MOTOR_WORDS = _word_index(Shm.MOTOR_POSITION, Shm.WK_MOTOR_POSITION)
ENCODER_WORDS = _word_index(Shm.ENCODER_POSITION, Shm.WK_ENCODER_POSITION)
COHERENT_MOTOR_WORDS = _word_index(Shm.COHERENT_MOTOR_POSITION, Shm.WK_COHERENT_MOTOR_POSITION)
COHERENT_ENCODER_WORDS = _word_index(Shm.COHERENT_ENCODER_POSITION,
                                     Shm.WK_COHERENT_ENCODER_POSITION)
DAC_WORDS = _word_index(Shm.DAC, Shm.WK_DAC)
COHERENT_DAC_WORDS = np.arange(10) + Shm.COHERENT_DAC // 4
SSI_WORDS = np.arange(10) + Shm.SSI_POSITION // 4


def limit_word(negative: np.ndarray, positive: np.ndarray) -> int:
    """Table 3-2 from per-axis input levels: X..S negative in bits 0-7, positive in 8-15,
    W/K negative in 16-17, positive in 24-25."""
    word = 0
    for a, (lo, hi) in enumerate(zip(negative.tolist(), positive.tolist(), strict=True)):
        shift = a if a < 8 else a + 8  # W/K: 16, 17
        word |= int(lo) << shift | int(hi) << (shift + 8)
    return word


def home_word(levels: np.ndarray) -> int:
    """Table 3-3: X..S in bits 0-7, W/K in bits 8-9."""
    return sum(int(v) << a for a, v in enumerate(levels.tolist()))
