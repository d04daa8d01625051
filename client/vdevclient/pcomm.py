"""Delta Tau PComm32 (Pcomm32.dll, spec pmac.md §3.1) for the virtual Turbo PMAC `pmac-turbo`, as
Python functions with PComm32's names, argument order and return codes::

    from vdevclient import pcomm

    pcomm.OpenPmacDevice(0)                               # the card whose `device` is 0
    buf = ctypes.create_string_buffer(256)
    rc = pcomm.PmacGetResponseA(0, buf, 256, "ver")      # buf.value == b"1.940\\r"
    assert rc == pcomm.COMM_EOT | 6 and rc.text == "1.940\\r"

The card is found on the daemon at $VDEVD_ENDPOINT (else tcp://127.0.0.1:5555, as
`vdevclient.connect`): device n is the pmac-turbo card whose `device` option is n; keyword-only
arguments of OpenPmacDevice choose another daemon. Text goes through the DPRAM ASCII handshake
(spec §2.10) exactly as the PCI driver does it, memory functions through the DPRAM region,
interrupts from the daemon's event stream of line `inta`.

Output parameters: a text buffer may be a ctypes char array (or `ctypes.byref` of one), a
`bytearray` (filled NUL-terminated, at most `maxchar` bytes) or a `list` (its contents replaced by
the one `str`); None is allowed. Functions returning a PComm status return a `CommResult`, an int
(`COMM_EOT | count` ...) that also carries the text as `.text`; PmacGetRomVersionA and
PmacGetRomDateA return the `str` where PComm returns the buffer pointer.

Responses (PmacGetResponseA, PmacGetControlResponseA): every data line ends with its CR, the final
ACK is removed; `COMM_EOT | count` when the ACK came; on an error the lines before it then the
error as a serial port with I6=1 shows it, `"\\x07ERR003\\r"`, with `COMM_ERROR | count` (no ACK
follows an error); `COMM_TIMEOUT | count` when the card stopped posting lines before the end
(card time, `timeout_ms`); `COMM_FAIL` for a device that is not open or a lost connection. A
command longer than 159 characters (MAX_DPRBUFFER with its NUL) is refused with COMM_FAIL.

Round trips: the card answers in the write of the command's control word, so a call is one
`batch` (PROTOCOL.md) [the command bytes at 0x0E9E, 0x0E9C := 1, the response slot, 0x0F40 := 0,
the slot ...], read ahead as far as this command's reply went the last time (two slots for a new
command); a longer reply costs one more batch, a slot the card has not filled a batch that waits
for it. The acknowledgement of the final ACK (0x0F40 := 0) is deferred into the next call's batch,
as the MAXk client defers its release, and rides in the next command's write (the command buffer
ends at 0x0F3F): a one-line reply is five ops.
"""

from __future__ import annotations

import ctypes
import functools
import logging
import math
import struct
import threading
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zmq

from vdevclient._cargs import put_text as _put_text
from vdevclient._cargs import target as _target
from vdevclient._cargs import text as _text
from vdevclient._pmac_bus import (
    ACK,
    BACKGROUND,
    CARD_TYPE,
    CMD_CHAR,
    CMD_CONTROL,
    CMD_MAX,
    CR,
    DPRAM,
    DPRAM_SIZE,
    HOST,
    IR_MASK,
    IR_STATUS,
    LINE,
    READY,
    REALTIME,
    RESP_CONTROL,
    RESP_SLOT,
    RT_MOTOR,
    HostIrq,
    MotorReport,
    Posted,
    PreprocessError,
    command_bytes,
    error_text,
    join48,
    motor_report,
    parse_slot,
    pmac_float,
    preprocess,
    realtime_motor,
)
from vdevclient.core import Rack, connect
from vdevclient.errors import VdevClientError

