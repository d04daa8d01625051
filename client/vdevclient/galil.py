"""The Galil DMC library (DMCCOM.H) for the virtual DMC-13X8 VME card, as Python functions.

Same names, argument order and return codes as Galil's C library (spec galil.md §6.2; behaviour
after the Linux `dmclnx` sources): every function returns a LONG code (`DMCNOERROR`, or one of the
negative `DMCERROR_*`) and writes its results through ctypes output parameters::

    h = ctypes.c_long()
    rc = galil.DMCOpen(1, 0, ctypes.byref(h))             # the first galil-dmc13x8 card
    buf = ctypes.create_string_buffer(256)
    rc = galil.DMCCommand(h, "TPX", buf, ctypes.sizeof(buf))  # buf.value == b"0000000000\\r\\n:"

Output parameters may be `ctypes.byref(x)`, `ctypes.pointer(x)` or the ctypes object itself; a
handle may be passed as an int or a `c_long`. Strings may be `str`, `bytes` or a ctypes char buffer.
The controller number of `DMCOpen` is the n-th card of type `galil-dmc13x8` in the order `hello`
lists the cards, on the daemon at $VDEVD_ENDPOINT (else tcp://127.0.0.1:5555, as
`vdevclient.connect`); keyword-only arguments after the C ones choose another (`endpoint=`).
"""

from __future__ import annotations

import ctypes
import functools
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zmq
from vdevmaps.galil import REV4DMCDataRecordAxisOffsets, REV4DMCDataRecordGeneralOffsets

from vdevclient._cargs import put_text
from vdevclient._cargs import target as _target
from vdevclient._cargs import text as _text
from vdevclient._galil_bus import (
    CARD_TYPE,
    DmcBus,
    DMCDataRecordAxisIds,
    DMCDataRecordItemIds,
    DMCDataRecordTypes,
    Reply,
    item_place,
    record_item,
    record_size,
    standard_type,
    terminators,
    too_long,
)
from vdevclient.core import Rack, connect
from vdevclient.errors import VdevClientError

log = logging.getLogger(__name__)

# -- return codes (DMCCOM.H) ---------------------------------------------------------------------------
DMCNOERROR = 0
DMCWARNING_MONITOR = 1
DMCERROR_TIMEOUT = -1
DMCERROR_COMMAND = -2
DMCERROR_CONTROLLER = -3
DMCERROR_FILE = -4
DMCERROR_DRIVER = -5
DMCERROR_HANDLE = -6
DMCERROR_HMODULE = -7
DMCERROR_MEMORY = -8
DMCERROR_BUFFERFULL = -9
DMCERROR_RESPONSEDATA = -10
DMCERROR_DMA = -11
DMCERROR_ARGUMENT = -12
DMCERROR_DATARECORD = -13
DMCERROR_DOWNLOAD = -14
DMCERROR_FIRMWARE = -15
DMCERROR_CONVERSION = -16
DMCERROR_RESOURCE = -17
DMCERROR_REGISTRY = -18
DMCERROR_BUSY = -19
DMCERROR_DEVICE_DISCONNECTED = -20

#: DMCError's texts [dmclnx.c DMCError]
_MESSAGES: dict[int, str] = {
    DMCERROR_TIMEOUT: "A time-out occurred while waiting for a response from the controller.",
    DMCERROR_CONTROLLER: "Galil controller could not be found in Windows registry.",
    DMCERROR_FILE: "File could not be opened.",
    DMCERROR_DRIVER: "Device driver could not be opened, or a read or write error occured.",
    DMCERROR_HANDLE: "Invalid Galil controller handle.",
    DMCERROR_HMODULE: "Support dynamic link library could not be loaded.",
    DMCERROR_MEMORY: "Out of memory.",
    DMCERROR_BUFFERFULL: "Response from the controller was larger than the response buffer supplied.",
    DMCERROR_RESPONSEDATA: "Response from the controller overflowed the internal additional "
                           "response buffer.",
    DMCERROR_DMA: "Could not communicate with DMA channel.",
    DMCERROR_ARGUMENT: "One or more required arguments to a DMC API function call was NULL.",
    DMCERROR_DATARECORD: "Could not access DMC data record.",
    DMCERROR_FIRMWARE: "Could not update the controller's firmware.",
    DMCERROR_DOWNLOAD: "Could not download the program to the controller.",
    DMCERROR_CONVERSION: "Could not convert DMC command (ASCII to binary or binary to ASCII).",
    DMCERROR_REGISTRY: "Could not access or modify the controller's registry information.",
    DMCERROR_RESOURCE: "Windows reports a resource conflict with the current hardware configuration.",
    DMCERROR_BUSY: "Controller is busy and not ready to accept commands.",
    DMCERROR_DEVICE_DISCONNECTED: "Controller has been disconnected from the communications channel "
                                  "(USB or Ethernet).",
}

