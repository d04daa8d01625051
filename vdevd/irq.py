"""Interrupt lines (DESIGN.md "Irq").

A card raises a line with a status word when its manual says it interrupts the host; the card's
own status/enable/acknowledge registers live in its regions. Each assertion becomes an
`IrqEvent` handed to the rack, which publishes it on PUB and wakes `wait` requests.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class IrqEvent:
    """One assertion: `seq` counts assertions of the card (all lines), from 1."""

    card: str
    line: str
    seq: int
    sim_time_ns: int
    status: int

    def as_dict(self) -> dict[str, object]:
        return {
            "card": self.card,
            "line": self.line,
            "seq": self.seq,
            "sim_time_ns": self.sim_time_ns,
            "status": self.status,
        }


class IrqLine:
    """A level-sensitive interrupt line: asserted until the card's acknowledge clears it."""

    def __init__(self, name: str, emit: Callable[[IrqLine, int], None]) -> None:
        self.name = name
        self.asserted = False
        self.status = 0
        self._emit = emit

    def trigger(self, status: int = 0) -> None:
        """Assert the line (again) with `status`; every call is one published assertion."""
        self.asserted = True
        self.status = status
        self._emit(self, status)

    def clear(self) -> None:
        """De-assert, as the card's acknowledge does."""
        self.asserted = False
