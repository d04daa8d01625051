"""What the motors of one Turbo PMAC card report, read-only: positions, velocity, following error,
DAC, encoder and capture registers, and the status words [spec pmac.md §2.6, §2.7, §1.5].

`MotorReports` is a view over a `Motors` (motors.py), which owns the state and the commands; it
reads the motors' public members and never changes them. Positions are motor counts: the core's
raw encoder count minus the home origin (motors.py "Units").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac import status
from vdevd.devices.pmac.status import MotorStatus1 as S1
from vdevd.devices.pmac.status import pack
from vdevd.rt import AxisFlag

if TYPE_CHECKING:
    from vdevd.devices.pmac.motors import Motors

DAC_FULL_SCALE = 32767  # 16-bit DAC, +-10 V [§2.7]
ENCODER_MASK = 0xFFFFFF  # the Servo IC's 24-bit counter [§1.5 register table]
# Ixx24 bit 17: the hardware limits are not used [A L1811-1877]
IXX24_LIMITS_OFF = 1 << 17

_STOPPED = int(AxisFlag.STOPPED_BY_LIMIT)


class MotorReports:
    """The read-only reports of the motors of one card (`P`, `V`, `F`, `?`, the DPRAM and the
    motor registers); motor index m is 0-based."""

    def __init__(self, motors: Motors) -> None:
        self.motors = motors
        self._ix = 100 * np.arange(1, motors.n + 1)  # I-variable number of Ixx00 per motor
        self._tmp = np.zeros(motors.n)
        self._counts = np.zeros(motors.n, dtype=np.int64)
        self._whole = np.zeros(motors.n)  # `_counts` as floats
        self._mask = np.full(motors.n, ENCODER_MASK, dtype=np.int64)  # an array: no scalar

    def _iv(self, yy: int) -> np.ndarray:
        return self.motors.ivars.values[self._ix + yy]

    # -- positions -----------------------------------------------------------------------------
    def position(self) -> np.ndarray:
        """Actual motor position, counts (encoder - home origin)."""
        mo = self.motors
        return mo.core.axes.fb - mo.origin

    def position_of(self, m: int) -> float:
        """`position()[m]` without computing every motor's (the on-line P report)."""
        mo = self.motors
        return float(mo.core.axes.fb[m] - mo.origin[m])

    def velocity(self) -> np.ndarray:
        """Filtered actual velocity, counts per servo cycle, over 16*(I60+1) cycles [SRM I60]."""
        return self.motors.filtered_velocity

    def commanded(self) -> np.ndarray:
        """Commanded motor position, counts (the actual position while the loop is open)."""
        mo = self.motors
        ax = mo.core.axes
        return np.where(mo.core.servo_on_mask, ax.cmd_pos, ax.fb) - mo.origin

    def following_error(self) -> np.ndarray:
        """Commanded - actual, counts (0 while the loop is open)."""
        return self.commanded() - self.position()

    def target(self) -> np.ndarray:
        """The end of the present move (Mxx63), else the commanded position, motor counts."""
        mo = self.motors
        core = mo.core
        ends = core.profile.moving & core.target_valid & core.servo_on_mask
        return np.where(ends, core.target - mo.origin, self.commanded())

    # -- registers -----------------------------------------------------------------------------
    def dac(self) -> np.ndarray:
        """The servo output in 16-bit DAC units (Mxx68/Mxx79)."""
        return np.clip(np.rint(self.motors.core.axes.out), -DAC_FULL_SCALE - 1, DAC_FULL_SCALE)

    def encoder(self) -> np.ndarray:
        """The 24-bit encoder counter (X:b+1), unsigned, wrapping: the hardware count, without
        the offset a compensation table puts on the loop's feedback (firmware._compensate)."""
        core = self.motors.core
        if core.any_slip:
            return (core.axes.encoder + core.encoder_slip.astype(np.int64)) & ENCODER_MASK
        return core.axes.encoder & ENCODER_MASK

    def encoder_fine(self) -> np.ndarray:
        """The encoder counter with the sub-count position of the motor behind it (counts, float):
        what the Servo IC's 1/T timers, extended compare and sub-count capture measure. A lost
        encoder has no fraction."""
        core = self.motors.core
        pos = core.axes.pos
        frac = pos - np.floor(pos)
        frac[core.encoder_loss] = 0.0
        return self.encoder() + frac

    def encoder_fine_into(self, out: np.ndarray) -> None:
        """`encoder_fine` written into `out` (one float per motor), with no allocation: the
        Servo ICs read it every cycle."""
        core = self.motors.core
        pos = core.axes.pos
        if not (core.any_slip or core.encoder_loss.tobytes().count(1)):
            self.fine_from(pos, core.axes.encoder, out)
            return
        counts = self._counts
        np.floor(pos, out)
        np.subtract(pos, out, out)
        if core.any_slip:
            np.copyto(counts, core.encoder_slip, casting="unsafe")
            np.add(counts, core.axes.encoder, counts)
            np.bitwise_and(counts, self._mask, counts)
        else:
            np.bitwise_and(core.axes.encoder, self._mask, counts)
        if core.encoder_loss.tobytes().count(1):
            out[core.encoder_loss] = 0.0
        np.add(counts, out, out)

    def keep_fine(self, pos: np.ndarray, counter: np.ndarray) -> bool:
        """Keep in `pos` and `counter` what `encoder_fine_into` computes from now, the motors'
        positions and counters, for `fine_from` (the Servo ICs compute their counters when
        read): True, or False (nothing kept) while a slip or a lost encoder adds to them."""
        core = self.motors.core
        if core.any_slip or core.encoder_loss.tobytes().count(1):
            return False
        pos[...] = core.axes.pos
        counter[...] = core.axes.encoder
        return True

    def fine_from(self, pos: np.ndarray, counter: np.ndarray, out: np.ndarray) -> None:
        """`encoder_fine_into` of motors at `pos` whose counters read `counter` (int64), with no
        slip and no lost encoder: the 24-bit counter plus the sub-count position."""
        counts, whole = self._counts, self._whole
        np.floor(pos, out)
        np.subtract(pos, out, out)
        np.bitwise_and(counter, self._mask, counts)
        whole[...] = counts  # the cast np.add(counts, out) makes, without its mixed-type loop
        np.add(whole, out, out)

    def capture(self) -> np.ndarray:
        """The counter value latched by the last home trigger (X:b+3 low 24 bits, Mxx73)."""
        return self.motors.homing.capture_counts.copy()

    # -- status ----------------------------------------------------------------------------------
    def limit_bits_now(self) -> np.ndarray:
        """Word-1 bits 21/22: a used hardware limit input, or the actual position beyond Ixx13 /
        Ixx14 [§2.6]."""
        mo = self.motors
        use = (mo.flag_mode & IXX24_LIMITS_OFF) == 0
        fb = mo.core.axes.fb
        pos = (mo.plim & use) | (fb > mo.soft_hi)
        neg = (mo.mlim & use) | (fb < mo.soft_lo)
        return pack(mo.n, ((S1.POS_END_LIMIT, pos), (S1.NEG_END_LIMIT, neg)))

    def in_position_now(self) -> np.ndarray:
        """Loop closed, desired velocity zero, no timed move, |FE| < Ixx28 [SRM p.283]."""
        band = self._iv(28) / 16
        core = self.motors.core
        return core.servo_on_mask & ~core.profile.moving & (self._abs_ferr() < band)

    def _abs_ferr(self) -> np.ndarray:
        """|commanded - actual| now (the core's ferr row is refreshed only by the tick)."""
        ax = self.motors.core.axes
        np.subtract(ax.cmd_pos, ax.fb, out=self._tmp)
        return np.abs(self._tmp, out=self._tmp)

    def status_words(self) -> tuple[np.ndarray, np.ndarray]:
        """(word 1, word 2) of every motor as `#n?` reports them [§2.6]; 0 for a motor that is
        not activated (Ixx00 = 0)."""
        mo = self.motors
        core, n = mo.core, mo.n
        closed = core.servo_on_mask
        w1 = status.word1(
            n, iv={yy: self._iv(yy) for yy in (1, 6, 34, 90, 96, 97)}, closed=closed,
            amp_enabled=mo.amp_enabled, moving=core.profile.moving,
            searching=mo.homing.searching, abort_decel=mo.abort_decel, timed=mo.timed,
            limits=np.where(mo.amp_enabled, self.limit_bits_now(), mo.limit_bits))
        w1 = w1 | (mo.dwell.astype(w1.dtype) << 15)  # dwell in progress [§2.6; SRM "?"]
        inpos = mo.inpos_scans > self._iv(88) if mo.count_inpos else self.in_position_now()
        warn_limit = self._iv(12) / 16
        warning = (closed & (warn_limit > 0) & (self._abs_ferr() > warn_limit)) | mo.fatal_error
        w2 = status.word2(
            n, in_position=inpos, warning=warning, fatal=mo.fatal_error, amp_fault=mo.amp_error,
            home_complete=mo.homing.home_complete,
            trigger_move=mo.homing.trigger_move_bits(core.profile.moving),
            stopped_on_limit=(core.axes.flags & _STOPPED) != 0,
            foreground=bool(mo.ivars.values[13] == 1), cs=mo.cs, axis_code=mo.axis_code)
        return np.where(mo.active, w1, 0), np.where(mo.active, w2, 0)