DEFAULT_TIMEOUT_MS = 1000  # DMCGetTimeout: "The default is 1000."
#: DMCSetTimeout(0) means "ignore time-out errors"; a wait needs an end in lockstep, so a reply is
#: awaited this long (simulated time) and a missing one is not reported
ZERO_TIMEOUT_BOUND_MS = 10_000
DEFAULT_REFRESH_RATE = 4  # DR-4: a record every 2^4 samples, the library's default [dmclnx.c]
OPEN_TRIES = 5  # DMCOpen writes ';' up to five times while the card answers '?' [dmclnx.c]
LINES_MEMO_SIZE = 256  # command texts whose line is remembered, per controller


# C enums put their members in the global namespace: so do these (DRIdAxis1, DRREV4GenOffAxis1...)
for _enum in (DMCDataRecordTypes, DMCDataRecordItemIds, DMCDataRecordAxisIds,
              REV4DMCDataRecordGeneralOffsets, REV4DMCDataRecordAxisOffsets):
    globals().update(_enum.__members__)


# -- open controllers ---------------------------------------------------------------------------------
@dataclass
class _Controller:
    """An open handle: its connection and what the library keeps for it."""

    bus: DmcBus
    timeout_ms: int = DEFAULT_TIMEOUT_MS  # as set; the bus holds the one it waits (0 -> a bound)
    additional: bytes = b""  # what the last response buffer could not hold
    refresh_rate: int = DEFAULT_REFRESH_RATE  # DR-n; 0: no data record access
    record_on: bool = False  # DR-n sent since open or the last reset
    record_size: int = 0  # from QZ
    record: bytes | None = None  # the last refreshed record
    #: str/bytes command -> (the line DMCCommand sends, the replies it waits for); bounded
    lines: dict[str | bytes, tuple[bytes, int]] = field(default_factory=dict)


_controllers: dict[int, _Controller] = {}
_next_handle = 1


def _handle(hdmc: Any) -> _Controller | None:
    value = getattr(hdmc, "value", hdmc)
    return _controllers.get(value) if isinstance(value, int) else None


def _set(param: Any, value: int) -> None:
    _target(param).value = value


def _put(buffer: Any, size: int, data: bytes) -> bool:
    """Copy `data` NUL-terminated into a char buffer of `size` bytes; False if it was cut."""
    return put_text(buffer, size, data) == len(data)


def _ascii_command(command: Any) -> bytes:
    """The line DMCCommand sends: CR appended unless it ends in CR or ';' [dmclnx.c DMCCommand]."""
    data = _text(command) if command is not None else b""
    return data if data.endswith((b"\r", b";")) else data + b"\r"


def _line(c: _Controller, command: Any) -> tuple[bytes, int]:
    """The line DMCCommand sends for `command` and the replies it waits for (one per ';' or CR;
    -1: a command of it is longer than the command FIFO takes, `too_long`); a str or bytes
    command's is remembered (a host repeats its polls), the oldest going first."""
    if type(command) is not str and type(command) is not bytes:
        data = _ascii_command(command)
        return data, -1 if too_long(data) else terminators(data)
    line = c.lines.get(command)
    if line is None:
        data = _ascii_command(command)
        line = (data, -1 if too_long(data) else terminators(data))
        if len(c.lines) >= LINES_MEMO_SIZE:
            del c.lines[next(iter(c.lines))]
        c.lines[command] = line
    return line


