"""Input/output and diagnostic RTCs [Ch5 "Input/Output", PARREAD; spec §4.3]."""

from __future__ import annotations

import struct
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.octavia import BANK2, Dpr

from vdevd.devices.octavia import cmd_interrupts
from vdevd.devices.octavia.state import CONTOURING, HALTING, Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

Groups = list[tuple[int, dict[str, Any]]]
PARREAD_CODES = range(0x10, 0x28)


def outp(on: bool, fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """OUTP_ON / OUTP_OFF: a 1 bit turns its output ON (driven low) / OFF (high), a 0 bit
    leaves it; outp1 bit i = OUTi, outp2 bit i = OUT(16+i) (the example's order, spec Q-11)."""
    bits = head["outp1"] | head["outp2"] << 16
    if on:
        fw.params.outputs_on |= bits
    else:
        fw.params.outputs_on &= ~bits


def inp_state(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Input polarity: bit 0 active low (the default), 1 active high; inp1 = IN0..15, inp2 =
    IN16..31 [Ch5 INP_STATE]. INPUT (094h) shows the levels after polarity from now on."""
    fw.params.inp_polarity = head["inp1"] | head["inp2"] << 16
    fw.refresh_inputs()


def posbrk_out(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Per axis, the outputs turned ON and OFF when its breakpoint fires; they stay in force
    [Ch5 POSBRK_OUT]."""
    p = fw.params
    for a, g in fw.axes_of(groups):
        p.posbrk_on_mask[a] = g["on1"] | g["on2"] << 16
        p.posbrk_off_mask[a] = g["off1"] | g["off2"] << 16


def parread(fw: Firmware, head: dict[str, Any], groups: Groups) -> None:
    """Write the parameters `m` names to 0B8h..0BFh (axes 1-4) and 8B8h..8BFh (axes 5-8) now,
    and echo m at 0B7h at the next 5 ms boundary ("may take more than 5 ms") [Ch5 PARREAD].
    A code outside 10h..27h is ignored: no data, no echo."""
    m = head["m"]
    if m not in PARREAD_CODES:
        return
    data = parread_data(fw, m)
    buf = fw.buf
    buf[Dpr.PARRDBK:Dpr.PARRDBK + 8] = data[:8]
    buf[Dpr.PARRDBK + BANK2:Dpr.PARRDBK + BANK2 + 8] = data[8:]
    fw.parread = m


def parread_data(fw: Firmware, m: int) -> bytes:
    """The 16 bytes of both banks for PARREAD m [Ch5 PARREAD; spec §4.3 table]."""
    p = fw.params

    def u16(values: np.ndarray) -> bytes:  # axes 1-4, then 5-8
        return struct.pack("<8H", *(int(v) & 0xFFFF for v in values[:8]))

    def u8(values: np.ndarray) -> bytes:
        return bytes(int(v) & 0xFF for v in values[:4]) + bytes(4) + bytes(
            int(v) & 0xFF for v in values[4:8]) + bytes(4)

    if 0x10 <= m <= 0x13:  # gains of axis m-10h+1 and of the bank-2 axis
        a = m - 0x10
        return b"".join(struct.pack("<4H", int(p.ki[x]), int(p.kp[x]), int(p.kf[x]), int(p.kd[x]))
                        for x in (a, a + 4))
    if m == 0x14:
        return u8(p.kilimit)
    if m == 0x15:
        return u8(p.outgain)
    if m == 0x16:
        return u16(p.maxacc)
    if m == 0x17:
        return cmd_interrupts.enabled_report(fw)
    if m == 0x18:
        modes = np.zeros(8, dtype=np.int64)
        modes[:fw.n] = fw.mode
        out = bytearray(16)
        for i, mode in enumerate((Mode.MOVE, Mode.STOP, Mode.VELMODE, Mode.CONTOUR)):
            on = (np.isin(modes, CONTOURING) if mode == Mode.CONTOUR  # ring and CUBIC_INT
                  else np.isin(modes, HALTING) if mode == Mode.STOP  # STOP, *ESTOP, EN_ERRHLT
                  else modes == mode)
            out[i] = sum(int(b) << k for k, b in enumerate(on[:4]))
            out[8 + i] = sum(int(b) << k for k, b in enumerate(on[4:]))
        return bytes(out)
    if m == 0x19:
        return u16(p.errhlt_thr)
    if m == 0x1A:
        return u16(p.err_thr)
    if m in (0x1B, 0x1C):  # breakpoints of axes 1,2 / 3,4 (bank 2: 5,6 / 7,8)
        a = 2 * (m - 0x1B)
        return b"".join(struct.pack("<2i", *(_i32(p.posbrk_at[x]) for x in (b, b + 1)))
                        for b in (a, a + 4))
    if m == 0x1D:
        rate = p.cubic_rate if p.cubic_mode else p.btrate
        return bytes((p.bufbrk & 0xFF, 0xFF if p.cubic_mode else 0)) + struct.pack(
            "<H", rate & 0xFFFF) + bytes(12)
    if m in (0x1E, 0x1F):  # POSBRK_OUT ON then OFF, OUT0..15 (spec Q-36)
        a = 2 * (m - 0x1E)
        return b"".join(struct.pack("<4H", int(p.posbrk_on_mask[x]) & 0xFFFF,
                                    int(p.posbrk_off_mask[x]) & 0xFFFF,
                                    int(p.posbrk_on_mask[x + 1]) & 0xFFFF,
                                    int(p.posbrk_off_mask[x + 1]) & 0xFFFF) for x in (a, a + 4))
    if m == 0x20:
        return u16(p.estop_acc)
    if m == 0x21:
        return bytes((0x11 if p.slave else 0x00,)) + bytes(15)
    if m == 0x22:
        return (p.outputs_on & 0xFFFFFFFF).to_bytes(4, "little") + bytes(12)
    if m == 0x23:
        return (p.inp_polarity & 0xFFFFFFFF).to_bytes(4, "little") + bytes(12)
    if m == 0x24:
        return u16(p.encflt_thr)
    if m == 0x26:
        return u16(p.ka)
    if m == 0x27:
        return u16(p.trq_limit)
    return bytes(16)  # 25h: "not used"


def _i32(value: float) -> int:
    return (int(value) + 2**31) % 2**32 - 2**31
