"""Coordinated motion of the DMC-13X8: the S and T coordinate planes over the axis firmware
(manual ch. 6 "Linear Interpolation Mode", "Vector Mode", "Specifying the Coordinate Plane").

A `Plane` holds its mode (LM axes, or VM's pair and tangent axis), VS VA VD VR VT, TN and the
`vector.Sequence` of its segments. While a plane runs, `Coordinated.sample()` moves the path one
sample and feeds the axes their commanded positions through `MotionCore.track` (the profile
generator then runs them in a straight line to that point at the next tick); at the end they
hold the last point exactly (`MotionCore.hold`). The virtual axis N may be one of VM's pair: it
takes part in the path and drives no motor; the path drives N's own commanded position
(virtual.py) from where N stands at BGS [M Ch6 §Virtual Axis]. Stop codes (spec §4.4): 100
while a sequence runs, 101 when it ended at its last vector, 4 after ST, 2/3 at a limit switch,
7 after AB, 6 at the abort input.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.galil import AxisStatus

from vdevd.devices.galil.motion import StopCode
from vdevd.devices.galil.vector import MAX_LENGTH, Sequence

if TYPE_CHECKING:
    from vdevd.devices.galil.motion import GalilMotion
    from vdevd.devices.galil.virtual import VirtualAxis

#: FL/BL at (or beyond) the position range: no soft limit (their defaults, 2147483647 and its
#: negative [spec §4.5])
_NO_SOFT_LIMIT = 2147483647
VIRTUAL = -1  # the N axis: no encoder, no DAC [M Ch6 §Virtual Axis]
SC_VECTOR_RUNNING = 100  # "motors running in vector sequence" (spec §4.4)
SC_VECTOR_DONE = 101  # "motors stopped at commanded vector" (spec §4.4)
#: the coordinated move status word of the data record (spec §2.5)
MOVE_IN_PROGRESS, MOVE_SLEWING, MOVE_STOPPING, MOVE_FINAL_DECEL = 1 << 15, 1 << 5, 1 << 4, 1 << 3
_COORDINATED = int(AxisStatus.COORDINATED)


class Plane:
    """One coordinate plane (S or T) with its settings and its sequence."""

    def __init__(self, name: str, dt: float) -> None:
        self.name = name
        self.dt = dt
        self.mode: str | None = None  # "LM" or "VM"
        self.axes: tuple[int, ...] = ()  # the path's axes (VIRTUAL for N)
        self.tangent: int | None = None  # VM's third axis
        self.tn_scale = 0.0  # TN m: counts per degree
        self.tn_offset = 0.0  # TN n: the tangent position at 0 degrees
        self.es = (1.0, 1.0)  # ES m,n: the counts of VM's two axes for one path unit each
        self._scale: list[float] = []  # per real axis of `track`: the ES factor taken at BGS
        self.vs, self.va, self.vd, self.vr, self.vt = 25_000.0, 256_000.0, 256_000.0, 1.0, 1.0
        self.seq = Sequence(1, dt)
        self.running = False
        self.stop_code = SC_VECTOR_RUNNING  # the code the axes get when the motion ends
        self.origin = np.zeros(0)  # the commanded positions of `track` at BGS (local zero)
        self.origin_list: list[float] = []
        self.track: list[int] = []  # the card's axes the path drives (and the tangent axis)
        self.track_idx = np.zeros(0, dtype=np.int64)
        self._dims: list[int] = []  # the path coordinate of each real axis of `track`
        self.virtual_dim: int | None = None  # the path coordinate of N while it runs
        self.virtual_origin = 0.0  # N's commanded position at BGS, less its redefinitions
        self.tracking = False
        self.soft = False  # a soft limit (FL/BL) is set on one of `track`'s axes at BGS
        #: the distance along the path this plane has ever travelled (a follower geared to the
        #: plane, `GA S`, follows its increments: a new sequence does not move it back)
        self.travelled = 0.0
        self._last_out = 0.0

    def set_mode(self, mode: str, axes: tuple[int, ...], tangent: int | None = None) -> None:
        """LM or VM: a new mode clears the sequence."""
        self.mode, self.axes, self.tangent = mode, axes, tangent
        self.seq = Sequence(len(axes), self.dt)

    def dim_scale(self) -> list[float]:
        """Per path coordinate, what ES multiplies it by: in vector mode the higher-resolution
        axis by the ratio of the two counts, so that the path is in the lower resolution's
        counts [M Ch6 §Compensating for Differences in Encoder Resolution]; 1 otherwise."""
        if self.mode != "VM" or len(self.axes) != 2:
            return [1.0] * len(self.axes)
        low = min(self.es)
        return [self.es[0] / low, self.es[1] / low]

    def fresh(self) -> Sequence:
        """The sequence new segments go into: a finished one gives way to a new one (its own
        local zero, segment count and length) [M Ch6 §Specifying Vector Segments]."""
        if self.seq.done:
            self.seq = Sequence(len(self.axes), self.dt)
        return self.seq

    def tangent_position(self, heading: float) -> float:
        """TN: the tangent axis at the path direction `heading` (radians) [M Ch6 §Tangent
        Motion]."""
        return self.tn_offset + self.tn_scale * math.degrees(heading)

    def initial_tangent(self) -> float:
        """_TN: the tangent axis's position for the first segment's direction, the angle taken
        in [0, 360) degrees."""
        angle = math.degrees(self.seq.first_heading) % 360.0 if self.seq.count else 0.0
        return float(round(self.tn_offset + self.tn_scale * angle))

    def move_status(self) -> int:
        """The coordinated move status of the data record (spec §2.5)."""
        if not self.running:
            return 0
        seq, s = self.seq, 0
        if seq.stopping:
            s |= MOVE_STOPPING
        elif seq.v > 0 and abs(seq.v - self.vs * self.vr) < 1e-9:
            s |= MOVE_SLEWING
        return s | MOVE_IN_PROGRESS


class Coordinated:
    """The S and T planes of one card over its axis firmware."""

    def __init__(self, motion: GalilMotion, virtual: VirtualAxis | None = None) -> None:
        self.motion = motion
        self.virtual = virtual  # the N axis a VM plane may drive
        self.core = motion.core
        self.n = motion.n
        self.planes = {"S": Plane("S", motion.dt), "T": Plane("T", motion.dt)}
        self.current = "S"  # CA: the plane vector commands address
        self.active = False  # a plane runs: the card is not at rest
        self._running: list[Plane] = []
        self._plans = -1  # the profile's plan count after the last track (nothing else planned)
        self._no_limits = bytes(motion.n)  # limit arrays with no switch active, as bytes

    @property
    def plane(self) -> Plane:
        return self.planes[self.current]

    # -- begin, stop, abort ------------------------------------------------------------------------
    def blocked(self, plane: Plane) -> bool:
        """Whether an axis of the first segment heads into an active limit switch [M Ch3]."""
        seg = plane.seq.segment(0)
        if seg.center is None:
            direction = [b - a for a, b in zip(seg.start, seg.end, strict=True)]
        else:
            sign = math.copysign(1.0, seg.dtheta)
            direction = [-math.sin(seg.theta0) * sign, math.cos(seg.theta0) * sign]
        m = self.motion
        for d, a in zip(direction, plane.axes, strict=True):
            if a != VIRTUAL and ((d > 0 and m.forward_limit[a]) or (d < 0 and m.reverse_limit[a])):
                return True
        return False

    def begin(self, plane: Plane) -> None:
        """BGS/BGT (the caller checked the sequence and the axes): the local zero is where the
        axes are [M Ch6 §Specifying Vector Segments]; SC 100 while the sequence runs."""
        core, m = self.core, self.motion
        real = [(d, a) for d, a in enumerate(plane.axes) if a != VIRTUAL]
        plane.track = [a for _, a in real]
        plane._dims = [d for d, _ in real]
        scale = plane.dim_scale()
        plane._scale = [scale[d] for d, _ in real]
        if plane.tangent is not None:
            plane.track.append(plane.tangent)
        plane.track_idx = np.asarray(plane.track, dtype=np.int64)
        plane.origin = np.rint(core.axes.cmd_pos[plane.track_idx])
        lim = core.limits
        plane.soft = bool((lim.soft_hi[plane.track_idx] < _NO_SOFT_LIMIT).any()
                          or (lim.soft_lo[plane.track_idx] > -_NO_SOFT_LIMIT).any())
        plane.origin_list = plane.origin.tolist()
        virtual = self.virtual
        plane.virtual_dim = None
        if virtual is not None and VIRTUAL in plane.axes:
            plane.virtual_dim = plane.axes.index(VIRTUAL)
            plane.virtual_origin = virtual.reference() - virtual.shifted  # N's redefinitions
            virtual.track(plane.virtual_origin)
        smoothing = round(1.0 / plane.vt) if plane.vt > 0 else 1
        plane.seq.ratio = plane.vr
        plane.seq.start(smoothing)
        plane.running, plane.tracking = True, True
        plane._last_out = plane.seq.out
        plane.stop_code = SC_VECTOR_DONE
        idx = plane.track_idx
        m.stop_code[idx] = SC_VECTOR_RUNNING
        m.stop_reason[idx] = 0
        core.track(plane.track, plane.origin)  # moving from now on: BG of an axis is TC 21
        m._moving_prev[idx] = True  # the axes' end is an end of motion (EI, AM)
        self._refresh()

    def stop(self, plane: Plane, code: int = StopCode.STOP_COMMAND) -> None:
        """ST S: decelerate along the path at VD; the rest of the sequence is dropped."""
        if plane.running and not plane.seq.stopping:
            plane.seq.stopping = True
            plane.stop_code = code
            self.motion.stop_code[plane.track_idx] = code  # "decelerating or stopped by ST"

    def abort(self) -> None:
        """AB: every running sequence ends where it is (the axes' abort stops them)."""
        for plane in self._running:
            self._end(plane)

    def planes_named(self, s: bool, t: bool) -> list[Plane]:
        return [p for p, on in ((self.planes["S"], s), (self.planes["T"], t)) if on]

    def plane_of(self, axis: int) -> Plane | None:
        """The running plane that drives `axis`."""
        for plane in self._running:
            if axis in plane.track:
                return plane
        return None

    # -- the sample --------------------------------------------------------------------------------
    def sample(self) -> None:
        """Before the motion of a sample: every running plane feeds its axes the next point, all
        in one `track` (the same axes every sample take its cheap step)."""
        axes: list[int] = []
        targets: list[float] = []
        m, prof = self.motion, self.core.profile
        replanned = prof.plans != self._plans  # something but the path planned: look at the axes
        none = self._no_limits
        limits = m.forward_limit.tobytes() != none or m.reverse_limit.tobytes() != none
        for plane in self._running:
            target = self._sample(plane, replanned, limits)
            if target is not None:
                axes += plane.track
                targets += target
        if axes:
            self.core.track(axes, targets)
        self._plans = prof.plans

    def _sample(self, plane: Plane, replanned: bool, limits: bool) -> list[float] | None:
        """The plane's next point for its axes; None when its motion ended here."""
        core, m = self.core, self.motion
        idx = plane.track_idx
        if replanned and plane.tracking and not core.profile.moving[idx].all():
            self._cut(plane)  # AB, the abort input, MO, an off-on-error or amplifier fault
            return None
        if limits and not plane.seq.stopping:
            vel = core.axes.cmd_vel[idx]
            fwd, rev = m.forward_limit[idx] & (vel > 0), m.reverse_limit[idx] & (vel < 0)
            if fwd.any() or rev.any():  # a limit switch: a decelerated stop [M Ch3]
                self.stop(plane, StopCode.FORWARD_LIMIT if fwd.any() else StopCode.REVERSE_LIMIT)
        if plane.soft and not plane.seq.stopping:
            # FL/BL: an axis whose commanded position has passed its soft limit, heading on,
            # stops the path at VD as a limit switch does [spec §4.5]
            pos, vel, lim = core.axes.cmd_pos[idx], core.axes.cmd_vel[idx], core.limits
            fwd = (pos > lim.soft_hi[idx]) & (vel > 0)
            rev = (pos < lim.soft_lo[idx]) & (vel < 0)
            if fwd.any() or rev.any():
                self.stop(plane, StopCode.FORWARD_LIMIT if fwd.any() else StopCode.REVERSE_LIMIT)
        seq = plane.seq
        seq.ratio = plane.vr
        more = seq.advance(plane.vs * plane.vr, plane.va, plane.vd)
        if seq.speed is not None:
            plane.vs = seq.speed  # `<n` is VS n from its segment on [M Ch6]
        plane.travelled += seq.out - plane._last_out
        plane._last_out = seq.out
        pos = seq.position()
        target = [o + k * pos[d]
                  for o, d, k in zip(plane.origin_list, plane._dims, plane._scale, strict=False)]
        if plane.tangent is not None:
            target.append(plane.tangent_position(seq.heading()))
        vd = plane.virtual_dim
        if vd is not None and self.virtual is not None:
            n_at = plane.virtual_origin + self.virtual.shifted + pos[vd]
            if more:
                self.virtual.track(n_at)
            else:
                self.virtual.hold(round(n_at) if plane.stop_code == SC_VECTOR_DONE else n_at)
        if more:
            return target
        code = plane.stop_code
        m.stop_reason[idx] = code
        m.stop_code[idx] = code
        core.hold(plane.track, np.rint(target) if code == SC_VECTOR_DONE else target)
        self._end(plane)
        return None

    def _cut(self, plane: Plane) -> None:
        """An axis of the plane stopped under it: the others stop where they are, with that
        axis's stop code (7, aborted, when it has none of its own, e.g. after MO)."""
        core, m, idx = self.core, self.motion, plane.track_idx
        stopped = idx[~core.profile.moving[idx]]
        codes = [c for c in m.stop_code[stopped].tolist() if c != SC_VECTOR_RUNNING]
        code = codes[0] if codes else int(StopCode.ABORT_COMMAND)
        m.stop_code[stopped[m.stop_code[stopped] == SC_VECTOR_RUNNING]] = code
        going = idx[core.profile.moving[idx]]
        if len(going):
            m.stop_reason[going] = code
            m.stop_code[going] = code
            core.hold(going)
        self._end(plane)

    def _end(self, plane: Plane) -> None:
        if plane.virtual_dim is not None and self.virtual is not None and self.virtual.path:
            self.virtual.hold()  # cut or aborted: N stops where the path left it
        plane.virtual_dim = None
        plane.running = plane.tracking = False
        plane.seq.done = True
        self._refresh()

    def _refresh(self) -> None:
        self._running = [p for p in self.planes.values() if p.running]
        self.active = bool(self._running)

    # -- what the card reports ---------------------------------------------------------------------
    def status_bits(self) -> np.ndarray:
        """Axis status bit 8, coordinated motion, on the axes of a running plane."""
        s = np.zeros(self.n, dtype=np.int64)
        for plane in self._running:
            s[plane.track_idx] = _COORDINATED
        return s

    def operand(self, name: str) -> float | None:
        """The coordinated operands (_LM _CS _AV _LE _VE _VPm _TN _BGS, with an optional plane
        letter), or None when `name` is none of them [M Ch6 Operand Summaries]."""
        key, rest = name[:2], name[2:]
        if key not in _OPERANDS and name != "BGS" and name != "BGT":
            return None
        if name in ("BGS", "BGT"):
            return float(self.planes[name[2]].running)
        if key == "VP":
            if len(rest) != 1 or rest not in _AXIS_LETTERS:
                return None
            return self._vp(_AXIS_LETTERS.index(rest) % 4)
        if rest not in ("", "S", "T"):
            return None
        plane = self.planes[rest] if rest else self.plane
        seq = plane.seq
        if key == "LM":
            return float(seq.free)
        if key == "CS":
            return float(seq.completed)
        if key == "AV":
            return float(round(seq.out))
        if key in ("LE", "VE"):
            return float(round(seq.total) % int(MAX_LENGTH + 1))
        return plane.initial_tangent()  # TN

    def _vp(self, axis: int) -> float:
        """_VPm: the axis's coordinate at the last intersection of its plane's path (the CA
        plane's, else the other's), absolute (the local zero of BGS added) [M Ch6 Operand
        Summary]."""
        plane = self.plane
        if axis not in plane.axes:  # the other plane's axis, or none's
            plane = self.planes["T" if self.current == "S" else "S"]
            if axis not in plane.axes:
                return 0.0
        d = plane.axes.index(axis)
        local = plane.seq.intersection()[d]
        origin = 0.0
        if plane.seq.started and axis in plane.track:
            origin = float(plane.origin[plane.track.index(axis)])
        return float(round(origin + local))


_OPERANDS = ("LM", "CS", "AV", "LE", "VE", "VP", "TN")
_AXIS_LETTERS = "XYZWABCD"
