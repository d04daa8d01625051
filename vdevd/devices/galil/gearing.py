"""Electronic gearing and gantry mode of the DMC-13X8 [M Ch6 §Electronic Gearing; spec §4.5].

`GA` names each follower's master (its main encoder X..W, its commanded position CX..CW, its
auxiliary encoder DX..DW), `GR` the ratio (+-127.9999, resolution 0.0001; 0 disengages), `GM`
gantry mode (ST and limit switches do not disengage). Every sample a geared axis's commanded
position moves by GR x the master's change (spec §5.3): the increment shifts the follower's whole
plan, so a PR/JG of the follower is superimposed on the gearing [M Ch6]. Vectorised over axes.
"""

from __future__ import annotations

import enum
from collections.abc import Callable

import numpy as np

from vdevd.devices.galil.motion import GalilMotion
from vdevd.devices.galil.virtual import VirtualAxis
from vdevd.rt import PlantKind

#: GR: +-127.9999 with a fractional resolution of .0001 [M Ch6 §Electronic Gearing]
GR_LIMIT = 127.9999
GR_RESOLUTION = 1e-4


class Source(enum.IntEnum):
    """What of the master axis a follower follows (GA n) [M Ch6 §Command Summary - Gearing]."""

    NONE = 0
    ENCODER = 1  # X, Y, Z, W: the main encoder (TP)
    COMMANDED = 2  # CX ...: the commanded position (RP)
    AUXILIARY = 3  # DX ...: the auxiliary encoder (TD)


class Gearing:
    """The gearing state of one card's axes: master, source, ratio, gantry flag."""

    def __init__(self, motion: GalilMotion, virtual: VirtualAxis | None = None) -> None:
        n = motion.n
        self.motion = motion
        #: the virtual axis N, master number n (`GA N`): its commanded position for every
        #: source (it has no encoder) [M Ch6 §Virtual Axis]
        self.virtual = virtual
        self._readings = np.zeros((4, n + 3))
        #: the distances the planes S and T have travelled (masters n+1, n+2: `GA S`, `GA T`,
        #: gearing to coordinated motion [M Ch6 §Electronic Gearing, Command Summary]); the
        #: firmware connects it to its Coordinated planes
        self.planes: Callable[[], tuple[float, float]] | None = None
        self.master = np.full(n, -1, dtype=np.int64)
        self.source = np.zeros(n, dtype=np.int64)
        self.ratio = np.zeros(n)
        self.gantry = np.zeros(n, dtype=bool)
        self._base_master = np.zeros(n)  # the master's reading when the ratio last changed
        self._base_offset = np.zeros(n)  # the increment applied up to then
        self._applied = np.zeros(n)  # the gearing's total increment so far
        self._last = np.zeros(n)  # the master's reading `_applied` was computed from
        self._idx = np.zeros(0, dtype=np.int64)

    @property
    def active(self) -> bool:
        """Whether any axis follows a master now."""
        return bool(len(self._idx))

    def readings(self) -> np.ndarray:
        """Per axis, what a follower of it would follow, by source (rows: Source); column n is
        the virtual axis N, n+1 and n+2 the distances of the planes S and T (one buffer,
        rewritten at each call)."""
        m, r = self.motion, self._readings
        n = m.n
        r[1, :n], r[2, :n], r[3, :n] = m.position(), m.core.axes.cmd_pos, m.auxiliary()
        if self.virtual is not None:
            r[1:, n] = self.virtual.position()
        if self.planes is not None:
            s, t = self.planes()
            r[1:, n + 1], r[1:, n + 2] = s, t
        return r

    def set_master(self, axes: list[int], masters: list[int], sources: list[int]) -> None:
        """GA: the masters of `axes`; a follower already geared goes on from the new master's
        reading (no jump)."""
        self.master[axes] = masters
        self.source[axes] = sources
        self._refresh()
        idx = np.intersect1d(self._idx, axes)
        self._base_master[idx] = self._last[idx] = self._reading(idx)
        self._base_offset[idx] = self._applied[idx]

    def set_ratio(self, axes: list[int], ratios: list[float]) -> None:
        """GR: new ratios, on the fly: the follower goes on from where it is [M Ch6]."""
        self._rebase()
        self.ratio[axes] = ratios
        self._refresh()

    def disengage(self, axes: np.ndarray | list[int]) -> None:
        """GR 0 on `axes` (ST or a limit switch in standard mode, AB, GR 0)."""
        self._rebase()
        self.ratio[axes] = 0.0
        self._refresh()

    def stopped(self, axes: list[int]) -> None:
        """ST disengages gearing in standard mode, not in gantry mode [M Ch6]."""
        standard = [a for a in axes if not self.gantry[a]]
        if standard:
            self.disengage(standard)

    def redefined(self, axes: np.ndarray, counts: np.ndarray) -> None:
        """Positions of `axes` redefined by `counts` (command and encoder alike, the ECAM cycle's
        end): their followers go on without a jump."""
        idx = self._idx
        if not len(idx):
            return
        shift = np.zeros(self.motion.n + 3)  # [n]: the virtual axis N; [n+1], [n+2]: S, T
        shift[axes] = counts
        moved = shift[self.master[idx]]
        if self.motion.plant_kind != PlantKind.STEPPER:  # TD does not move on a servo axis
            moved = np.where(self.source[idx] == Source.AUXILIARY, 0.0, moved)
        self._base_master[idx] += moved
        self._last[idx] += moved

    def _rebase(self) -> None:
        """Make the present master readings the base of the increments that follow."""
        idx = self._idx
        if len(idx):
            self._base_master[idx] = self._last[idx]
            self._base_offset[idx] = self._applied[idx]

    def _reading(self, idx: np.ndarray) -> np.ndarray:
        return self.readings()[self.source[idx], self.master[idx]]

    def _refresh(self) -> None:
        was = self._idx
        engaged = (self.ratio != 0) & (self.master >= 0) & (self.source != Source.NONE)
        self._idx = np.flatnonzero(engaged)
        new = np.setdiff1d(self._idx, was)
        if len(new):
            self._base_master[new] = self._last[new] = self._reading(new)
            self._base_offset[new] = self._applied[new]

    def step(self) -> None:
        """Before a sample: each follower's commanded position moves by GR x the master's change
        since the last sample (a limit switch it heads into disengages it in standard mode)."""
        idx = self._idx
        m = self.motion
        reading = self._reading(idx)
        want = self._base_offset[idx] + self.ratio[idx] * (reading - self._base_master[idx])
        delta = want - self._applied[idx]
        blocked = ((m.forward_limit[idx] & (delta > 0)) | (m.reverse_limit[idx] & (delta < 0))) & \
            ~self.gantry[idx]
        if blocked.any():
            self.disengage(idx[blocked])
            keep = ~blocked
            idx, want, delta, reading = idx[keep], want[keep], delta[keep], reading[keep]
        self._last[idx] = reading
        if not len(idx) or not delta.any():
            return
        self._applied[idx] = want
        m.core.profile.shift_many(idx, delta)