__all__ = [
    "COMM_ANYERR", "COMM_EOT", "COMM_ERROR", "COMM_FAIL", "COMM_OK", "COMM_TIMEOUT",
    "COMM_UNSOLICITED", "INTRBUFFER", "MAX_COMM_BUFFER", "MAX_DPRBUFFER", "MAX_DPRREADBUFFER",
    "ClosePmacDevice", "CommResult", "DrvNumberOfDevices", "HostIrq", "MotorReport",
    "OpenPmacDevice", "PmacDPRAvailable", "PmacDPRBackgroundEx", "PmacDPRFloat",
    "PmacDPRGetFloat", "PmacDPRGetGlobalStatus", "PmacDPRGetMem", "PmacDPRLFixed",
    "PmacDPRPosition", "PmacDPRRealTimeEx", "PmacDPRSetFloat", "PmacDPRSetMem", "PmacDownloadA",
    "PmacGetControlResponseA", "PmacGetLineA", "PmacGetPmacType", "PmacGetResponseA",
    "PmacGetRomDateA", "PmacGetRomVersionA", "PmacGetVariable", "PmacGetVariableDouble",
    "PmacINTRFuncCallInit", "PmacINTRTerminate", "PmacReadReady", "PmacSelect", "PmacSendCharA",
    "PmacSendLineA",
]

log = logging.getLogger(__name__)

# -- return codes and sizes (PComm32 runtime header) -------------------------------------------------
COMM_EOT = 0x80000000  # the response ended with ACK
COMM_TIMEOUT = 0xC0000000
COMM_ERROR = 0xE0000000  # the card answered BELL ERRnnn
COMM_FAIL = 0xF0000000
COMM_ANYERR = 0x70000000
COMM_UNSOLICITED = 0x10000000
COMM_OK = 1
MAX_COMM_BUFFER = 256
MAX_DPRBUFFER = 160
MAX_DPRREADBUFFER = 256


def COMM_CHARS(c: int) -> int:
    return c & 0x0FFFFFFF


def COMM_STATUS(c: int) -> int:
    return c & 0xF0000000


def IS_COMM_EOT(c: int) -> bool:
    return COMM_STATUS(c) == COMM_EOT


def IS_COMM_ERROR(c: int) -> bool:
    return COMM_STATUS(c) == COMM_ERROR


def IS_COMM_TIMEOUT(c: int) -> bool:
    return COMM_STATUS(c) == COMM_TIMEOUT


def IS_COMM_FAIL(c: int) -> bool:
    return COMM_STATUS(c) == COMM_FAIL


class INTRBUFFER(ctypes.Structure):
    """What a PMACINTRPROC receives a pointer to; `dwInterruptType` is the IR number (0-7)."""

    _fields_ = [("lpData", ctypes.c_char_p), ("dwBufferLength", ctypes.c_ulong),
                ("dwInterruptType", ctypes.c_ulong)]


class CommResult(int):
    """A PComm status code (`COMM_EOT | count` ...) that also carries the response as `.text`."""

    text: str

    def __new__(cls, value: int, text: str = "") -> CommResult:
        obj = super().__new__(cls, value)
        obj.text = text
        return obj


DEFAULT_TIMEOUT_MS = 1000  # card time a missing line is waited for
MEMO_SIZE = 256  # commands whose reply length (slots posted) is remembered
MAX_READS = 64  # response slots read ahead in one batch
DOWNLOAD_CHUNK = 32  # download lines sent per batch
#: PmacGetPmacType's answer from TYPE (ASSUMPTION: PComm32's PMACDEVICETYPE numbering was not found)
PMAC_TYPES = {"PMAC1": 0, "PMAC2": 1, "PMACUL": 2, "TURBO1": 3, "TURBO2": 4, "TURBOUL": 5}
_NS_PER_MS = 1_000_000


# -- output parameters ------------------------------------------------------------------------------
def _char(value: Any) -> int:
    if isinstance(value, int):
        return value & 0xFF
    data = _text(value) if not isinstance(value, ctypes.c_char) else value.value
    return data[0] if data else 0


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


