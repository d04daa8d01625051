"""Table RTCs [Ch5 "DSPL High-Level Language Table Related", LOAD_CUBIC_TABLE,
CLEAR_CUBIC_TABLE; Ch8; spec octavia.md §5.9, §6]: the compensation tables, the compensation
table each axis uses, and the internal cubic spline table's storage (CUBIC_INT, which runs it, is
the contouring's).

All tables live in the board RAM with its real aliasing (ram.py): loading the cubic table
overwrites cam points and compensation tables 1-4 as on the card. A download copies its data out
of the staging area at 120h before 3C2h is cleared [Ch5 LOAD_*]. The compensation math is in
the *Table Compensation Application Notes*, not included: the tables are stored, not applied
(spec §5.9). Out-of-range arguments (no error report in the manual) are ignored and logged.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import STAGING_BYTES, Dpr

from vdevd.devices.octavia.cmd_cam import staging_warning, tables_changed
from vdevd.devices.octavia.ram import COMP_ENTRIES, COMP_TABLES, CUBIC_POINTS

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

Groups = list[tuple[int, dict[str, Any]]]
MAX_COMP_LOAD = STAGING_BYTES // 2  # 336 16-bit entries a download [Ch5 LOAD_POS_TABLE]
MAX_CUBIC_LOAD = STAGING_BYTES // 4  # 168 32-bit positions [Ch5 LOAD_CUBIC_TABLE]


def _staged(fw: Firmware, dtype: str, count: int) -> np.ndarray:
    """`count` values of `dtype` from the staging area at 120h."""
    size = np.dtype(dtype).itemsize * count
    return np.frombuffer(bytes(fw.buf[Dpr.RINGBUF:Dpr.RINGBUF + size]), dtype=dtype).astype(
        np.int64)


def _load_comp(fw: Firmware, head: dict[str, Any], name: str, velocity: bool) -> None:
    mask, index, num = int(head["table"]), int(head["index"]), int(head["num"])
    if not 1 <= num <= MAX_COMP_LOAD or index + num > COMP_ENTRIES:
        log.warning("octavia: %s of %d entries at %d (1..%d within %d): ignored", name, num,
                    index, MAX_COMP_LOAD, COMP_ENTRIES)
        return
    staging_warning(fw, name)
    values = _staged(fw, "<u2", num)
    if velocity:
        fw.ram.store_vel_table(mask, index, values)
    else:
        fw.ram.store_pos_table(mask, index, values)
    tables_changed(fw)


def load_pos_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Copy `num` 16-bit entries (1..336) from 120h into the position compensation table(s)
    whose bits are set in `table`, from `index` on [Ch5 LOAD_POS_TABLE]; several bits load
    each table (spec Q-37)."""
    _load_comp(fw, head, "LOAD_POS_TABLE", velocity=False)


def load_vel_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """As LOAD_POS_TABLE, into the velocity compensation tables [Ch5 LOAD_VEL_TABLE]."""
    _load_comp(fw, head, "LOAD_VEL_TABLE", velocity=True)


def clear_pos_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Zero the position compensation tables whose bits are set in `n` [Ch5 CLEAR_POS_TABLE]."""
    fw.ram.clear_pos_table(int(head["n"]))
    tables_changed(fw)


def clear_vel_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Zero the velocity compensation tables whose bits are set in `n` [Ch5 CLEAR_VEL_TABLE]."""
    fw.ram.clear_vel_table(int(head["n"]))
    tables_changed(fw)


def table_sel(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The compensation table each axis of `n` uses [Ch5 TABLE_SEL]: 1..4 in the manual, 1..8
    accepted (Ch8 has eight, spec Q-26); another value leaves that axis's selection."""
    for a, g in fw.axes_of(groups):
        tb = int(g["tb"])
        if 1 <= tb <= COMP_TABLES:
            fw.params.table_sel[a] = tb
        else:
            log.warning("octavia: TABLE_SEL axis %d: table %d is not 1..%d: ignored", a + 1, tb,
                        COMP_TABLES)


def load_cubic_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Copy `num` int32 positions (1..168) from 120h into the internal cubic spline table from
    `index` (0..4095) on [Ch5 LOAD_CUBIC_TABLE]; it aliases the cam table and compensation
    tables 1-4 [Ch8]."""
    index, num = int(head["index"]), int(head["num"])
    if not 1 <= num <= MAX_CUBIC_LOAD or index + num > CUBIC_POINTS:
        log.warning("octavia: LOAD_CUBIC_TABLE of %d points at %d (1..%d within %d): ignored",
                    num, index, MAX_CUBIC_LOAD, CUBIC_POINTS)
        return
    staging_warning(fw, "LOAD_CUBIC_TABLE")
    fw.ram.store_cubic_points(index, _staged(fw, "<i4", num))
    tables_changed(fw)


def clear_cubic_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Clear the internal cubic spline storage, RAM 2000h..3FFFh: with it the cam table and
    compensation tables 1-4, which share that area (spec §6.1) [Ch5 CLEAR_CUBIC_TABLE]."""
    fw.ram.clear_cubic()
    tables_changed(fw)
