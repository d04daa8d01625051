"""Interrupt-control RTCs [Ch5 "Interrupt Control"; spec §3.2, §3.3]: what each enables, and the
two disable masks. The conditions are checked by the firmware every sample."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import DisableBit

from vdevd.devices.octavia.state import Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

Groups = list[tuple[int, dict[str, Any]]]
#: EN_PROBE's input codes: bit codes 01h/02h/04h/08h, and 03h taken as EXT3 (spec Q-8)
PROBE_CODES = {0x01: 1, 0x02: 2, 0x04: 3, 0x08: 4, 0x03: 3}


def en_bufbrk(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Interrupt (1FFEh b0) when fewer ring slots than `buffbrk` are occupied [Ch5 EN_BUFBRK];
    stays enabled."""
    fw.params.bufbrk, fw.params.bufbrk_on = int(head["buffbrk"]), True


def en_encflt(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Encoder fault per axis: mode m bit 0: |FE| over fer and the encoder's hardware status
    bit; bit 1: |FE| over fer alone [Ch5 EN_ENCFLT; spec Q-10]. Issuing it again re-closes the
    loop of an axis a fault opened."""
    p = fw.params
    p.encflt_mode = int(head["m"])
    for a, g in fw.axes_of(groups):
        p.encflt_thr[a], p.encflt_on[a] = g["fer"], True
        if fw.mode[a] == Mode.OPEN and fw.open_dac[a] == 0 and fw.fault_open[a]:
            fw.core.servo_on(a)
            fw.mode[a], fw.fault_open[a] = Mode.HOLD, False
    fw.any_open = bool((fw.mode == Mode.OPEN).any())


def en_err(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Following-error interrupt over fer counts [Ch5 EN_ERR]: not disabled when it fires (it
    fires again after the error came back under the setpoint, spec Q-7)."""
    p = fw.params
    for a, g in fw.axes_of(groups):
        p.err_thr[a], p.err_on[a], p.err_over[a] = g["fer"], True, False


def en_errhlt(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Following-error interrupt and halt at ESTOP_ACC [Ch5 EN_ERRHLT]; "ignored if the
    respective axis abort maximum acceleration is zero" (Note 1)."""
    p = fw.params
    for a, g in fw.axes_of(groups):
        if p.estop_acc[a]:
            p.errhlt_thr[a], p.errhlt_on[a], p.errhlt_over[a] = g["fer"], True, False


def en_index(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Search the first index edge of one axis; there the actual positions of all axes are
    latched to INDPOS [Ch5 EN_INDEX]. One axis at a time: a new EN_INDEX replaces the last;
    one-shot (spec Q-7). A mask of several axes takes the lowest."""
    axes = fw.mask(head["n"])
    if axes:
        fw.params.index_axis = axes[0]
        fw.arm_index()


def en_motcp(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Motion-complete interrupt on the axes of n, at every completion [Ch5 EN_MOTCP]."""
    for a in fw.mask(head["n"]):
        fw.params.motcp_on[a] = True


def en_posbrk(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Position breakpoint per axis: fires once the axis has travelled |pos - start| either way,
    then disables itself [Ch5 EN_POSBRK, Note 2]."""
    p = fw.params
    enc = fw.core.axes.encoder
    for a, g in fw.axes_of(groups):
        p.posbrk_at[a], p.posbrk_from[a], p.posbrk_on[a] = g["pos"], float(enc[a]), True


def en_probe(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Interrupt on the first active edge of one *EXTx input, latching all axes' positions to
    PRB [Ch5 EN_PROBE]; one input at a time, one-shot (spec Q-7). Another code: ignored."""
    if head["m"] in PROBE_CODES:
        fw.params.probe_input = PROBE_CODES[head["m"]]


def disabl_int(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """One mask byte per axis of n; a set bit disables that interrupt of that axis; buffer
    breakpoint and probe are global: their bit in any byte disables them [Ch5 DISABL_INT;
    spec §3.3]."""
    p = fw.params
    for a, g in fw.axes_of(groups):
        bits = DisableBit(g["mask"] & 0x7F)
        if bits & DisableBit.MOTCP:
            p.motcp_on[a] = False
        if bits & DisableBit.INDEX and p.index_axis == a:
            p.index_axis = -1
        if bits & DisableBit.POSBRK:
            p.posbrk_on[a] = False
        if bits & DisableBit.ERR:
            p.err_on[a] = False
        if bits & DisableBit.ERR_HALT:
            p.errhlt_on[a] = False
        if bits & DisableBit.PROBE:
            p.probe_input = 0
        if bits & DisableBit.BUFBRK:
            p.bufbrk_on = False


def disabl2_int(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """b0 of each axis's byte disables its encoder-fault interrupt [Ch5 DISABL2_INT]."""
    for a, g in fw.axes_of(groups):
        if g["mask"] & 1:
            fw.params.encflt_on[a] = False


def int5ms(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """The 5 ms interrupt (DSPSTAT2 b6), on for m != 0 [Ch5 INT5MS] (only in the `int5ms`
    firmware: the table has no 8Eh otherwise)."""
    fw.params.int5ms = head["m"] != 0


def enabled_report(fw: Firmware) -> bytes:
    """PARREAD 17h: 0B8h b0 buffer breakpoint; 0B9h FE-halt (low nibble) and FE (high) axes;
    0BAh index (low) and breakpoint (high); 0BBh motion complete (low) and probe (high) [Ch5
    PARREAD]; bank 2 the same for axes 5-8."""
    p = fw.params
    index = np.zeros(8, dtype=bool)
    if p.index_axis >= 0:
        index[p.index_axis] = True
    probe = np.zeros(8, dtype=bool)
    if p.probe_input:
        probe[:] = True  # the probe is global: reported on every axis's nibble

    def nib(bits: np.ndarray, bank: int) -> int:
        return int(sum(int(b) << i for i, b in enumerate(bits[4 * bank:4 * bank + 4])))

    out = bytearray()
    for bank in (0, 1):
        out += bytes((int(p.bufbrk_on),
                      nib(p.errhlt_on, bank) | nib(p.err_on, bank) << 4,
                      nib(index, bank) | nib(p.posbrk_on, bank) << 4,
                      nib(p.motcp_on, bank) | nib(probe, bank) << 4, 0, 0, 0, 0))
    return bytes(out)