# -- devices ----------------------------------------------------------------------------------------
class _Device:
    """An open device: its connection, the ops the next batch runs first (the deferred
    acknowledgement), the reply lengths seen, and the interrupt thread."""

    def __init__(self, number: int, rack: Rack, info: dict[str, Any]) -> None:
        self.number = number
        self.rack = rack
        self.card = str(info["name"])
        self.motors = int(info.get("motors") or 8)
        self.ethernet = str(info.get("ethernet") or "")
        self.timeout_ms = DEFAULT_TIMEOUT_MS
        self.lock = threading.RLock()
        where = {"card": self.card, "region": DPRAM}
        self.where = where
        self.ack = {"op": "write", "offset": RESP_CONTROL, "data": b"\0\0", **where}
        self.slot = {"op": "read", "offset": RESP_CONTROL, "size": RESP_SLOT, **where}
        self.go = {"op": "write", "offset": CMD_CONTROL, "data": b"\1\0", **where}
        self.gate = {"op": "wait", "on": "value", "offset": RESP_CONTROL, "size": 2, "mask": 0xFFFF,
                     "value": ACK, "cmp": "eq", "timeout_ns": 0, **where}
        self.pending: list[dict[str, Any]] = []
        self.memo: OrderedDict[bytes, int] = OrderedDict()
        self.scale: dict[int, float] = {}  # motor -> Ixx08 * 32
        self.interrupts: _Interrupts | None = None
        self.drain()

    # -- ops and batches ----------------------------------------------------------------------------
    def write(self, offset: int, data: bytes) -> dict[str, Any]:
        return {"op": "write", "offset": offset, "data": data, **self.where}

    def read(self, offset: int, size: int) -> dict[str, Any]:
        return {"op": "read", "offset": offset, "size": size, **self.where}

    def batch(self, ops: list[dict[str, Any]], wait_ns: int = 0) -> list[Any]:
        return self.rack.call({"op": "batch", "ops": ops}, wait_ns / 1e9)

    def begin(self) -> list[dict[str, Any]]:
        ops, self.pending = self.pending, []
        return ops

    def wait_posted(self) -> dict[str, Any]:
        return {"op": "wait", "on": "value", "offset": RESP_CONTROL, "size": 2, "mask": 0xFFFF,
                "value": 0, "cmp": "ne", "timeout_ns": self.timeout_ms * _NS_PER_MS, **self.where}

    def drain(self) -> None:
        """Acknowledge what a previous host left in the response slot (at most a reply's worth)."""
        ops = [self.slot]
        for _ in range(MAX_COMM_BUFFER):
            if parse_slot(self.batch(ops)[-1]) is None:
                return
            ops = [self.ack, self.slot]

    # -- the ASCII handshake ------------------------------------------------------------------------
    def collect(self, ops: list[dict[str, Any]], key: bytes | None, posted: list[Posted] | None = None,
                need_ack: bool = False) -> tuple[list[Posted], bool]:
        """Run `ops` (they make the card post lines) and read the response slot until the reply's
        end (ACK or an error): (the lines, True), or (the lines so far, False) on a time-out."""
        posted = posted if posted is not None else []
        n = self.memo.get(key, 2) if key is not None else 2
        waiting = False
        while True:
            first = len(ops)
            if waiting:
                ops.append(self.wait_posted())
            reads = []
            for _ in range(n):
                if need_ack:
                    ops.append(self.ack)
                reads.append(len(ops))
                ops.append(self.slot)
                need_ack = True
            res = self.batch(ops, self.timeout_ms * _NS_PER_MS if waiting else 0)
            if waiting and not res[first]["fired"]:
                return posted, False
            ops = []
            for j, at in enumerate(reads):
                line = parse_slot(res[at])
                if line is None:  # not posted yet: wait for it (the ack before this read ran)
                    need_ack, waiting, n = False, True, 1
                    break
                posted.append(line)
                if line.terminator != CR:
                    if j == len(reads) - 1:
                        self.pending.append(self.ack)  # deferred into the next call's batch
                    if key is not None:
                        self.memo[key] = len(posted)
                        self.memo.move_to_end(key)
                        if len(self.memo) > MEMO_SIZE:
                            self.memo.popitem(last=False)
                    return posted, True
            else:
                waiting, n = False, min(2 * n, MAX_READS)

    def command_ops(self, line: bytes, ops: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """`ops` (the pending ones) then the command: its bytes at 0x0E9E and 0x0E9C := 1. A
        pending acknowledgement as the last op rides in the bytes' write instead, padded up to
        0x0F40 (the buffer ends where the response control word starts): one op less."""
        data = command_bytes(line)
        if ops and ops[-1] is self.ack:
            ops.pop()
            data = data.ljust(RESP_CONTROL - CMD_CHAR, b"\0") + b"\0\0"
        ops += (self.write(CMD_CHAR, data), self.go)
        return ops

    def control_ops(self, ch: int) -> list[dict[str, Any]]:
        return [self.write(CMD_CHAR, bytes([ch])), self.go]

    def response(self, line: bytes) -> tuple[bytes, int]:
        """A command line's reply (CR-terminated lines, the error text) and its COMM status."""
        ops = self.command_ops(line, self.begin())
        return _reply(*self.collect(ops, line))

    def get_variable(self, ch: str, num: int) -> str | None:
        data, status = self.response(f"{ch}{num}".encode("latin-1"))
        return data.decode("latin-1").strip() if status == COMM_EOT else None


def _reply(posted: list[Posted], complete: bool) -> tuple[bytes, int]:
    data = b"".join(p.text + b"\r" for p in posted if p.terminator == CR)
    if not complete:
        return data, COMM_TIMEOUT
    last = posted[-1]
    if last.terminator is None:
        return data + error_text(last.error), COMM_ERROR
    return data, COMM_EOT


_devices: dict[int, _Device] = {}


def _device(dwDevice: Any) -> _Device | None:
    return _devices.get(int(getattr(dwDevice, "value", dwDevice)))


def _guarded(fail: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """A closed device gives `fail`, and so does a transport failure (logged), as a driver error."""

    def wrap(fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def call(dwDevice: Any, *args: Any, **kwargs: Any) -> Any:
            dev = _device(dwDevice)
            if dev is None:
                return fail() if callable(fail) else fail
            try:
                with dev.lock:
                    return fn(dev, *args, **kwargs)
            except (VdevClientError, zmq.ZMQError) as exc:
                log.warning("%s(%s): %s", fn.__name__, dev.number, exc)
                return fail() if callable(fail) else fail

        return call

    return wrap


def _pmac_cards(rack: Rack) -> list[dict[str, Any]]:
    return [c for c in rack.info["cards"] if c["type"] == CARD_TYPE]


def _with_rack(endpoint: str | None, fn: Callable[[Rack], Any]) -> Any:
    rack = connect(endpoint)
    try:
        return fn(rack)
    finally:
        rack.close()


# -- opening ------------------------------------------------------------------------------------------
def OpenPmacDevice(dwDevice: int, *, endpoint: str | None = None, events: str | None = None) -> bool:
    """Open device `dwDevice`: the pmac-turbo card whose `device` is that number. False when no
    such card is configured or the daemon does not answer. Opening an open device is True."""
    number = int(getattr(dwDevice, "value", dwDevice))
    if number in _devices:
        return True
    try:
        rack = connect(endpoint, events)
    except (VdevClientError, zmq.ZMQError) as exc:
        log.warning("OpenPmacDevice(%d): %s", number, exc)
        return False
    try:
        found = [c for c in _pmac_cards(rack) if int(c.get("device", -1)) == number]
        if not found:
            rack.close()
            return False
        _devices[number] = _Device(number, rack, found[0])
    except (VdevClientError, zmq.ZMQError) as exc:
        log.warning("OpenPmacDevice(%d): %s", number, exc)
        rack.close()
        return False
    return True


def ClosePmacDevice(dwDevice: int) -> bool:
    """Stop its interrupt callbacks, send the deferred acknowledgement, close the connection."""
    dev = _devices.pop(int(getattr(dwDevice, "value", dwDevice)), None)
    if dev is None:
        return False
    with dev.lock:
        try:
            if dev.interrupts is not None:
                dev.interrupts.stop()
            if dev.pending:
                dev.batch(dev.begin())
        except (VdevClientError, zmq.ZMQError) as exc:
            log.warning("ClosePmacDevice(%d): %s", dev.number, exc)
        finally:
            dev.rack.close()
    return True


def DrvNumberOfDevices(*, endpoint: str | None = None) -> int:
    """The number of pmac-turbo cards on the daemon (one `hello`)."""
    return int(_with_rack(endpoint, lambda rack: len(_pmac_cards(rack))))


def PmacSelect(hwnd: Any = None, *, endpoint: str | None = None) -> int:
    """PComm's device picker without a window: the lowest device number, -1 when none."""
    numbers = _with_rack(endpoint, lambda rack: sorted(int(c.get("device", 0)) for c in _pmac_cards(rack)))
    return int(numbers[0]) if numbers else -1


# -- ASCII communication ---------------------------------------------------------------------------
@_guarded(lambda: CommResult(COMM_FAIL))
def PmacGetResponseA(dev: _Device, s: Any, maxchar: int, outstr: Any) -> CommResult:
    """Send `outstr` and return its response (see the module docstring for the format and codes).
    Lines separated by CR in `outstr` go one after the other; an error stops there."""
    data, status = b"", COMM_EOT
    for line in _text(outstr).replace(b"\n", b"\r").split(b"\r") or [b""]:
        if len(line) >= CMD_MAX:
            log.warning("PmacGetResponseA(%d): a command of %d characters (at most %d)",
                        dev.number, len(line), CMD_MAX - 1)
            return CommResult(COMM_FAIL)
        more, status = dev.response(line)
        data += more
        if status != COMM_EOT:
            break
    return _result(s, maxchar, data, status)


def _result(s: Any, maxchar: int, data: bytes, status: int) -> CommResult:
    n = _put_text(s, maxchar, data) if s is not None else len(data)
    return CommResult(status | n, data[:n].decode("latin-1"))


@_guarded(lambda: CommResult(COMM_FAIL))
def PmacGetControlResponseA(dev: _Device, s: Any, maxchar: int, outchar: Any) -> CommResult:
    """Send a control character (^B ^C ^F ^G ^P ^V ...; a str, bytes or int) and return its text,
    each line ending with CR, `COMM_EOT | count`."""
    ch = _char(outchar)
    data, status = _reply(*dev.collect(dev.begin() + dev.control_ops(ch), b"\0" + bytes([ch])))
    return _result(s, maxchar, data, status)


@_guarded(COMM_FAIL)
def PmacSendLineA(dev: _Device, outstr: Any) -> int:
    """Send a command line without reading its response (PmacGetLineA reads it): the number of
    characters sent, COMM_FAIL for a line over 159 characters."""
    line = _text(outstr).rstrip(b"\r\n")
    if len(line) >= CMD_MAX:
        return COMM_FAIL
    dev.batch(dev.command_ops(line, dev.begin()))
    return len(line)


@_guarded(lambda: CommResult(COMM_FAIL))
def PmacGetLineA(dev: _Device, s: Any, maxchar: int) -> CommResult:
    """One posted response line, taken and acknowledged: a data line without its CR and its count
    (no status bits: more follows); the final ACK as `COMM_EOT | 0`; an error as its text with
    `COMM_ERROR | count`; `COMM_TIMEOUT` when nothing comes within `timeout_ms` (card time)."""
    res = dev.batch(dev.begin() + [dev.slot, dev.ack])
    line = parse_slot(res[-2])
    if line is None:
        res = dev.batch([dev.wait_posted(), dev.slot, dev.ack], dev.timeout_ms * _NS_PER_MS)
        if not res[0]["fired"]:
            return _result(s, maxchar, b"", COMM_TIMEOUT)
        line = parse_slot(res[-2])
        assert line is not None
    if line.terminator is None:
        return _result(s, maxchar, error_text(line.error), COMM_ERROR)
    return _result(s, maxchar, line.text, 0 if line.terminator == CR else COMM_EOT)


@_guarded(COMM_FAIL)
def PmacSendCharA(dev: _Device, outch: Any) -> int:
    """Send one control character through the DPRAM control-character slot; its text is read
    with PmacGetLineA. 1 (characters sent)."""
    dev.batch(dev.begin() + dev.control_ops(_char(outch)))
    return 1


@_guarded(False)
def PmacReadReady(dev: _Device) -> bool:
    """A response line is posted and not yet read."""
    res = dev.batch(dev.begin() + [dev.read(RESP_CONTROL, 2)])
    return bool(int.from_bytes(res[-1], "little"))


@_guarded(lambda: 0)
def PmacGetVariable(dev: _Device, ch: Any, num: int, default: int = 0) -> int:
    """The variable `ch``num` (I, P, Q, M) as an integer (a fraction truncated, `$hex` read as
    hex); `default` when the card refuses it or the reply is not a number."""
    value = dev.get_variable(_text(ch).decode("latin-1"), int(num))
    number = _number(value)
    return int(number) if number is not None and math.isfinite(number) else int(default)


@_guarded(lambda: 0.0)
def PmacGetVariableDouble(dev: _Device, ch: Any, num: int, default: float = 0.0) -> float:
    """The variable `ch``num` as a float; `default` when it cannot be read."""
    number = _number(dev.get_variable(_text(ch).decode("latin-1"), int(num)))
    return number if number is not None else float(default)


def _number(text: str | None) -> float | None:
    if not text:
        return None
    try:
        return float(int(text[1:], 16)) if text.startswith("$") else float(text)
    except ValueError:
        return None


@_guarded(-1)
def PmacGetPmacType(dev: _Device) -> int:
    """The card's type from `TYPE` (PMAC_TYPES: TURBO2 is 4); -1 when unknown."""
    return PMAC_TYPES.get(_query(dev, b"TYPE").upper(), -1)


def _query(dev: _Device, command: bytes) -> str:
    data, status = dev.response(command)
    return data.decode("latin-1").strip() if status == COMM_EOT else ""


@_guarded("")
def PmacGetRomVersionA(dev: _Device, s: Any, maxchar: int) -> str:
    """The firmware version (`VER`, "1.940") into `s`, and returned."""
    text = _query(dev, b"VER")
    _put_text(s, maxchar, text.encode("latin-1"))
    return text


@_guarded("")
def PmacGetRomDateA(dev: _Device, s: Any, maxchar: int) -> str:
    """The firmware date (`DATE`) into `s`, and returned."""
    text = _query(dev, b"DATE")
    _put_text(s, maxchar, text.encode("latin-1"))
    return text


# -- download -----------------------------------------------------------------------------------------
@_guarded(0)
def PmacDownloadA(dev: _Device, msgproc: Any, getproc: Any, progress: Any, filename: Any,
                  macro: bool = True, map: bool = False, log: bool = False, dnld: bool = True) -> int:
    """Download a file of on-line commands: preprocess it (comments after `;` or `//`, blank
    lines, `#define NAME value` replaced as whole words when `macro`), then send it line by line
    when `dnld`; stop at the first ERRnnn. 1 when every line was accepted, 0 otherwise.

    `msgproc(str, newline)` receives the error ("file:line: text: ERRnnn") and a closing
    message, `progress(percent)` the progress after each batch. With an empty `filename`, lines
    come from `getproc(index, buffer, maxlen)` (a ctypes buffer it fills; 0 ends) instead.
    Not supported (PreprocessError, reported through msgproc): #include, #ifdef and the other
    conditionals, #undef, macros with arguments. `map` and `log` (the map and log files PComm
    writes) are ignored. Lines go DOWNLOAD_CHUNK to a batch; a line that answers data or an
    error ends its batch early (a zero-time `wait` for the ACK gates the next line)."""
    name = _text(filename).decode("latin-1")
    say = _messenger(msgproc)
    try:
        source = Path(name).read_text(encoding="latin-1") if name else _from_getproc(getproc)
        lines = preprocess(source, bool(macro))
    except (OSError, PreprocessError) as exc:
        say(f"{name or 'download'}: {exc}")
        return 0
    if not dnld:
        return 1
    i = 0
    while i < len(lines):
        chunk = lines[i:i + DOWNLOAD_CHUNK]
        ops = dev.begin()
        marks = []
        for _, text in chunk:
            dev.command_ops(text.encode("latin-1")[:CMD_MAX - 1], ops)
            marks.append(len(ops))
            ops += (dev.slot, dev.gate, dev.ack)
        res = dev.batch(ops)
        for k, at in enumerate(marks):
            if res[at + 1] is not None and res[at + 1]["fired"]:
                continue
            first = parse_slot(res[at])  # this line answered data, an error or nothing yet
            if first is not None and first.terminator != CR:
                posted, done = [first], True
                dev.pending.append(dev.ack)
            else:
                posted, done = dev.collect([], None, [first] if first else [], need_ack=first is not None)
            data, status = _reply(posted, done)
            if status != COMM_EOT:
                number, text = chunk[k]
                what = data.decode("latin-1").strip("\x07\r").split("\r")[-1] or "no response"
                say(f"{name or 'download'}:{number}: {text}: {what}")
                return 0
            i += k + 1
            break
        else:
            i += len(chunk)
        if progress is not None:
            progress(100 * i // len(lines))
    say(f"{name or 'download'}: {len(lines)} lines downloaded")
    return 1


def _messenger(msgproc: Any) -> Callable[[str], None]:
    def say(text: str) -> None:
        log.info("PmacDownloadA: %s", text)
        if msgproc is not None:
            # a ctypes callback (it has argtypes) takes LPSTR as bytes, a Python one a str
            msgproc(text.encode("latin-1") if hasattr(msgproc, "argtypes") else text, True)

    return say


def _from_getproc(getproc: Any) -> str:
    if getproc is None:
        return ""
    out = []
    buf = ctypes.create_string_buffer(MAX_COMM_BUFFER)
    for index in range(1 << 20):
        if getproc(index, buf, MAX_COMM_BUFFER) <= 0:
            break
        out.append(buf.value.decode("latin-1"))
    return "\n".join(out)


# -- DPRAM ----------------------------------------------------------------------------------------------
def _pieces(offset: int, count: int) -> list[tuple[int, int]]:
    """A 2- or 4-byte access the bus would refuse misaligned, as a byte and a block."""
    if count in (2, 4) and offset % count:
        return [(offset, 1), (offset + 1, count - 1)]
    return [(offset, count)]


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
    res = dev.batch(dev.begin() + [dev.read(o, n) for o, n in _pieces(offset, count)])
    data = b"".join(res[-len(_pieces(offset, count)):])
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
    dev.batch(dev.begin() + [dev.write(o, data[o - offset:o - offset + n])
                             for o, n in _pieces(offset, len(data))])
    return val


@_guarded(0.0)
def PmacDPRGetFloat(dev: _Device, offset: int) -> float:
    """The 32-bit IEEE float at host byte `offset` (`F:` format)."""
    res = dev.batch(dev.begin() + [dev.read(o, n) for o, n in _pieces(int(offset), 4)])
    return float(struct.unpack("<f", b"".join(r for r in res if isinstance(r, bytes))[-4:])[0])


@_guarded(None)
def PmacDPRSetFloat(dev: _Device, offset: int, val: float) -> None:
    data = struct.pack("<f", float(val))
    dev.batch(dev.begin() + [dev.write(o, data[o - int(offset):o - int(offset) + n])
                             for o, n in _pieces(int(offset), 4)])


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
    """Switch the real-time motor buffer on (I47 = `period` servo cycles, I48 = 1; the handshake
    cleared so the first sample comes at once) or off (I48 = 0). The card reports all its motors:
    `mask` is accepted and not used."""
    line = f"I47={max(int(period), 1)} I48=1" if on else "I48=0"
    ops = dev.command_ops(line.encode(), [*dev.begin(), dev.write(REALTIME, b"\0\0")])
    return _reply(*dev.collect(ops, line.encode()))[1] == COMM_EOT


@_guarded(False)
def PmacDPRBackgroundEx(dev: _Device, on: int, period: int, crd: int) -> bool:
    """Switch the background buffer (global and C.S. status) on (I49 = `period`, I50 = 1) or off.
    The card reports all 16 coordinate systems: `crd` is accepted and not used."""
    line = f"I49={max(int(period), 1)} I50=1" if on else "I50=0"
    ops = dev.command_ops(line.encode(), [*dev.begin(), dev.write(BACKGROUND, b"\0\0")])
    return _reply(*dev.collect(ops, line.encode()))[1] == COMM_EOT


def _sample(dev: _Device, buffer: int, offset: int, size: int) -> bytes:
    """`size` bytes at `offset` of a reporting buffer (`buffer`: its handshake word) from the card's
    next sample: one batch [clear the handshake, wait for the card to set bit 15, read]. The card
    posts only while the bit is clear, so a read without the wait would give the sample taken
    just after the previous clear. In lockstep the wait advances time to the next sample (I47 or
    I49 servo cycles); with reporting off it ends after `timeout_ms` and the stale data is read."""
    timeout_ns = dev.timeout_ms * _NS_PER_MS
    wait = {"op": "wait", "on": "value", "offset": buffer, "size": 2, "mask": READY, "value": READY,
            "cmp": "eq", "timeout_ns": timeout_ns, **dev.where}
    res = dev.batch(dev.begin() + [dev.write(buffer, b"\0\0"), wait, dev.read(offset, size)], timeout_ns)
    if res[-2]["fired"]:
        return bytes(res[-1])
    log.warning("%s: no sample in the reporting buffer at %#x (reporting off?)", dev.card, buffer)
    return bytes(dev.batch([dev.read(offset, size)])[-1])


@_guarded(0.0)
def PmacDPRPosition(dev: _Device, mtr: int, units: float) -> float:
    """Motor `mtr`'s (1-based) actual position from the card's next real-time sample (see
    `_sample`; PmacDPRRealTimeEx must be on), in counts times `units`. Ixx08 is read once per
    motor, on its first use (one more round trip)."""
    mtr = int(mtr)
    if not 1 <= mtr <= dev.motors:
        return 0.0
    if mtr not in dev.scale:
        dev.scale[mtr] = 32.0 * (_number(dev.get_variable("I", 100 * mtr + 8)) or 1.0)
    return motor_report(_sample(dev, REALTIME, realtime_motor(mtr), RT_MOTOR)).actual / dev.scale[mtr] * units


@_guarded(None)
def PmacDPRGetGlobalStatus(dev: _Device, gs: Any = None) -> tuple[int, int] | None:
    """The two global status words of the next background sample (PmacDPRBackgroundEx on), into
    `gs` (DWORD[2], ctypes array or list) and returned."""
    words = struct.unpack_from("<II", _sample(dev, BACKGROUND, BACKGROUND + 8, 8))
    target = _target(gs)
    if target is not None:
        target[0], target[1] = words
    return words


# -- interrupts -----------------------------------------------------------------------------------------
class _Interrupts:
    """A thread on its own connection that receives the card's `inta` events, acknowledges the
    interrupt controller's status bits of `mask` (W1C at host byte 8) and calls the callback once
    per bit, IR0 first."""

    def __init__(self, dev: _Device, callback: Any, msg: int, mask: int) -> None:
        self.callback, self.msg, self.mask = callback, msg, mask
        self.rack = connect(dev.rack.endpoint, dev.rack.events_endpoint or None)
        try:
            self.card = self.rack.card(dev.card)
            self.host = self.card.region(HOST)
            self.card.irq.subscribe()
        except BaseException:
            self.rack.close()
            raise
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._run, name=f"pcomm-intr-{dev.number}", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        try:
            while not self.stopping.is_set():
                for event in self.card.irq.events(timeout_s=0.05):
                    if event.get("line") == LINE:
                        self._deliver(int(event.get("status", 0)) & self.mask)
                    if self.stopping.is_set():
                        break
        except (VdevClientError, zmq.ZMQError) as exc:
            if not self.stopping.is_set():
                log.warning("interrupt thread: %s", exc)

    def _deliver(self, bits: int) -> None:
        if not bits:
            return
        self.host.write(IR_STATUS, bytes([bits]))
        for irq in range(8):
            if bits >> irq & 1:
                buffer = INTRBUFFER(None, 0, irq)
                try:
                    self.callback(self.msg, ctypes.pointer(buffer))
                except Exception:
                    log.exception("interrupt callback for IR%d", irq)

    def stop(self) -> None:
        self.stopping.set()
        self.thread.join(5.0)
        self.rack.close()


@_guarded(False)
def PmacINTRFuncCallInit(dev: _Device, callback: Any, msg: int, ulMask: int) -> bool:
    """Call `callback(msg, pointer(INTRBUFFER))` for every interrupt of the card's controller bits
    in `ulMask` (HostIrq: IR4 = ASCII response ready ...): the mask is written to the enable
    register (host byte 9) and a thread with its own connection follows line `inta` on the
    daemon's event stream, acknowledges each cause and calls back from that thread. A second
    call replaces the first."""
    if dev.interrupts is not None:
        dev.interrupts.stop()
        dev.interrupts = None
    mask = int(ulMask) & 0xFF
    dev.interrupts = _Interrupts(dev, callback, int(msg), mask)
    dev.batch(dev.begin() + [{"op": "write", "card": dev.card, "region": HOST, "offset": IR_MASK,
                              "data": bytes([mask])}])
    return True


@_guarded(False)
def PmacINTRTerminate(dev: _Device) -> bool:
    """Disable the card's interrupts (mask 0) and stop the callbacks."""
    dev.batch(dev.begin() + [{"op": "write", "card": dev.card, "region": HOST, "offset": IR_MASK,
                              "data": b"\0"}])
    if dev.interrupts is not None:
        dev.interrupts.stop()
        dev.interrupts = None
    return True
