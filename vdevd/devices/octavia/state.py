"""The Octavia firmware's parameters and modes: everything RTCs set, in the manual's raw units,
one slot per DPR axis (8, whatever the card's axis count) [Ch5; spec octavia.md §1.5, §4.3].

`Params.reset()` is the power-up/RESET state of spec §1.5: "Reset clears all card parameters"
[Ch7 Power-Up/Reset State]; what it does not clear (tables, DSPL program, autostart) lives
elsewhere (ram.py, the DSPL surface).
"""

from __future__ import annotations

import enum

import numpy as np
from vdevmaps.octavia import MAX_AXES

N = MAX_AXES


class Mode(enum.IntEnum):
    """What an axis runs (PARREAD 18h reports MOVE, STOP, VELMODE and CONTOUR, spec §4.3)."""

    HOLD = 0  # closed-loop hold at the command position
    MOVE = 1  # AXMOVE family (absolute, relative, S-curve, timed)
    STOP = 2  # halting under STOP or STOP_DSPL at MAXACC
    VELMODE = 3
    CONTOUR = 4  # ring-buffer contouring (2nd order or cubic)
    OPEN = 5  # DDAC open loop, or an encoder fault's 0 V
    CAM = 6
    GEAR = 7
    CUBIC = 8  # CUBIC_INT from the internal table
    ESTOP = 9  # halting under *ESTOP or EN_ERRHLT at ESTOP_ACC


#: the modes START, AXMOVE, REL_AXMOVE and VELMODE conflict with (Ch7 "Conflicting Commands")
MOTION_MODES = (int(Mode.MOVE), int(Mode.VELMODE))
HALTING = (int(Mode.STOP), int(Mode.ESTOP))  # plain ints: `in` and np.isin, fast
#: the contouring modes: the ring buffer (START) and the internal table (CUBIC_INT)
CONTOURING = (int(Mode.CONTOUR), int(Mode.CUBIC))


class Params:
    """The parameters RTCs set (raw manual units), per axis and global."""

    def __init__(self) -> None:
        z = np.zeros
        # control law [Ch5 CTRL, CTRL_KA, KILIMIT, OUTGAIN, TRQ_LIMIT, OFFSET]
        self.ki, self.kp, self.kf, self.kd, self.ka = (z(N) for _ in range(5))
        self.kilimit = z(N, dtype=np.int64)
        self.outgain = z(N, dtype=np.int64)
        self.trq_limit = z(N)
        self.offset_v = z(N)
        self.maxacc = z(N)  # raw 1.15 [Ch5 MAXACC]
        self.estop_acc = z(N)  # raw 1.15 [Ch5 ESTOP_ACC]
        # interrupts [Ch5 EN_*; spec §3.2]
        self.err_thr = z(N)  # EN_ERR setpoints
        self.errhlt_thr = z(N)
        self.encflt_thr = z(N)
        self.err_on = z(N, dtype=bool)
        self.errhlt_on = z(N, dtype=bool)
        self.encflt_on = z(N, dtype=bool)
        self.encflt_mode = 0
        self.err_over = z(N, dtype=bool)  # |FE| > threshold at the last check (edges)
        self.errhlt_over = z(N, dtype=bool)
        self.motcp_on = z(N, dtype=bool)
        self.posbrk_on = z(N, dtype=bool)
        self.posbrk_at = z(N)  # the breakpoint position
        self.posbrk_from = z(N)  # where the axis was when it was enabled
        self.posbrk_on_mask = z(N, dtype=np.int64)  # POSBRK_OUT masks (OUT0..31)
        self.posbrk_off_mask = z(N, dtype=np.int64)
        self.index_axis = -1  # EN_INDEX (one axis at a time)
        self.probe_input = 0  # EN_PROBE's EXT bit code (one input at a time)
        self.bufbrk_on = False
        self.bufbrk = 0
        self.int5ms = False
        # contouring [Ch5 BTRATE, CUBIC_RATE, CUBIC_SCALE]
        self.btrate = 0
        self.cubic_rate = 25
        self.cubic_mode = False  # the last rate command was CUBIC_RATE (spec §4.4)
        self.cubic_mult = np.full(N, 0x4000)
        self.cubic_shift = z(N)
        # I/O [Ch5 INP_STATE, OUTP_ON/OFF]
        self.inp_polarity = 0  # bit set: active high
        self.outputs_on = 0  # bit set: output ON (driven low)
        # misc [Ch5 SYNC, OVERRIDE, STEPPER_ON, TABLE_SEL]
        self.slave = False
        self.override = 0x10000
        self.stepper_on = 0
        self.table_sel = np.ones(N, dtype=np.int64)
        self.reset()

    def reset(self) -> None:
        """The power-up/RESET defaults (spec §1.5)."""
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value[...] = 0
        self.trq_limit[:] = 0x7FFF
        self.cubic_mult[:] = 0x4000
        self.table_sel[:] = 1
        self.encflt_mode = 0
        self.index_axis, self.probe_input = -1, 0
        self.bufbrk_on, self.bufbrk, self.int5ms = False, 0, False
        self.btrate, self.cubic_rate, self.cubic_mode = 0, 25, False
        self.inp_polarity = self.outputs_on = 0
        self.slave, self.override, self.stepper_on = False, 0x10000, 0


def mask_axes(mask: int, n: int) -> list[int]:
    """The 0-based axes of an axis mask (bit 0 = axis 1) that the card has."""
    return [a for a in range(n) if mask >> a & 1]


def axes_bits(axes: np.ndarray) -> int:
    """An axis mask of a bool array (bit k = axis k+1)."""
    return int(np.dot(axes.astype(np.int64), 1 << np.arange(len(axes), dtype=np.int64)))
