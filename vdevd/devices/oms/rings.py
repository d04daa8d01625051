"""The firmware side of the shared-memory rings (sans-I/O: pure functions over the window's bytes).

Command ring [S §3.4.6; spec §2.4]: the host writes bytes from its insert index (0x0F0) and then
the index; the firmware takes the bytes from its process index (0x0F4) up to it and advances the
process index. Response ring [S §3.4.7; spec §2.5]: the firmware writes one reply (text + LF) from
its insert index (0x0F8), advances it and sets the message semaphore (0x094); the host takes the
bytes between its process index (0x0FC) and 0x0F8 as one message and releases the semaphore.
Capture ring [S §3.7]: 55 entries, the oldest overwritten when full.
"""

from __future__ import annotations

import struct

from vdevmaps.oms import CAPTURE_ENTRY_SIZE, CAPTURE_SLOTS, RING_SIZE, Shm

from vdevd.region import Memory

_U32 = struct.Struct(">I")
_ENTRY = struct.Struct(">iBBHH")
# the offsets as plain ints (an IntEnum costs a conversion on every access)
_SEMAPHORE = int(Shm.MESSAGE_SEMAPHORE)
_CMD_INSERT, _CMD_PROCESS = int(Shm.COMMAND_INSERT), int(Shm.COMMAND_PROCESS)
_RSP_INSERT, _RSP_PROCESS = int(Shm.RESPONSE_INSERT), int(Shm.RESPONSE_PROCESS)
_CMD_RING, _RSP_RING = int(Shm.COMMAND_RING), int(Shm.RESPONSE_RING)


def u32(buf: Memory, offset: int) -> int:
    return _U32.unpack_from(buf, offset)[0]


def put_u32(buf: Memory, offset: int, value: int) -> None:
    _U32.pack_into(buf, offset, value & 0xFFFFFFFF)


def commands_waiting(buf: Memory) -> bool:
    """Whether the host has put bytes in the command ring that `take_commands` has not taken."""
    return u32(buf, _CMD_INSERT) % RING_SIZE != u32(buf, _CMD_PROCESS) % RING_SIZE


def take_commands(buf: Memory) -> bytes:
    """The bytes the host has put in the command ring since the last call; advances 0x0F4.

    An index outside 0..1023 is taken modulo the ring size (the firmware masks it)."""
    insert = u32(buf, _CMD_INSERT) % RING_SIZE
    process = u32(buf, _CMD_PROCESS) % RING_SIZE
    if insert == process:
        return b""
    if insert > process:
        data = bytes(buf[_CMD_RING + process: _CMD_RING + insert])
    else:
        data = bytes(buf[_CMD_RING + process: _CMD_RING + RING_SIZE]) + bytes(
            buf[_CMD_RING: _CMD_RING + insert])
    put_u32(buf, _CMD_PROCESS, insert)
    return data


def response_free(buf: Memory) -> bool:
    """The host has released the last reply: semaphore 0 and its process index caught up."""
    return u32(buf, _SEMAPHORE) == 0 and u32(buf, _RSP_PROCESS) % RING_SIZE == u32(
        buf, _RSP_INSERT) % RING_SIZE


def post_response(buf: Memory, text: bytes) -> None:
    """Write one reply (the caller adds the LF) from 0x0F8, advance it, set the semaphore."""
    if len(text) >= RING_SIZE:
        text = text[: RING_SIZE - 2] + b"\n"
    insert = u32(buf, _RSP_INSERT) % RING_SIZE
    end = insert + len(text)
    if end <= RING_SIZE:
        buf[_RSP_RING + insert: _RSP_RING + end] = text
    else:
        first = RING_SIZE - insert
        buf[_RSP_RING + insert: _RSP_RING + RING_SIZE] = text[:first]
        buf[_RSP_RING: _RSP_RING + end - RING_SIZE] = text[first:]
    put_u32(buf, _RSP_INSERT, end % RING_SIZE)
    put_u32(buf, _SEMAPHORE, 1)


def push_capture(buf: Memory, position: int, axis: int, home_bits: int, rising: int,
                 falling: int) -> None:
    """Store one capture entry at the insert index; when the ring is full the removal index is
    pushed on (the oldest entry is lost) [S §3.7]."""
    insert = buf[Shm.CAPTURE_INSERT] % CAPTURE_SLOTS
    at = Shm.CAPTURE_ENTRIES + insert * CAPTURE_ENTRY_SIZE
    position = (position + 2**31) % 2**32 - 2**31
    _ENTRY.pack_into(buf, at, position, axis, home_bits, rising & 0xFFFF, falling & 0xFFFF)
    insert = (insert + 1) % CAPTURE_SLOTS
    buf[Shm.CAPTURE_INSERT] = insert
    if insert == buf[Shm.CAPTURE_REMOVAL] % CAPTURE_SLOTS:
        buf[Shm.CAPTURE_REMOVAL] = (insert + 1) % CAPTURE_SLOTS
