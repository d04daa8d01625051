"""The data record of the secondary FIFO: Galil record revision 4 (manual ch. 4 "DMA / Secondary
FIFO Memory Map"): 24 general bytes, 16 for the S and T planes, 28 per axis.

Byte order: little-endian by default, as Galil's host code reads its records (spec §8 question 1);
the card option `record_endian` switches it.
"""

from __future__ import annotations

import numpy as np

GENERAL_SIZE, COORDINATED_SIZE, AXIS_SIZE = 24, 16, 28


def record_dtype(axes: int, endian: str = "little") -> np.dtype:
    """The record layout for `axes` axes (2- and 3-axis cards drop the trailing axis blocks)."""
    e = "<" if endian == "little" else ">"
    axis = np.dtype([
        ("status", e + "u2"), ("switches", "u1"), ("stop_code", "u1"),
        ("reference", e + "i4"), ("position", e + "i4"), ("error", e + "i4"),
        ("aux", e + "i4"), ("velocity", e + "i4"), ("torque", e + "i2"), ("analog", e + "i2"),
    ])
    return np.dtype([
        ("sample", e + "u2"), ("inputs", "u1", (10,)), ("outputs", "u1", (10,)),
        ("error_code", "u1"), ("general_status", "u1"),
        ("s_segments", e + "u2"), ("s_status", e + "u2"), ("s_distance", e + "i4"),
        ("t_segments", e + "u2"), ("t_status", e + "u2"), ("t_distance", e + "i4"),
        ("axis", axis, (axes,)),
    ])


class GeneralStatus:
    """Bits of the general status byte (ch. 4 "General Status Information")."""

    ECHO_ON = 1 << 0
    TRACE_ON = 1 << 1
    WAITING_FOR_IN = 1 << 2
    PROGRAM_RUNNING = 1 << 7

