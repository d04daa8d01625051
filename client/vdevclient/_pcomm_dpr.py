"""PComm32's DPRAM functions (spec pmac.md §3.1): raw memory, IEEE and PMAC floats, and the real-time
and background reporting buffers in the Turbo layout (PComm32 dprrtdbt.h `realtTURBO`, dprbkg.h
`backgTURBO`; EPICS tpmac drvPmac.c; the card's README "Reporting buffers"). Re-exported from
`vdevclient.pcomm`. The offsets duplicate vdevd/devices/pmac/dpram.py: keep them in step.

On the daemon's machine the raw accesses (`PmacDPRGetMem`, `PmacDPRSetMem`, the float and
data-ready functions) go through the daemon's shared memory, as PComm32 reads the real DPRAM
through its mapping (decision 0010); the handshake words and the sampling waits stay requests."""

from __future__ import annotations

import ctypes
import logging
import struct
from typing import Any

from vdevmaps.pmac import (
    BG_CS_COUNT,
    BG_READY,
    BG_STATUS,
    DPRAM_SIZE,
    READY,
    RESP_CONTROL,
    RT_MASK,
    RT_MOTOR,
    RT_READY,
)

from vdevclient._cargs import target as _target
from vdevclient._pcomm_codes import COMM_EOT
from vdevclient._pcomm_device import _NS_PER_MS, _Device, _guarded, _number, _reply
from vdevclient._pmac_bus import (
    RESP_SLOT,
    MotorReport,
    join48,
    motor_report,
    pmac_float,
    realtime_motor,
)

log = logging.getLogger("vdevclient.pcomm")  # the public module's logger

# -- source and destination parameters -------------------------------------------------------------
def _bytes_of(val: Any, count: int) -> bytes:
    """`count` bytes of a source parameter: bytes-like, a ctypes object, a list of byte values."""
    val = _target(val)
    if isinstance(val, list | tuple):
        return bytes(int(v) & 0xFF for v in val[:count])
    if isinstance(val, ctypes._SimpleCData | ctypes.Array | ctypes.Structure):
        return ctypes.string_at(ctypes.addressof(val), min(count, ctypes.sizeof(val)))
    return bytes(val)[:count]


def _fill(val: Any, data: bytes) -> None:
    """Copy `data` into a destination parameter (ctypes object, bytearray or list)."""
    target = _target(val)
    if target is None:
        return
    if isinstance(target, list):
        target[:len(data)] = list(data)
    elif isinstance(target, bytearray | memoryview):
        target[:len(data)] = data
    else:
        ctypes.memmove(ctypes.addressof(target), data, min(len(data), ctypes.sizeof(target)))


# -- DPRAM ----------------------------------------------------------------------------------------------
def _pieces(offset: int, count: int) -> list[tuple[int, int]]:
    """A 2- or 4-byte access the bus would refuse misaligned, as a byte and a block."""
    if count in (2, 4) and offset % count:
        return [(offset, 1), (offset + 1, count - 1)]
    return [(offset, count)]


def _mapped(dev: _Device, pieces: list[tuple[int, int]]) -> bool:
    """Every piece goes through shared memory, and none touches the response slot while its
    acknowledgement is still deferred (`dev.pending`: the ack lets the card post its next line
    there, so such a read or write goes in the batch after it, as before)."""
    memory = dev.memory
    if not all(memory.is_mapped(o, n) for o, n in pieces):
        return False
    return not dev.pending or all(o + n <= RESP_CONTROL or o >= RESP_CONTROL + RESP_SLOT
                                  for o, n in pieces)


def _get(dev: _Device, offset: int, count: int) -> bytes:
    """`count` bytes at `offset`: from shared memory, else in one batch after the pending ops."""
    pieces = _pieces(offset, count)
    if _mapped(dev, pieces):
        return b"".join(dev.memory.read(o, n) for o, n in pieces)
    res = dev.batch(dev.begin() + [dev.read(o, n) for o, n in pieces])
    return b"".join(res[-len(pieces):])


def _set(dev: _Device, offset: int, data: bytes) -> None:
    """`data` at `offset`: into shared memory, else in one batch after the pending ops."""
    pieces = _pieces(offset, len(data))
    if _mapped(dev, pieces):
        for o, n in pieces:
            dev.memory.write(o, data[o - offset:o - offset + n])
        return
    dev.batch(dev.begin() + [dev.write(o, data[o - offset:o - offset + n]) for o, n in pieces])