def _guarded(fn: Callable[..., int]) -> Callable[..., int]:
    """Transport failures (no daemon, a closed rack) become DMCERROR_DRIVER, as a driver error."""

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> int:
        try:
            return fn(*args, **kwargs)
        except (VdevClientError, zmq.ZMQError) as exc:
            log.warning("%s: %s", fn.__name__, exc)
            return DMCERROR_DRIVER

    return call


def _reply(c: _Controller, reply: Reply, response: Any, size: int) -> int:
    """Hand a reply to the caller with DMCCommand's return code (see _outcome)."""
    whole = _put(response, size, reply.data) if response is not None and size else True
    return _outcome(c, reply, whole, size)


def _outcome(c: _Controller, reply: Reply, whole: bool, size: int) -> int:
    """DMCCommand's return code: '?' -> DMCERROR_COMMAND (even after a time-out), a time-out, a
    reply cut to the buffer (`whole` false) -> DMCERROR_BUFFERFULL (the rest is
    DMCGetAdditionalResponse's)."""
    c.additional = b"" if whole else reply.data[max(int(size) - 1, 0):]
    if b"?" in reply.data:
        return DMCERROR_COMMAND
    if reply.timed_out and c.timeout_ms:
        return DMCERROR_TIMEOUT
    return DMCNOERROR if whole else DMCERROR_BUFFERFULL


# -- opening ------------------------------------------------------------------------------------------
@_guarded
def DMCOpen(usController: int, hwnd: Any, phdmc: Any, *, endpoint: str | None = None,
            events: str | None = None, refresh_rate: int = DEFAULT_REFRESH_RATE) -> int:
    """Open controller `usController` (1-based, the n-th galil-dmc13x8 card of the rack) and write
    its handle to `phdmc`. A non-zero `hwnd` enables the card's interrupt output (2, 4 to N+3).
    `refresh_rate`: the data record comes every 2^n samples (DR-n, sent when a record is first
    needed: building records costs the card time); 0 means no data record access."""
    if phdmc is None:
        return DMCERROR_ARGUMENT
    _set(phdmc, -1)
    rack = connect(endpoint, events)
    cards = [card.name for card in rack.cards() if card.type == CARD_TYPE]
    if not 1 <= int(usController) <= len(cards):
        rack.close()
        return DMCERROR_CONTROLLER
    return _open(rack, cards[int(usController) - 1], hwnd, phdmc, refresh_rate)


@_guarded
def DMCOpenDesc(pszDescription: Any, hwnd: Any, phdmc: Any, pControllerNum: Any = None, *,
                endpoint: str | None = None, events: str | None = None,
                refresh_rate: int = DEFAULT_REFRESH_RATE) -> int:
    """Open the controller whose description is `pszDescription`: here the card's name ("galil0");
    its controller number goes to `pControllerNum` when given."""
    if phdmc is None:
        return DMCERROR_ARGUMENT
    _set(phdmc, -1)
    name = _text(pszDescription).decode("latin-1")
    rack = connect(endpoint, events)
    cards = [card.name for card in rack.cards() if card.type == CARD_TYPE]
    if name not in cards:
        rack.close()
        return DMCERROR_CONTROLLER
    if pControllerNum is not None:
        _set(pControllerNum, cards.index(name) + 1)
    return _open(rack, name, hwnd, phdmc, refresh_rate)


def _open(rack: Rack, card: str, hwnd: Any, phdmc: Any, refresh_rate: int) -> int:
    """The library's opening sequence [dmclnx.c DMCOpen]: drain, ';' until ':' (a '>' is the
    boot monitor), clear the FIFOs, echo off. QZ and DR-n wait for the first record."""
    global _next_handle
    c = _Controller(DmcBus(rack, card, timeout_ms=DEFAULT_TIMEOUT_MS), refresh_rate=refresh_rate)
    try:
        rc = _start(c, hwnd)
    except BaseException:
        rack.close()
        raise
    if rc < 0:
        rack.close()
        return rc
    handle, _next_handle = _next_handle, _next_handle + 1
    _controllers[handle] = c
    _set(phdmc, handle)
    return rc


