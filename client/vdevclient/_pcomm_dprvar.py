"""PComm32's DPRAM background variable buffer functions (I55): the read buffer (PmacDPRVarBufInit,
PmacDPRVarBufRead ...) and the write buffer (PmacDPRWriteBuffer), in the Turbo layout [Turbo UM
p.407-410; EPICS tpmac drvPmac.c drvPmacVarSetup/drvPmacVarRead; PComm32 dprbkg.h `backgvar`,
`backgvarwrite`, `VBGWFormat`; runtime headers for the signatures; the card's dpram_vars.py and
README "Variable buffers"]. Re-exported from `vdevclient.pcomm`.

An entry of `addrarray` (and a VBGWFormat's `type_addr`) is the two 16-bit words of the card's
address specification as one 32-bit value: the register's Turbo address in bits 0-18 and the
register in bits 20-21 (0 Y, 1 L, 2 X): `0x106001` is L:$6001 (P1), `0x200000` X:$000000 (the
servo counter), `0x000000 | a` Y:a (VBG_Y, VBG_L, VBG_X below). ASSUMPTIONS (PComm32's own source
was not retrieved): the users share one single-user table, placed by `VB_CLIENT_START`; each
read takes a fresh update (the data-ready bit cleared, then waited for, as EPICS does);
PmacDPRWriteBuffer answers the entries the card took (0 when it did not take them in time).
"""

from __future__ import annotations

import ctypes
import struct
from typing import Any

from vdevmaps.pmac import (
    OPEN_USE,
    VB_CLIENT_START,
    VB_CONTROL,
    VB_MAX_ENTRIES,
    VB_READY,
    VB_SIZE,
    VB_START,
    VB_TIMER,
    VBW_CLIENT_START,
    VBW_MAX_ENTRIES,
    VBW_SIZE,
    VBW_START,
)

from vdevclient._cargs import target as _target
from vdevclient._pcomm_codes import COMM_EOT
from vdevclient._pcomm_device import _NS_PER_MS, _Device, _guarded, _reply
from vdevclient._pcomm_dpr import _get, _set

MAX_VBGBUF_USERS = 9  # PComm32 dpr.h
#: the register in an `addrarray` entry (bits 20-21: the card's type word bits 4-5)
VBG_Y, VBG_L, VBG_X = 0x000000, 0x100000, 0x200000


class VBGWFormat(ctypes.Structure):
    """PComm32 dprbkg.h: an entry of the write buffer (address and type, then the data)."""

    _fields_ = [("type_addr", ctypes.c_long), ("data1", ctypes.c_long), ("data2", ctypes.c_long)]


def _long(entry: int) -> bool:
    return (entry >> 20 & 3) == 1


def _users(dev: _Device) -> dict[int, list[int]]:
    if dev.vbg is None:
        dev.vbg = {}
    users: dict[int, list[int]] = dev.vbg
    return users


def _layout(dev: _Device) -> dict[int, tuple[int, list[int]]]:
    """Per handle, the byte offset of its first data word and its entries, in table order."""
    at = OPEN_USE + 4 * (VB_CLIENT_START + sum(len(e) for e in _users(dev).values()))
    out = {}
    for h, entries in sorted(_users(dev).items()):
        out[h] = (at, entries)
        at += sum(8 if _long(e) else 4 for e in entries)
    return out


def _setup(dev: _Device) -> None:
    """Write the table: size 0, the start, every user's specifications, the size, control 0."""
    entries = [e for _, es in sorted(_users(dev).items()) for e in es]
    table = b"".join(struct.pack("<HH", e & 0xFFFF, (e >> 16) & 0x37) for e in entries)
    ops = [dev.write(VB_SIZE, b"\0\0"), dev.write(VB_START, struct.pack("<H", VB_CLIENT_START))]
    if table:
        ops.append(dev.write(OPEN_USE + 4 * VB_CLIENT_START, table))
    ops += [dev.write(VB_SIZE, struct.pack("<H", len(entries))), dev.write(VB_CONTROL, b"\0\0")]
    dev.batch(dev.begin() + ops)


def _entries(addrarray: Any, n: int) -> list[int]:
    arr = _target(addrarray)
    return [int(getattr(arr[i], "value", arr[i])) for i in range(n)]


@_guarded(False)
def PmacDPRBackGroundVar(dev: _Device, on: Any) -> bool:
    """I55 := 1 (the variable buffers served) or 0."""
    line = f"I55={1 if on else 0}".encode()
    return _reply(*dev.collect(dev.command_ops(line, dev.begin()), line))[1] == COMM_EOT


@_guarded(-1)
def PmacDPRVarBufInit(dev: _Device, new_num_entries: int, addrarray: Any) -> int:
    """A new user of the read buffer with `new_num_entries` registers (see the module's entry
    form): its handle (0-8), or -1 when no room (9 users, 128 registers in all)."""
    users = _users(dev)
    n = int(new_num_entries)
    total = sum(len(e) for e in users.values())
    free = [h for h in range(MAX_VBGBUF_USERS) if h not in users]
    if n < 1 or not free or total + n > VB_MAX_ENTRIES:
        return -1
    users[free[0]] = _entries(addrarray, n)
    _setup(dev)
    return free[0]


