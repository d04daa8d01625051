"""The motion-program fields of the DPRAM background buffer's C.S. records [PComm32 dprbkg.h
`backcTURBO`, `bkfdptrTURBO`; README "Reporting buffers"]: the feed rate (F) or move time (TM)
as a 48-bit float, the time-base pointer word with its slewing and feed-hold bits, the nine axis
positions as 48-bit floats (A B C U V W X Y Z, what L:$002041-$002049 give), the program lines
remaining (PR), the move time and TA/TS time left (ms, as MOVETIME) and the executing line (the
offset PE reports). A 48-bit float is two 24-bit words, the low (Y) word first [UM p.402]."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.pmac import (
    BG_CS_SIZE,
    CS_AXES,
    CS_FDPTR,
    CS_FEED,
    CS_PE,
    CS_PR,
    CS_TATS,
    CS_TIMREM,
    FDPTR_HOLD,
    FDPTR_SLEW,
)

from vdevd.devices.pmac import prog_reports
from vdevd.devices.pmac.coord import AXES
from vdevd.devices.pmac.numbers import pmac_float_words

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

_WORDS = BG_CS_SIZE // 4


def _float48(v: float) -> tuple[int, int]:
    """(low, high) 24-bit words of the 48-bit PMAC float of v (Y first, as the buffer has it)."""
    x, y = pmac_float_words(v)
    return y, x


def program_words(fw: Firmware, n: int) -> np.ndarray:
    """The program fields of the first `n` C.S. records, as 24-bit words (the other words 0)."""
    out = np.zeros((n, _WORDS), dtype=np.int64)
    commanded = fw.reports.commanded()
    iv = fw.ivars.values
    for s in range(1, n + 1):
        row = out[s - 1]
        r = fw.motion.runner(s)
        row[CS_FEED:CS_FEED + 2] = _float48(r.tm if r.tm_mode else r.f)
        pointer = int(iv[5000 + 100 * s + 93]) & 0x7FFFF
        if fw.timebase.present(s - 1) != fw.feed[s - 1] or r.hold != r.hold_target:
            pointer |= FDPTR_SLEW
        if r.running and r.hold_target == 0.0:
            pointer |= FDPTR_HOLD
        row[CS_FDPTR] = pointer
        for k, axis in enumerate(AXES):
            value = fw.coord.axis_position(s, axis, commanded)
            row[CS_AXES + 2 * k:CS_AXES + 2 * k + 2] = _float48(value)
        row[CS_PR] = prog_reports.lines_remaining(r)
        row[CS_TIMREM] = round(r.move_time_left())
        row[CS_TATS] = round(prog_reports.tats_time_left(r))
        row[CS_PE] = prog_reports.line_at(fw.motion.store, *r.exec_at)
    return out