@_guarded(False)
def PmacDPRAvailable(dev: _Device) -> bool:
    """The card has a DPRAM (every pmac-turbo has)."""
    return True


@_guarded(None)
def PmacDPRGetMem(dev: _Device, offset: int, count: int, val: Any = None) -> bytes | None:
    """`count` bytes at host byte `offset`, copied into `val` (a ctypes object, bytearray or list)
    and returned; None when the range is outside the DPRAM or the device is not open."""
    offset, count = int(offset), int(count)
    if count <= 0 or offset < 0 or offset + count > DPRAM_SIZE:
        return None
    data = _get(dev, offset, count)
    _fill(val, data)
    return data


@_guarded(None)
def PmacDPRSetMem(dev: _Device, offset: int, count: int, val: Any) -> Any:
    """Write `count` bytes of `val` (bytes-like, ctypes object, list of byte values) at host byte
    `offset`; returns `val`, None when outside the DPRAM. A write of the handshake words acts."""
    offset = int(offset)
    data = _bytes_of(val, int(count))
    if not data or offset < 0 or offset + len(data) > DPRAM_SIZE:
        return None
    _set(dev, offset, data)
    return val


@_guarded(0.0)
def PmacDPRGetFloat(dev: _Device, offset: int) -> float:
    """The 32-bit IEEE float at host byte `offset` (`F:` format)."""
    return float(struct.unpack("<f", _get(dev, int(offset), 4))[0])


@_guarded(None)
def PmacDPRSetFloat(dev: _Device, offset: int, val: float) -> None:
    _set(dev, int(offset), struct.pack("<f", float(val)))


def _halves(d: Any) -> tuple[int, int]:
    d = _target(d)
    return int(getattr(d[0], "value", d[0])), int(getattr(d[1], "value", d[1]))


def PmacDPRFloat(d: Any, scale: float) -> float:
    """A 48-bit PMAC float given as its two sign-extended 24-bit DPRAM words (low, high), times
    `scale`."""
    return pmac_float(*_halves(d)) * scale


def PmacDPRLFixed(d: Any, scale: float) -> float:
    """A 48-bit fixed-point value given as its two sign-extended 24-bit words, times `scale`."""
    return join48(*_halves(d)) * scale


@_guarded(False)
def PmacDPRRealTimeEx(dev: _Device, mask: int, period: int, on: int) -> bool:
    """Switch the real-time motor buffer on: `mask` (bit n-1 = motor n) to L:$06001C, the
    data-ready bit cleared so the first sample comes at once, I47 = `period` servo cycles,
    I48 = 1; or off (I48 = 0)."""
    if on:
        line = f"I47={max(int(period), 1)} I48=1"
        setup = [dev.write(RT_MASK, struct.pack("<I", int(mask) & 0xFFFFFFFF)),
                 dev.write(RT_READY, b"\0\0")]
    else:
        line, setup = "I48=0", []
    ops = dev.command_ops(line.encode(), [*dev.begin(), *setup])
    return _reply(*dev.collect(ops, line.encode()))[1] == COMM_EOT


@_guarded(False)
def PmacDPRBackgroundEx(dev: _Device, on: int, period: int, crd: int) -> bool:
    """Switch the background buffer on: `crd` coordinate systems (0-16) to Y:$06019D, the
    data-ready bit cleared, I50 = `period` servo cycles, I49 = 1; or off (I49 = 0)."""
    if on:
        line = f"I50={max(int(period), 1)} I49=1"
        setup = [dev.write(BG_CS_COUNT, struct.pack("<H", min(max(int(crd), 0), 16))),
                 dev.write(BG_READY, b"\0\0")]
    else:
        line, setup = "I49=0", []
    ops = dev.command_ops(line.encode(), [*dev.begin(), *setup])
    return _reply(*dev.collect(ops, line.encode()))[1] == COMM_EOT


@_guarded(None)
def PmacDPRResetDataReadyBit(dev: _Device) -> None:
    """Clear the real-time buffer's data-ready bit (X:$06001B bit 15): request the next sample."""
    _set(dev, RT_READY, b"\0\0")


