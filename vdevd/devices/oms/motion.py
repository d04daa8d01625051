"""The MAXk's axes over the numpy motion core (spec oms.md §5).

Open-loop steppers (PSO) and steppers with encoder (PSE) drive the core's stepper plant, servos
(PSM) its servo plant through the PID; `plant = "ideal"` makes every axis follow its command
exactly. Moves are the linear (trapezoid) profile: VL peak velocity, AC for acceleration and
deceleration [S §2.14]. The limit inputs are raw TTL levels; LTH/LTL give the active level, the
limit mode (hard: stop at once; soft: decelerate; off: ignored) what a switch does [S §4.2].
"""

from __future__ import annotations

import math

import numpy as np

from vdevd.devices.oms.params import Params
from vdevd.rt import MotionCore, PlantKind
from vdevd.rt.axes import AxisFlag

_KIND = {"O": PlantKind.STEPPER, "E": PlantKind.STEPPER, "M": PlantKind.SERVO}


class OmsMotion:
    """Motion of one card: the core, the raw limit/home input levels and the home searches."""

    def __init__(self, params: Params, period_ns: int, ideal: bool = False) -> None:
        n = params.n
        self.n = n
        self.params = params
        self.ideal = ideal
        kinds = [PlantKind.IDEAL if ideal else _KIND[t] for t in params.ptype]
        self.core = MotionCore(n, period_ns, kinds)
        # raw input levels (1 = TTL high); open inputs are pulled high [spec §2.3]
        self.limit_pos_level = np.ones(n, dtype=bool)
        self.limit_neg_level = np.ones(n, dtype=bool)
        self.home_level = np.ones(n, dtype=bool)
        self.limit_seen = np.zeros(n, dtype=bool)  # a limit stop already reported
        self.direction = np.ones(n)  # +1 / -1: the direction of the last motion command
        # home searches: -1 none; else the value loaded at the switch and whether to ramp down
        self.home_value = np.zeros(n)
        self.home_ramp = np.ones(n, dtype=bool)
        self.searching = np.zeros(n, dtype=bool)
        self.home_edge = np.full(n, math.inf)  # backdoor: a home switch at a position
        self.home_edge_set = False
        on = [t != "M" or params.closed_loop[a] for a, t in enumerate(params.ptype)]
        self.core.servo_on(np.flatnonzero(on))
        self.apply_gains()
        self.apply_limits()

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
        """Feed the switches to the core; hard mode stops at once, soft mode decelerates at AC."""
        p, lim = self.params, self.core.limits
        soft = np.array([m == "S" for m in p.limit_mode])
        lim.limit_dec[:] = np.where(soft, p.values["AC"], np.inf)
        pos, neg = self.limit_active()
        self.core.set_inputs(hard_limit_pos=pos, hard_limit_neg=neg, home=self.home_active())

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
        v = self.params.values
        self.limit_seen[a] = False
        here = float(self.core.axes.cmd_pos[a])
        if target != here:
            self.direction[a] = 1.0 if target > here else -1.0
        self.core.move_absolute(a, target, v["VL"][a], v["AC"][a], v["AC"][a])

    def jog(self, a: int, velocity: float) -> None:
        ac = float(self.params.values["AC"][a])
        self.limit_seen[a] = False
        if velocity:
            self.direction[a] = 1.0 if velocity > 0 else -1.0
        self.core.jog(a, velocity, ac, ac)

    def stop(self, a: int) -> None:
        self.core.stop(a, float(self.params.values["AC"][a]))

    def kill(self, a: int) -> None:
        """Stop without deceleration [spec §2.6, KL]."""
        self.core.abort(a)

    def home(self, a: int, forward: bool, value: float, ramp: bool) -> None:
        """HM/HR (ramp) and KM/KR (stop at once): run at VL toward the home switch; where it
        becomes active the position counter is loaded with `value` [S §4.3, §4.8]."""
        self.home_value[a], self.home_ramp[a] = value, ramp
        self.searching[a] = True
        self.jog(a, float(self.params.values["VL"][a]) * (1 if forward else -1))
        if not self.moving(a):  # refused by a limit
            self.searching[a] = False
            return
        self.check_homes()

    def check_homes(self) -> None:
        """Searching axes on an active home switch: load the value, ramp down or stop."""
        found = np.flatnonzero(self.searching & self.home_active())
        for a in found.tolist():
            self.searching[a] = False
            dec = float(self.params.values["AC"][a]) if self.home_ramp[a] else math.inf
            self.core.redefine_and_stop(a, float(self.home_value[a]), dec)

    def tick(self) -> int:
        events = self.core.tick()
        if self.searching.any():
            self.searching &= self.core.profile.moving  # a limit or a stop ended the search
            if self.home_edge_set:
                self.update_home_edges()
            self.check_homes()
        return events

    # -- home switch positions ------------------------------------------------------------------------
    def update_home_edges(self) -> None:
        """Axes with a home switch at a position: the level follows the axis position."""
        edge = self.home_edge
        on = np.isfinite(edge)
        pos = self.core.axes.pos
        active_level = self.params.home_high
        at = pos >= edge  # the switch is active at and above the edge
        self.home_level = np.where(on, np.where(at, active_level, ~active_level), self.home_level)

    def set_home_edge(self, a: int, position: float | None) -> None:
        self.home_edge[a] = math.inf if position is None else position
        self.home_edge_set = bool(np.isfinite(self.home_edge).any())
        if self.home_edge_set:
            self.update_home_edges()

    # -- axis type, loop and gains ----------------------------------------------------------------------
    def set_kind(self, a: int, ptype: str) -> None:
        kind = PlantKind.IDEAL if self.ideal else _KIND[ptype]
        if int(self.core.kinds[a]) != int(kind):
            self.core.set_kind(a, kind)
        self.set_closed_loop(a, ptype != "M" or bool(self.params.closed_loop[a]))

    def set_closed_loop(self, a: int, on: bool) -> None:
        """CL1: the servo holds and follows its command; CL0: open loop, output KO only."""
        if self.params.ptype[a] != "M":
            on = True  # a stepper always follows its pulses
        if on and not self.core.servo_on_mask[a]:
            self.core.servo_on(a)
        elif not on and self.core.servo_on_mask[a]:
            self.core.servo_off(a)

    def apply_gains(self) -> None:
        """The servo gains; the mapping of KP/KI/KD/KO onto the core PID is in README.md."""

    # -- what the card reports -----------------------------------------------------------------------
    def motor_position(self) -> np.ndarray:
        """RP: the commanded (motor) position, whole counts."""
        return np.rint(self.core.axes.cmd_pos)

    def encoder_position(self) -> np.ndarray:
        return self.core.axes.encoder

    def velocity(self) -> np.ndarray:
        return np.rint(self.core.axes.cmd_vel)

    def direction_positive(self) -> np.ndarray:
        return self.core.axes.cmd_vel >= 0

    def stopped_by_limit(self, a: int) -> bool:
        return bool(self.core.axes.flags[a] & AxisFlag.STOPPED_BY_LIMIT)


def clip32(values: np.ndarray) -> np.ndarray:
    """Positions as the 32-bit counters show them (wrapping)."""
    v = np.asarray(values, dtype=np.float64)
    v = np.where(np.isfinite(v), v, 0.0)
    return ((v.astype(np.int64) + 2**31) % 2**32 - 2**31).astype(np.int64)

