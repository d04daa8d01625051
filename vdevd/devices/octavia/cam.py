"""Electronic cam and gearing: the follower laws, vectorised over slave axes [Ch5 CAM family,
GEAR family; spec octavia.md §5.6, §5.7]. Units are counts and samples (200 µs).

Per sample, each engaged slave's target is

* cam:  s* = s0 + cyc·Sc + S_j + (μ − M_j)·R_j/128, with μ the master's travel since engagement
  folded into [0, Mc) and cyc the whole cycles folded out (either direction), j = max{j : M_j ≤ μ};
* gear: s* = s0 + r·(leader − l0)/2^frac_bits.

Assumptions (the manual is silent; spec Q-5, Q-21, Q-22b):

* The master position is whatever the firmware passes (spec: actual by default, cfg command).
  Master travel is accumulated from int32-wrapped per-sample differences, so a master that rolls
  over ±2^31 keeps its cam phase; targets are wrapped to int32.
* The ratio R_j only interpolates inside a segment; each point re-anchors at S_j (no drift).
  Division by 2^bits rounds to nearest, ties towards +∞ (add half, arithmetic shift: the DSP idiom).
* CAMCOUNT is the absolute table index j (tablestart + offset).
* CAM_POS / GEAR_POS engage at the first sample where the master has reached the trigger
  position, from either side (or sits on it when armed); m0 = the trigger, so the overshoot of
  that sample is followed at once. CAM_PROBE / GEAR_PROBE engage at the EXT edge with m0 = the
  latched master position. s0 is the slave's command position at engagement.
* CAM_POINT computes the ratio (S_{k+1} − S_k)·128/(M_{k+1} − M_k) rounded to nearest (ties
  towards +∞) and saturated to 8000h..7FFFh, so slopes up to the manual's 255.999 store as 7FFFh.
  A slope outside −256 ≤ r < 256 or a non-zero slope under 1/128 (stored rounded, 0 or ±1)
  makes `place_cam_point` return False, for the firmware to log: the card has no error report
  for it. The point itself is always stored. A master step ≤ 0 stores ratio 0 without a report
  (a table built point by point has such steps until its next point arrives); `table_problem`
  checks the whole table when a CAM command engages it.
* A table whose master cycle is not positive (no valid table loaded) is followed as if the cycle
  were 1 count; `table_problem` names what is wrong for the firmware's log at CAM time.
* MAXACC limiting of the slave, STOP/ESTOP and REL_AXMOVE_SLAVE are the firmware's (spec §5.6).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np
import numpy.typing as npt

from vdevd.devices.octavia.ram import CAM_POINTS, BoardRam, IntArray, wrap_i32

RATIO_FRAC_BITS = 7                     # 1 sign, 8 integer, 7 fraction bits [Ch5 GEAR, LOAD_CAM_TABLE]
RATIO_MIN, RATIO_MAX = -0x8000, 0x7FFF  # −256 .. 255.99 (×128)
MIN_TABLE_SIZE = 3                      # [Ch5 CAM]
EXT_CODES = (0x01, 0x02, 0x04, 0x08)    # *EXT1..*EXT4 [Ch5 CAM_PROBE, GEAR_PROBE]


class Follow(IntEnum):
    """What a slave axis is doing with respect to its master."""

    OFF = 0
    AT_POSITION = 1   # armed by CAM_POS / GEAR_POS
    ON_PROBE = 2      # armed by CAM_PROBE / GEAR_PROBE
    ENGAGED = 3


def _shift_round(values: IntArray, bits: int) -> IntArray:
    """values / 2^bits rounded to nearest (ties towards +∞)."""
    return (values + (1 << bits >> 1)) >> bits


def _ratios(d_master: IntArray, d_slave: IntArray) -> tuple[IntArray, npt.NDArray[np.bool_]]:
    """The ×128 ratio codes of segments (saturated; 0 where the master does not advance) and
    whether each advancing segment's slope is representable."""
    positive = d_master > 0
    den = np.where(positive, d_master, 1)
    code = (2 * (d_slave << RATIO_FRAC_BITS) + den) // (2 * den)   # round half up
    fits = (d_slave >= -256 * d_master) & (d_slave < 256 * d_master)
    fits &= (d_slave == 0) | (np.abs(d_slave) << RATIO_FRAC_BITS >= d_master)   # |r| ≥ 1/128
    fits |= ~positive   # a table still being built point by point: `table_problem` at CAM time
    return np.where(positive, np.clip(code, RATIO_MIN, RATIO_MAX), 0), fits


