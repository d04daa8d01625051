"""The status block of BAR0 as numpy views, and the motion status and motion I/O words
[M §4.8.1, §4.1.1.4; spec adlink.md §2.1, §2.14].

The axis records (`vdevmaps.adlink.Axis`) are one structured array over the bar's memory, so the
kernel publishes every axis in a few vectorised assignments.
"""

from __future__ import annotations

import numpy as np
from vdevmaps.adlink import AXIS_STRIDE, Axis, Bar

from vdevd.region import Memory

#: the axis record, field by field at the offsets of `vdevmaps.adlink.Axis`
AXIS_DTYPE = np.dtype({
    "names": ["msts", "mio", "stop_code", "cmd_counter", "encoder", "mq_usage", "gear", "servo",
              "cmd_pos", "fbk_pos", "target", "err_pos", "cmd_vel", "fbk_vel"],
    "formats": ["<i4"] * 8 + ["<f8"] * 6,
    "offsets": [Axis.MSTS, Axis.MIO, Axis.STOP_CODE, Axis.CMD_COUNTER, Axis.ENCODER,
                Axis.MQ_USAGE, Axis.GEAR, Axis.SERVO, Axis.CMD_POS, Axis.FBK_POS, Axis.TARGET,
                Axis.ERR_POS, Axis.CMD_VEL, Axis.FBK_VEL],
    "itemsize": AXIS_STRIDE,
})



def axis_records(buf: Memory, n: int) -> np.ndarray:
    """The n axis records of the bar, as a structured array sharing its memory."""
    return np.ndarray((n,), dtype=AXIS_DTYPE, buffer=buf, offset=int(Bar.AXIS))


def u32_words(buf: Memory, offset: int, count: int) -> np.ndarray:
    return np.ndarray((count,), dtype="<u4", buffer=buf, offset=offset)


def bit(flags: np.ndarray, n: int) -> np.ndarray:
    """A bool row as the bit `n` of an int64 row."""
    return flags.astype(np.int64) << n


def wrap_i32(values: np.ndarray) -> np.ndarray:
    """Counters as I32 two's complement: they wrap at 2^32 (spec Q20)."""
    return ((np.asarray(values, dtype=np.int64) + 2**31) % 2**32 - 2**31).astype(np.int32)
