"""Galil's gclib Python wrapper (`gclib.py`, class `py`) for the virtual DMC-13X8 VME card.

An existing gclib script runs by changing its import (`from vdevclient import gclib`)::

    g = gclib.py()
    g.GOpen("galil0")                    # a card name, optionally "galil0 --endpoint tcp://..."
    print(g.GCommand("TPX"))             # "0000000000": trimmed of the final ':' and whitespace
    g.GMotionComplete("X")
    g.GClose()

Errors raise `GclibError` with gclib's texts ("question mark returned by controller", "device
timed out", ...). Built on `vdevclient.galil`: a `py` holds a DMC library handle. Addresses take
gclib's `--flags`: `--endpoint URL`, `--events URL` (the daemon), `--timeout ms` / `-t ms`; other
gclib flags (`--direct`, `-d`, `-s ALL`, `--subscribe ALL`) are accepted and ignored.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import shlex
from typing import Any

from vdevmaps.galil import AXIS_SIZE, FIRST_AXIS

from vdevclient import galil
from vdevclient._galil_bus import DmcBus, decode_record

# gclib_errors.h: the codes and texts GclibError carries
G_NO_ERROR = 0
G_TIMEOUT = -1100
G_OPEN_ERROR = -1101
G_UNSUPPORTED_FUNCTION = -1109
G_CONNECTION_NOT_ESTABLISHED = -1201
G_BAD_RESPONSE_QUESTION_MARK = -10000
G_BAD_VALUE_RANGE = -10002
G_BAD_LOST_DATA = -10004
G_BAD_ADDRESS = -10006
G_BAD_FILE = -10005
G_DATA_RECORD_ERROR = -1107
G_GCLIB_ERROR = -1
G_GCLIB_NON_BLOCKING_READ_EMPTY = -4

_TEXTS = {
    G_TIMEOUT: "device timed out",
    G_OPEN_ERROR: "device failed to open",
    G_UNSUPPORTED_FUNCTION: "function not supported on this communication bus",
    G_CONNECTION_NOT_ESTABLISHED: "connection to hardware not established",
    G_BAD_RESPONSE_QUESTION_MARK: "question mark returned by controller",
    G_BAD_VALUE_RANGE: "value passed to function was bad or out of range",
    G_BAD_LOST_DATA: "data was lost due to buffer or fifo limitations",
    G_BAD_ADDRESS: "a bad address was specified in open",
    G_BAD_FILE: "file was not found, contents are invalid, or write failed",
    G_DATA_RECORD_ERROR: "data record error",
    G_GCLIB_ERROR: "gclib unexpected error",
    G_GCLIB_NON_BLOCKING_READ_EMPTY: "data was not waiting for a zero-timeout read",
}

#: GRecord's method (gclib.h): G_QR asks with the QR command, G_DR takes the DR stream. The
#: DMC-13X8 has only the secondary FIFO, so both read it.
G_QR = 0
G_DR = 1

DEFAULT_TIMEOUT_MS = 5000  # gclib's default timeout (py._timeout)
MOTION_POLL_MS = 10  # GMotionComplete polls _BG this often (card time)
_BUF_SIZE = 500_000  # gclib.py's response buffer: "big enough to fit an entire program"
G_BOUNDS = -1  # GArrayUpload/GArrayDownload: first/last omitted, the whole array (gclib.h)
G_CR = 0  # GArrayUpload's delimiters (gclib.h)
G_COMMA = 1

#: what a DMC library code becomes in gclib
_FROM_DMC = {
    galil.DMCERROR_TIMEOUT: G_TIMEOUT,
    galil.DMCERROR_COMMAND: G_BAD_RESPONSE_QUESTION_MARK,
    galil.DMCERROR_CONTROLLER: G_OPEN_ERROR,
    galil.DMCERROR_DRIVER: G_OPEN_ERROR,
    galil.DMCERROR_HANDLE: G_CONNECTION_NOT_ESTABLISHED,
    galil.DMCERROR_BUFFERFULL: G_BAD_LOST_DATA,
    galil.DMCERROR_DATARECORD: G_DATA_RECORD_ERROR,
    galil.DMCERROR_DOWNLOAD: G_BAD_RESPONSE_QUESTION_MARK,
}


class GclibError(Exception):
    """Error class for non-zero gclib return codes."""


def _rc(code: int) -> None:
    """Raise GclibError with gclib's text for a non-zero code (a DMC library code or a G_ one)."""
    if code == G_NO_ERROR:
        return
    code = _FROM_DMC.get(code, code)
    raise GclibError(_TEXTS.get(code, _TEXTS[G_GCLIB_ERROR]))


