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
    """A level-sensitive interrupt line: asserted until the card's acknowledge clears it.

    `asserted` is the card's internal state. While the host masks the line (PCI command bit 10,
    Interrupt Disable) an assertion does not reach the host: no event, no `wait` woken; when
    the mask is lifted with the line still asserted, the host sees it asserted (one event)."""

    def __init__(self, name: str, emit: Callable[[IrqLine, int], None]) -> None:
        self.name = name
        self.asserted = False
        self.status = 0
        self.masked = False
        self._emit = emit

    def trigger(self, status: int = 0) -> None:
        """Assert the line (again) with `status`; every call is one published assertion, unless
        the host masks the line."""
        self.asserted = True
        self.status = status
        if not self.masked:
            self._emit(self, status)

    def clear(self) -> None:
        """De-assert, as the card's acknowledge does."""
        self.asserted = False

    def mask(self, masked: bool) -> None:
        """Mask (True) or unmask the line on the host side; unmasking a line asserted inside
        the card delivers it."""
        was, self.masked = self.masked, masked
        if was and not masked and self.asserted:
            self._emit(self, self.status)
