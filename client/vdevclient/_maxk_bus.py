"""The pure parts of the OMS MAXk host interface (spec oms.md §2-3): plain-int masks derived from
the register maps (`vdevmaps.oms`, shared with the daemon), framing a command, slicing the rings,
decoding capture entries.

Nothing here talks to a daemon; `vdevclient.maxk` drives these registers in batches.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from vdevmaps.oms import (
    CAPTURE_ENTRY_SIZE,
    CAPTURE_SLOTS,
    MAX_MESSAGE,
    RING_SIZE,
    AxisFlags,
    FirmwareState,
    MaxkDoorbell,
    Shm,
)

TERMINATOR = b";"
LF = b"\n"
#: the four ring indices in one 16-byte read: command insert/process, response insert/process
INDICES = Shm.COMMAND_INSERT
INDICES_SIZE = 16

#: plain ints of the bits the client combines (IntFlag arithmetic is slow on a hot path)
ALL_DONE = 0xFF
EVENT_BITS = 0x0101_0101  # done, over-travel and slip of the axis in the X slot
COMMAND_ERROR = int(MaxkDoorbell.COMMAND_ERROR)
WK_NOTIFICATION = (int(MaxkDoorbell.W_NOTIFICATION), int(MaxkDoorbell.K_NOTIFICATION))
ODBR_ALL = 0x07FF_FFFF
WK_ALL = int(AxisFlags.DONE | AxisFlags.OVERTRAVEL | AxisFlags.SLIP)
#: the low three bits of a running card; 0xFFFFFFFF (power-up not complete) has all three set
FIRMWARE_PHASE = int(FirmwareState.NOT_DOWNLOADED | FirmwareState.INITIALIZING | FirmwareState.RUNNING)
RUNNING = int(FirmwareState.RUNNING)


class MessageTooLong(ValueError):
    """A command string longer than the ring can hold (1023 bytes with its ';')."""


def frame(command: str | bytes) -> bytes:
    """The bytes a driver writes into the command ring: ASCII, ';' appended if missing (EPICS'
    terminator, E-drvMAXv mod 25); MessageTooLong over 1023 bytes."""
    data = command.encode("latin-1") if isinstance(command, str) else bytes(command)
    if not data.endswith(TERMINATOR):
        data += TERMINATOR
    if len(data) > MAX_MESSAGE:
        raise MessageTooLong(f"a command of {len(data)} bytes exceeds the {MAX_MESSAGE}-byte limit")
    return data


def ring_pieces(index: int, size: int) -> list[tuple[int, int, int]]:
    """(ring offset, start, length) of `size` bytes from ring index `index`, split where the ring
    wraps: `data[start:start + length]` goes to `ring + offset`. Each piece is an access the bus
    takes: 2 or 4 bytes are one access of that width and must be aligned (PROTOCOL.md), so such
    a piece at an odd place is written as a byte and a block of the rest."""
    if index + size <= RING_SIZE and (size not in (2, 4) or not index % size):
        return [(index, 0, size)]  # the usual case: one piece
    first = min(size, RING_SIZE - index)
    pieces = [(index, 0, first)]
    if first < size:
        pieces.append((0, first, size - first))
    out = []
    for offset, start, length in pieces:
        if length in (2, 4) and offset % length:
            out += [(offset, start, 1), (offset + 1, start + 1, length - 1)]
        else:
            out.append((offset, start, length))
    return out


def ring_slice(ring: bytes | memoryview, start: int, end: int) -> bytes:
    """The bytes of a 1024-byte ring between the indices `start` (inclusive) and `end`."""
    if start <= end:
        return bytes(ring[start:end])
    return bytes(ring[start:]) + bytes(ring[:end])


def strip_reply(message: bytes) -> str:
    """A reply's text: one message ends in LF (fw >= 1.30; older firmware sent LF NUL)."""
    return message.rstrip(b"\0").removesuffix(LF).decode("latin-1")


def be32(data: bytes, offset: int = 0) -> int:
    return int.from_bytes(data[offset:offset + 4], "big")


def le32(data: bytes) -> int:
    return int.from_bytes(data, "little")


@dataclass(frozen=True)
class CaptureEntry:
    """One real-time capture record (Table 3-5/3-6)."""

    encoder: int  # the captured encoder position
    axis: int  # 0 = X ... 9 = K
    home: int  # 0x01 home switch rising, 0x02 encoder home event, 0x04 home switch falling
    io_rising: int  # GP inputs whose positive edge triggered the capture
    io_falling: int


_ENTRY = struct.Struct(">iBBHH")


def capture_entries(block: bytes) -> tuple[int, int, list[CaptureEntry]]:
    """(insert, removal, the entries from removal up to insert) of the CAPTURE_SIZE bytes at 0x1540."""
    insert, removal = block[0] % CAPTURE_SLOTS, block[1] % CAPTURE_SLOTS
    out = []
    slot = removal
    while slot != insert:
        off = 2 + slot * CAPTURE_ENTRY_SIZE
        out.append(CaptureEntry(*_ENTRY.unpack_from(block, off)))
        slot = (slot + 1) % CAPTURE_SLOTS
    return insert, removal, out
