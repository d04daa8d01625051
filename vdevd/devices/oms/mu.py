"""The MPC8245 message unit as the MAXk uses it (sans-I/O state machine; spec §2.9, §3).

The firmware rings the outbound doorbell (done, over-travel, slip, command error, W/K notice) and
writes the outbound message registers (OMR0: a text reply; OMR1: capture data); the host reads
OMISR and clears by writing ones. INTA is asserted while an unmasked source is pending.
"""

from __future__ import annotations

from collections.abc import Callable

from vdevmaps.oms import INTA_SOURCES, Mu, Omisr

_OM0I, _OM1I, _ODI = int(Omisr.OM0I), int(Omisr.OM1I), int(Omisr.ODI)
_DOORBELL_BITS = 0x1FFFFFFF  # bits 29-31 of the MPC824x doorbell are reserved
_OMISR, _OMIMR, _ODBR, _IDBR = int(Mu.OMISR), int(Mu.OMIMR), int(Mu.ODBR), int(Mu.IDBR)
_IMR0, _IMR1 = int(Mu.IMR0), int(Mu.IMR1)
#: the registers that read back what is stored in them, by offset
_STORED = {_OMIMR: "omimr", int(Mu.OMR0): "omr0", int(Mu.OMR1): "omr1", _ODBR: "odbr",
           _IMR0: "imr0", _IMR1: "imr1"}


class MessageUnit:
    """OMISR/OMIMR/OMR0/OMR1/ODBR/IDBR; `on_line(level)` is called when INTA changes."""

    def __init__(self, on_line: Callable[[bool], None] | None = None,
                 on_inbound: Callable[[int], None] | None = None) -> None:
        self.on_line = on_line
        self.on_inbound = on_inbound
        self.reset()

    def reset(self) -> None:
        self.messages = 0  # OM0I | OM1I latched
        self.omimr = 0
        self.omr0 = 0
        self.omr1 = 0
        self.odbr = 0
        self.imr0 = 0
        self.imr1 = 0
        self.line = False

    # -- what the firmware does ---------------------------------------------------------------
    def ring(self, bits: int) -> None:
        """Set outbound doorbell bits."""
        self.odbr |= bits & _DOORBELL_BITS
        self._update()

    def message(self, register: int, value: int) -> None:
        """Write OMR0 (register 0) or OMR1 (1): latches OM0I/OM1I."""
        if register == 0:
            self.omr0, self.messages = value & 0xFFFFFFFF, self.messages | _OM0I
        else:
            self.omr1, self.messages = value & 0xFFFFFFFF, self.messages | _OM1I
        self._update()

    # -- what the host sees ------------------------------------------------------------------------
    @property
    def omisr(self) -> int:
        return self.messages | (_ODI if self.odbr else 0)

    def read(self, offset: int) -> int:
        if offset == _OMISR:
            return self.omisr
        name = _STORED.get(offset)
        return 0 if name is None else int(getattr(self, name))

    def write(self, offset: int, value: int) -> None:
        """Host write: OMISR and ODBR clear the bits written as ones; OMIMR masks; IDBR kicks
        the firmware (spec §2.9); the other registers are stored or ignored."""
        if offset == _OMISR:
            self.messages &= ~value
        elif offset == _ODBR:
            self.odbr &= ~value
        elif offset == _OMIMR:
            self.omimr = value & 0xFFFFFFFF
        elif offset == _IMR0:
            self.imr0 = value
        elif offset == _IMR1:
            self.imr1 = value
        elif offset == _IDBR and self.on_inbound is not None:
            self.on_inbound(value)
        self._update()

    def _update(self) -> None:
        level = bool(self.omisr & ~self.omimr & INTA_SOURCES)
        if level != self.line:
            self.line = level
            if self.on_line is not None:
                self.on_line(level)
