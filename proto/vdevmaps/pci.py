"""The PCI configuration header, type 0 (PCI Local Bus Specification 2.3, §6.1, Figure 6-1):
offsets and bits of the `config` region every PCI card has, and its `lspci -n` line."""

from __future__ import annotations

import struct

CONFIG_SIZE = 256
VENDOR_ID, DEVICE_ID, COMMAND, STATUS = 0x00, 0x02, 0x04, 0x06
REVISION_ID, CLASS_CODE, CACHE_LINE_SIZE, LATENCY_TIMER = 0x08, 0x09, 0x0C, 0x0D
HEADER_TYPE, BAR0, SUBSYSTEM_VENDOR_ID, SUBSYSTEM_ID = 0x0E, 0x10, 0x2C, 0x2E
INTERRUPT_LINE, INTERRUPT_PIN = 0x3C, 0x3D
#: command register bits: I/O space, memory space, bus master, parity error response, SERR#
#: enable, interrupt disable (§6.2.2)
COMMAND_IO, COMMAND_MEMORY, COMMAND_MASTER = 0x0001, 0x0002, 0x0004
COMMAND_PARITY, COMMAND_SERR, COMMAND_INTX_DISABLE = 0x0040, 0x0100, 0x0400
#: status bit 3, Interrupt Status (PCI 2.3): the device's INTx# is asserted
STATUS_INTERRUPT = 1 << 3
#: DEVSEL# timing medium (status bits 10:9 = 01)
STATUS_DEVSEL_MEDIUM = 0x0200
#: the header bytes `lspci_line` needs
IDENTITY_SIZE = 0x30


def lspci_line(header: bytes) -> str:
    """`<class>: <vendor>:<device> (rev <rev>)`, hex as `lspci -n` prints it, from the first
    IDENTITY_SIZE bytes of a configuration header."""
    vendor, device = struct.unpack_from("<HH", header, VENDOR_ID)
    revision = header[REVISION_ID]
    class_code = int.from_bytes(header[CLASS_CODE:CLASS_CODE + 3], "little")
    return f"{class_code >> 8:04x}: {vendor:04x}:{device:04x} (rev {revision:02x})"
