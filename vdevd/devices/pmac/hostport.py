"""The PCI host port and the card's interrupt controller, without I/O [spec pmac.md §2.11].

Host port (ASSUMPTION, DSP563xx HI08 convention, README): eight byte registers; offset 2 is the
interface status (bit 0 RXDF: a character from the card is waiting, bit 1 TXDE: the host may
write); offsets 5, 6, 7 are the data bytes, characters pass one per transfer through offset 7. A
line written there runs at its CR; control characters act at once. The reply, framed by I3/I6 as
on a serial port, is read back character by character from offset 7.

Interrupt controller (ASSUMPTION, proposed model of §2.11): offset 8 status (write 1 to clear),
offset 9 enable mask; IR0 in-position, IR1 buffer request, IR2 fatal following error, IR3 warning
following error, IR4 ASCII response ready, IR5 compare EQU1, IR6 compare EQU5, IR7 DPRAM. The line
INTA is asserted while status & mask is not zero; each rising of a bit there is one event.

The register offsets and the interrupt bits (`HostIrq`) are vdevmaps.pmac's, which the client
shares.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from vdevmaps.pmac import DATA, ISR, RXDF, TXDE

MAX_LINE = 256


class HostPort:
    """The character interface: `command(line) -> bytes` and `control(ch) -> bytes` are the
    port's interpreter; `raise_irq(bits)` reports interrupt sources."""

    def __init__(self, command: Callable[[str], bytes], control: Callable[[int], bytes]) -> None:
        self._command = command
        self._control = control
        self.line = bytearray()
        self.out: deque[int] = deque()
        self.regs = bytearray(8)

    def reset(self) -> None:
        self.line.clear()
        self.out.clear()

    def read(self, offset: int) -> int:
        if offset == ISR:
            return (RXDF if self.out else 0) | TXDE
        if offset == DATA:
            return self.out.popleft() if self.out else 0
        return self.regs[offset]

    def peek(self, offset: int) -> int:
        """`read` without taking a character from the data register."""
        if offset == DATA:
            return self.out[0] if self.out else 0
        return self.read(offset)

    def write(self, offset: int, value: int) -> None:
        if offset != DATA:
            self.regs[offset] = value
            return
        if value == 0x0D:
            text = self.line.decode("latin-1")
            self.line.clear()
            self.out.extend(self._command(text))
        elif 1 <= value <= 26:
            if value == 0x18:  # ^X flushes the port both ways
                self.line.clear()
                self.out.clear()
            self.out.extend(self._control(value))
        elif len(self.line) < MAX_LINE:
            self.line.append(value)


class InterruptController:
    """Status and mask of IR0-IR7; `fire(status)` asserts INTA (one event), `drop()` releases it."""

    def __init__(self, fire: Callable[[int], None], drop: Callable[[], None]) -> None:
        self.status = 0
        self.mask = 0
        self.asserted = False
        self._fire, self._drop = fire, drop

    def reset(self) -> None:
        self.status = self.mask = 0
        self._update()

    def raise_(self, bits: int) -> None:
        if self.status & bits == bits:
            return  # already pending: no new event
        new = bits & ~self.status
        self.status |= bits
        if new & self.mask:
            self.asserted = True
            self._fire(self.status)

    def write_status(self, value: int) -> None:
        self.status &= ~value
        self._update()

    def write_mask(self, value: int) -> None:
        self.mask = value & 0xFF
        self._update()

    def _update(self) -> None:
        active = bool(self.status & self.mask)
        if active and not self.asserted:
            self.asserted = True
            self._fire(self.status)
        elif self.asserted and not active:
            self.asserted = False
            self._drop()
