"""The axis world: the mechanics around a card's axes (DESIGN.md "The axis world").

Per axis, where the stage's hard-limit switches, home switch, encoder index pulses and probe
targets are, in the stage's physical encoder counts (which stay where they are when software
redefines zero), and the fault flags a test injects. A card senses its inputs from the physical
positions every tick (`AxisWorld.sense`), so a homing routine finds the switches where a real stage
has them. The backdoor's forces (`set_limit(..., active=True)`) hold an input active whatever the
position; releasing the force hands the input back to the mechanics.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: the keys of one `[[card.axis]]` table
AXIS_KEYS = ("limits", "home", "index", "probe", "amp_fault", "encoder_loss")
#: most probe positions one axis may list
MAX_PROBES = 64


@dataclass(frozen=True, slots=True)
class AxisMechanics:
    """One `[[card.axis]]` table: positions in physical counts."""

    #: (negative, positive): each switch is active at or beyond its position
    limits: tuple[float, float] | None = None
    #: (from, to): the home switch is active while from <= position <= to
    home: tuple[float, float] | None = None
    #: (period, phase): an index pulse at phase + k * period, for every integer k
    index: tuple[float, float] | None = None
    #: positions where the probe (registration input) fires as the axis crosses them
    probe: tuple[float, ...] = ()
    amp_fault: bool = False
    encoder_loss: bool = False

    @classmethod
    def parse(cls, table: Any, where: str) -> AxisMechanics:
        """A `[[card.axis]]` table checked; ValueError naming the key otherwise."""
        if not isinstance(table, Mapping):
            raise ValueError(f"{where}: must be a table ([[card.axis]])")
        unknown = sorted(set(table) - set(AXIS_KEYS))
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key (keys: {', '.join(AXIS_KEYS)})")
        limits = _pair(table, "limits", where, strict=True)
        home = _pair(table, "home", where, strict=False)
        index = None
        if "index" in table:
            idx = table["index"]
            if not isinstance(idx, Mapping) or set(idx) - {"period", "phase"} or "period" not in idx:
                raise ValueError(f"{where}.index: expected {{period = counts, phase = counts}}")
            period, phase = _number(idx["period"], f"{where}.index.period"), 0.0
            if "phase" in idx:
                phase = _number(idx["phase"], f"{where}.index.phase")
            if period <= 0:
                raise ValueError(f"{where}.index.period: {period!r} is not a positive count")
            index = (period, phase)
        probe = table.get("probe", [])
        if not isinstance(probe, list) or len(probe) > MAX_PROBES:
            raise ValueError(f"{where}.probe: expected a list of at most {MAX_PROBES} positions")
        probes = tuple(_number(p, f"{where}.probe") for p in probe)
        flags = {}
        for key in ("amp_fault", "encoder_loss"):
            value = table.get(key, False)
            if not isinstance(value, bool):
                raise ValueError(f"{where}.{key}: expected true or false, got {value!r}")
            flags[key] = value
        return cls(limits, home, index, probes, **flags)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{where}: expected a finite number of counts, got {value!r}")
    return float(value)


def _pair(table: Mapping[str, Any], key: str, where: str, strict: bool) -> tuple[float, float] | None:
    if key not in table:
        return None
    value = table[key]
    if not isinstance(value, list) or len(value) != 2:
        raise ValueError(f"{where}.{key}: expected [low, high] in counts, got {value!r}")
    lo, hi = (_number(v, f"{where}.{key}") for v in value)
    if lo > hi or (strict and lo == hi):
        raise ValueError(f"{where}.{key}: {lo:g} must be below {hi:g}")
    return lo, hi


class AxisWorld:
    """The mechanics and the injected faults of n axes, and the input levels sensed from them.

    `limit_pos`, `limit_neg`, `home` are the levels last sensed (True = switch active); the
    `force_*` arrays hold inputs active from the backdoor; `amp_fault`, `encoder_loss`, `jammed`
    are the fault flags (config, then backdoor); `mechanical` says whether positions matter at
    all. `index_period`/`index_phase` place the index pulses, which each card's own encoder
    model reads (its index logic, capture and truth tables differ by card).
    """

    def __init__(self, n: int, mechanics: Sequence[AxisMechanics] = ()) -> None:
        if len(mechanics) > n:
            raise ValueError(f"axis: {len(mechanics)} [[card.axis]] tables for {n} axes")
        self.n = n
        self.neg_at = np.full(n, -np.inf)
        self.pos_at = np.full(n, np.inf)
        self.home_lo = np.full(n, np.inf)
        self.home_hi = np.full(n, -np.inf)
        self.index_period = np.zeros(n)
        self.index_phase = np.zeros(n)
        self.probes: list[np.ndarray] = [np.zeros(0) for _ in range(n)]
        self.force_pos = np.zeros(n, dtype=bool)
        self.force_neg = np.zeros(n, dtype=bool)
        self.force_home = np.zeros(n, dtype=bool)
        self.amp_fault = np.zeros(n, dtype=bool)
        self.encoder_loss = np.zeros(n, dtype=bool)
        self.jammed = np.zeros(n, dtype=bool)
        self.estop = False
        self.limit_pos = np.zeros(n, dtype=bool)
        self.limit_neg = np.zeros(n, dtype=bool)
        self.home = np.zeros(n, dtype=bool)
        for a, m in enumerate(mechanics):
            if m.limits is not None:
                self.neg_at[a], self.pos_at[a] = m.limits
            if m.home is not None:
                self.home_lo[a], self.home_hi[a] = m.home
            if m.index is not None:
                self.index_period[a], self.index_phase[a] = m.index
            self.probes[a] = np.array(sorted(m.probe))
            self.amp_fault[a], self.encoder_loss[a] = m.amp_fault, m.encoder_loss
        self._mechanics_changed()

    def _mechanics_changed(self) -> None:
        self.mechanical = bool(np.isfinite(self.neg_at).any() or np.isfinite(self.pos_at).any()
                               or (self.home_lo <= self.home_hi).any())

    # -- sensing (every tick of a card whose world is mechanical) --------------------------------
    def sense(self, physical: np.ndarray) -> bool:
        """Refresh the switch levels from the physical positions; True when a level changed."""
        pos = (physical >= self.pos_at) | self.force_pos
        neg = (physical <= self.neg_at) | self.force_neg
        home = ((physical >= self.home_lo) & (physical <= self.home_hi)) | self.force_home
        if (np.array_equal(pos, self.limit_pos) and np.array_equal(neg, self.limit_neg)
                and np.array_equal(home, self.home)):
            return False
        self.limit_pos, self.limit_neg, self.home = pos, neg, home
        return True

    def forced(self) -> None:
        """Levels from the forces alone (a card whose world has no mechanics)."""
        self.limit_pos = self.force_pos.copy()
        self.limit_neg = self.force_neg.copy()
        self.home = self.force_home.copy()

    def probe_between(self, axis: int, a: float, b: float) -> float | None:
        """The first probe position passed going from a to b (a excluded), or None."""
        targets = self.probes[axis]
        if not len(targets) or a == b:
            return None
        lo, hi = (a, b) if b > a else (b, a)
        hit = targets[(targets > lo) & (targets <= hi)] if b > a else targets[(targets >= lo)
                                                                               & (targets < hi)]
        if not len(hit):
            return None
        return float(hit[0] if b > a else hit[-1])

    # -- the backdoor -----------------------------------------------------------------------------
    def force_limit(self, axis: int, positive: bool, active: bool) -> None:
        (self.force_pos if positive else self.force_neg)[axis] = active

    def force_home_switch(self, axis: int, active: bool) -> None:
        self.force_home[axis] = active

    def set_home_window(self, axis: int, low: float, high: float) -> None:
        if not (math.isfinite(low) and math.isfinite(high)) or low > high:
            raise ValueError(f"home window [{low}, {high}]: need finite low <= high")
        self.home_lo[axis], self.home_hi[axis] = low, high
        self._mechanics_changed()

    def remove_home_window(self, axis: int) -> None:
        """No home switch on the stage of `axis` (a force still holds the input active)."""
        self.home_lo[axis], self.home_hi[axis] = np.inf, -np.inf
        self._mechanics_changed()

    def set_index(self, axis: int, period: float, phase: float) -> None:
        if not (math.isfinite(period) and math.isfinite(phase)) or period < 0:
            raise ValueError(f"index period {period}: need a finite count >= 0 (0: none)")
        self.index_period[axis], self.index_phase[axis] = period, phase

    def set_fault(self, which: str, axis: int, active: bool) -> None:
        """`which`: amp_fault, encoder_loss or jammed."""
        getattr(self, which)[axis] = active
