"""The data record of the secondary FIFO: Galil record revision 4 (manual ch. 4 "DMA / Secondary
FIFO Memory Map"): 24 general bytes, 16 for the S and T planes, 28 per axis.

The layout (offsets, item types, status bits) is `vdevmaps.galil`, the one the client decodes;
this module makes a numpy dtype of it. Byte order: little-endian by default, as Galil's host code
reads its records (spec §8 question 1); the card option `record_endian` switches it.
"""

from __future__ import annotations

import numpy as np
from vdevmaps.galil import AXIS_ITEMS, AXIS_SIZE, FIRST_AXIS, GENERAL_ITEMS


def record_dtype(axes: int, endian: str = "little") -> np.dtype:
    """The record layout for `axes` axes (2- and 3-axis cards drop the trailing axis blocks);
    fields are named as `vdevmaps.galil.GENERAL_ITEMS` and, under `axis`, `AXIS_ITEMS`."""
    e = "<" if endian == "little" else ">"
    axis = np.dtype({"names": [name for name, _, _ in AXIS_ITEMS],
                     "formats": [e + fmt for _, _, fmt in AXIS_ITEMS],
                     "offsets": [int(offset) for _, offset, _ in AXIS_ITEMS], "itemsize": AXIS_SIZE})
    return np.dtype({"names": [*(name for name, _, _ in GENERAL_ITEMS), "axis"],
                     "formats": [*(e + fmt for _, _, fmt in GENERAL_ITEMS), (axis, (axes,))],
                     "offsets": [*(int(offset) for _, offset, _ in GENERAL_ITEMS), FIRST_AXIS],
                     "itemsize": FIRST_AXIS + AXIS_SIZE * axes})