@_guarded(False)
def PmacDPRVarBufRemove(dev: _Device, h: int) -> bool:
    """Drop user `h` and rewrite the table."""
    if _users(dev).pop(int(h), None) is None:
        return False
    _setup(dev)
    return True


@_guarded(False)
def PmacDPRVarBufChange(dev: _Device, handle: int, new_num_entries: int, addrarray: Any) -> bool:
    """User `handle`'s registers replaced."""
    users = _users(dev)
    h, n = int(handle), int(new_num_entries)
    others = sum(len(e) for k, e in users.items() if k != h)
    if h not in users or n < 1 or others + n > VB_MAX_ENTRIES:
        return False
    users[h] = _entries(addrarray, n)
    _setup(dev)
    return True


def _fresh(dev: _Device, offset: int, size: int) -> bytes | None:
    """`size` bytes at `offset` from the card's next update: clear the data-ready bit, wait for
    it, read (None when the card did not post in `timeout_ms`: I55 off)."""
    timeout_ns = dev.timeout_ms * _NS_PER_MS
    wait = {"op": "wait", "on": "value", "offset": VB_CONTROL, "size": 2, "mask": VB_READY,
            "value": VB_READY, "cmp": "eq", "timeout_ns": timeout_ns, **dev.where}
    res = dev.batch(dev.begin() + [dev.write(VB_CONTROL, b"\0\0"), wait, dev.read(offset, size)],
                    timeout_ns)
    return bytes(res[-1]) if res[-2]["fired"] else None


def _put_longs(dest: Any, values: list[int]) -> None:
    arr = _target(dest)
    if arr is None:
        return
    for i, v in enumerate(values):
        if isinstance(arr, list) and i >= len(arr):
            arr.append(v)
        elif hasattr(arr[i], "value"):
            arr[i].value = v
        else:
            arr[i] = v


def _words(data: bytes) -> list[int]:
    return list(struct.unpack(f"<{len(data) // 4}i", data))


@_guarded(False)
def PmacDPRVarBufRead(dev: _Device, h: int, entry_num: int, long_2: Any) -> bool:
    """Register `entry_num` (0-based) of user `h` from the next update, as the card writes it
    (one sign-extended 32-bit word, an L register two: Y then X), into `long_2` (long[2])."""
    got = _layout(dev).get(int(h))
    if got is None or not 0 <= int(entry_num) < len(got[1]):
        return False
    at, entries = got
    at += sum(8 if _long(e) else 4 for e in entries[:int(entry_num)])
    data = _fresh(dev, at, 8 if _long(entries[int(entry_num)]) else 4)
    if data is None:
        return False
    _put_longs(long_2, _words(data))
    return True


@_guarded(False)
def PmacDPRVarBufReadEx(dev: _Device, h: int, long_x: Any) -> bool:
    """Every register of user `h` from one update, their words in order, into `long_x`."""
    got = _layout(dev).get(int(h))
    if got is None:
        return False
    at, entries = got
    data = _fresh(dev, at, sum(8 if _long(e) else 4 for e in entries))
    if data is None:
        return False
    _put_longs(long_x, _words(data))
    return True


@_guarded(0)
def PmacDPRGetVBGServoTimer(dev: _Device) -> int:
    """X:$060411: the servo count's low 16 bits at the last update."""
    return int(struct.unpack("<H", _get(dev, VB_TIMER, 2))[0])


@_guarded(0)
def PmacDPRGetVBGNumEntries(dev: _Device, h: int) -> int:
    return len(_users(dev).get(int(h), []))


@_guarded(0)
def PmacDPRGetVBGTotalEntries(dev: _Device) -> int:
    return sum(len(e) for e in _users(dev).values())


@_guarded(0)
def PmacDPRWriteBuffer(dev: _Device, num_entries: int, the_data: Any) -> int:
    """Write up to 32 registers through the write buffer: the entries at `VBW_CLIENT_START`, its
    start, then their number; the card copies them in its next background pass and writes 0
    there. The entries it took, or 0 (I55 off: not taken within `timeout_ms`)."""
    n = int(num_entries)
    data = _target(the_data)
    if not 1 <= n <= VBW_MAX_ENTRIES:
        return 0
    rows = []
    for i in range(n):
        e = data[i]
        ta, d1, d2 = ((e.type_addr, e.data1, e.data2) if hasattr(e, "type_addr") else e)
        rows.append(struct.pack("<HHii", int(ta) & 0xFFFF, int(ta) >> 16 & 0x37, int(d1), int(d2)))
    _set(dev, VBW_SIZE, b"\0\0")
    timeout_ns = dev.timeout_ms * _NS_PER_MS
    wait = {"op": "wait", "on": "value", "offset": VBW_SIZE, "size": 2, "mask": 0xFFFF,
            "value": 0, "cmp": "eq", "timeout_ns": timeout_ns, **dev.where}
    res = dev.batch(dev.begin() + [
        dev.write(OPEN_USE + 4 * VBW_CLIENT_START, b"".join(rows)),
        dev.write(VBW_START, struct.pack("<H", VBW_CLIENT_START)),
        dev.write(VBW_SIZE, struct.pack("<H", n)), wait], timeout_ns)
    if res[-1]["fired"]:
        return n
    _set(dev, VBW_SIZE, b"\0\0")  # withdrawn: the card must not take them later
    return 0