def _start(c: _Controller, hwnd: Any) -> int:
    bus = c.bus
    bus.drain()
    reply = Reply(b"", timed_out=True)
    for _ in range(OPEN_TRIES):
        reply = bus.command(b";", 1)
        if b"?" not in reply.data:
            break
    if reply.timed_out:
        return DMCERROR_TIMEOUT
    if b">" in reply.data:
        return DMCWARNING_MONITOR
    bus.clear()
    if hwnd:
        bus.enable_interrupts()
    bus.command(b"EO0\r", 1)
    return DMCNOERROR


@_guarded
def DMCClose(hdmc: Any) -> int:
    """Close the handle (the data record stays on, as in Galil's library)."""
    c = _controllers.pop(getattr(hdmc, "value", hdmc), None)
    if c is None:
        return DMCERROR_HANDLE
    c.bus.rack.close()
    return DMCNOERROR


# -- commands -----------------------------------------------------------------------------------------
@_guarded
def DMCCommand(hdmc: Any, pszCommand: Any, pchResponse: Any, cbResponse: int) -> int:
    """Send an ASCII command line (CR appended unless it ends in CR or ';') and read the reply
    until one ':' or '?' per command; '?' gives DMCERROR_COMMAND (DMCError tells why). A line
    longer than the command FIFO goes in pieces of whole commands; a command longer than the
    FIFO takes (511 characters) is not sent: DMCERROR_ARGUMENT."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    data, replies = _line(c, pszCommand)
    if replies < 0:
        return DMCERROR_ARGUMENT
    return _reply(c, c.bus.command_line(data, replies), pchResponse, cbResponse)


def command_text(hdmc: Any, command: Any, size: int) -> tuple[int, bytes]:
    """DMCCommand into a response buffer of `size` (> 0) bytes, without the buffer (for
    vdevclient.gclib): its return code and the text the buffer would then hold."""
    try:
        c = _handle(hdmc)
        if c is None:
            return DMCERROR_HANDLE, b""
        data, replies = _line(c, command)
        if replies < 0:
            return DMCERROR_ARGUMENT, b""
        reply = c.bus.command_line(data, replies)
    except (VdevClientError, zmq.ZMQError) as exc:
        log.warning("DMCCommand: %s", exc)
        return DMCERROR_DRIVER, b""
    whole = len(reply.data) < size
    text = reply.data if whole else reply.data[:size - 1]
    return _outcome(c, reply, whole, size), text.split(b"\0", 1)[0]  # a C string ends at NUL


@_guarded
def DMCFastCommand(hdmc: Any, pszCommand: Any) -> int:
    """Send a command line without waiting for its reply; the reply goes to the unsolicited
    buffer when it comes."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    command = _ascii_command(pszCommand)
    if too_long(command):
        return DMCERROR_ARGUMENT
    c.bus.send(command, terminators(command))
    return DMCNOERROR


@_guarded
def DMCBinaryCommand(hdmc: Any, pbCommand: Any, ulCommandLength: int, pchResponse: Any,
                     cbResponse: int) -> int:
    """Send a binary command (spec §4.2: opcode 0x80-0xFF, format, coordinated, axis mask, data)
    and read until ':' or '?' [dmcbin.c]."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pbCommand is None or not ulCommandLength:
        return DMCERROR_ARGUMENT
    command = bytes(_target(pbCommand))[:int(ulCommandLength)]
    return _reply(c, c.bus.command(command, 1), pchResponse, cbResponse)


@_guarded
def DMCGetUnsolicitedResponse(hdmc: Any, pchResponse: Any, cbResponse: int) -> int:
    """What came from the card outside any command's reply (program output, late replies)."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pchResponse is None or not cbResponse:
        return DMCERROR_ARGUMENT
    c.bus.drain()
    pending = bytes(c.bus.unsolicited)
    n = max(int(cbResponse) - 1, 0)
    _put(pchResponse, cbResponse, pending[:n])
    del c.bus.unsolicited[:n]
    return DMCNOERROR


