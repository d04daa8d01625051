"""Ring-buffer contouring: the 84-slot ring at 120h read at every interval, 2nd-order (BTRATE) or
cubic (CUBIC_RATE) interpolation down to the 200 us sample [Ch4 Contouring, Ch5 START, VECCHG,
EN_BUFBRK, Ch6 Contouring, Ch7 Data Run-Out; spec octavia.md §2.5.4, §4.4, §5.4].

`Segments` is the interpolator both contouring modes share (the internal table's CUBIC_INT too,
cubic_int.py): per axis the end state of the interval under way, and the interval's commanded
positions (one row per sample, counts) computed once when the interval is fetched. A sample
then costs one row handed to the motion core (`MotionCore.track`), for all the axes at once.

`RingContour` fetches the intervals from the ring: at each interval's start one 8-byte slot
{pos i32, vel i32 16.16} per contouring axis, in increasing axis order, at OUTPTR (3C1h), which it
advances; each slot is the state to reach at the END of the interval. NOTES-contour.md lists
the assumptions.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.octavia import RING_SLOTS, Dpr, DspStat1, HostInt

from vdevd.devices.octavia.spline import hermite, second_order
from vdevd.devices.octavia.state import HALTING, Mode

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

BLOCK_SAMPLES = 25  # BTRATE m selects 25 * (m + 1) samples: 5, 10, 15, 20 ms [Ch5 BTRATE]
VECCHG_LEVELS = 3  # "Three buffer levels are used to implement this instruction" [Ch5 VECCHG]
_OUT, _IN = int(Dpr.OUTPTR), int(Dpr.INPTR)
#: the modes whose axes START or a vector change cannot take (Ch7 "Conflicting Commands"; an
#: axis running CUBIC_INT contours too)
BUSY_MODES = (int(Mode.MOVE), int(Mode.VELMODE), int(Mode.CUBIC))
_NO_AXES = np.zeros(0, dtype=np.intp)


def decode_velocity(raw: np.ndarray) -> np.ndarray:
    """Velocity words (int32) in counts/sample: 25-bit two's complement 16.16, bits 25..31
    ignored (spec Q-38; `vdevmaps.octavia.vel_from_raw`, vectorised)."""
    v = raw.astype(np.int64) & 0x1FFFFFF
    v -= (v & 0x1000000) << 1
    return v / 65536.0


def axis_coding(raw: int) -> int:
    """The axis mask a cubic-ring velocity word codes in its upper nibble (bits 28..31), or 0
    when the nibble is the sign extension of bit 24 (no coding) [Ch6 Contouring; spec Q-16]."""
    nibble = (raw >> 28) & 0xF
    return 0 if nibble == (0xF if raw & 0x1000000 else 0) else nibble


class Segments:
    """The interpolator of one contouring task over some of the card's axes: `axes` (0-based,
    increasing) follow `path`, the commanded positions of the interval under way (row t = the
    end of sample t + 1), `t` rows of which ran; `p_end`, `v_end` are every axis's state at the
    end of its last interval (counts, counts/sample)."""

    mode = Mode.CONTOUR

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self._mode = int(self.mode)  # a plain int: numpy compares it without the enum's lookups
        n = fw.n
        self.p_end = np.zeros(n)
        self.v_end = np.zeros(n)
        self.axes = _NO_AXES
        self.path = np.zeros((0, 0))
        self.t = 0
        self.running = False

    def reset(self) -> None:
        """Power-up / RESET: nothing runs (the firmware aborted every axis)."""
        self.running = False
        self.axes = _NO_AXES
        self.path = np.zeros((0, 0))
        self.t = 0

    def redefined(self, axis: int, shift: float) -> None:
        """POS_SHIFT of `axis` while it contours: its path moves with its counter, so the motor
        goes on where it was going ("without losing position integrity" [Ch5 POS_SHIFT])."""
        if not self.running:
            return
        self.p_end[axis] += shift
        cols = np.flatnonzero(self.axes == axis)
        if len(cols) and self.path.size:
            self.path[:, cols] += shift


    def join(self, axes: np.ndarray) -> None:
        """`axes` start contouring from their present commanded state, at rest (spec §5.4)."""
        fw = self.fw
        self.fw.close_loop(axes)
        self.p_end[axes] = fw.core.axes.cmd_pos[axes]
        self.v_end[axes] = 0.0
        fw.mode[axes] = self.mode

    def plan(self, p1: np.ndarray, v1: np.ndarray, samples: int, cubic: bool) -> None:
        """The next interval of `axes`: from (p_end, v_end) to (p1, v1) in `samples` samples, a
        cubic Hermite segment or a 2nd-order block (spline.py), rounded to counts."""
        axes = self.axes
        shape = hermite if cubic else second_order
        positions, _ = shape(self.p_end[axes], self.v_end[axes], p1, v1, samples)
        self.path = np.rint(positions)
        self.p_end[axes] = p1
        self.v_end[axes] = v1
        self.t = 0

    def follow(self) -> None:
        """One sample of the interval under way: every axis to its next commanded position."""
        self.fw.core.track(self.axes, self.path[self.t])
        self.t += 1

    def released(self) -> bool:
        """Whether a command took some of `axes` away (STOP, *ESTOP, EN_ERRHLT halting them)."""
        return bool((self.fw.mode[self.axes] != self._mode).any())

    def finish(self, axes: np.ndarray) -> None:
        """`axes` stop contouring: they hold where the path left them."""
        if len(axes):
            self.fw.core.hold(axes)
            self.fw.mode[axes] = Mode.HOLD


class RingContour(Segments):
    """Contouring from the DPR ring buffer (START, VECCHG, EN_BUFBRK; spec §2.5.4, §5.4).

    `layout` is the active axis set the host's data follows (START, VECCHG, the cubic axis
    coding): one slot per layout axis per interval. `axes`, the axes that follow their slots, is
    the layout less the axes STOP (or *ESTOP, EN_ERRHLT) took away: their slots are still read,
    so the host's data stays aligned, and the contour ends when no axis follows any more."""

    def __init__(self, fw: Firmware) -> None:
        super().__init__(fw)
        self.ring = np.ndarray((RING_SLOTS, 2), "<i4", buffer=fw.buf, offset=int(Dpr.RINGBUF))
        self.layout = _NO_AXES
        self.cubic = False  # the mode START found (spec §4.4: the last rate command)
        self.vecchg: list[tuple[int, np.ndarray]] = []  # pending (slot m, axes)
        self.bufbrk_armed = True

    def reset(self) -> None:
        super().reset()
        self.layout = _NO_AXES
        self.vecchg.clear()
        self.bufbrk_armed = True

    # -- commands ----------------------------------------------------------------------------------
    def start(self, axes: list[int]) -> None:
        """START: contour `axes` from their present commanded state; the first interval is
        fetched at this sample [Ch5 START]."""
        idx = np.array(axes, dtype=np.intp)
        self.cubic = self.fw.params.cubic_mode
        self.layout = self.axes = idx
        self.join(idx)
        self.path = np.zeros((0, len(idx)))
        self.t = 0
        self.bufbrk_armed = True
        self.running = True

    def queue_vecchg(self, slot: int, axes: list[int]) -> None:
        """VECCHG: from slot `slot` on, the layout is `axes`; a fourth pending change is
        discarded with "vector change buffer overflow" (1FFEh b3) [Ch5 VECCHG, Ch6 Contouring]."""
        if len(self.vecchg) >= VECCHG_LEVELS:
            self.fw.mailbox.post(int(HostInt.VECCHG_OVERFLOW))
            return
        self.vecchg.append((slot, np.array(axes, dtype=np.intp)))

    # -- the sample ------------------------------------------------------------------------------
    def step(self) -> None:
        """One sample while running (the firmware calls it before the core's tick)."""
        if self.released():
            self.release()
            if not self.running:
                return
        if self.t == len(self.path):
            self.fetch()
            if not self.running:
                return
        self.follow()

    def release(self) -> None:
        """Axes that left CONTOUR under a command stop following; their slots are still read.
        No axis left: the contour ends, the ring left as it is (the host clears it) [Ch5 STOP]."""
        keep = self.fw.mode[self.axes] == Mode.CONTOUR
        self.axes = self.axes[keep]
        self.path = self.path[:, keep]
        if not len(self.axes):
            self.end()

    def end(self) -> None:
        self.running = False
        self.axes = _NO_AXES
        self.vecchg.clear()

    def fetch(self) -> None:
        """The next interval: one slot per layout axis at OUTPTR, OUTPTR advanced past them; an
        empty ring ends the contour (at rest) or runs it out (moving) [Ch6 Contouring, Ch7 Data
        Run-Out]; the buffer breakpoint on a fall below its threshold [Ch5 EN_BUFBRK]."""
        fw, buf = self.fw, self.fw.buf
        out = buf[_OUT] % RING_SLOTS
        used = (buf[_IN] - out) % RING_SLOTS
        if self.vecchg and self.vecchg[0][0] == out:
            self.change_layout(self.vecchg.pop(0)[1])
        if self.cubic and used:
            coded = axis_coding(int(self.ring[out, 1]))
            if coded:
                self.change_layout(np.array(fw.mask(coded), dtype=np.intp))
        k = len(self.layout)
        if used < k or not len(self.axes):
            self.run_out()
            return
        slots = (out + np.arange(k)) % RING_SLOTS
        raw = self.ring[slots]
        buf[_OUT] = (out + k) % RING_SLOTS
        p = fw.params
        if used >= p.bufbrk:  # at or over the threshold (the host refilled): armed again
            self.bufbrk_armed = True
        if p.bufbrk_on and self.bufbrk_armed and used - k < p.bufbrk:
            self.bufbrk_armed = False
            fw.mailbox.post(int(HostInt.BUFBRK))
        cols = np.searchsorted(self.layout, self.axes)
        samples = p.cubic_rate if self.cubic else BLOCK_SAMPLES * (p.btrate + 1)
        self.plan(raw[cols, 0].astype(np.float64), decode_velocity(raw[cols, 1]), samples,
                  self.cubic)

    def run_out(self) -> None:
        """Fewer slots than layout axes: every end velocity 0 ends the contour (no motion
        complete [Ch5 EN_MOTCP]); else "data run-out" (1FFEh b5) and the axes hold at the last
        point [Ch7 Data Run-Out]."""
        axes = self.axes
        if len(axes) and (self.v_end[axes] != 0).any():
            self.fw.mailbox.post(int(HostInt.RUN_OUT))
        self.finish(axes)
        self.end()

    def change_layout(self, new: np.ndarray) -> None:
        """A vector change (VECCHG, or the cubic ring's axis coding): axes that leave the layout
        hold; axes that join start from their commanded state, unless they move under another
        command or halt ("conflicting commands" / "RTC ignored": their slots are read unused)."""
        fw = self.fw
        self.finish(np.setdiff1d(self.axes, new))
        joining = np.setdiff1d(new, self.layout)
        mode = fw.mode[joining]
        halting = np.isin(mode, HALTING) | fw.estop
        busy = np.isin(mode, BUSY_MODES) & ~halting
        if halting.any():
            fw.post_stat1(DspStat1.IGNORED, _bits(joining[halting]))
        if busy.any():
            fw.post_stat1(DspStat1.CONFLICT, _bits(joining[busy]))
        joining = joining[~(halting | busy)]
        self.join(joining)
        self.layout = new
        self.axes = np.union1d(np.intersect1d(self.axes, new), joining).astype(np.intp)


def _bits(axes: np.ndarray) -> int:
    return int(sum(1 << int(a) for a in axes))
