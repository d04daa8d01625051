"""The status block of BAR0 as numpy views, and the motion status and motion I/O words
[M §4.8.1, §4.1.1.4; spec adlink.md §2.1, §2.14].

The axis records (`vdevmaps.adlink.Axis`) are two strided blocks over the bar's memory (their
I32 and their F64 fields), so the kernel publishes every axis in two assignments.
"""

from __future__ import annotations

import numpy as np
from vdevmaps.adlink import AXIS_STRIDE, Axis, Bar

from vdevd.region import Memory


def axis_blocks(buf: Memory, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The n axis records of the bar as two (n, fields) views sharing its memory: the I32
    fields MSTS ... SERVO and the F64 fields CMD_POS ... FBK_VEL (each run contiguous in a
    record), so the kernel publishes every axis in two assignments."""
    ints = np.ndarray((n, 8), dtype="<i4", buffer=buf, offset=int(Bar.AXIS) + Axis.MSTS,
                      strides=(AXIS_STRIDE, 4))
    floats = np.ndarray((n, 6), dtype="<f8", buffer=buf, offset=int(Bar.AXIS) + Axis.CMD_POS,
                        strides=(AXIS_STRIDE, 8))
    return ints, floats


def u32_words(buf: Memory, offset: int, count: int) -> np.ndarray:
    return np.ndarray((count,), dtype="<u4", buffer=buf, offset=offset)