@_guarded
def DMCGetAdditionalResponseLen(hdmc: Any, pulResponseLen: Any) -> int:
    """The length of what did not fit the last response buffer (DMCERROR_BUFFERFULL)."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pulResponseLen is None:
        return DMCERROR_ARGUMENT
    _set(pulResponseLen, len(c.additional))
    return DMCNOERROR


@_guarded
def DMCGetAdditionalResponse(hdmc: Any, pchResponse: Any, cbResponse: int) -> int:
    """The rest of the last response; the internal buffer is emptied."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pchResponse is None or not cbResponse:
        return DMCERROR_ARGUMENT
    _put(pchResponse, cbResponse, c.additional)
    c.additional = b""
    return DMCNOERROR


@_guarded
def DMCError(hdmc: Any, lError: int, pchMessage: Any, cbMessage: int) -> int:
    """The text of an error code; for DMCERROR_COMMAND the card's reason (`TC1`, e.g.
    "1 Unrecognized command.") [dmclnx.c DMCError]; for DMCERROR_DOWNLOAD also the line in
    error (`MG_ED`)."""
    if pchMessage is None or not cbMessage:
        return DMCERROR_ARGUMENT
    rc, text = DMCNOERROR, _MESSAGES.get(int(lError), "Unknown error.").encode()
    if lError == DMCNOERROR:
        text = b""
    elif lError == DMCERROR_COMMAND:
        text = b"Could not retrieve error code from controller."
        c = _handle(hdmc)
        if c is not None:
            reply = c.bus.command(b"TC1\r", 1)
            rc = _reply(c, reply, None, 0)
            if rc == DMCNOERROR:
                cause = reply.data.rstrip(b":\r\n")
                text = cause + b"." if cause else b"Unknown command error."
    elif lError == DMCERROR_DOWNLOAD:
        c = _handle(hdmc)
        if c is not None:
            cause = c.bus.command(b"TC1\r", 1).data.rstrip(b":\r\n")
            line = c.bus.command(b"MG_ED\r", 1).data.rstrip(b":\r\n").strip()
            if cause and line:
                text += b" " + cause + b" at line " + str(int(float(line))).encode() + b"."
    _put(pchMessage, cbMessage, text)
    return rc


@_guarded
def DMCClear(hdmc: Any) -> int:
    """Clear both FIFOs: read N+3, write 01 80 01 80, read N+3 [M Ch4 §Clearing FIFO Buffer]."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    c.bus.clear()
    return DMCNOERROR


def _reset(c: _Controller, command: bytes) -> int:
    reply = c.bus.command(command, 1)
    rc = _reply(c, reply, None, 0)
    c.bus.forget()
    c.record_on = False  # the reset turned the data record off
    if rc == DMCNOERROR:
        rc = _reply(c, c.bus.command(b"EO0\r", 1), None, 0)
    return rc


@_guarded
def DMCReset(hdmc: Any) -> int:
    """`RS`, then echo off."""
    c = _handle(hdmc)
    return DMCERROR_HANDLE if c is None else _reset(c, b"RS\r")


@_guarded
def DMCMasterReset(hdmc: Any) -> int:
    """^R^S (factory defaults), then echo off."""
    c = _handle(hdmc)
    return DMCERROR_HANDLE if c is None else _reset(c, b"\x12\x13\r")


@_guarded
def DMCVersion(hdmc: Any, pchVersion: Any, cbVersion: int) -> int:
    """The firmware revision: the card's answer to ^R^V, its first line."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pchVersion is None or not cbVersion:
        return DMCERROR_ARGUMENT
    reply = c.bus.command(b"\x12\x16\r", 1)
    rc = _reply(c, reply, None, 0)
    if rc == DMCNOERROR and not reply.data.strip(b":\r\n"):
        rc = DMCERROR_COMMAND
    _put(pchVersion, cbVersion, reply.data.split(b"\r", 1)[0] if rc == DMCNOERROR else b"")
    return rc


# -- arrays --------------------------------------------------------------------------------------------
LONG_LINE = 1024  # bytes of a long line (QD's data) written per batch before the reply is read


def long_command(bus: DmcBus, data: bytes, replies: int) -> Reply:
    """`bus.command` for a line of any length: the bytes beyond the last LONG_LINE go first, a
    batch per LONG_LINE (as the library's DMCWriteData calls), so no batch holds hundreds of
    waits for FIFO room."""
    cut = max(len(data) - LONG_LINE, 0)
    for start in range(0, cut, LONG_LINE):
        bus.send(data[start:min(start + LONG_LINE, cut)], 0)
    return bus.command(data[cut:], replies)


