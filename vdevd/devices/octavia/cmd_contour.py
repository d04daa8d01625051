"""Contouring set-up RTCs [Ch5 "Contouring": BTRATE, CUBIC_RATE, START, VECCHG, CUBIC_SCALE,
CUBIC_INT; spec octavia.md §4.3 "Contouring set-up RTCs", §4.4]. The interpolation runs in
contour.py (the ring buffer) and cubic_int.py (the internal table).

The last of BTRATE and CUBIC_RATE selects the ring's mode (2nd order or cubic) for the next
START (spec §4.4). START and CUBIC_INT are refused like the simple-motion commands (cmd_motion):
"RTC ignored" for an axis halting under STOP or *ESTOP, "conflicting commands" for an axis in
AXMOVE or VELMODE motion, or contouring the other way [Ch7 Table 7-1].
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from vdevmaps.octavia import RING_SLOTS

from vdevd.devices.octavia.contour import BUSY_MODES
from vdevd.devices.octavia.state import Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)
Groups = list[tuple[int, dict[str, Any]]]
CUBIC_RATES = range(5, 512)  # 1.0 .. 102.2 ms [Ch5 CUBIC_RATE]


def btrate(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """2nd-order block transfer rate m = 0..3: 5, 10, 15, 20 ms per ring point [Ch5 BTRATE];
    another m is ignored. Selects 2nd-order ring contouring."""
    if 0 <= head["m"] <= 3:
        fw.params.btrate, fw.params.cubic_mode = int(head["m"]), False
    else:
        log.warning("octavia: BTRATE m=%d is not 0..3: ignored", head["m"])


def cubic_rate(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Cubic-spline point interval m x 200 us, m = 5..511 [Ch5 CUBIC_RATE]; another m is
    ignored. Selects cubic ring contouring, and sets CUBIC_INT's interval."""
    if head["m"] in CUBIC_RATES:
        fw.params.cubic_rate, fw.params.cubic_mode = int(head["m"]), True
    else:
        log.warning("octavia: CUBIC_RATE m=%d is not 5..511: ignored", head["m"])


def start(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Start ring-buffer contouring on the axes of n together [Ch5 START]; ignored while
    contouring is in progress (Note): the ring's. A START naming an axis that runs CUBIC_INT
    is a conflict (README "Ring buffer"), one naming other axes runs beside it."""
    if fw.contour.running:
        return
    axes = fw.mask(head["n"])
    if axes and not fw.discarded(axes, BUSY_MODES):
        fw.contour.start(axes)


def vecchg(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """From ring slot m on, the contouring axes are those of n [Ch5 VECCHG]; up to three wait
    (a fourth: 1FFEh b3). A slot past the ring, or no axis of the card, is ignored."""
    axes = fw.mask(head["n"])
    if axes and head["m"] < RING_SLOTS:
        fw.contour.queue_vecchg(int(head["m"]), axes)
    else:
        log.warning("octavia: VECCHG n=%02Xh m=%d: no axis or no slot: ignored", head["n"], head["m"])


def cubic_scale(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Per axis, the s1.14 multiplier and the int32 shift applied to the table's positions
    when CUBIC_INT runs [Ch5 CUBIC_SCALE]."""
    p = fw.params
    for a, g in fw.axes_of(groups):
        p.cubic_mult[a], p.cubic_shift[a] = g["pos_mult"], g["pos_shift"]


def cubic_int(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Run m table entries from si, n times (0: for ever), on the axes of ax [Ch5 CUBIC_INT].
    One run at a time: another while one runs is ignored, as is one the table cannot give."""
    axes = fw.mask(head["ax"])
    if not axes:
        return
    if fw.cubic.running:
        log.warning("octavia: CUBIC_INT while one runs: ignored")
        return
    if fw.discarded(axes, (int(Mode.MOVE), int(Mode.VELMODE), int(Mode.CONTOUR))):
        return
    try:
        fw.cubic.start(axes, int(head["m"]), int(head["si"]), int(head["n"]))
    except ValueError as exc:
        log.warning("octavia: %s: ignored", exc)
