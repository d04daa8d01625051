"""Electronic gearing RTCs [Ch5 "Coordinated Motion - Gearing": GEAR, GEAR_POS, GEAR_PROBE,
GEAR_OFF, GEAR_OFF_ACC, REL_AXMOVE_SLAVE; spec octavia.md §4.3, §5.7].

The followers are the groups of `m`, each with its ratio r: 1 sign, 8 integer, 7 fraction bits
per the text (x128), or x4096 as the manual's examples have it (2000h = 2.0), by the card option
`gear_ratio_bits` (spec Q-5). Errors are ignored and logged as in cmd_cam.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from vdevmaps.octavia import DspStat1, acc_from_raw, vel_from_raw

from vdevd.devices.octavia.cmd_cam import master_axis, probe_code
from vdevd.devices.octavia.state import CONTOURING, Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

Groups = list[tuple[int, dict[str, Any]]]


def _engage(fw: Firmware, head: dict[str, Any], groups: Groups, name: str, how: str) -> None:
    leader = master_axis(fw, head["n"], name)
    followers = fw.axes_of(groups)
    if leader is None or not followers:
        return
    if fw.discarded([a for a, _ in followers], CONTOURING, halting=False):
        return
    if how == "probe":
        if not probe_code(fw, head["q"], name):
            return
        fw.params.probe_input = 0  # "will disable any previously enabled EN_PROBE interrupt"
    for a, g in followers:
        arg = int(g["tp"]) if how == "at" else int(head.get("q", 0))
        try:
            fw.follow.gear_engage(a, leader, int(g["r"]), how, arg)
        except ValueError as exc:
            log.warning("octavia: %s, follower axis %d: %s: ignored", name, a + 1, exc)


def gear(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The followers of `m` follow leader `n` at their ratios, engaged at once [Ch5 GEAR]."""
    _engage(fw, head, groups, "GEAR", "now")


def gear_pos(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """As GEAR, each follower engaging when the leader reaches its tp [Ch5 GEAR_POS]."""
    _engage(fw, head, groups, "GEAR_POS", "at")


def gear_probe(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """As GEAR, engaging at the next active edge of *EXTq; disables EN_PROBE, and that edge
    raises no interrupt [Ch5 GEAR_PROBE Note 1]."""
    _engage(fw, head, groups, "GEAR_PROBE", "probe")


def gear_off(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Disengage the followers of `n` at once [Ch5 GEAR_OFF]."""
    fw.follow.disengage(fw.mask(head["n"]), Mode.GEAR, acc=False)


def gear_off_acc(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Disengage the followers of `n`, which come to a stop at MAXACC [Ch5 GEAR_OFF_ACC]."""
    fw.follow.disengage(fw.mask(head["n"]), Mode.GEAR, acc=True)


def rel_axmove_slave(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """A relative trapezoid (acc 1.15, rel_pos counts, slew |rel_vel| 16.16) superimposed on
    each engaged cam or gear slave of `n`, one group per axis (spec Q-22a) [Ch5
    REL_AXMOVE_SLAVE]; motion complete at its end. Like AXMOVE, refused with "RTC ignored"
    while *ESTOP is active; an axis that is not an engaged slave, or zero acc or slew, is
    left alone (logged)."""
    todo = fw.axes_of(groups)
    halting = fw.halting([a for a, _ in todo])
    if halting:
        fw.post_stat1(DspStat1.IGNORED, sum(1 << a for a in halting))
        return
    for a, g in todo:
        acc, vel = acc_from_raw(g["acc"]), abs(vel_from_raw(g["rel_vel"]))
        if acc <= 0 or vel <= 0:
            continue
        if not fw.follow.superimpose(a, acc, int(g["rel_pos"]), vel):
            log.warning("octavia: REL_AXMOVE_SLAVE: axis %d is not an engaged slave: ignored",
                        a + 1)
