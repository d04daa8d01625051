"""What the MAXk does with an axis's incremental encoder besides counting [S §4.7, §4.8, §2.13;
spec oms.md §5.3-5.5]: index pulses, slip and stall detection, servo runaway, and position
maintenance of steppers with encoder.

- Index pulses are at encoder counts phase + k·period (backdoor `set_index`); they are looked for
  only on axes that need them (a home search in HI mode, an index capture), a few numpy calls
  per tick.
- Slip/stall: |encoder − ratio·motor| beyond the tolerance ES (encoder counts, factory 0 = off).
  It is the core's following-error limit: on a stepper (PSE) the following error is the slip in
  motor counts (the steps follow the command exactly, the encoder may not), on a servo (PSM) the
  following error itself (a stall). A servo whose error passes 32768 counts runs away: the card
  "will disable the PID" [S §2.13 L451]. Both cost the core's three ufunc calls per tick while
  enabled (always on a card with servo axes, for the runaway).
- Position maintenance (PSE with CL1): at rest with a target, when the encoder is more than HD
  counts from target·ratio the motor is moved by the difference at min(HV, HG·|error|) counts/s
  (HV 0: no correction). The target stays the host's (a correction is not a new target).
"""

from __future__ import annotations

import math

import numpy as np

from vdevd.devices.oms.params import Params
from vdevd.rt import MotionCore
from vdevd.rt.axes import AxisFlag

RUNAWAY = 32768  # "if the error is greater than 32768, the controller will disable the PID"
_FE_TRIP = int(AxisFlag.FE_TRIP)


class Encoders:
    """The encoder features of one card's axes over its motion core."""

    def __init__(self, core: MotionCore, params: Params) -> None:
        n = params.n
        self.core = core
        self.params = params
        # index pulses [S §4.8]
        self.index_period = np.full(n, 4096.0)
        self.index_phase = np.zeros(n)
        self.index_watch = np.zeros(n, dtype=bool)
        self.watching = False
        self.index_hit = np.zeros(n, dtype=bool)  # an index pulse passed in the last tick
        self.index_at = np.zeros(n)  # its encoder count
        self._enc_prev = np.zeros(n)
        # slip, stall, runaway, amplifier fault: what was already reported
        self._tripped = np.zeros(n, dtype=bool)
        self._faulted = np.zeros(n, dtype=bool)
        # position maintenance
        self.maintained = np.zeros(n, dtype=bool)
        self.maintaining = False

    # -- index pulses ----------------------------------------------------------------------------
    def watch_index(self, mask: np.ndarray) -> None:
        """Look for index pulses on the axes of `mask` from now on."""
        new = mask & ~self.index_watch
        self._enc_prev[new] = self.core.axes.encoder[new]
        self.index_watch[:] = mask
        self.watching = bool(mask.any())
        if not self.watching:
            self.index_hit[:] = False

    def step_index(self) -> None:
        """After a tick: which watched axes passed an index pulse, and at which count."""
        enc = self.core.axes.encoder
        period, phase = self.index_period, self.index_phase
        k_now = np.floor((enc - phase) / period)
        k_prev = np.floor((self._enc_prev - phase) / period)
        np.logical_and(self.index_watch, k_now != k_prev, out=self.index_hit)
        np.multiply(np.maximum(k_now, k_prev), period, out=self.index_at)
        self.index_at += phase
        self._enc_prev[:] = enc

    def renumbered(self, a: int, shift: float) -> None:
        """Axis a's counts moved by `shift` (a home search): the index pulses stay where they
        are on the axis."""
        self.index_phase[a] += shift * float(self.core.encoder_scale[a])
        self._enc_prev[a] = self.core.axes.encoder[a]

    # -- slip, stall and runaway ---------------------------------------------------------------------
    def apply_slip(self) -> None:
        """The core's following-error limits from ES, the axis types and the encoder ratio
        (after ES, PS, ER or a restore). A stepper's limit allows the encoder's own count of
        quantisation besides ES."""
        p = self.params
        es = p.values["ES"]
        ptype = np.array(p.ptype)
        ratio = self.core.encoder_scale
        stepper = np.where(es > 0, es / ratio + 1.0, 0.0)
        servo = np.where(es > 0, np.minimum(es, RUNAWAY), RUNAWAY)
        limit = np.where(ptype == "E", stepper, np.where(ptype == "M", servo, 0.0))
        self.core.set_fe_limit(slice(None), limit)

    def new_trips(self) -> np.ndarray:
        """Axes whose slip, stall or runaway was detected since the last call."""
        tripped = (self.core.axes.flags & _FE_TRIP) != 0
        new = np.flatnonzero(tripped & ~self._tripped)
        self._tripped[:] = tripped
        return new

    def runaway(self, a: int) -> bool:
        """A servo whose following error passed 32768 counts."""
        return self.params.ptype[a] == "M" and abs(float(self.core.axes.ferr[a])) > RUNAWAY

    def rearm(self, a: int) -> None:
        """A new motion command (or CL1): the slip detection of axis a looks again."""
        self.core.axes.flags[a] &= ~_FE_TRIP
        self._tripped[a] = False

    def new_amp_faults(self) -> np.ndarray:
        """Axes whose amplifier fault input became active since the last call."""
        fault = self.core.amp_fault
        new = np.flatnonzero(fault & ~self._faulted)
        self._faulted[:] = fault
        return new

    # -- position maintenance ---------------------------------------------------------------------
    def configure_maintenance(self) -> None:
        """Steppers with encoder (PSE) with the loop closed (CL1) hold their target."""
        p = self.params
        self.maintained[:] = np.array([t == "E" for t in p.ptype]) & p.closed_loop
        self.maintaining = bool(self.maintained.any())

    def maintain(self) -> None:
        """After a tick: correct the axes at rest outside the deadband HD."""
        core = self.core
        idle = self.maintained & core.target_valid & ~core.profile.moving & ~self._tripped
        if not idle.any():
            return
        v = self.params.values
        goal = np.floor(core.target * core.encoder_scale)
        error = goal - core.axes.encoder
        out = idle & (np.abs(error) > v["HD"]) & (v["HV"] > 0)
        for a in np.flatnonzero(out).tolist():
            self._correct(a, float(error[a]))

    def _correct(self, a: int, error: float) -> None:
        core, v = self.core, self.params.values
        here = float(core.axes.cmd_pos[a])
        to = float(np.rint(here + error / float(core.encoder_scale[a])))
        if to == np.rint(here) or core.limits.blocked(a, to - here):
            return
        speed = min(float(v["HV"][a]), max(1.0, float(v["HG"][a]) * abs(error)))
        target = int(core.target[a])
        core.move_absolute(a, to, speed, v["AC"][a], v["AC"][a])
        core.target[a] = target  # the host's target, not the correction's

    def in_deadband(self, a: int) -> bool:
        """The encoder within HD counts of the target (of the motor position when the axis has
        no target: after a jog or a stop) [spec §4.2 EA char 4]."""
        core = self.core
        ref = float(core.target[a]) if core.target_valid[a] else float(np.rint(core.axes.cmd_pos[a]))
        goal = math.floor(ref * float(core.encoder_scale[a]) + 1e-9)
        return abs(goal - int(core.axes.encoder[a])) <= float(self.params.values["HD"][a])
