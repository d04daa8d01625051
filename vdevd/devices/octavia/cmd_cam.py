"""Cam RTCs [Ch5 "Coordinated Motion - Cam": CAM, CAM_POS, CAM_PROBE, CAM_OFF, CAM_OFF_ACC,
CAM_POINT, LOAD_CAM_TABLE; spec octavia.md §4.3, §5.6], and what the cam and gear families share:
the master byte, the conflict check, the probe codes.

The slaves are the groups of `m`; the follower runs in follow.py. The manual gives no error report
for a bad cam command: what the card cannot run (a table outside the 1600 points, no single
master, a slave that is its own master, an EXT code other than 01h/02h/04h/08h) is ignored and
logged (README "Cam and gearing"). A slave that contours (ring buffer or CUBIC_INT) makes the
command conflict: discarded whole with "conflicting commands" (000h b6, 007h), as the manual
rules for contouring against RTC motion [Ch7 Conflicting Commands].
"""

from __future__ import annotations

import logging
import struct
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import STAGING_BYTES, Dpr

from vdevd.devices.octavia.cam import EXT_CODES, place_cam_point, table_problem
from vdevd.devices.octavia.ram import CAM_POINTS
from vdevd.devices.octavia.state import CONTOURING, Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

Groups = list[tuple[int, dict[str, Any]]]
CAM_POINT_BYTES = 10  # master i32, slave i32, ratio i16 [Ch5 LOAD_CAM_TABLE]
MAX_CAM_LOAD = STAGING_BYTES // CAM_POINT_BYTES  # 67 points a download
#: modes a slave cannot have: contouring from the ring buffer or the internal table


def master_axis(fw: Firmware, mask: int, name: str) -> int | None:
    """The master (leader) of `n`: "the ONLY master axis" [Ch5 CAM, GEAR]; None (logged) unless
    exactly one axis the card has is named."""
    axes = fw.mask(mask)
    if bin(mask).count("1") != 1 or not axes:
        log.warning("octavia: %s master byte %02Xh does not name one axis of the card: ignored",
                    name, mask)
        return None
    return axes[0]


def probe_code(fw: Firmware, q: int, name: str) -> bool:
    """q is one of the EXT bit codes 01h/02h/04h/08h [Ch5 CAM_PROBE, GEAR_PROBE] (the GEAR_PROBE
    example's 20h is a manual error, spec Q-30): else the command is ignored (logged)."""
    if q in EXT_CODES:
        return True
    log.warning("octavia: %s q=%02Xh is not an *EXT code (01h, 02h, 04h, 08h): ignored", name, q)
    return False


def _engage(fw: Firmware, head: dict[str, Any], groups: Groups, name: str, how: str) -> None:
    master = master_axis(fw, head["n"], name)
    slaves = fw.axes_of(groups)
    if master is None or not slaves:
        return
    if fw.discarded([a for a, _ in slaves], CONTOURING, halting=False):
        return
    if how == "probe":
        if not probe_code(fw, head["q"], name):
            return
        fw.params.probe_input = 0  # "will disable any previously enabled EN_PROBE interrupt"
    ram_master, ram_slave, _ = fw.ram.cam_points(0, CAM_POINTS)
    for a, g in slaves:
        start, size = int(g["tablestart"]), int(g["tablesize"])
        arg = int(g["masterpos"]) if how == "at" else int(head.get("q", 0))
        try:
            fw.follow.cam_engage(a, master, start, size, how, arg)
        except ValueError as exc:
            log.warning("octavia: %s, slave axis %d: %s: ignored", name, a + 1, exc)
            continue
        problem = table_problem(ram_master[start:start + size], ram_slave[start:start + size])
        if problem:
            log.warning("octavia: %s, slave axis %d: the cam table at %d (%d points): %s",
                        name, a + 1, start, size, problem)


def cam(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Engage the slaves of `m` on master `n` at once, each on its table (start, size) of the
    1600 cam points [Ch5 CAM]."""
    _engage(fw, head, groups, "CAM", "now")


def cam_pos(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """As CAM, each slave engaging when the master reaches its masterpos [Ch5 CAM_POS]."""
    _engage(fw, head, groups, "CAM_POS", "at")


def cam_probe(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """As CAM, engaging at the next active edge of *EXTq; disables EN_PROBE, and that edge
    raises no interrupt [Ch5 CAM_PROBE Note]."""
    _engage(fw, head, groups, "CAM_PROBE", "probe")


def cam_off(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Disengage the cam slaves of `n` at once: they hold where they are [Ch5 CAM_OFF]."""
    fw.follow.disengage(fw.mask(head["n"]), Mode.CAM, acc=False)


def cam_off_acc(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Disengage the cam slaves of `n`, which come to a stop at MAXACC [Ch5 CAM_OFF_ACC]."""
    fw.follow.disengage(fw.mask(head["n"]), Mode.CAM, acc=True)


def cam_point(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Store one (master, slave) point at `index` of the table (start, size) and compute the
    ratios it changes; "on the fly" too [Ch5 CAM_POINT]."""
    try:
        fits = place_cam_point(fw.ram, head["tablestart"], head["tablesize"], head["index"],
                               head["masterpos"], head["slavepos"])
    except ValueError as exc:
        log.warning("octavia: CAM_POINT: %s: ignored", exc)
        return
    if not fits:
        log.warning("octavia: CAM_POINT %d of the table at %d: a ratio outside -256..255.99 or "
                    "under 1/128 (stored saturated)", head["index"], head["tablestart"])
    tables_changed(fw)


def load_cam_table(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Copy `numpts` 10-byte points (master i32, slave i32, ratio i16 x128) from 120h to the cam
    table from `index` on [Ch5 LOAD_CAM_TABLE]; 1..67 points within the 1600 (spec Q-37),
    else ignored (logged). The data is taken before 3C2h is cleared."""
    index, num = int(head["index"]), int(head["numpts"])
    if not 1 <= num <= MAX_CAM_LOAD or index + num > CAM_POINTS:
        log.warning("octavia: LOAD_CAM_TABLE of %d points at %d (1..%d within %d): ignored",
                    num, index, MAX_CAM_LOAD, CAM_POINTS)
        return
    staging_warning(fw, "LOAD_CAM_TABLE")
    raw = bytes(fw.buf[Dpr.RINGBUF:Dpr.RINGBUF + num * CAM_POINT_BYTES])
    points = np.array(list(struct.iter_unpack("<iih", raw)), dtype=np.int64)
    fw.ram.store_cam_points(index, points[:, 0], points[:, 1], points[:, 2])
    tables_changed(fw)


def staging_warning(fw: Firmware, name: str) -> None:
    """LOAD_* "cannot be used in conjunction with ring buffer-based contouring" [Ch5
    LOAD_CAM_TABLE]: run anyway, logged (spec Q-37)."""
    if (fw.mode == Mode.CONTOUR).any():
        log.warning("octavia: %s while the ring buffer contours: the staging area is the ring",
                    name)


def tables_changed(fw: Firmware) -> None:
    """The board RAM changed: the cam followers re-read their points (the tables alias, Ch8),
    and the battery-backed image is due to be saved."""
    fw.follow.cam.refresh()
    fw.nv_dirty = True