@_guarded
def DMCArrayDownload(hdmc: Any, pszArrayName: Any, usFirstElement: int, usLastElement: int,
                     pchData: Any, cbData: int, pulBytesWritten: Any) -> int:
    """Write elements first..last of a dimensioned array: `QD name[],first,last` CR, the data
    (numbers separated by commas or CR; as Galil's library, LF and spaces become '0'), ^Z; the
    card answers ':' or '?' (DMCERROR_COMMAND: a missing array, a bad range or number; DMCError
    tells which) [DMCLIB DMCArrayDownload]."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pszArrayName is None or pchData is None or not cbData or pulBytesWritten is None:
        return DMCERROR_ARGUMENT
    data = _text(pchData)[:int(cbData)].replace(b"\n", b"0").replace(b" ", b"0")
    _set(pulBytesWritten, 0)
    line = b"QD %s[],%d,%d\r" % (_text(pszArrayName), int(usFirstElement), int(usLastElement))
    rc = _reply(c, long_command(c.bus, line + data + b"\x1a", 1), None, 0)
    if rc == DMCNOERROR:
        _set(pulBytesWritten, len(data))
    return rc


@_guarded
def DMCArrayUpload(hdmc: Any, pszArrayName: Any, usFirstElement: int, usLastElement: int,
                   pchData: Any, cbData: int, pulBytesRead: Any, fComma: int) -> int:
    """Read elements first..last of an array: `QU name[],first,last,fComma`; the values
    separated by commas (fComma 1) or CR (0), without the final CR LF ':' (a '?' empties the
    buffer: DMCERROR_COMMAND) [DMCLIB DMCArrayUpload]."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pszArrayName is None or pchData is None or not cbData or pulBytesRead is None:
        return DMCERROR_ARGUMENT
    _set(pulBytesRead, 0)
    line = b"QU %s[],%d,%d,%d\r" % (_text(pszArrayName), int(usFirstElement), int(usLastElement),
                                    int(fComma))
    reply = c.bus.command(line, 1)
    if b"?" in reply.data:
        _put(pchData, cbData, b"")
        return _outcome(c, reply, True, cbData)
    values = reply.data.rstrip(b"\x1a:\r\n")
    rc = _outcome(c, reply._replace(data=values), _put(pchData, cbData, values), cbData)
    _set(pulBytesRead, min(len(values), max(int(cbData) - 1, 0)))
    return rc


# -- interrupts ----------------------------------------------------------------------------------------
@_guarded
def DMCGetInterruptStatus(hdmc: Any, pusStatus: Any) -> int:
    """The oldest queued interrupt status code (write 6 to N+3, read N+3); 0 when none."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pusStatus is None:
        return DMCERROR_ARGUMENT
    _set(pusStatus, c.bus.interrupt_status())
    return DMCNOERROR


# -- data record ---------------------------------------------------------------------------------------
def _record_access(c: _Controller) -> bool:
    """Turn the data record on if it is not (QZ sizes it, DR-n starts it) [dmclnx.c DMCOpen]."""
    if c.record_on:
        return True
    if not c.refresh_rate:
        return False
    if not c.record_size:
        qz = c.bus.command(b"QZ\r", 1)
        size = None if qz.timed_out or b"?" in qz.data else record_size(qz.data.decode("latin-1"))
        if size is None:
            return False
        c.record_size = size
    dr = c.bus.command(b"DR-%d\r" % c.refresh_rate, 1)
    c.record_on = not dr.timed_out and b"?" not in dr.data
    return c.record_on


@_guarded
def DMCRefreshDataRecord(hdmc: Any, ulLength: int) -> int:
    """Read a fresh data record from the secondary FIFO [M Ch4 §Polling Mode Read Procedure]: the
    latest the card loaded (every 2^n samples), or the next one once the last was read."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if not _record_access(c):
        return DMCERROR_DATARECORD
    record = c.bus.read_record(c.record_size)
    if record is None:
        return DMCERROR_TIMEOUT
    c.record = record
    return DMCNOERROR