def cam_point_ratio(d_master: int, d_slave: int) -> int:
    """The ×128 ratio code the card computes for a segment of (d_master, d_slave) counts
    [Ch5 CAM_POINT, LOAD_CAM_TABLE]: rounded to nearest, saturated (module docstring)."""
    code, _ = _ratios(np.array([d_master], np.int64), np.array([d_slave], np.int64))
    return int(code[0])


def table_ratios(master: npt.ArrayLike, slave: npt.ArrayLike) -> IntArray:
    """The ratio codes of a whole table of points, the last one 0 [Ch5 LOAD_CAM_TABLE]."""
    m, s = np.asarray(master, np.int64), np.asarray(slave, np.int64)
    code, _ = _ratios(np.diff(m), np.diff(s))
    return np.append(code, 0)


def table_problem(master: npt.ArrayLike, slave: npt.ArrayLike) -> str | None:
    """What makes a table unusable by the follower, or None [Ch5 CAM_POINT: point 0 is (0,0);
    spec §5.6: master positions strictly increasing]."""
    m, s = np.asarray(master, np.int64), np.asarray(slave, np.int64)
    if m[0] != 0 or s[0] != 0:
        return f"first point is ({m[0]}, {s[0]}), not (0, 0)"
    if (np.diff(m) <= 0).any():
        return "master positions do not increase"
    return None


def check_table_span(start: int, size: int) -> None:
    """tablestart/tablesize of CAM, CAM_POS, CAM_PROBE and CAM_POINT: 3 ≤ size and the table
    inside the 1600 points (spec Q-21: start 1600 is impossible)."""
    if start < 0 or size < MIN_TABLE_SIZE or start + size > CAM_POINTS:
        raise ValueError(f"cam table start {start}, size {size} is not within {CAM_POINTS} points")


def place_cam_point(ram: BoardRam, tablestart: int, tablesize: int, index: int,
                    masterpos: int, slavepos: int) -> bool:
    """CAM_POINT: store point `index` of the table and recompute the ratios that depend on it
    (the previous point's and its own; the last point's is 0). False when one of these slopes
    is out of range (stored saturated)."""
    check_table_span(tablestart, tablesize)
    if not 0 <= index < tablesize:
        raise ValueError(f"cam point index {index} is not within the table size {tablesize}")
    ram.store_cam_points(tablestart + index, [masterpos], [slavepos], [0])  # the last point keeps 0
    first, last = max(index - 1, 0), min(index + 1, tablesize - 1)
    master, slave, _ = ram.cam_points(tablestart + first, last - first + 1)
    code, fits = _ratios(np.diff(master), np.diff(slave))
    ram.store_cam_points(tablestart + first, master[:-1], slave[:-1], code)
    return bool(fits.all())


