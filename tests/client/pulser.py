"""A small test card served through `DaemonThread(rack=...)`: big-endian registers and an
interrupt line raised from the backdoor."""

from __future__ import annotations

import functools

from vdevd.devices.base import Card, CardContext, control
from vdevd.region import Region
from vdevd.testing import DaemonThread, rack_of


class Pulser(Card):
    """A big-endian card: 16 bytes of registers `regs` and one line `irq`."""

    type_name = "pulser"
    endian = "big"

    def __init__(self, name: str, ctx: CardContext) -> None:
        super().__init__(name, {}, ctx)
        self.regs = self.add_region(Region("regs", 16, widths=(1, 2, 4), endian="big"))
        self.line = self.add_irq("irq")

    @control()
    def pulse(self, status: int) -> None:
        """Assert the line with `status`."""
        self.line.trigger(status)

    @control()
    def load(self, offset: int, value: int) -> None:
        """Set a 32-bit register as the card's firmware does."""
        self.regs.set(offset, value)

    @control()
    def value(self, offset: int) -> int:
        """A 32-bit register as the card's firmware reads it."""
        (word,) = self.regs.unpack(offset, "I")
        assert isinstance(word, int)
        return word


def serve_pulsers(*names: str) -> DaemonThread:
    """A lockstep daemon holding one Pulser per name (none: an empty rack)."""
    return DaemonThread(rack=rack_of(*(functools.partial(Pulser, name) for name in names)))