@_guarded(0)
def PmacDPRGetDataReadyBit(dev: _Device) -> int:
    """1 while a real-time sample is posted and not yet taken, else 0."""
    word = struct.unpack("<H", _get(dev, RT_READY, 2))[0]
    return int(bool(word & READY))


def _sample(dev: _Device, ready: int, offset: int, size: int) -> bytes:
    """`size` bytes at `offset` of the card's next sample of the buffer whose data-ready word is
    at `ready`: one batch [clear data ready, wait for the card to set it, read]. The card writes
    only while the bit is clear, so a read without the wait would give the sample taken just
    after the previous clear. In lockstep the wait advances time to the next sample (I47 or I49
    servo cycles); with reporting off it ends after `timeout_ms` and the stale data is read."""
    timeout_ns = dev.timeout_ms * _NS_PER_MS
    wait = {"op": "wait", "on": "value", "offset": ready, "size": 2, "mask": READY, "value": READY,
            "cmp": "eq", "timeout_ns": timeout_ns, **dev.where}
    res = dev.batch(dev.begin() + [dev.write(ready, b"\0\0"), wait, dev.read(offset, size)], timeout_ns)
    if res[-2]["fired"]:
        return bytes(res[-1])
    log.warning("%s: no sample in the reporting buffer at %#x (reporting off?)", dev.card, ready)
    return bytes(dev.batch([dev.read(offset, size)])[-1])


def _motor(dev: _Device, mtr: int) -> MotorReport | None:
    """Motor `mtr`'s record from the next real-time sample; None for a motor the card lacks."""
    if not 1 <= mtr <= dev.motors:
        return None
    return motor_report(_sample(dev, RT_READY, realtime_motor(mtr), RT_MOTOR))


def _position_scale(dev: _Device, mtr: int) -> float:
    """Ixx08 * 32, read once per motor (one more round trip on first use)."""
    if mtr not in dev.scale:
        dev.scale[mtr] = 32.0 * (_number(dev.get_variable("I", 100 * mtr + 8)) or 1.0)
    return dev.scale[mtr]


@_guarded(0.0)
def PmacDPRPosition(dev: _Device, mtr: int, units: float) -> float:
    """Motor `mtr`'s (1-based) actual position from the card's next real-time sample (see
    `_sample`; PmacDPRRealTimeEx must be on with the motor in its mask), counts times `units`."""
    rec = _motor(dev, int(mtr))
    return 0.0 if rec is None else rec.actual / _position_scale(dev, int(mtr)) * units


@_guarded(0.0)
def PmacDPRFollowError(dev: _Device, mtr: int, units: float) -> float:
    """Motor `mtr`'s following error from the next real-time sample, counts times `units`."""
    rec = _motor(dev, int(mtr))
    return 0.0 if rec is None else rec.following_error / _position_scale(dev, int(mtr)) * units


@_guarded(0.0)
def PmacDPRGetVel(dev: _Device, mtr: int, units: float) -> float:
    """Motor `mtr`'s filtered velocity from the next real-time sample, counts per servo cycle
    times `units` (Ixx09 is read on every call)."""
    rec = _motor(dev, int(mtr))
    if rec is None:
        return 0.0
    return rec.velocity / (32.0 * (_number(dev.get_variable("I", 100 * int(mtr) + 9)) or 1.0)) * units


@_guarded(0)
def PmacDPRMotorServoStatusTurbo(dev: _Device, mtr: int) -> int:
    """Motor `mtr`'s servo status (status word 1, the `?` reply's first word) from the next
    real-time sample (PComm32 returns it as `struct ssTURBO`)."""
    rec = _motor(dev, int(mtr))
    return 0 if rec is None else rec.status1


@_guarded(None)
def PmacDPRGetGlobalStatus(dev: _Device, gs: Any = None) -> tuple[int, int] | None:
    """The global status of the next background sample (PmacDPRBackgroundEx on) as the DPRAM
    holds it, L:$0601A2: Y:$000006 (the second word of `???`) then X:$000006 (the first), into
    `gs` (DWORD[2], ctypes array or list) and returned."""
    lo, hi = struct.unpack("<II", _sample(dev, BG_READY, BG_STATUS, 8))
    words = (lo & 0xFFFFFF, hi & 0xFFFFFF)
    target = _target(gs)
    if target is not None:
        target[0], target[1] = words
    return words