def _preprocessor_limit(preprocessor: str) -> int | None:
    """The line length of "--max n" (None without), G_BAD_VALUE_RANGE for another option."""
    words = preprocessor.split()
    if not words:
        return None
    if len(words) == 2 and words[0] == "--max" and words[1].isdigit():
        return int(words[1])
    _rc(G_BAD_VALUE_RANGE)
    return None


def _parse_address(address: str) -> tuple[str, dict[str, str]]:
    """(card name, {flag: value}) of "galil0 --endpoint tcp://... -t 1000"."""
    try:
        words = shlex.split(address)
    except ValueError:
        _rc(G_BAD_ADDRESS)
    card, flags = "", {}
    takes_value = {"--endpoint": "endpoint", "--events": "events", "--timeout": "timeout",
                   "-t": "timeout", "-s": "", "--subscribe": "", "--baud": "", "-b": ""}
    i = 0
    while i < len(words):
        word = words[i]
        if word in takes_value:
            if i + 1 >= len(words):
                _rc(G_BAD_ADDRESS)
            if takes_value[word]:
                flags[takes_value[word]] = words[i + 1]
            i += 2
            continue
        if not word.startswith("-"):
            if card:
                _rc(G_BAD_ADDRESS)
            card = word
        i += 1
    if not card:
        _rc(G_BAD_ADDRESS)
    return card, flags


