"""The OMS MAXk host interface as the host sees it (spec oms.md §2-3): the shared-memory map of BAR2
(`shm`, big-endian), the message-unit registers of BAR4 (`mu`, little-endian), their bits, and the
pure parts of the text protocol (framing a command, slicing the rings, decoding capture entries).

Nothing here talks to a daemon; `vdevclient.maxk` drives these registers in batches.
"""

from __future__ import annotations

import enum
import struct
from dataclasses import dataclass

CARD_TYPE = "oms-maxk"
SHM = "shm"  # BAR2, the 64 KiB dual-port RAM [S §3.2]
MU = "mu"  # BAR4, the MPC8245 message unit (spec §2.9)
AXES = "XYZTUVRSWK"  # canonical axis order [S App C L1340]
RING_SIZE = 1024  # both ASCII rings (Table 3-1)
MAX_MESSAGE = RING_SIZE - 1  # "drivers reject messages > 1023 bytes" (spec §2.4)
TERMINATOR = b";"
LF = b"\n"


class Shm(enum.IntEnum):
    """Byte offsets in the shared memory, Table 3-1 as spec §2.2 reconstructs it; 32-bit BE words."""

    MOTOR_POSITION = 0x000  # X..S, int32 each
    ENCODER_POSITION = 0x020  # X..S
    LIMITS = 0x040  # Table 3-2, raw input levels
    HOME = 0x044  # Table 3-3
    FIRMWARE_STATE = 0x048  # Table 3-4
    DIRECT_COMMAND = 0x04C  # §2.6: the card writes 0 back when done
    POSITION_REQUEST = 0x050  # §2.7: nonzero = snapshot please; the card writes 0 back
    COHERENT_MOTOR = 0x054  # X..S
    COHERENT_ENCODER = 0x074  # X..S
    MESSAGE_SEMAPHORE = 0x094  # §2.5: 1 = a reply is posted; the host writes 0 to release it
    GPIO = 0x09C
    WK_MOTOR = 0x0AC  # W, K
    WK_ENCODER = 0x0B4
    WK_COHERENT_MOTOR = 0x0BC
    WK_COHERENT_ENCODER = 0x0C4
    W_FLAGS = 0x0CC  # ODBR-shaped (AxisFlags), host W1C
    K_FLAGS = 0x0D0
    COMMAND_INSERT = 0x0F0  # host: the doorbell of the text channel
    COMMAND_PROCESS = 0x0F4  # card
    RESPONSE_INSERT = 0x0F8  # card
    RESPONSE_PROCESS = 0x0FC  # host
    COMMAND_RING = 0x100
    RESPONSE_RING = 0x500
    CAPTURE_INSERT = 0x1540  # §2.8, one byte each
    CAPTURE_REMOVAL = 0x1541
    CAPTURE_ENTRIES = 0x1542
    DAC = 0x2E80  # X..S
    WK_DAC = 0x2EC8
    SSI_POSITION = 0x3520  # X..K


#: the four ring indices in one 16-byte read: command insert/process, response insert/process
INDICES = Shm.COMMAND_INSERT
INDICES_SIZE = 16
CAPTURE_SLOTS = 55
CAPTURE_ENTRY_SIZE = 10
CAPTURE_SIZE = 2 + CAPTURE_SLOTS * CAPTURE_ENTRY_SIZE  # from CAPTURE_INSERT, Table 3-5


class Mu(enum.IntEnum):
    """Message-unit registers, MPC824x offsets [UB-I2O]; 32-bit LE accesses only (spec §2.9)."""

    OMISR = 0x030
    OMIMR = 0x034
    OMR0 = 0x058
    OMR1 = 0x05C
    ODBR = 0x060
    IDBR = 0x068


class Omisr(enum.IntFlag):
    """Outbound message interrupt status (W1C for OM0I/OM1I); OMIMR has the same bits, 1 = masked."""

    OM0I = 1 << 0  # OMR0 written: a text reply is posted
    OM1I = 1 << 1  # OMR1 written: real-time capture data
    ODI = 1 << 3  # ODBR != 0 (read-only)


class MaxkDoorbell(enum.IntFlag):
    """Outbound doorbell register, spec §3.1 [S §3.4.1-3.4.5]; the host clears bits by writing 1s."""

    DONE_X = 1 << 0
    DONE_Y = 1 << 1
    DONE_Z = 1 << 2
    DONE_T = 1 << 3
    DONE_U = 1 << 4
    DONE_V = 1 << 5
    DONE_R = 1 << 6
    DONE_S = 1 << 7
    OVERTRAVEL_X = 1 << 8
    OVERTRAVEL_Y = 1 << 9
    OVERTRAVEL_Z = 1 << 10
    OVERTRAVEL_T = 1 << 11
    OVERTRAVEL_U = 1 << 12
    OVERTRAVEL_V = 1 << 13
    OVERTRAVEL_R = 1 << 14
    OVERTRAVEL_S = 1 << 15
    SLIP_X = 1 << 16
    SLIP_Y = 1 << 17
    SLIP_Z = 1 << 18
    SLIP_T = 1 << 19
    SLIP_U = 1 << 20
    SLIP_V = 1 << 21
    SLIP_R = 1 << 22
    SLIP_S = 1 << 23
    COMMAND_ERROR = 1 << 24
    W_NOTIFICATION = 1 << 25  # details in Shm.W_FLAGS
    K_NOTIFICATION = 1 << 26  # details in Shm.K_FLAGS


class AxisFlags(enum.IntFlag):
    """The W and K status-flag words: the ODBR layout with the axis in the X slot (spec §3.1, §8 q.4)."""

    DONE = 1 << 0
    OVERTRAVEL = 1 << 8
    SLIP = 1 << 16


class FirmwareState(enum.IntFlag):
    """The firmware state word (Table 3-4)."""

    NOT_DOWNLOADED = 1 << 0
    INITIALIZING = 1 << 1
    RUNNING = 1 << 2
    APPLICATION_CHECKSUM_ERROR = 1 << 8
    APPLICATION_PROGRAMMING_ERROR = 1 << 9
    DEFAULTS_CHECKSUM_ERROR = 1 << 12
    DEFAULTS_PROGRAMMING_ERROR = 1 << 13
    ALTERNATE_CHECKSUM_ERROR = 1 << 14
    ALTERNATE_PROGRAMMING_ERROR = 1 << 15
    POWER_UP_SET = 1 << 16
    ALTERNATE_SET = 1 << 17
    FACTORY_SET = 1 << 18


class DirectCommand(enum.IntEnum):
    """Codes of the direct command mailbox 0x04C [SLAC-MAXv `enum directCommand`], spec §2.6."""

    CONTROLLER_ID_QUERY = 1
    KILL_ALL_MOTION = 2
    RESET_CONTROLLER = 3
    SOFTBOOT_CONTROLLER = 4


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
