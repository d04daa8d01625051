"""DSPL RTCs [Ch5 "DSPL High-Level Language Variable Related" and "Flagging": CHANGE_VAR,
MONITOR_VAR, START_DSPL, STOP_DSPL, SIGNAL_DSPL, CLEAR_DSPL, DSPL_AUTOSTART; spec octavia.md §7]
on the surface dspl.py keeps. There is no DSPL interpreter: a program is "loaded" only through
the card's backdoor (`dspl_load`), as no download path is documented.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import AUTOSTART_ENABLE, Dpr, DsplErr, DspStat2

from vdevd.devices.octavia import cmd_motion
from vdevd.devices.octavia.dspl import SLOTS, STATUS_WORDS, VAR_BYTES, VARIABLES
from vdevd.devices.octavia.ram import RAM_WORDS, TABLE_BASE

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

Groups = list[tuple[int, dict[str, Any]]]
MAX_CHANGES = 8  # CHANGE_VAR m: 1..8 (8 pairs fill the 57-byte window) [Ch5 CHANGE_VAR]
#: DSPL program storage: not given by Ch8; assumed outside the tables' 2000h..5FFFh (spec §6)
PROGRAM_AREAS = ((0, TABLE_BASE), (0x6000, RAM_WORDS))


def change_var(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Set `m` (1..8) variables, each (var 1..128, 6 raw bytes) [Ch5 CHANGE_VAR]; another m
    is ignored (logged), as is a pair naming no variable."""
    m = int(head["m"])
    if not 1 <= m <= MAX_CHANGES:
        log.warning("octavia: CHANGE_VAR m=%d is not 1..%d: ignored", m, MAX_CHANGES)
        return
    for _, g in groups:
        var = int(g["var"])
        if 1 <= var <= VARIABLES:
            fw.dspl.change(var, g["value"])
            fw.nv_dirty = True
        else:
            log.warning("octavia: CHANGE_VAR VAR%d is not VAR1..VAR%d: ignored", var, VARIABLES)


def monitor_var(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Map a variable to each monitor slot whose bit (0..3) is set in `m`, one varnum byte per
    set bit (spec Q-23); the slots show them from the next 5 ms on [Ch5 MONITOR_VAR]. A varnum
    outside 1..128 leaves the slot showing what it shows (logged); bits 4..7 are unused (their
    bytes are read, spec §1.1)."""
    for bit, g in groups:
        slot, var = bit - 1, int(g["var"])
        if slot >= SLOTS:
            continue
        if 1 <= var <= VARIABLES:
            fw.dspl.watch(slot, var)
        else:
            log.warning("octavia: MONITOR_VAR slot %d: VAR%d is not VAR1..VAR%d", bit, var,
                        VARIABLES)
            fw.dspl.watch(slot, 0)


def start_dspl(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Start the loaded DSPL program [Ch5 START_DSPL]; with none loaded, nothing (spec §7)."""
    if fw.dspl.loaded:
        fw.dspl.running = True


def stop_dspl(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """End the DSPL program, and halt the motion of all axes at MAXACC [Ch5 STOP_DSPL]: as STOP
    does, an axis whose MAXACC is 0 is left alone; engaged cam and gear slaves follow their
    halting masters, engaged, as under *ESTOP (README "DSPL")."""
    dspl = fw.dspl
    dspl.running = False
    dspl.status[:] = 0
    dspl.stale = True
    axes = fw.follow.unfollowed(np.arange(fw.n))
    axes = axes[fw.params.maxacc[axes] > 0]
    if len(axes):
        cmd_motion.halt(fw, axes, estop=False)


def signal_dspl(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Release a DSPL WAIT_UNTIL_RTC [Ch5 SIGNAL_DSPL]: counted (no interpreter waits)."""
    fw.dspl.signals += 1


def clear_dspl(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Clear the DSPL program storage [Ch5 CLEAR_DSPL]: the program ends and is gone."""
    dspl = fw.dspl
    dspl.loaded = dspl.running = False
    dspl.status[:] = 0
    dspl.stale = True
    for lo, hi in PROGRAM_AREAS:
        fw.ram.words[lo:hi] = 0
    fw.nv_dirty = True


def dspl_autostart(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """x = 55h enables, any other value disables, starting the loaded program at power-up;
    non-volatile [Ch5 DSPL_AUTOSTART]."""
    fw.dspl.autostart = head["x"] == AUTOSTART_ENABLE
    fw.nv_dirty = True


# -- what a DSPL program would do, for the card's backdoor (README "Backdoor") ---------------------
def report(fw: Firmware) -> dict[str, Any]:
    """The DSPL state the DPR does not show."""
    d = fw.dspl
    return {"autostart": bool(d.autostart), "loaded": bool(d.loaded), "running": bool(d.running),
            "signals": int(d.signals), "monitor": [int(v) for v in d.monitor],
            "status": {k: int(v) for k, v in zip(STATUS_WORDS, d.status, strict=True)},
            "table_sel": [int(t) for t in fw.params.table_sel[:fw.n]]}


def load(fw: Firmware, loaded: bool) -> None:
    """A DSPL program is (or no longer is) in the battery-backed RAM: the download the manual
    does not document. Unloading ends a running program."""
    fw.dspl.loaded = loaded
    fw.dspl.running = fw.dspl.running and loaded
    fw.nv_dirty = True


def host_interrupt(fw: Firmware, value: int) -> None:
    """INT_HOST of a DSPL program: DSPSTAT2 b4, `value` OR-ed into 00Eh, 1FFEh b6 [Table 6-2]."""
    if not 0 <= value <= 0xFF:
        raise ValueError(f"value {value} is not a byte")
    fw.post_stat2(DspStat2.DSPL_INT, int(Dpr.INTAXIS_DSPL), value)


def program_error(fw: Firmware, too_many: bool, not_found: bool) -> None:
    """A DSPL program running error: DSPSTAT2 b5, 00Fh b0 (more than 3 programs at once) and/or
    b1 (cannot find the program to stop), 1FFEh b6 [Table 6-2]."""
    bits = (DsplErr.TOO_MANY if too_many else 0) | (DsplErr.NOT_FOUND if not_found else 0)
    if not bits:
        raise ValueError("name an error: too_many or not_found")
    fw.post_stat2(DspStat2.DSPL_ERR, int(Dpr.DSPLERR), int(bits))


def set_status(fw: Firmware, lines: dict[str, int | None]) -> None:
    """The line numbers the status words show (PRG1STAT 07Eh, PRG2STAT 080h, PLCSTAT 084h)."""
    for key, line in lines.items():
        if line is None:
            continue
        if not 0 <= line <= 0xFFFF:
            raise ValueError(f"{key} line {line} is not 0..65535")
        fw.dspl.status[STATUS_WORDS.index(key)] = line
    fw.dspl.stale = True


def variable(fw: Firmware, var: int, value: int | None) -> int:
    """VAR`var`'s 6 bytes as an unsigned little-endian integer, set first to `value` if given
    (a DSPL program's assignment)."""
    if not 1 <= var <= VARIABLES:
        raise ValueError(f"VAR{var} is not VAR1..VAR{VARIABLES}")
    if value is not None:
        if not 0 <= value < 1 << (8 * VAR_BYTES):
            raise ValueError(f"value {value} is not 48 bits")
        fw.dspl.change(var, value.to_bytes(VAR_BYTES, "little"))
        fw.nv_dirty = True
    return int.from_bytes(fw.dspl.vars[var - 1].tobytes(), "little")