class py:
    """Represents a single Python connection to a Galil controller (here a galil-dmc13x8 card)."""

    def __init__(self) -> None:
        self._gcon = ctypes.c_long(0)
        self._buf = ctypes.create_string_buffer(_BUF_SIZE)
        self._timeout = DEFAULT_TIMEOUT_MS
        self._initial_timeout = DEFAULT_TIMEOUT_MS
        self._address = ""
        self._irq_seq: int | None = None
        self._irq_enabled = False

    def __del__(self) -> None:
        try:
            self.GClose()
        except Exception:  # at interpreter exit there is no one to tell
            pass

    def _cc(self) -> DmcBus:
        """The open connection's bus; GclibError if there is none."""
        bus = galil.bus_of(self._gcon) if self._gcon.value else None
        if bus is None:
            _rc(G_CONNECTION_NOT_ESTABLISHED)
        assert bus is not None
        return bus

    def GOpen(self, address: str) -> None:
        """Open a connection to the card named first in `address` (see the module docstring)."""
        card, flags = _parse_address(address)
        self.GClose()
        timeout = flags.get("timeout", str(DEFAULT_TIMEOUT_MS))
        if not timeout.isdigit():
            _rc(G_BAD_ADDRESS)
        handle = ctypes.c_long(0)
        _rc(galil.DMCOpenDesc(card, 0, ctypes.byref(handle), endpoint=flags.get("endpoint"),
                              events=flags.get("events")))
        self._gcon = handle
        self._address = card
        self._irq_seq, self._irq_enabled = None, False
        self._initial_timeout = int(timeout)
        self.GTimeout(self._initial_timeout)

    def GClose(self) -> None:
        """Close the connection (nothing happens without one)."""
        if self._gcon.value:
            galil.DMCClose(self._gcon)
            self._gcon = ctypes.c_long(0)

    def GCommand(self, command: str) -> str:
        """Send a command and return its reply trimmed of the final ':' and of whitespace; a
        command longer than the card's command FIFO takes (511 characters) is not sent:
        "value passed to function was bad or out of range"."""
        rc, text = galil.command_text(self._gcon, command, _BUF_SIZE)
        if rc == galil.DMCERROR_ARGUMENT:  # a command longer than the command FIFO takes
            _rc(G_BAD_VALUE_RANGE)
        _rc(rc)  # no connection: DMCERROR_HANDLE, "connection to hardware not established"
        response = text.decode("latin-1")
        return response[:-1].strip() if response.endswith(":") else response.strip()

    # -- application programs ------------------------------------------------------------------------
    def GProgramDownload(self, program: str, preprocessor: str = "") -> None:
        """Download `program` (lines separated by CR, LF or CR LF) with DL; a line the card
        refuses raises "question mark returned by controller" (TC1 tells why). `preprocessor`:
        "" leaves blank and REM lines out; "--max n" also checks every line is at most n
        characters (a longer one: "value passed to function was bad or out of range")."""
        self._cc()
        limit = _preprocessor_limit(preprocessor)
        data = program.encode("latin-1")
        if limit is not None and any(len(line) > limit for line in galil.program_lines(data)):
            _rc(G_BAD_VALUE_RANGE)
        _rc(galil.DMCDownloadFromBuffer(self._gcon, data, None))

    def GProgramUpload(self) -> str:
        """The program on the card, its lines ending CR LF."""
        self._cc()
        c = galil.controller_of(self._gcon)
        assert c is not None
        rc, program = galil.upload(c)
        _rc(rc)
        return program.decode("latin-1")

    def GProgramDownloadFile(self, file_path: str, preprocessor: str = "") -> None:
        """Download the program file `file_path` (see GProgramDownload)."""
        try:
            with open(file_path, encoding="latin-1") as f:
                program = f.read()
        except OSError:
            _rc(G_BAD_FILE)
        self.GProgramDownload(program, preprocessor)

    def GProgramUploadFile(self, file_path: str) -> None:
        """Upload the card's program into the file `file_path`."""
        program = self.GProgramUpload()
        try:
            with open(file_path, "w", encoding="latin-1", newline="") as f:
                f.write(program)
        except OSError:
            _rc(G_BAD_FILE)

    def GTimeout(self, timeout: int) -> None:
        """Set the timeout in ms; -1 restores the one GOpen set."""
        self._cc()
        if timeout < -1:
            _rc(G_BAD_VALUE_RANGE)
        value = self._initial_timeout if timeout == -1 else timeout
        _rc(galil.DMCSetTimeout(self._gcon, value))
        self._timeout = timeout

    @property
    def timeout(self) -> int:
        return self._timeout

    @timeout.setter
    def timeout(self, timeout: int) -> None:
        self.GTimeout(timeout)

    def GMotionComplete(self, axes: str) -> None:
        """Return once every axis in `axes` ("XY", "AB") has stopped: polls `MG _BGx` as gclib
        does, letting MOTION_POLL_MS of card time pass between polls."""
        bus = self._cc()
        for axis in axes.strip().upper():
            while float(self.GCommand(f"MG _BG{axis}")):
                bus.pause(MOTION_POLL_MS)

    def GSleep(self, val: int) -> None:
        """Let `val` ms pass on the card's clock (a lockstep step, or a wall-clock sleep)."""
        self._cc().pause(int(val))

    def GMessage(self) -> str:
        """Unsolicited output of the card (what arrived outside command replies)."""
        self._cc()
        _rc(galil.DMCGetUnsolicitedResponse(self._gcon, self._buf, _BUF_SIZE))
        return str(self._buf.value.decode("latin-1"))

    def GInfo(self) -> str:
        """The connection: "<card> on <endpoint>, <firmware revision>"."""
        bus = self._cc()
        _rc(galil.DMCVersion(self._gcon, self._buf, _BUF_SIZE))
        return f"{self._address} on {bus.rack.endpoint}, {self._buf.value.decode('latin-1')}"

    def GVersion(self) -> str:
        """The library version, "py." and the version of vdevd's client."""
        return "py." + importlib.metadata.version("vdevd")

    def GInterrupt(self) -> int:
        """The next interrupt status byte of the card (0xD1 for "Y motion complete"), waiting up
        to the timeout for one (timeout 0: none waiting is an error); enables the card's
        interrupt output on first use."""
        bus = self._cc()
        if not self._irq_enabled:
            bus.enable_interrupts()
            self._irq_enabled = True
        code = bus.interrupt_status()
        if code:
            return code
        wait_ms = self._initial_timeout if self._timeout == -1 else self._timeout
        if not wait_ms:
            _rc(G_GCLIB_NON_BLOCKING_READ_EMPTY)
        while True:
            code, seq = bus.wait_interrupt(wait_ms, self._irq_seq)
            if seq is None:
                _rc(G_TIMEOUT)
            self._irq_seq = seq
            if code:
                return code

    def GRecord(self, method: int = G_DR) -> dict[str, Any]:
        """A fresh data record decoded by item name (`sample_number`, `axis_a_motor_position`,
        ...). Both methods read the card's secondary FIFO (the DMC-13X8 has no QR)."""
        self._cc()
        if method not in (G_QR, G_DR):
            _rc(G_BAD_VALUE_RANGE)
        _rc(galil.DMCRefreshDataRecord(self._gcon, 0))
        size = ctypes.c_ushort()
        _rc(galil.DMCGetDataRecordSize(self._gcon, ctypes.byref(size)))
        record = ctypes.create_string_buffer(size.value)
        _rc(galil.DMCCopyDataRecord(self._gcon, record))
        axes = (size.value - FIRST_AXIS) // AXIS_SIZE
        return decode_record(record.raw, axes)

    # -- arrays (gclib.h GArrayDownload, GArrayUpload; gclibo.h GArray*File) ------------------------
    def _array_command(self, line: str, data: bytes = b"") -> bytes:
        """One QU/QD exchange: its reply without the final CR LF ':' ('?': GclibError)."""
        reply = galil.long_command(self._cc(), line.encode("latin-1") + data, 1)
        if b"?" in reply.data:
            _rc(G_BAD_RESPONSE_QUESTION_MARK)
        if reply.timed_out:
            _rc(G_TIMEOUT)
        return reply.data.rstrip(b"\x1a:\r\n")

    @staticmethod
    def _bounds(first: int, last: int) -> str:
        """`,first,last` of QU/QD, G_BOUNDS (-1) left empty: the card takes the array's ends."""
        return "".join("," + ("" if v == G_BOUNDS else str(int(v))) for v in (first, last))

    def GArrayDownload(self, name: str, first: int, last: int, array_data: list[Any]) -> None:
        """Write `array_data` (numbers) into elements first.. of the dimensioned array `name`
        (first/last -1: from 0 / to the end): `QD name[],first,last`, the values separated by
        commas, a backslash. A missing array, a bad range or value: GclibError."""
        data = ",".join(str(val) for val in array_data).encode("latin-1")
        self._array_command(f"QD {name}[]{self._bounds(first, last)}\r", data + b"\\")

    def GArrayUpload(self, name: str, first: int = G_BOUNDS, last: int = G_BOUNDS,
                     delim: int = G_COMMA) -> list[float]:
        """Elements first..last of array `name` (-1: the array's ends) as floats: `QU`."""
        if delim not in (G_CR, G_COMMA):
            _rc(G_BAD_VALUE_RANGE)
        text = self._array_command(f"QU {name}[]{self._bounds(first, last)},{delim}\r")
        return [float(s) for s in text.decode("latin-1").split("," if delim else "\r")]

    def GArrayUploadFile(self, file_path: str, names: list[str] | None = None) -> None:
        """Write arrays (`names`; none: every array LA lists) to a CSV file as gclib does: the
        names on the first line, then one line per element index, an empty cell where an array
        has ended, every line ended by CR."""
        if not names:
            listing = self.GCommand("LA").replace("\n", "\r").split("\r")
            names = [line.split("[", 1)[0].strip() for line in listing if "[" in line]
        columns = []
        for name in names:
            text = self._array_command(f"QU {name}[],,,{G_CR}\r").decode("latin-1")
            columns.append([cell.replace(" ", "") for cell in text.split("\r")])
        rows = [",".join(names)]
        for i in range(max((len(c) for c in columns), default=0)):
            rows.append(",".join(c[i] if i < len(c) else "" for c in columns))
        try:
            with open(file_path, "w", encoding="latin-1", newline="") as f:
                f.write("".join(row + "\r" for row in rows))
        except OSError:
            _rc(G_BAD_FILE)

    def GArrayDownloadFile(self, file_path: str) -> None:
        """Arrays from a CSV file (GArrayUploadFile's form; CR, LF or CR LF lines): each array
        is deallocated, dimensioned to its cells (`DA`, `DM`) and written (`QD`)."""
        try:
            with open(file_path, encoding="latin-1", newline="") as f:
                text = f.read()
        except OSError:
            _rc(G_BAD_FILE)
        lines = [line for line in text.replace("\r\n", "\r").replace("\n", "\r").split("\r")]
        names = [n.strip() for n in (lines[0] if lines else "").split(",") if n.strip()]
        if not names:
            _rc(G_BAD_FILE)
        cells: list[list[str]] = [[] for _ in names]
        for line in lines[1:]:
            for column, cell in zip(cells, line.split(","), strict=False):
                if cell.strip():
                    column.append(cell.strip())
        for name, column in zip(names, cells, strict=True):
            self.GCommand(f"DA {name}[]")
            self.GCommand(f"DM {name}[{len(column)}]")
            self.GArrayDownload(name, G_BOUNDS, G_BOUNDS, column)
