"""The NURBS RTCs [Ch9; spec §5.10, Q-27]: codes and layouts are vdevd's (vdevmaps.octavia
NURBS_RTCS, the card README); the curve runs from the DPR rings (nurbs.py) on axes 1, 2, 3,
one sample at a time (`Firmware.nurbs_sample`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from vdevmaps.octavia import DspStat1

from vdevd.devices.octavia.nurbs import NurbsResult, NurbsState
from vdevd.devices.octavia.state import Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

Groups = list[tuple[int, dict[str, Any]]]
AXES = (0, 1, 2)  # X, Y, Z drive axes 1, 2, 3 (an assumption: Ch9 names no axes)


def nurbs(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Start the curve from the rings as the host filled them: FeedRate (counts/sample),
    NURBSRate (ms), FirstKnot, LastKnot, NumCtrlPts [Ch9]. As START: axes in AXMOVE or VELMODE
    motion conflict, halting axes ignore it; bad arguments or ring data: ignored (logged)."""
    axes = [a for a in AXES if a < fw.n]
    if fw.halting(axes):
        fw.post_stat1(DspStat1.IGNORED, sum(1 << a for a in fw.halting(axes)))
        return
    modes = fw.mode.tolist()
    busy = [a for a in axes if modes[a] in (Mode.MOVE, Mode.VELMODE, Mode.CONTOUR)]
    if busy:
        fw.post_stat1(DspStat1.CONFLICT, sum(1 << a for a in busy))
        return
    result = fw.nurbs.start(fw.nurbs_rings, head["feed"], head["rate"], head["first"],
                            head["last"], head["npts"])
    if result is not NurbsResult.OK:
        fw.refuse("NURBS", ValueError(result.value))
        return
    for a in axes:
        fw.mode[a] = Mode.CONTOUR
    fw.nurbs_axes = axes
    fw.nurbs_pending = fw.nurbs_count()


def nurbs_bufbrk(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The NURBS buffer-breakpoint interrupt (1FFEh b7) when fewer knots than `threshold` are
    pending [Ch9]; 0 disarms it."""
    fw.nurbs_threshold = int(head["threshold"])


def nurbs_feedrate(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """A new FeedRate on the fly, from the next curve point [Ch9]."""
    if fw.nurbs.set_feed(head["feed"]) is not NurbsResult.OK:
        fw.refuse("NURBS_FEEDRATE", ValueError("bad feed rate"))


def running(fw: Firmware) -> bool:
    return fw.nurbs.state in (NurbsState.RUNNING, NurbsState.STARVED)
