"""What the MAXk does with an axis's incremental encoder besides counting [S §4.7, §4.8, §2.13;
spec oms.md §5.3-5.5]: index pulses, slip and stall detection, servo runaway, and position
maintenance of steppers with encoder.

- Index pulses are at encoder counts phase + k·period of the stage (the axis world's `index`,
  backdoor `set_index`; one per 4096 counts from 0 when it gives none): physical counts, which
  LP and home searches do not move (`place_index`, `renumbered`). They are looked for only on
  axes that need them (HI home mode, an index capture), a few numpy calls per tick.
- Encoder home logic [S §4.3, §4.8]: the phase A/B levels follow from the count, x4 quadrature
  [S §4.7], counted from the index: the index pulse is one quadrature cycle wide (4 counts, an
  ungated index) and its first count is A high, B low, the manual's default home quadrant, then
  A high B high, A low B high, A low B low (A leads B on a positive move). `HT`/`EH` (params.py)
  say which levels of A, B and the index are home; during an HI search the first count in the
  direction of travel where they hold is found in closed form, per axis (`first_home_count`).
- The home condition the firmware sees [S §4.3, §4.8] is one: HS the switch; HI the truth table,
  the switch term (`switch_holds`) AND the encoder terms at a count (`first_home_count`). A
  search stops where it holds (motion.py), EA char 5 reports it where the axis stands
  (`home_condition`), and an index capture in HI mode records the count where the encoder terms
  begin to hold (`first_rise_count`: the "encoder home event" of Table 3-6) with the switch term
  holding; in HS mode the encoder's home event is its index pulse.
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

from vdevd.devices.oms.params import HOME_IGNORED, Params
from vdevd.rt import MotionCore
from vdevd.rt.axes import AxisFlag

RUNAWAY = 32768  # "if the error is greater than 32768, the controller will disable the PID"
_FE_TRIP = int(AxisFlag.FE_TRIP)
INDEX_WIDTH = 4  # counts: the index pulse spans one quadrature cycle
#: phase A and phase B levels in the four quadrature states of a cycle, counted from the index
PHASE_A = np.array([1, 1, 0, 0])
PHASE_B = np.array([0, 1, 1, 0])
_STATES = np.arange(4)
#: the card's index pulses when the axis world gives none: one every 4096 counts from 0
DEFAULT_INDEX = (4096.0, 0.0)
#: the period of "no index pulse" (set_index period 0): the nearest pulse is 2**43 counts away,
#: beyond any position the 32-bit counters reach
NO_INDEX = float(2**44)


def first_home_count(place: np.ndarray, down: np.ndarray, period: np.ndarray,
                     pattern: np.ndarray) -> np.ndarray:
    """Per axis, how many counts the axis moves (down where `down`, else up) from a count at
    `place` in its index period (0 = the index count, whole counts) to the first count where
    the encoder terms of `pattern` (rows A, B, index, ...: 1 active, 0 inactive, 2 ignored)
    hold: 0 where they hold at once, inf where no count of the period qualifies. A count's
    quadrature state is its place mod 4, it is inside the index pulse for places 0-3; the
    candidates are the next count in each of the four states, vectorised over axes."""
    q = _STATES[None, :]
    r0, per, dn = place[:, None], period[:, None], down[:, None]
    a, b, index = pattern[:, 0, None], pattern[:, 1, None], pattern[:, 2, None]
    ok = ((a == 2) | (a == PHASE_A[None, :])) & ((b == 2) | (b == PHASE_B[None, :])) & (q < per)
    # the next count in state q anywhere in the period; across the period's end the cycle
    # starts again at the index (the states run on when the period is a multiple of 4)
    up = np.mod(q - r0, 4)
    up_wrap = r0 + up >= per
    top = per - 1 - np.mod(per - 1 - q, 4)  # the period's last count in state q
    below = np.mod(r0 - q, 4)
    down_wrap = r0 - below < 0
    steps = np.where(dn, np.where(down_wrap, r0 + per - top, below),
                     np.where(up_wrap, per - r0 + q, up))
    place_hit = np.where(dn, np.where(down_wrap, top, r0 - below),
                         np.where(up_wrap, q, r0 + up))
    # index inactive: a count in the pulse moves on to the next one in the same state
    inside = (index == 0) & (place_hit < INDEX_WIDTH)
    steps = np.where(inside, np.where(dn, steps + place_hit + per - top, steps + 4), steps)
    ok &= ~inside | np.where(dn, top >= INDEX_WIDTH, q + 4 < per)
    # index active: the count in state q of the pulse (this one's, else the next pulse's)
    steps = np.where(index == 1, np.where(dn, np.mod(r0 - q, per), np.mod(q - r0, per)), steps)
    return np.asarray(np.where(ok, steps, np.inf).min(axis=1))


def switch_holds(entry: np.ndarray, active: np.ndarray) -> np.ndarray:
    """Where the home switch term of the truth table holds [S §4.8]: entry 2 (ignored), 1 with
    the switch active, 0 with it inactive."""
    return (entry == HOME_IGNORED) | (active == (entry == 1))


def _walk(place: np.ndarray, down: np.ndarray, period: np.ndarray,
          steps: np.ndarray) -> np.ndarray:
    """The place in the index period `steps` counts on from `place` in the direction of travel."""
    return np.asarray(np.mod(place + np.where(down, -steps, steps), period))


def _failing(pattern: np.ndarray) -> np.ndarray:
    """Per encoder term t (rows A, B, index) a table of that term alone at the level where it
    fails (the others ignored), per axis: shape (3, n, 4)."""
    n = len(pattern)
    terms = np.arange(3)
    single = np.full((3, n, 4), HOME_IGNORED, dtype=pattern.dtype)
    single[terms, :, terms] = 1 - pattern[:, :3].T
    return single


def first_rise_count(place: np.ndarray, down: np.ndarray, period: np.ndarray,
                     pattern: np.ndarray) -> np.ndarray:
    """Per axis, how many counts the axis moves from `place` (where it stands, not counted) to
    the first count where the encoder terms of `pattern` begin to hold: they hold there and not
    at the count before it (1 = the next count; inf: never). From a count where they hold, the
    axis first has to reach one where a term not ignored fails. Built on first_home_count, the
    search the HI homing uses (one call of 5 rows per axis, a second from inside the counts
    where the terms hold)."""
    n = len(place)
    one = _walk(place, down, period, np.ones(n))
    rows = np.concatenate([pattern[None], pattern[None], _failing(pattern)]).reshape(5 * n, 4)
    found = first_home_count(np.concatenate([one, place, one, one, one]), np.tile(down, 5),
                             np.tile(period, 5), rows).reshape(5, n)
    steps, held = found[0], found[1] == 0
    leave = np.where(pattern[:, :3].T == HOME_IGNORED, np.inf, found[2:]).min(axis=0)
    inside = held & (steps == 0)  # still where the terms hold: wait for a term to fail
    if inside.any():
        finite = np.isfinite(leave)
        k = np.where(inside & finite, leave, 0.0)
        again = k + first_home_count(_walk(one, down, period, k), down, period, pattern)
        steps = np.where(inside, np.where(finite, again, np.inf), steps)
    return np.asarray(steps + 1.0)


class Encoders:
    """The encoder features of one card's axes over its motion core."""

    def __init__(self, core: MotionCore, params: Params) -> None:
        n = params.n
        self.core = core
        self.params = params
        # index pulses [S §4.8]
        self.index_period = np.full(n, DEFAULT_INDEX[0])
        self.index_phase = np.full(n, DEFAULT_INDEX[1])
        #: the raw encoder count less the stage's physical one: what LP and home searches
        #: shifted (the pulses stay on the stage, `place_index`)
        self.enc_zero = np.zeros(n)
        self.index_watch = np.zeros(n, dtype=bool)
        self.watching = False
        self.index_hit = np.zeros(n, dtype=bool)  # an index pulse passed in the last tick
        self.index_at = np.zeros(n)  # its encoder count
        self._enc_prev = np.zeros(n)
        self.tick_start = np.zeros(n)  # the encoder count before the last tick (watched axes)
        # home_rise: per axis the next count where the encoder terms begin to hold from the
        # count `_rise_from` on, both times the direction `_rise_sign` (0: none known), for
        # the table, period and phase of the key
        self._rise_next = np.zeros(n)
        self._rise_from = np.zeros(n)
        self._rise_sign = np.zeros(n)
        self._rise_key = (params.home_pattern.copy(), self.index_period.copy(),
                          self.index_phase.copy())
        # the encoder terms of the home logic (HT/EH) during an HI search
        self.home_hit = np.zeros(n, dtype=bool)  # they held at a count passed in the last tick
        self.home_at = np.zeros(n)  # the first such count
        # slip, stall, runaway, amplifier fault: what was already reported
        self._tripped = np.zeros(n, dtype=bool)
        self._faulted = np.zeros(n, dtype=bool)
        # position maintenance
        self.maintained = np.zeros(n, dtype=bool)
        self.maintaining = False

    # -- index pulses ----------------------------------------------------------------------------
    def place_index(self, a: int, period: float, phase: float) -> None:
        """Axis a's index pulses at the stage's physical encoder counts phase + k·period (the
        axis world, backdoor `set_index`); period 0: none."""
        if period > 0:
            self.index_period[a], self.index_phase[a] = period, phase + self.enc_zero[a]
        else:
            self.index_period[a], self.index_phase[a] = NO_INDEX, NO_INDEX / 2 + self.enc_zero[a]

    def watch_index(self, mask: np.ndarray) -> None:
        """Look for index pulses on the axes of `mask` from now on."""
        new = mask & ~self.index_watch
        self._enc_prev[new] = self.core.axes.encoder[new]
        self.index_watch[:] = mask
        self.watching = bool(mask.any())
        if not self.watching:
            self.index_hit[:] = False

    def step_index(self, homing: np.ndarray | None = None) -> None:
        """After a tick: which watched axes passed an index pulse, and at which count; for the
        axes of `homing` (HI searches) also the first count passed where the encoder terms of
        the home logic held (`home_hit`, `home_at`)."""
        enc = self.core.axes.encoder
        period, phase = self.index_period, self.index_phase
        k_now = np.floor((enc - phase) / period)
        k_prev = np.floor((self._enc_prev - phase) / period)
        np.logical_and(self.index_watch, k_now != k_prev, out=self.index_hit)
        np.multiply(np.maximum(k_now, k_prev), period, out=self.index_at)
        self.index_at += phase
        if homing is not None:
            moved = enc - self._enc_prev
            down = moved < 0
            first = self._enc_prev + np.where(down, -1.0, 1.0)  # the first count passed
            steps = self.home_steps(first, down)
            np.logical_and(homing, steps < np.abs(moved), out=self.home_hit)
            self.home_at[:] = np.where(self.home_hit, np.where(down, -steps, steps) + first, 0.0)
        self.tick_start[...] = self._enc_prev
        self._enc_prev[:] = enc

    def _places(self, counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(place in the index period, the period) of encoder `counts`, per axis."""
        period = np.maximum(np.rint(self.index_period), 1.0)
        return np.mod(np.floor(counts - self.index_phase), period), period

    def home_steps(self, counts: np.ndarray, down: np.ndarray) -> np.ndarray:
        """How far each axis moves from encoder `counts` to the next count where the encoder
        terms of its home truth table hold (first_home_count)."""
        place, period = self._places(counts)
        return first_home_count(place, down, period, self.params.home_pattern)

    def home_condition(self, hi: np.ndarray, switch_active: np.ndarray) -> np.ndarray:
        """The home condition each axis's firmware sees where it stands [S §4.3, §4.8]: HS the
        switch active; HI (`hi`) its truth table, the switch term and the encoder terms at the
        present count (EA char 5)."""
        table = switch_holds(self.params.home_pattern[:, 3], switch_active) & self.terms_here()
        return np.where(hi, table, switch_active)

    def terms_here(self) -> np.ndarray:
        """Axes whose encoder terms of the home logic hold at the count where they stand."""
        enc = self.core.axes.encoder.astype(float)
        return np.asarray(self.home_steps(enc, np.zeros(len(enc), dtype=bool)) == 0)

    def home_rise(self, axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Axes of `axes` (watched: `watch_index`) whose encoder terms of the home logic began
        to hold at a count passed in the last tick (first_rise_count), and that count (the
        first such; 0 elsewhere). Where the terms begin to hold depends only on the count and
        the direction, so the next such count is kept while the axis runs on toward it and
        looked for again once passed, on a reversal, or for a new table or index."""
        enc, start = self.core.axes.encoder, self.tick_start
        moved = enc - start
        moving = axes & (moved != 0)
        if not moving.any():
            return moving, np.zeros(len(enc))
        sign = np.sign(moved)
        p, key = self.params.home_pattern, self._rise_key
        if ((key[0] != p).any() or (key[1] != self.index_period).any()
                or (key[2] != self.index_phase).any()):
            self._rise_key = (p.copy(), self.index_period.copy(), self.index_phase.copy())
            self._rise_sign[:] = 0.0
        # in the direction of travel: the start, where the next rise was looked for, and it
        here, nxt = start * sign, self._rise_next
        known = (sign == self._rise_sign) & (here >= self._rise_from) & (here < nxt)
        stale = moving & ~known
        if stale.any():
            place, period = self._places(start)
            found = here + first_rise_count(place, sign < 0, period, p)
            np.copyto(nxt, found, where=stale)
            np.copyto(self._rise_from, here, where=stale)
            np.copyto(self._rise_sign, sign, where=stale)
        hit = moving & (nxt - here <= np.abs(moved))
        return hit, np.where(hit, nxt, 0.0) * sign  # (nxt may be inf where no hit)

    def home_here(self, axes: np.ndarray) -> np.ndarray:
        """Axes of `axes` whose encoder terms of the home logic hold where they stand (a search
        that starts there is home at once: the logic is level-based); `home_at` their count."""
        here = axes & self.terms_here()
        self.home_at[here] = self.core.axes.encoder[here]
        return here

    def renumbered(self, a: int, shift: float) -> None:
        """Axis a's counts moved by `shift` (a home search): the index pulses stay where they
        are on the axis."""
        counts = shift * float(self.core.encoder_scale[a])
        self.index_phase[a] += counts
        self.enc_zero[a] += counts
        self.tick_start[a] += counts
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
