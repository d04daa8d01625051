"""The scope's trigger machine, sans-I/O (issue 23 §1; proto/PROTOCOL.md "Scope").

A `Trigger` says what starts a recording: `now` (at arming), `register` (the masked value of a
register changes, or becomes `value`), `irq` (an interrupt on a line of the card, or on any),
`position` (an axis's actual position crosses `level` rising, falling or either way). A
`TriggerMachine` is fed what the card shows after each tick (the register's value, the card's
interrupt sequence number, the axis position at each sample) and says when the trigger fires.
It fires once; it keeps plain ints and floats (a snapshot pickles it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("now", "register", "irq", "position")
DIRECTIONS = ("rising", "falling", "either")


@dataclass
class Trigger:
    """What fires a recording; the fields of the other kinds are ignored."""

    kind: str = "now"
    # register: `width` bytes at `offset` of `region`, masked
    region: str = ""
    offset: int = 0
    width: int = 4
    mask: int = 0xFFFF_FFFF
    value: int | None = None  # None: any change of the masked value
    # irq: a line of the card, None: any line
    line: str | None = None
    # position: the axis (its index and name), the level in counts, the direction
    axis: int = 0
    axis_name: str = ""
    level: float = 0.0
    direction: str = "rising"

    def describe(self) -> dict[str, object]:
        """The trigger as the `scope` status reports it (the fields of its kind)."""
        if self.kind == "register":
            return {"kind": "register", "region": self.region, "offset": self.offset,
                    "width": self.width, "mask": self.mask, "value": self.value}
        if self.kind == "irq":
            return {"kind": "irq", "line": self.line}
        if self.kind == "position":
            return {"kind": "position", "axis": self.axis_name, "level": self.level,
                    "direction": self.direction}
        return {"kind": "now"}


class TriggerMachine:
    """Armed until its condition holds once, then fired (`fired`)."""

    def __init__(self, trigger: Trigger, register: int = 0, irq_seq: int = 0,
                 position: float | None = None) -> None:
        """The card's state at arming: the register's raw value, the interrupt sequence number
        of the line (or of the card), the axis position (None: not known yet)."""
        self.trigger = trigger
        self.fired = trigger.kind == "now"
        self._last_masked = register & trigger.mask
        self._irq_seq = irq_seq
        self._last_position = position

    def register(self, raw: int) -> bool:
        """The register reads `raw` after a tick: whether the trigger fires now."""
        t = self.trigger
        if self.fired or t.kind != "register":
            return False
        masked, before = raw & t.mask, self._last_masked
        self._last_masked = masked
        if masked == before:
            return False
        self.fired = t.value is None or masked == t.value
        return self.fired

    def irq(self, seq: int) -> bool:
        """The line's (or card's) last interrupt has sequence number `seq` (0: none yet)."""
        if self.fired or self.trigger.kind != "irq":
            return False
        self.fired = seq > self._irq_seq
        return self.fired

    def position(self, values: np.ndarray) -> int:
        """The axis was at `values` at the next samples, in order: the index of the first sample
        at which it crossed the level since the one before (-1: none; vectorised)."""
        t = self.trigger
        if self.fired or t.kind != "position" or not len(values):
            return -1
        before = np.empty(len(values))
        before[1:] = values[:-1]
        before[0] = values[0] if self._last_position is None else self._last_position
        self._last_position = float(values[-1])
        level = t.level
        rising = (before < level) & (values >= level)
        falling = (before > level) & (values <= level)
        hit = rising if t.direction == "rising" else falling if t.direction == "falling" \
            else rising | falling
        if not hit.any():
            return -1
        self.fired = True
        return int(hit.argmax())
