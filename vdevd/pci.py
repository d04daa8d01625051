"""PCI configuration space: the 256-byte type 0 header of a PCI card (DESIGN.md "PCI
configuration space"; PCI Local Bus Specification 2.3, chapter 6).

The region `config` is little-endian, read and written in 1, 2 or 4 bytes as configuration
cycles are. Reads have no side effects; writes land only where PCI allows: the command register's
writable bits, the cache line size and latency timer, the BARs (the bits above the BAR's size, so
that writing all-ones and reading back gives the size, as a BIOS sizes a BAR) and the interrupt
line. Status bit 3 (Interrupt Status, PCI 2.3) follows the card's interrupt line level; command
bit 10 (Interrupt Disable, PCI 2.3 §6.2.2: "a value of 1 disables the assertion of its INTx#
signal") keeps that level from the host (`IrqLine.mask`).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from vdevmaps.pci import (
    BAR0,
    CACHE_LINE_SIZE,
    CLASS_CODE,
    COMMAND,
    COMMAND_INTX_DISABLE,
    COMMAND_IO,
    COMMAND_MASTER,
    COMMAND_MEMORY,
    COMMAND_PARITY,
    COMMAND_SERR,
    CONFIG_SIZE,
    HEADER_TYPE,
    INTERRUPT_LINE,
    INTERRUPT_PIN,
    LATENCY_TIMER,
    REVISION_ID,
    STATUS,
    STATUS_DEVSEL_MEDIUM,
    STATUS_INTERRUPT,
    SUBSYSTEM_VENDOR_ID,
    VENDOR_ID,
)

from vdevd.irq import IrqLine
from vdevd.region import Region

#: the command register bits a device of this kind implements (PCI 2.3 §6.2.2)
COMMAND_WRITABLE = (COMMAND_IO | COMMAND_MEMORY | COMMAND_MASTER | COMMAND_PARITY | COMMAND_SERR
                    | COMMAND_INTX_DISABLE)


@dataclass(frozen=True, slots=True)
class Bar:
    """A base address register: its size in bytes (a power of two) and kind."""

    size: int
    io: bool = False
    prefetchable: bool = False

    def flags(self) -> int:
        """The read-only low bits: I/O space, or 32-bit memory (prefetchable or not)."""
        return 0x1 if self.io else (0x8 if self.prefetchable else 0x0)


@dataclass(frozen=True, slots=True)
class PciIdentity:
    """What a card's configuration header says about it (its README gives the sources)."""

    vendor: int
    device: int
    revision: int
    class_code: int  # base class << 16 | sub-class << 8 | programming interface
    subsystem_vendor: int
    subsystem: int
    bars: tuple[Bar | None, ...] = ()  # BAR0.. BAR5; None: not implemented (reads 0)
    interrupt_pin: int = 1  # INTA#
    interrupt_line: int = 0xFF  # not yet assigned by the host


def bar_addresses(bars: tuple[Bar | None, ...], base: int = 0xF000_0000) -> list[int]:
    """Addresses a BIOS would give the memory BARs, each aligned to its size, from `base`; I/O
    BARs from 0xE000."""
    out, mem, io = [], base, 0xE000
    for bar in bars:
        if bar is None:
            out.append(0)
        elif bar.io:
            io = -(-io // bar.size) * bar.size
            out.append(io)
            io += bar.size
        else:
            mem = -(-mem // bar.size) * bar.size
            out.append(mem)
            mem += bar.size
    return out


class ConfigSpace:
    """The `config` region of one PCI card."""

    def __init__(self, identity: PciIdentity, irq: IrqLine | None, base: int = 0xF000_0000
                 ) -> None:
        if len(identity.bars) > 6:
            raise ValueError("a type 0 header has six BARs")
        for bar in identity.bars:
            if bar is not None and (bar.size < 16 or bar.size & (bar.size - 1)):
                raise ValueError(f"BAR size {bar.size:#x} is not a power of two >= 16")
        self.identity = identity
        self.irq = irq
        self.region = Region("config", CONFIG_SIZE, widths=(1, 2, 4), endian="little",
                             description="PCI configuration space, type 0 header (PCI 2.3 §6.1)")
        self._addresses = bar_addresses(identity.bars, base)
        self.reset()
        self.region.hook(0, CONFIG_SIZE, on_read=self._read, on_write=self._write, peek=self._read)

    def reset(self) -> None:
        """The header as at power-up (RST#): command 0, the BARs at their assigned addresses."""
        i, buf = self.identity, self.region.buf
        buf[:] = bytes(CONFIG_SIZE)
        struct.pack_into("<HHHH", buf, VENDOR_ID, i.vendor, i.device, 0, STATUS_DEVSEL_MEDIUM)
        buf[REVISION_ID] = i.revision
        buf[CLASS_CODE:CLASS_CODE + 3] = i.class_code.to_bytes(3, "little")
        buf[HEADER_TYPE] = 0x00
        for n, (bar, address) in enumerate(zip(i.bars, self._addresses, strict=True)):
            if bar is not None:
                struct.pack_into("<I", buf, BAR0 + 4 * n, address | bar.flags())
        struct.pack_into("<HH", buf, SUBSYSTEM_VENDOR_ID, i.subsystem_vendor, i.subsystem)
        buf[INTERRUPT_LINE], buf[INTERRUPT_PIN] = i.interrupt_line, i.interrupt_pin
        if self.irq is not None:
            self.irq.mask(False)  # Interrupt Disable is 0 after RST#

    def _read(self, offset: int, size: int) -> bytes:
        data = bytearray(self.region.buf[offset:offset + size])
        if offset <= STATUS < offset + size and self.irq is not None and self.irq.asserted:
            data[STATUS - offset] |= STATUS_INTERRUPT
        return bytes(data)

    def _write(self, offset: int, data: bytes) -> None:
        buf = self.region.buf
        for k, byte in enumerate(data):
            at = offset + k
            mask = self._writable(at)
            buf[at] = (buf[at] & ~mask) | (byte & mask)
        if self.irq is not None and offset <= COMMAND + 1 and offset + len(data) > COMMAND:
            command = struct.unpack_from("<H", buf, COMMAND)[0]
            self.irq.mask(bool(command & COMMAND_INTX_DISABLE))

    def _writable(self, at: int) -> int:
        """The bits of byte `at` a configuration write may change."""
        if at in (COMMAND, COMMAND + 1):
            return (COMMAND_WRITABLE >> (8 * (at - COMMAND))) & 0xFF
        if at in (CACHE_LINE_SIZE, LATENCY_TIMER, INTERRUPT_LINE):
            return 0xFF
        if BAR0 <= at < BAR0 + 24:
            n, k = divmod(at - BAR0, 4)
            bars = self.identity.bars
            bar = bars[n] if n < len(bars) else None
            if bar is None:
                return 0
            mask = (~(bar.size - 1)) & 0xFFFF_FFFF & ~(0x3 if bar.io else 0xF)
            return (mask >> (8 * k)) & 0xFF
        return 0
