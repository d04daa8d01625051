"""The MAXk's axes over the numpy motion core (spec oms.md §5).

Open-loop steppers (PSO) and steppers with encoder (PSE) drive the core's stepper plant, servos
(PSM) its servo plant through the PID; `plant = "ideal"` makes every axis follow its command
exactly. Moves from rest follow the axis's profile (card option `profiles`: linear, parabolic or
S-curve, each with base velocity; profile.py): VB, AC, VL [S §2.14; spec §5.2]; a move that
starts while the axis runs is the core's trapezoid from there, whatever the profile. The limit
inputs are raw TTL levels; LTH/LTL give the active level, the limit mode (hard: stop at once;
soft: decelerate at AC; off: ignored) what a switch does [S §4.2]. Home searches: HM/HR/KM/KR run
at VL until the home condition (the switch; in HI mode the AND of the terms of the axis's home
truth table HT/EH that are not ignored: phase A, phase B, index, switch) and load the operand
into the position counter where it occurred [S §4.3, §4.8]. The card's
commanded position is whole counts: an axis whose stop ended between two counts holds the nearer
one (`hold_whole_counts`). Encoder features (slip, runaway, index pulses, position maintenance)
are in encoder.py.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vdevd.devices.oms import profile
from vdevd.devices.oms.encoder import Encoders, switch_holds
from vdevd.devices.oms.params import Params
from vdevd.devices.oms.servo import ServoLaw
from vdevd.rt import MotionCore, PlantKind
from vdevd.rt.axes import AxisFlag

_KIND = {"O": PlantKind.STEPPER, "E": PlantKind.STEPPER, "M": PlantKind.SERVO}
_DONE = int(AxisFlag.DONE)
#: the deceleration of a stop "without deceleration" (hard limit, KM/KR, counts/s^2): the axis
#: stands still within the update cycle
HARD_STOP = 1e15
_TRAVEL_POS, _TRAVEL_NEG = int(AxisFlag.SOFT_LIMIT_POS), int(AxisFlag.SOFT_LIMIT_NEG)
_LIMIT_STOP = _TRAVEL_POS | _TRAVEL_NEG | int(AxisFlag.STOPPED_BY_LIMIT)


class OmsMotion:
    """Motion of one card: the core, the raw limit/home input levels and the home searches."""

    def __init__(self, params: Params, period_ns: float, ideal: bool = False,
                 profiles: Sequence[str] | None = None) -> None:
        n = params.n
        self.n = n
        self.params = params
        self.ideal = ideal
        #: per axis: the planner of a move from rest (spec §5.2; ValueError on an unknown name)
        self.planners = [profile.planner(name) for name in
                         (["linear"] * n if profiles is None else profiles)]
        kinds = [PlantKind.IDEAL if ideal else _KIND[t] for t in params.ptype]
        self.core = MotionCore(n, period_ns, kinds)
        # raw input levels (1 = TTL high); open inputs are pulled high [spec §2.3]
        self.limit_pos_level = np.ones(n, dtype=bool)
        self.limit_neg_level = np.ones(n, dtype=bool)
        self.home_level = np.ones(n, dtype=bool)
        self.limit_seen = np.zeros(n, dtype=bool)  # a limit stop already reported
        self.travel_limited = False  # some axis has software travel limits
        self.direction = np.ones(n)  # +1 / -1: the direction of the last motion command
        self.on_path = np.zeros(n, dtype=bool)  # a running contour moves the axis
        # home searches: -1 none; else the value loaded at the switch and whether to ramp down
        self.home_value = np.zeros(n)
        self.home_ramp = np.ones(n, dtype=bool)
        self.searching = np.zeros(n, dtype=bool)
        self.home_edge = np.full(n, math.inf)  # backdoor: a home switch at a position ...
        self.home_top = np.full(n, math.inf)  # ... active from home_edge up to home_top
        self.home_edge_set = False
        #: the axis world's switches (card.py, set_world): active or not, and the axes whose
        #: switches sit at positions, wired for whatever polarity the host sets (`wire`)
        self.world_pos = np.zeros(n, dtype=bool)
        self.world_neg = np.zeros(n, dtype=bool)
        self.home_world = np.zeros(n, dtype=bool)
        self.wired_limits = np.zeros(n, dtype=bool)
        self.wired_home = np.zeros(n, dtype=bool)
        #: the world's home window in physical counts (empty: lo > hi)
        self.window_lo = np.full(n, math.inf)
        self.window_hi = np.full(n, -math.inf)
        self.home_index = np.zeros(n, dtype=bool)  # HI mode: home = the truth table (HT/EH)
        self.index_capture = np.zeros(n, dtype=bool)  # index pulses make capture entries
        self.encoders = Encoders(self.core, params)
        on = [t != "M" or params.closed_loop[a] for a, t in enumerate(params.ptype)]
        self.core.servo_on(np.flatnonzero(on))
        self.servo = ServoLaw(self.core, params)
        self.apply_gains()
        self.apply_limits()
        self.encoders.configure_maintenance()

    # -- configuration -------------------------------------------------------------------------------
    def limit_active(self) -> tuple[np.ndarray, np.ndarray]:
        """(positive, negative) limit switches active, after polarity and mode F (off)."""
        p = self.params
        on = np.array([m != "F" for m in p.limit_mode])
        pos = (self.limit_pos_level == p.limit_high) & on
        neg = (self.limit_neg_level == p.limit_high) & on
        return pos, neg

    def home_active(self) -> np.ndarray:
        return self.home_level == self.params.home_high

    def apply_limits(self) -> None:
        """Feed the switches to the core (hard mode stops at once, soft mode decelerates at AC),
        then the slip tolerances (ES, the axis types, ER: encoder.py)."""
        self.wire()
        p, lim = self.params, self.core.limits
        soft = np.array([m == "S" for m in p.limit_mode])
        lim.limit_dec[:] = np.where(soft, p.values["AC"], HARD_STOP)
        pos, neg = self.limit_active()
        self.core.set_inputs(hard_limit_pos=pos, hard_limit_neg=neg, home=self.home_active())
        self.encoders.apply_slip()

    def set_travel_limits(self, limits: Sequence[tuple[float, float] | None]) -> None:
        """Software travel limits per axis, (low, high) or None [S §2.14 "Software (soft)
        over-travel"]: the core plans a move or jog heading past one to stop at it and flags
        the stop as a limit stop (over-travel, queue flushed); a move from beyond back is
        allowed."""
        lim = self.core.limits
        lim.soft_lo[:] = [-math.inf if pair is None else pair[0] for pair in limits]
        lim.soft_hi[:] = [math.inf if pair is None else pair[1] for pair in limits]
        self.travel_limited = any(pair is not None for pair in limits)

    def path_begins(self, axes: Sequence[int], start: Sequence[float],
                    end: Sequence[float]) -> None:
        """A contour starts on `axes` (a motion command for QA): each moved axis takes the
        direction from `start` to `end`, and a limit stop is no longer reported or shown. Their
        last move's target no longer holds (MR counts from where the path leaves them, position
        maintenance waits) and whole-count holds leave them to the path."""
        flags, core = self.core.axes.flags, self.core
        for a in axes:
            flags[a] &= ~_LIMIT_STOP
            self.limit_seen[a] = False
            if end[a] != start[a]:
                self.direction[a] = 1.0 if end[a] > start[a] else -1.0
        index = list(axes)
        self.on_path[index] = True
        core.target_valid[index] = False

    def path_ends(self, axes: Sequence[int], ends: Sequence[int] | None = None) -> None:
        """The contour on `axes` is over; run to its end, the axes rest on `ends`, which become
        their target (as a move's: MR counts from it, position maintenance holds it), except
        on an axis whose loop is open (CL0), whose command follows the axis instead."""
        index = list(axes)
        self.on_path[index] = False
        if ends is not None:
            core = self.core
            core.target[index] = ends
            core.target_valid[index] = core.servo_on_mask[index]

    def travel_stop(self, a: int, positive: bool) -> None:
        """A contour stopped at axis a's software travel limit in that direction."""
        self.core.axes.flags[a] |= _TRAVEL_POS if positive else _TRAVEL_NEG

    def at_travel_limit(self, a: int, positive: bool) -> bool:
        """Axis a's software travel limit in that direction stopped its last motion."""
        return bool(self.core.axes.flags[a] & (_TRAVEL_POS if positive else _TRAVEL_NEG))

    # -- commands ------------------------------------------------------------------------------------
    def moving(self, a: int) -> bool:
        return bool(self.core.profile.moving[a])

    def new_limit_stops(self) -> np.ndarray:
        """Axes that a limit stopped or refused since their last motion command."""
        stopped = (self.core.axes.flags & AxisFlag.STOPPED_BY_LIMIT) != 0
        new = np.flatnonzero(stopped & ~self.limit_seen)
        self.limit_seen |= stopped
        return new

    def target_base(self, a: int) -> float:
        """Where a relative move starts: the last target, else the present command."""
        core = self.core
        if core.target_valid[a]:
            return float(core.target[a])
        return float(np.rint(core.axes.cmd_pos[a]))

    def move_to(self, a: int, target: float) -> None:
        """A move to `target`: from rest the axis's profile with VB (linear, parabolic or
        S-curve), else (the axis runs) the core's trapezoid from its present velocity."""
        v, core = self.params.values, self.core
        self._begin(a)
        here = float(core.axes.cmd_pos[a])
        if target != here:
            self.direction[a] = 1.0 if target > here else -1.0
        vb, vl, ac = float(v["VB"][a]), float(v["VL"][a]), float(v["AC"][a])
        if core.profile.moving[a] or core.axes.cmd_vel[a]:
            core.move_absolute(a, target, vl, ac, ac)
            return

        planner = self.planners[a]

        def plan(t: float, p: float, vel: float, goal: float) -> list[profile.Phase]:
            return planner(t, p, goal, vb, vl, ac)

        core.move_planned(a, target, plan, ac)

    def _begin(self, a: int) -> None:
        """A motion command: a new limit stop or slip of the axis is reported again."""
        self.limit_seen[a] = False
        self.encoders.rearm(a)

    def jog(self, a: int, velocity: float) -> None:
        ac = float(self.params.values["AC"][a])
        self._begin(a)
        if velocity:
            self.direction[a] = 1.0 if velocity > 0 else -1.0
        self.core.jog(a, velocity, ac, ac)

    def stop(self, a: int) -> None:
        self.core.stop(a, float(self.params.values["AC"][a]))

    def kill(self, a: int) -> None:
        """Stop without deceleration [spec §2.6, KL]."""
        self.core.abort(a)

    def home(self, a: int, forward: bool, value: float, ramp: bool) -> None:
        """HM/HR (ramp) and KM/KR (stop at once): run at VL toward the home switch; where the
        home condition occurs the position counter is loaded with `value` [S §4.3, §4.8]. An
        axis already on its switch (switch mode) is homed where it stands."""
        self.home_value[a], self.home_ramp[a] = value, ramp
        self.searching[a] = True
        self.encoders.home_hit[a] = False  # no count passed yet in this search
        self.jog(a, float(self.params.values["VL"][a]) * (1 if forward else -1))
        if not self.moving(a):  # refused by a limit
            self.searching[a] = False
            return
        self.check_homes(started=True)

    def check_homes(self, started: bool = False) -> None:
        """Searching axes whose home condition holds. HS: the switch active. HI: each term of the
        axis's truth table that is not ignored [S §4.8]: the switch active or inactive as it
        says, in this update cycle, and the encoder terms (A, B, index) at a count passed in the
        last cycle, or, as the search starts, where the axis stands. The operand is what the
        counter reads where the condition occurred (the switch edge, the count where the encoder
        terms held); the axis then ramps down at AC (HM/HR) or stops at once (KM/KR), so it ends
        at operand + what it ran past that point."""
        active, hi = self.home_active(), self.home_index
        switch = self.params.home_pattern[:, 3]
        hit = self.searching & np.where(hi, switch_holds(switch, active), active)
        enc = self.encoders
        if hi.any():
            encoder_terms = enc.home_here(self.searching & hi) if started else enc.home_hit
            hit &= ~hi | encoder_terms
        for a in np.flatnonzero(hit).tolist():
            self.searching[a] = False
            dec = float(self.params.values["AC"][a]) if self.home_ramp[a] else HARD_STOP
            ax = self.core.axes
            past = 0.0  # how far the axis ran past where the condition occurred
            if hi[a]:
                past = (float(ax.encoder[a]) - float(enc.home_at[a])) / float(
                    self.core.encoder_scale[a])
            elif not started and math.isfinite(self.home_edge[a]):
                edge = self.home_edge[a] if ax.cmd_vel[a] >= 0 else self.home_top[a]
                past = float(ax.pos[a]) - float(edge) if math.isfinite(edge) else 0.0
            elif not started and self.window_lo[a] <= self.window_hi[a]:
                past = self._past_window(a)
            before = float(ax.pos[a])
            self.core.redefine_and_stop(a, float(self.home_value[a]) + past, dec)
            self.renumbered(a, float(ax.pos[a]) - before)

    def _past_window(self, a: int) -> float:
        """How far the axis ran past the edge of its world home window (physical counts) that
        it crossed in the last cycle; 0 when it met none (the switch held by the backdoor)."""
        ax = self.core.axes
        up = ax.cmd_vel[a] >= 0
        edge = float(self.window_lo[a] if up else self.window_hi[a])
        past = float(self.core.physical()[a]) - edge
        travel = abs(float(ax.vel[a])) * self.core.dt + 1.0
        return past if 0.0 <= (past if up else -past) <= travel else 0.0

    def renumbered(self, a: int, shift: float) -> None:
        """Axis a's counters moved by `shift` counts (a home found, LP): the switches the
        backdoor placed and the index pulses stay where they are on the axis."""
        self.home_edge[a] += shift
        self.home_top[a] += shift
        self.encoders.renumbered(a, shift)

    def tick(self) -> int:
        return self.after_core(self.core.tick())

    def after_core(self, events: int) -> int:
        """The rest of a tick after the core's, which reported `events` (returned): whole-count
        holds, the servo law's outputs, index pulses, home switch edges and searches, position
        maintenance."""
        if events & _DONE:
            self.hold_whole_counts()
        self.servo.after_tick()
        enc = self.encoders
        searching = b"\x01" in self.searching.tobytes()  # bools: bytes 0 and 1
        if enc.watching:
            enc.step_index(self.searching & self.home_index if searching else None)
        if self.home_edge_set:
            self.update_home_edges()
        if searching:
            self.searching &= self.core.profile.moving  # a limit or a stop ended the search
            self.check_homes()
        if enc.maintaining:
            enc.maintain()
        return events

    def core_only(self) -> bool:
        """Whether `after_core` does nothing after a tick without events: no servo output set
        after the PID, no index watched, no home switch edge or search, no maintenance (kept in
        step with `after_core`: MaxkCard.run runs such ticks as the core's alone)."""
        enc = self.encoders
        return not (self.servo.acting or enc.watching or self.home_edge_set or enc.maintaining
                    or b"\x01" in self.searching.tobytes())

    def hold_whole_counts(self) -> None:
        """Axes at rest under control (steppers, CL1 servos) hold a whole count, the one RP
        reports. The core's stops (ST, a limit, a home ramp-down, a kill) end where the
        deceleration takes them, between two counts; a servo commanded there hunts one encoder
        count around it forever. Run when a profile ends (a DONE event); an axis on a running
        contour's path is left to the path."""
        core = self.core
        cmd = core.axes.cmd_pos
        whole = np.rint(cmd)
        snap = np.flatnonzero(~core.profile.moving & ~self.on_path & core.servo_on_mask
                              & (whole != cmd))
        if not len(snap):
            return
        for a in snap.tolist():
            core.profile.hold(a, float(whole[a]))
        core.profile.commit()

    def set_home_mode(self, a: int, index: bool) -> None:
        """HI (home = the truth table of switch and encoder signals) or HS (the switch alone)."""
        self.home_index[a] = index
        self.encoders.watch_index(self.home_index | self.index_capture)

    def set_index_capture(self, a: int, on: bool) -> None:
        """Index pulses of axis a make capture entries (capture.py)."""
        self.index_capture[a] = on
        self.encoders.watch_index(self.home_index | self.index_capture)

    # -- home switch positions ------------------------------------------------------------------------
    def update_home_edges(self) -> None:
        """Axes with a home switch at a position: the level follows the axis position."""
        edge = self.home_edge
        on = np.isfinite(edge)
        pos = self.core.axes.pos
        active_level = self.params.home_high
        at = (pos >= edge) & (pos < self.home_top) | self.home_world  # from the edge, below the top
        self.home_level = np.where(on, np.where(at, active_level, ~active_level), self.home_level)

    def set_world(self, pos: np.ndarray, neg: np.ndarray, home: np.ndarray,
                  wired_limits: np.ndarray, wired_home: np.ndarray) -> None:
        """The axis world's switches (True = active). On the `wired` axes, whose switches sit at
        positions, the raw levels follow the polarity LTH/LTL and HH/HL give, now and after
        (`wire`): the installation is wired for it. On the others (switches only held by the
        backdoor) a switch that changes takes the level the polarity gives at that moment and
        keeps it, as before the axis world: a later LTH/HH changes what that level means."""
        p = self.params
        for active, seen, level, high in (
                (pos, self.world_pos, self.limit_pos_level, p.limit_high),
                (neg, self.world_neg, self.limit_neg_level, p.limit_high),
                (home, self.home_world, self.home_level, p.home_high)):
            changed = active != seen
            np.copyto(level, np.where(active, high, ~high), where=changed)
            seen[:] = active
        self.wired_limits[:], self.wired_home[:] = wired_limits, wired_home
        if self.home_edge_set:
            self.update_home_edges()
        self.apply_limits()

    def wire(self) -> None:
        """The raw levels of the wired switches from the present polarity (see set_world)."""
        p = self.params
        if self.wired_limits.any():
            high, wired = p.limit_high, self.wired_limits
            np.copyto(self.limit_pos_level, np.where(self.world_pos, high, ~high), where=wired)
            np.copyto(self.limit_neg_level, np.where(self.world_neg, high, ~high), where=wired)
        if self.wired_home.any():
            high, wired = p.home_high, self.wired_home & ~np.isfinite(self.home_edge)
            np.copyto(self.home_level, np.where(self.home_world, high, ~high), where=wired)

    def set_home_edge(self, a: int, position: float | None, width: float | None = None) -> None:
        """A home switch active from `position` up (for `width` counts if given); None: none."""
        self.home_edge[a] = math.inf if position is None else position
        self.home_top[a] = math.inf if position is None or width is None else position + width
        self.home_edge_set = bool(np.isfinite(self.home_edge).any())
        if self.home_edge_set:
            self.update_home_edges()

    # -- axis type, loop and gains ----------------------------------------------------------------------
    def set_kind(self, a: int, ptype: str) -> None:
        kind = PlantKind.IDEAL if self.ideal else _KIND[ptype]
        if int(self.core.kinds[a]) != int(kind):
            self.core.set_kind(a, kind)
        self.set_closed_loop(a, ptype != "M" or bool(self.params.closed_loop[a]))
        self.encoders.apply_slip()

    def set_closed_loop(self, a: int, on: bool) -> None:
        """CL1: the servo holds and follows its command; CL0: open loop, output KO only."""
        if self.params.ptype[a] != "M":
            on = True  # a stepper always follows its pulses
        if on and not self.core.servo_on_mask[a]:
            self.core.servo_on(a)
            self.encoders.rearm(a)
        elif not on and self.core.servo_on_mask[a]:
            self.core.servo_off(a)
        self.apply_gains()
        self.encoders.configure_maintenance()

    def apply_gains(self) -> None:
        """The servo gains onto the core's PID (servo.py)."""
        self.servo.apply()

    # -- what the card reports -----------------------------------------------------------------------
    def motor_position(self) -> np.ndarray:
        """RP: the commanded (motor) position, whole counts."""
        return np.rint(self.core.axes.cmd_pos)

    def encoder_position(self) -> np.ndarray:
        return self.core.axes.encoder

    def in_deadband(self, a: int) -> bool:
        return self.encoders.in_deadband(a)

    def forget_slip(self, a: int) -> float:
        """LPE on a stepper: slip detection takes the counters as they are now. The counts the
        encoder lost leave the core (which compares the encoder with the steps); the caller
        keeps them in its encoder offset, so the reading does not change. Returns them."""
        slip = float(self.core.encoder_slip[a])
        if slip:
            self.core.slip_encoder(a, -slip)
        return slip

    def velocity(self) -> np.ndarray:
        return np.rint(self.core.axes.cmd_vel)

    def direction_positive(self) -> np.ndarray:
        return self.core.axes.cmd_vel >= 0

    def stopped_by_limit(self, a: int) -> bool:
        return bool(self.core.axes.flags[a] & AxisFlag.STOPPED_BY_LIMIT)