@_guarded
def DMCGetDataRecord(hdmc: Any, usGeneralOffset: int, usAxisInfoOffset: int, pusDataType: Any,
                     plData: Any) -> int:
    """One item of the last refreshed record by offsets (DRREV4GenOff*, DRREV4AxisOff*); with
    *pusDataType 0 the type of a standard offset is filled in."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if plData is None or pusDataType is None:
        return DMCERROR_ARGUMENT
    if c.record is None:
        return DMCERROR_DATARECORD
    general, axis = int(usGeneralOffset), int(usAxisInfoOffset)
    data_type = int(_target(pusDataType).value) or standard_type(general, axis)
    return _deliver_item(c.record, c.record_size, general, axis, data_type, pusDataType, plData)


@_guarded
def DMCGetDataRecordByItemId(hdmc: Any, usItemId: int, usAxisId: int, pusDataType: Any,
                             plData: Any) -> int:
    """One item of the last refreshed record by id (DRId*; DRIdAxis1.. for axis items)."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if plData is None or pusDataType is None:
        return DMCERROR_ARGUMENT
    if c.record is None:
        return DMCERROR_DATARECORD
    place = item_place(int(usItemId), int(usAxisId))
    if place is None:
        return DMCERROR_DATARECORD
    general, axis, data_type = place
    return _deliver_item(c.record, c.record_size, general, axis, int(data_type), pusDataType,
                         plData)


def _deliver_item(record: bytes, size: int, general: int, axis: int, data_type: int,
                  pusDataType: Any, plData: Any) -> int:
    """Fill the two output parameters of DMCGetDataRecord(ByItemId): the item's type and its
    value in the record."""
    _set(pusDataType, data_type)
    value = record_item(record, size, general, axis, data_type)
    if value is None:
        return DMCERROR_DATARECORD
    _set(plData, value)
    return DMCNOERROR


@_guarded
def DMCGetDataRecordSize(hdmc: Any, pusRecordSize: Any) -> int:
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pusRecordSize is None:
        return DMCERROR_ARGUMENT
    if not _record_access(c):
        return DMCERROR_DATARECORD
    _set(pusRecordSize, c.record_size)
    return DMCNOERROR


@_guarded
def DMCCopyDataRecord(hdmc: Any, pDataRecord: Any) -> int:
    """A copy of the last refreshed record (DMCGetDataRecordSize bytes) into `pDataRecord`."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pDataRecord is None:
        return DMCERROR_ARGUMENT
    if c.record is None:
        return DMCERROR_DATARECORD
    target = _target(pDataRecord)
    if ctypes.sizeof(target) < len(c.record):
        return DMCERROR_ARGUMENT
    ctypes.memmove(ctypes.addressof(target), c.record, len(c.record))
    return DMCNOERROR


@_guarded
def DMCGetDataRecordRevision(hdmc: Any, pusRevision: Any) -> int:
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pusRevision is None:
        return DMCERROR_ARGUMENT
    if not _record_access(c):
        return DMCERROR_DATARECORD
    _set(pusRevision, 4)
    return DMCNOERROR


# -- configuration -------------------------------------------------------------------------------------
@_guarded
def DMCGetTimeout(hdmc: Any, pTimeout: Any) -> int:
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pTimeout is None:
        return DMCERROR_ARGUMENT
    _set(pTimeout, c.timeout_ms)
    return DMCNOERROR


@_guarded
def DMCSetTimeout(hdmc: Any, lTimeout: int) -> int:
    """The reply time-out in ms of (simulated, in lockstep) card time; 0 ignores time-outs."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    timeout = int(getattr(lTimeout, "value", lTimeout))
    if timeout < 0:
        return DMCERROR_ARGUMENT
    c.timeout_ms = timeout
    c.bus.timeout_ms = timeout or ZERO_TIMEOUT_BOUND_MS
    return DMCNOERROR


# -- application programs [DMCLIB DMCDownloadFile, DMCUploadFile; spec §6.2] -------------------------
UPLOAD_END = b"\x1a"  # UL ends the program with ^Z, then ':'