class _Followers:
    """Engagement state shared by cam and gear slaves: master axis, trigger, anchor."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.mode = np.zeros(n, np.int64)       # Follow
        self.master = np.zeros(n, np.int64)     # master (leader) axis index
        self.trigger = np.zeros(n, np.int64)    # masterpos / tp of an AT_POSITION slave
        self.ext = np.zeros(n, np.int64)        # EXT code of an ON_PROBE slave
        self.last = np.zeros(n, np.int64)       # master position at the previous sample
        self.s0 = np.zeros(n, np.int64)         # slave command position at engagement

    @property
    def engaged(self) -> npt.NDArray[np.bool_]:
        """The slaves following now."""
        return self.mode == Follow.ENGAGED

    @property
    def active(self) -> bool:
        """Any slave engaged or armed (the firmware skips `targets` otherwise)."""
        return bool(self.mode.any())

    def _arm(self, axis: int, master: int, mode: Follow) -> None:
        if not (0 <= axis < self.n and 0 <= master < self.n) or axis == master:
            raise ValueError(f"slave axis {axis} cannot follow master axis {master}")
        self.mode[axis], self.master[axis] = mode, master

    def _engage_now(self, axis: int, master: int, master_position: int, slave_position: int) -> None:
        self._arm(axis, master, Follow.ENGAGED)
        self.last[axis], self.s0[axis] = master_position, slave_position
        self._restart(np.arange(self.n) == axis)

    def _arm_at(self, axis: int, master: int, trigger: int, master_position: int) -> None:
        self._arm(axis, master, Follow.AT_POSITION)
        self.trigger[axis], self.last[axis] = trigger, master_position

    def _arm_probe(self, axis: int, master: int, ext: int) -> None:
        if ext not in EXT_CODES:
            raise ValueError(f"EXT code {ext:#x} is not one of 01h, 02h, 04h, 08h")
        self._arm(axis, master, Follow.ON_PROBE)
        self.ext[axis] = ext

    def disengage(self, axis: int) -> None:
        """CAM_OFF / GEAR_OFF (and the start of *_OFF_ACC): stop following, or disarm."""
        self.mode[axis] = Follow.OFF

    def probe(self, ext: int, latched: npt.ArrayLike, commands: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """The `ext` input went active: engage the slaves armed on it, m0 = the master's position
        in `latched` (all axes, latched at the edge), s0 = their `commands`. Returns them."""
        hit = (self.mode == Follow.ON_PROBE) & (self.ext == ext)
        if hit.any():
            self.last[hit] = np.asarray(latched, np.int64)[self.master[hit]]
            self.s0[hit] = np.asarray(commands, np.int64)[hit]
            self.mode[hit] = Follow.ENGAGED
            self._restart(hit)
        return hit

    def _restart(self, mask: npt.NDArray[np.bool_]) -> None:
        """Clear the follower state of newly engaged slaves."""
        raise NotImplementedError

    def _advance(self, positions: npt.ArrayLike, commands: npt.ArrayLike) -> IntArray:
        """Engage AT_POSITION slaves whose master reached the trigger; return each engaged slave's
        master travel since the previous sample (0 for the others)."""
        now = np.asarray(positions, np.int64)[self.master]
        armed = self.mode == Follow.AT_POSITION
        if armed.any():
            off = wrap_i32(self.trigger - self.last)
            step = wrap_i32(now - self.last)
            hit = armed & ((off == 0) | ((off > 0) & (step >= off)) | ((off < 0) & (step <= off)))
            if hit.any():
                self.last[hit] = self.trigger[hit]
                self.s0[hit] = np.asarray(commands, np.int64)[hit]
                self.mode[hit] = Follow.ENGAGED
                self._restart(hit)
            self.last[armed & ~hit] = now[armed & ~hit]
        engaged = self.mode == Follow.ENGAGED
        delta = np.where(engaged, wrap_i32(now - self.last), 0)
        self.last[engaged] = now[engaged]
        return delta


class CamFollowers(_Followers):
    """The cam slaves of a card (one entry per axis) over the cam table in `ram` [Ch5 CAM]."""

    def __init__(self, n: int, ram: BoardRam) -> None:
        super().__init__(n)
        self.ram = ram
        self.start = np.zeros(n, np.int64)
        self.size = np.full(n, MIN_TABLE_SIZE, np.int64)
        self.mu = np.zeros(n, np.int64)         # master phase in the cycle, 0 ≤ μ < Mc
        self.cycles = np.zeros(n, np.int64)     # whole master cycles since engagement (signed)
        self.camcount = np.zeros(n, np.int64)   # absolute index j of the current point (CAMCOUNT)
        self.m_points: IntArray
        self.s_points: IntArray
        self.r_points: IntArray
        self.refresh()

    def refresh(self) -> None:
        """Re-read the 1600 cam points after any write to the table area (LOAD_CAM_TABLE,
        CAM_POINT, and the aliasing LOAD_CUBIC_TABLE / LOAD_*_TABLE / CLEAR_*)."""
        self.m_points, self.s_points, self.r_points = self.ram.cam_points(0, CAM_POINTS)

    def _table(self, axis: int, start: int, size: int) -> None:
        check_table_span(start, size)
        self.start[axis], self.size[axis] = start, size

    def engage(self, axis: int, master: int, start: int, size: int, master_position: int,
               slave_position: int) -> None:
        """CAM: `axis` follows `master` at once on table start..start+size−1."""
        self._table(axis, start, size)
        self._engage_now(axis, master, master_position, slave_position)

    def engage_at(self, axis: int, master: int, start: int, size: int, masterpos: int,
                  master_position: int) -> None:
        """CAM_POS: engage when the master reaches `masterpos` (now at `master_position`)."""
        self._table(axis, start, size)
        self._arm_at(axis, master, masterpos, master_position)

    def engage_on_probe(self, axis: int, master: int, start: int, size: int, ext: int) -> None:
        """CAM_PROBE: engage at the next active edge of the EXT input coded `ext` (`probe`)."""
        self._table(axis, start, size)
        self._arm_probe(axis, master, ext)

    def _restart(self, mask: npt.NDArray[np.bool_]) -> None:
        self.mu[mask] = 0
        self.cycles[mask] = 0
        self.camcount[mask] = self.start[mask]

    def targets(self, positions: npt.ArrayLike, commands: npt.ArrayLike) -> tuple[IntArray, IntArray]:
        """One sample: from every axis' master-source `positions` and command `commands`, the
        target of each axis (the cam position where engaged, `commands` elsewhere) and CAMCOUNT."""
        delta = self._advance(positions, commands)
        engaged = self.mode == Follow.ENGAGED
        out = np.array(commands, np.int64)
        if not engaged.any():
            return out, self.camcount.copy()
        m, s, r = self.m_points, self.s_points, self.r_points
        lo = self.start
        end = lo + self.size - 1
        cycle = np.maximum(m[end], 1)
        self.mu += delta
        wraps = self.mu // cycle
        self.mu -= wraps * cycle
        self.cycles += wraps
        j = self._point(engaged, lo, end - 1)
        target = self.s0 + self.cycles * s[end] + s[j] + _shift_round((self.mu - m[j]) * r[j],
                                                                      RATIO_FRAC_BITS)
        out[engaged] = wrap_i32(target[engaged])
        self.camcount[engaged] = j[engaged]
        return out, self.camcount.copy()

    def _point(self, engaged: npt.NDArray[np.bool_], lo: IntArray, hi: IntArray) -> IntArray:
        """j = max{j in lo..hi : M_j ≤ μ} per slave: the last point if it still holds, else a
        binary search vectorised over the slaves (≤ 11 steps for 1600 points)."""
        m, mu = self.m_points, self.mu
        j = np.clip(self.camcount, lo, hi)
        holds = (m[j] <= mu) & ((j == hi) | (m[j + 1] > mu))   # j + 1 ≤ the last point
        if holds[engaged].all():
            return j
        a, b = lo.copy(), hi.copy()
        while (a < b).any():
            mid = (a + b + 1) >> 1
            up = m[mid] <= mu
            a = np.where(up, mid, a)
            b = np.where(up, b, mid - 1)
        return a


class Gears(_Followers):
    """The electronic-gear followers of a card (one entry per axis) [Ch5 GEAR family].
    `frac_bits` is the ratio's fraction width: 7 per the text, 12 per the examples (spec Q-5)."""

    def __init__(self, n: int, frac_bits: int = RATIO_FRAC_BITS) -> None:
        super().__init__(n)
        if not 0 <= frac_bits <= 15:
            raise ValueError(f"gear ratio fraction bits {frac_bits} is not 0..15")
        self.frac_bits = frac_bits
        self.ratio = np.zeros(n, np.int64)      # raw int16 code
        self.travel = np.zeros(n, np.int64)     # leader travel since engagement (leader − l0)

    def _set_ratio(self, axis: int, ratio: int) -> None:
        if not RATIO_MIN <= ratio <= RATIO_MAX:
            raise ValueError(f"gear ratio code {ratio} is not a 16-bit two's complement value")
        self.ratio[axis] = ratio

    def engage(self, axis: int, leader: int, ratio: int, leader_position: int,
               follower_position: int) -> None:
        """GEAR: `axis` follows `leader` at once with the raw ratio code `ratio`."""
        self._set_ratio(axis, ratio)
        self._engage_now(axis, leader, leader_position, follower_position)

    def engage_at(self, axis: int, leader: int, ratio: int, tp: int, leader_position: int) -> None:
        """GEAR_POS: engage when the leader reaches `tp` (now at `leader_position`)."""
        self._set_ratio(axis, ratio)
        self._arm_at(axis, leader, tp, leader_position)

    def engage_on_probe(self, axis: int, leader: int, ratio: int, ext: int) -> None:
        """GEAR_PROBE: engage at the next active edge of the EXT input coded `ext` (`probe`)."""
        self._set_ratio(axis, ratio)
        self._arm_probe(axis, leader, ext)

    def _restart(self, mask: npt.NDArray[np.bool_]) -> None:
        self.travel[mask] = 0

    def targets(self, positions: npt.ArrayLike, commands: npt.ArrayLike) -> IntArray:
        """One sample: the target of each axis (s0 + r·(leader − l0) where engaged, `commands`
        elsewhere) from every axis' leader-source `positions`."""
        self.travel += self._advance(positions, commands)
        engaged = self.mode == Follow.ENGAGED
        out = np.array(commands, np.int64)
        if engaged.any():
            target = self.s0 + _shift_round(self.ratio * self.travel, self.frac_bits)
            out[engaged] = wrap_i32(target[engaged])
        return out
