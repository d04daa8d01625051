"""The electronic cam of the DMC-13X8 [M Ch6 §Electronic Cam; spec §4.5, §5.3].

`EA` names the master (its main encoder), `EM` the master's cycle and each slave's change per
cycle, `EP m,n` the table's master interval and start, `ET[i]` the slave positions at master
position n + i*m (i = 0..256), `EB 1` enables the mode, `EG`/`EQ` engage and disengage each
slave when the master passes a position of its cycle (at once if the position is outside it).
An engaged slave's commanded position is the table, linearly interpolated at the master's
position within its cycle; at the end of a cycle the master's position is redefined by its cycle
and each engaged slave's by its change per cycle, the motion going on [M Ch6 Step 2].
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.motion import GalilMotion
from vdevd.devices.galil.virtual import VirtualAxis

TABLE_POINTS = 257  # ET[0] ... ET[256] [M Ch6 §Electronic Cam Step 4]
MASTER_CYCLE_LIMIT = 8_388_607  # [M Ch6 Step 2]
SLAVE_CHANGE_LIMIT = 2_147_483_647
SC_RUNNING, SC_STOPPED = 60, 61  # SC while and after ECAM (spec §4.4)


class Ecam:
    """The cam of one card: master, cycles, table, engagement per slave."""

    def __init__(self, motion: GalilMotion, virtual: VirtualAxis | None = None) -> None:
        n = motion.n
        self.motion = motion
        #: the virtual axis N, master number n (`EA N`) [M Ch6 §Virtual Axis]
        self.virtual = virtual
        self.master = -1
        #: EM: the master's entry is its cycle, slaves' their change; entry n is N's (`EMN=`)
        self.cycle = np.zeros(n + 1)
        self.interval = 0.0
        self.start = 0.0
        self.table = np.zeros((TABLE_POINTS, n))
        self.index = 0  # EC
        self.enabled = False
        self.engaged = np.zeros(n, dtype=bool)
        self.engage_at = np.full(n, np.nan)  # EG pending: the master position
        self.disengage_at = np.full(n, np.nan)  # EQ pending
        #: called with (axes, counts) when positions are redefined at the end of a cycle
        self.on_redefine: Callable[[np.ndarray, np.ndarray], None] | None = None
        self._prev = 0.0  # the master's reading at the last sample

    @property
    def active(self) -> bool:
        """Whether a slave is engaged or waits to engage."""
        return bool(self.engaged.any() or np.isfinite(self.engage_at).any())

    @property
    def master_cycle(self) -> float:
        return float(self.cycle[self.master]) if self.master >= 0 else 0.0

    def check_idle(self) -> None:
        """EA, EM and EP are refused while a slave is engaged (TC 100)."""
        if self.engaged.any():
            raise GalilError(TC.NOT_VALID_RUNNING_ECAM)

    def check_master(self) -> None:
        """A master with a cycle (TC 102) whose cycle the table covers (TC 103)."""
        if self.master < 0 or self.master_cycle <= 0:
            raise GalilError(TC.NO_ECAM_MASTER)
        if self.interval <= 0 or self.master_cycle > 256 * self.interval:
            raise GalilError(TC.ECAM_MODULUS_TOO_LARGE)

    def set_table(self, row: int, axes: list[int], values: list[float]) -> None:
        """ET[row]: slave positions at master position start + row * interval."""
        if not 0 <= row < TABLE_POINTS:
            raise GalilError(TC.ECAM_INDEX)
        self.table[row, axes] = values

    def enable(self, on: bool) -> None:
        """EB 1 / EB 0 (which disengages every slave at once)."""
        if on:
            self.check_master()
            self._prev = self._reading()
        else:
            self.release_all()
        self.enabled = on

    def release_all(self) -> None:
        """Every slave disengaged at once (EB 0, AB)."""
        self._release(np.flatnonzero(self.engaged))
        self.engage_at[:] = np.nan
        self.disengage_at[:] = np.nan

    def engage(self, axes: list[int], positions: list[float]) -> None:
        """EG: engage when the master passes `positions` (outside the cycle: now)."""
        if not self.enabled:
            raise GalilError(TC.EB1_FIRST)
        self.check_master()
        if self.master in axes:
            raise GalilError(TC.NOT_VALID_PERFORMING_ECAM, "the master is no slave")
        cycle = self.master_cycle
        p = self._reading()
        now = []
        for a, x in zip(axes, positions, strict=True):
            if x < 0 or x >= cycle or np.mod(p, cycle) == x:
                now.append(a)
            else:
                self.engage_at[a] = x
        if now:
            self._engage(np.asarray(now, dtype=np.int64))

    def disengage(self, axes: list[int], positions: list[float]) -> None:
        """EQ: disengage when the master passes `positions` (outside the cycle: now)."""
        if not self.enabled:
            raise GalilError(TC.EB1_FIRST)
        cycle = self.master_cycle
        now = []
        for a, x in zip(axes, positions, strict=True):
            self.engage_at[a] = np.nan
            if x < 0 or x >= cycle:
                now.append(a)
            elif self.engaged[a]:
                self.disengage_at[a] = x
        self._release(np.asarray(now, dtype=np.int64))

    def _reading(self) -> float:
        """The master's main encoder; N's commanded position (it has no encoder)."""
        if self.virtual is not None and self.master == self.motion.n:
            return self.virtual.position()
        return float(self.motion.position()[self.master])

    def _engage(self, idx: np.ndarray) -> None:
        idx = idx[~self.engaged[idx]]
        self.engaged[idx] = True
        self.engage_at[idx] = np.nan
        self.motion.stop_code[idx] = SC_RUNNING

    def _release(self, idx: np.ndarray) -> None:
        idx = idx[self.engaged[idx]]
        self.engaged[idx] = False
        self.disengage_at[idx] = np.nan
        self.motion.stop_code[idx] = SC_STOPPED

    def positions(self, p: float, idx: np.ndarray) -> np.ndarray:
        """The table at master reading `p` (within the cycle) for the slaves `idx`, linear
        between points, flat before the first and after the last."""
        u = (p - self.start) / self.interval
        i = int(min(max(np.floor(u), 0), TABLE_POINTS - 2))
        f = min(max(u - i, 0.0), 1.0)
        rows = self.table[i:i + 2][:, idx]
        return rows[0] + (rows[1] - rows[0]) * f

    def _wrap(self, p: float) -> float:
        """At the end of a cycle the positions are redefined: the master's by its cycle, each
        engaged slave's by its change per cycle, in the table's direction [M Ch6 Step 2]; the
        motion goes on. Returns the master's reading after."""
        cycle = self.master_cycle
        turns = np.floor(p / cycle)
        if not turns:
            return p
        idx = np.flatnonzero(self.engaged)
        last = min(int(round(cycle / self.interval)), TABLE_POINTS - 1)
        direction = np.where(self.table[last, idx] < self.table[0, idx], -1.0, 1.0)
        axes = np.concatenate(([self.master], idx)).astype(np.int64)
        counts = -turns * np.concatenate(([cycle], np.abs(self.cycle[idx]) * direction))
        if self.virtual is not None and self.master == self.motion.n:  # N redefines its own
            self.virtual.shift(float(counts[0]))
            self.motion.core.shift_position(axes[1:], counts[1:])
        else:
            self.motion.core.shift_position(axes, counts)
        if self.on_redefine is not None:
            self.on_redefine(axes, counts)
        self._prev -= turns * cycle
        return p - turns * cycle

    def _crossed(self, marks: np.ndarray, p: float) -> np.ndarray:
        """Which finite `marks` (positions within the cycle) the master passed since the last
        sample, in either direction."""
        cycle = self.master_cycle
        ok = np.isfinite(marks)
        m = np.where(ok, marks, 0.0)
        return ok & (np.floor((p - m) / cycle) != np.floor((self._prev - m) / cycle))

    def step(self) -> None:
        """Before a sample: pending engagements and disengagements, then the slaves' commanded
        positions from the table at the master's reading."""
        p = self._wrap(self._reading())
        if np.isfinite(self.engage_at).any():
            hit = self._crossed(self.engage_at, p)
            if hit.any():
                self._engage(np.flatnonzero(hit))
        if np.isfinite(self.disengage_at).any():
            hit = self._crossed(self.disengage_at, p)
            if hit.any():
                self._release(np.flatnonzero(hit))
        self._prev = p
        idx = np.flatnonzero(self.engaged)
        if not len(idx):
            return
        core = self.motion.core
        delta = self.positions(p, idx) - core.axes.cmd_pos[idx]
        if delta.any():
            core.profile.shift_many(idx, delta)