def program_lines(text: bytes) -> list[bytes]:
    """The lines DMCDownloadFile sends: CR, LF or CR LF separated, trailing blanks removed, blank
    lines and REM lines left out [DMCLIB]."""
    lines = text.replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")
    out = [line.rstrip() for line in lines]
    return [line for line in out if line and not line.lstrip().startswith(b"REM")]


def download(c: _Controller, program: bytes, label: bytes = b"") -> int:
    """`EO0`, `DL[#label]`, the lines, `\\`: all the command FIFO's bursts in one batch; the
    card answers ':' once it has checked the program, '?' (DMCERROR_DOWNLOAD) when it refused
    a line (DMCError: TC1)."""
    data = b"EO0\rDL" + label + b"\r" + b"".join(line + b"\r" for line in program_lines(program))
    reply = c.bus.download(data + b"\\", 2)
    if b"?" in reply.data:
        return DMCERROR_DOWNLOAD
    if reply.timed_out and c.timeout_ms:
        return DMCERROR_TIMEOUT
    return DMCNOERROR


def upload(c: _Controller) -> tuple[int, bytes]:
    """`UL`: the program's lines (CR LF ends each), read until ^Z and the ':' after it."""
    reply = c.bus.command_until(b"UL\r", UPLOAD_END)
    if reply.timed_out:
        return (DMCERROR_TIMEOUT if c.timeout_ms else DMCNOERROR), b""
    if UPLOAD_END not in reply.data:
        return DMCERROR_COMMAND, b""
    return DMCNOERROR, reply.data.split(UPLOAD_END, 1)[0]


def _label(pszLabel: Any) -> bytes:
    label = _text(pszLabel) if pszLabel is not None else b""
    return label if not label or label.startswith(b"#") else b"#" + label


@_guarded
def DMCDownloadFromBuffer(hdmc: Any, pszBuffer: Any, pszLabel: Any = None) -> int:
    """Download the program in `pszBuffer` (from `pszLabel` on, when given: DL#label)."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pszBuffer is None:
        return DMCERROR_ARGUMENT
    return download(c, _text(pszBuffer), _label(pszLabel))


@_guarded
def DMCDownloadFile(hdmc: Any, pszFileName: Any, pszLabel: Any = None) -> int:
    """Download the program file `pszFileName`; DMCERROR_FILE when it cannot be read."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pszFileName is None:
        return DMCERROR_ARGUMENT
    try:
        with open(_text(pszFileName), "rb") as f:
            program = f.read()
    except OSError:
        return DMCERROR_FILE
    return download(c, program, _label(pszLabel))


@_guarded
def DMCUploadToBuffer(hdmc: Any, pchBuffer: Any, cbBuffer: int) -> int:
    """Upload the program into `pchBuffer` (NUL-terminated); DMCERROR_BUFFERFULL when it does
    not fit (the buffer then holds what did)."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pchBuffer is None or not cbBuffer:
        return DMCERROR_ARGUMENT
    rc, program = upload(c)
    if rc != DMCNOERROR:
        return rc
    return DMCNOERROR if _put(pchBuffer, cbBuffer, program) else DMCERROR_BUFFERFULL


@_guarded
def DMCUploadFile(hdmc: Any, pszFileName: Any) -> int:
    """Upload the program into the file `pszFileName`; DMCERROR_FILE when it cannot be written."""
    c = _handle(hdmc)
    if c is None:
        return DMCERROR_HANDLE
    if pszFileName is None:
        return DMCERROR_ARGUMENT
    rc, program = upload(c)
    if rc != DMCNOERROR:
        return rc
    try:
        with open(_text(pszFileName), "wb") as f:
            f.write(program)
    except OSError:
        return DMCERROR_FILE
    return DMCNOERROR


def controller_of(hdmc: Any) -> _Controller | None:
    """The open controller behind a handle (for vdevclient.gclib), None for a bad handle."""
    return _handle(hdmc)


def bus_of(hdmc: Any) -> DmcBus | None:
    """The register protocol behind a handle (for vdevclient.gclib), None for a bad handle."""
    c = _handle(hdmc)
    return None if c is None else c.bus
