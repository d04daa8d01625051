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
for it. The last slot of a batch is read by its head alone (control word and count: all of an ACK
or an error); a data line found there is still posted, and the next batch reads it whole. The
acknowledgement of the final ACK (0x0F40 := 0) is deferred into the next call's batch, as the
MAXk client defers its release, and rides in the next command's write (the command buffer ends
at 0x0F3F): a one-line reply is five ops, and a command sent again reuses the batch built for it
the first time.
"""

from __future__ import annotations

import ctypes
import logging
import math
from collections.abc import Callable
from typing import Any

import zmq
from vdevmaps.pmac import CARD_TYPE, CMD_MAX, CR, HOST, IR_MASK, RESP_CONTROL, HostIrq

from vdevclient._cargs import put_text as _put_text
from vdevclient._cargs import text as _text
from vdevclient._pcomm_codes import (
    COMM_ANYERR,
    COMM_EOT,
    COMM_ERROR,
    COMM_FAIL,
    COMM_OK,
    COMM_TIMEOUT,
    COMM_UNSOLICITED,
    INTRBUFFER,
    MAX_COMM_BUFFER,
    MAX_DPRBUFFER,
    MAX_DPRREADBUFFER,
    CommResult,
)
from vdevclient._pcomm_codes import COMM_CHARS as COMM_CHARS
from vdevclient._pcomm_codes import COMM_STATUS as COMM_STATUS
from vdevclient._pcomm_codes import IS_COMM_EOT as IS_COMM_EOT
from vdevclient._pcomm_codes import IS_COMM_ERROR as IS_COMM_ERROR
from vdevclient._pcomm_codes import IS_COMM_FAIL as IS_COMM_FAIL
from vdevclient._pcomm_codes import IS_COMM_TIMEOUT as IS_COMM_TIMEOUT
from vdevclient._pcomm_device import _NS_PER_MS, _Device, _devices, _guarded, _Interrupts, _number, _reply
from vdevclient._pcomm_device import DEFAULT_TIMEOUT_MS as DEFAULT_TIMEOUT_MS
from vdevclient._pcomm_device import MAX_READS as MAX_READS
from vdevclient._pcomm_device import MEMO_SIZE as MEMO_SIZE
from vdevclient._pcomm_download import DOWNLOAD_CHUNK as DOWNLOAD_CHUNK
from vdevclient._pcomm_download import PmacDownloadA
from vdevclient._pcomm_dpr import (
    MotorReport,
    PmacDPRAvailable,
    PmacDPRBackgroundEx,
    PmacDPRFloat,
    PmacDPRFollowError,
    PmacDPRGetDataReadyBit,
    PmacDPRGetFloat,
    PmacDPRGetGlobalStatus,
    PmacDPRGetMem,
    PmacDPRGetVel,
    PmacDPRLFixed,
    PmacDPRMotorServoStatusTurbo,
    PmacDPRPosition,
    PmacDPRRealTimeEx,
    PmacDPRResetDataReadyBit,
    PmacDPRSetFloat,
    PmacDPRSetMem,
)
from vdevclient._pcomm_dprrot import (  # the binary rotary buffer, I45 [PComm32 dpr.h rotbuf]
    DprBufBsy,
    DprBufErr,
    DprCmdErr,
    DprEOF,
    DprOk,
    PmacDPRAsciiStrToRotA,
    PmacDPRRotBuf,
    PmacDPRRotBufChange,
    PmacDPRRotBufInit,
    PmacDPRRotBufRemove,
)
from vdevclient._pcomm_dprvar import (  # DPRAM variable buffers, I55 [PComm32 dprbkg.h]
    MAX_VBGBUF_USERS,
    VBG_L,
    VBG_X,
    VBG_Y,
    PmacDPRBackGroundVar,
    PmacDPRGetVBGNumEntries,
    PmacDPRGetVBGServoTimer,
    PmacDPRGetVBGTotalEntries,
    PmacDPRVarBufChange,
    PmacDPRVarBufInit,
    PmacDPRVarBufRead,
    PmacDPRVarBufReadEx,
    PmacDPRVarBufRemove,
    PmacDPRWriteBuffer,
    VBGWFormat,
)
from vdevclient._pcomm_gather import (  # data gathering [PComm32 Gather.h]
    GAT_DPR_NOWRAP,
    GAT_DPR_WRAP,
    GAT_RAM_NOWRAP,
    GAT_RAM_WRAP,
    PmacClearGather,
    PmacClearGatherData,
    PmacCollectGatherData,
    PmacGetGather,
    PmacGetGatherEnable,
    PmacGetGatherMode,
    PmacGetGatherPeriod,
    PmacGetGatherPoint,
    PmacGetGatherSamples,
    PmacGetGatherSampleTime,
    PmacGetNumGatherSamples,
    PmacGetNumGatherSources,
    PmacInitGather,
    PmacInitPlotGather,
    PmacSetGather,
    PmacSetGatherEnable,
    PmacSetGatherMode,
    PmacSetGatherPeriod,
    PmacSetGatherSampleTime,
    PmacStartGather,
    PmacStopGather,
)
from vdevclient._pmac_bus import error_text, parse_slot
from vdevclient.core import Rack, connect
from vdevclient.errors import VdevClientError

__all__ = [
    "COMM_ANYERR", "COMM_EOT", "COMM_ERROR", "COMM_FAIL", "COMM_OK", "COMM_TIMEOUT",
    "COMM_UNSOLICITED", "INTRBUFFER", "MAX_COMM_BUFFER", "MAX_DPRBUFFER", "MAX_DPRREADBUFFER",
    "ClosePmacDevice", "CommResult", "DrvNumberOfDevices", "HostIrq", "MotorReport",
    "OpenPmacDevice", "PmacDPRAvailable", "PmacDPRBackgroundEx", "PmacDPRFloat",
    "PmacDPRFollowError", "PmacDPRGetDataReadyBit", "PmacDPRGetFloat", "PmacDPRGetGlobalStatus",
    "PmacDPRGetMem", "PmacDPRGetVel", "PmacDPRLFixed", "PmacDPRMotorServoStatusTurbo",
    "PmacDPRPosition", "PmacDPRRealTimeEx", "PmacDPRResetDataReadyBit", "PmacDPRSetFloat",
    "PmacDPRSetMem", "PmacDownloadA",
    "PmacGetControlResponseA", "PmacGetLineA", "PmacGetPmacType", "PmacGetResponseA",
    "PmacGetRomDateA", "PmacGetRomVersionA", "PmacGetVariable", "PmacGetVariableDouble",
    "PmacINTRFuncCallInit", "PmacINTRTerminate", "PmacReadReady", "PmacSelect", "PmacSendCharA",
    "PmacSendLineA",
    # data gathering (_pcomm_gather.py)
    "GAT_DPR_NOWRAP",
    "GAT_DPR_WRAP",
    "GAT_RAM_NOWRAP",
    "GAT_RAM_WRAP",
    "PmacClearGather",
    "PmacClearGatherData",
    "PmacCollectGatherData",
    "PmacGetGather",
    "PmacGetGatherEnable",
    "PmacGetGatherMode",
    "PmacGetGatherPeriod",
    "PmacGetGatherPoint",
    "PmacGetGatherSamples",
    "PmacGetGatherSampleTime",
    "PmacGetNumGatherSamples",
    "PmacGetNumGatherSources",
    "PmacInitGather",
    "PmacInitPlotGather",
    "PmacSetGather",
    "PmacSetGatherEnable",
    "PmacSetGatherMode",
    "PmacSetGatherPeriod",
    "PmacSetGatherSampleTime",
    "PmacStartGather",
    "PmacStopGather",
    # DPRAM variable buffers, I55 (_pcomm_dprvar.py)
    "MAX_VBGBUF_USERS", "VBG_L", "VBG_X", "VBG_Y", "VBGWFormat", "PmacDPRBackGroundVar",
    "PmacDPRGetVBGNumEntries", "PmacDPRGetVBGServoTimer", "PmacDPRGetVBGTotalEntries",
    "PmacDPRVarBufChange", "PmacDPRVarBufInit", "PmacDPRVarBufRead", "PmacDPRVarBufReadEx",
    "PmacDPRVarBufRemove", "PmacDPRWriteBuffer",
    # the binary rotary buffer, I45 (_pcomm_dprrot.py)
    "DprBufBsy", "DprBufErr", "DprCmdErr", "DprEOF", "DprOk", "PmacDPRAsciiStrToRotA",
    "PmacDPRRotBuf", "PmacDPRRotBufChange", "PmacDPRRotBufInit", "PmacDPRRotBufRemove",
]

log = logging.getLogger(__name__)

#: PmacGetPmacType's answer from TYPE (ASSUMPTION: PComm32's PMACDEVICETYPE numbering was not found)
PMAC_TYPES = {"PMAC1": 0, "PMAC2": 1, "PMACUL": 2, "TURBO1": 3, "TURBO2": 4, "TURBOUL": 5}


# -- control-character parameters -----------------------------------------------------------------------
def _char(value: Any) -> int:
    if isinstance(value, int):
        return value & 0xFF
    data = _text(value) if not isinstance(value, ctypes.c_char) else value.value
    return data[0] if data else 0


# -- opening ------------------------------------------------------------------------------------------
def _pmac_cards(rack: Rack) -> list[dict[str, Any]]:
    return [c for c in rack.info["cards"] if c["type"] == CARD_TYPE]


def _with_rack(endpoint: str | None, fn: Callable[[Rack], Any]) -> Any:
    rack = connect(endpoint)
    try:
        return fn(rack)
    finally:
        rack.close()


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
    text = outstr.encode("latin-1") if type(outstr) is str else _text(outstr)
    if b"\r" in text or b"\n" in text:
        lines = text.replace(b"\n", b"\r").split(b"\r")
    elif len(text) < CMD_MAX:  # one line, the usual call
        return _result(s, maxchar, *dev.response(text))
    else:
        lines = [text]
    data, status = b"", COMM_EOT
    for line in lines:
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


# -- interrupts -----------------------------------------------------------------------------------------
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
