"""The PMAC Ethernet protocol (ACC-54E / UMAC Turbo CPU), server side, without I/O (spec pmac.md §3.2).

A request is an 8-byte header -- RequestType u8, Request u8, wValue, wIndex, wLength u16 big-endian --
followed by wLength data bytes when the request carries data [UMAC-CPU p.36, EPICS-IP `ethernetCmd`].
`EthernetSession` is one TCP connection: it is fed raw bytes, buffers partial packets, runs every
complete request against its `Port` and returns one reply per request, to be sent with one write.

Decisions where the sources are silent (spec §6 question 16; recorded in the card README):

* Replies of one byte: download requests that only need acknowledging (SENDLINE, FLUSH, SENDCTRLCHAR,
  SETMEM, SETBIT, SETBITS, PORT write, FWDOWNLOAD) answer `@` (0x40), as real units do [EPICS-IP,
  bliss]; a read with nothing to return (GETBUFFER or GETLINE with no pending output, a GETRESPONSE
  or CTRL_RESPONSE whose text is empty) answers one NUL, the empty C string -- bliss reports that a
  real PMAC "returns \\x00 when the buffer is empty", and dls-pmaclib's GETBUFFER loop then stops
  with `IOPmacSentNullError` instead of waiting for its timeout.
* A request that cannot be served (RequestType neither 0x40 nor 0xC0, unknown Request, wrong data
  length, DPRAM or host-port offset out of range, GETMEM of more than 1400 bytes) answers one BELL
  (0x07), the PMAC's "invalid" character (I3 table [SRM p.37]); the session continues. Only a data
  length above ETHERNET_DATA_SIZE loses the packet framing: the session then closes (`closed`).
* Which requests carry data: GETRESPONSE, SENDLINE, SETMEM (pcommx sends it with 0xC0), SETBIT,
  SETBITS, WRITEBUFFER, FWDOWNLOAD, and IPADDRESS with 0x40; every other known request carries none
  whatever its wLength (GETBUFFER sends 2048, some clients leave it uninitialised); an unknown
  request carries data when its RequestType is host-to-device (bit 7 clear, the USB convention).
* The port's output is one byte stream. GETRESPONSE first discards what an earlier request left in
  it (so a client that gave up half-way through a long reply is not answered with stale text), runs
  the line and returns "all characters up to an ACK or LF; after a BEL or STX only up to the next
  CR; at most 1400 bytes" [UMAC-CPU p.36]; GETBUFFER returns the next such piece. With I3=2 a whole
  reply ends at its ACK, so a reply longer than 1400 bytes goes out as exact 1400-byte chunks.
* Command text is cut at the first NUL (C clients may send it) and split at CR: each line runs in
  turn and the replies are concatenated, as on a serial port (EPICS may append the CR).
* SENDCTRLCHAR queues the character's text as pending output and answers `@`; CTRL_RESPONSE answers
  the text itself (rest over 1400 bytes queued). ^X also discards the pending output. The character is
  taken from wValue, or from its high byte when EPICS sends it in host byte order.
* WRITEBUFFER: lines are numbered from 1 (so an all-zero status never names a line); the replies of
  lines that succeed are discarded; the first line whose reply holds `<BELL>ERRnnn` stops the buffer.
  WRITEERROR (undocumented) answers the 4-byte status of the last WRITEBUFFER (zeros before any).
* SETBITS: the first 32-bit word is the set mask, the second the clear mask [ACC-54E text quoted by
  pmacEthernet clients]; SETBIT ORs its mask when wIndex != 0, else ANDs it (the client sends ~mask).
  DPRAM words are little-endian.
* VR_IPADDRESS reads the address the client connected to (loopback by default); a write is kept for
  this connection only and echoed (a real card applies it after a power cycle).
* A port that raises in `command` answers `<BELL>ERR003<CR>` (logged with its traceback); nothing
  raises out of `receive`.
* Bounded (issue 22): pending output past `max_pending` bytes (SENDLINE replies never fetched)
  closes the session (`overflowed`); `receive(data, limit=1)` runs one request and keeps the rest
  for the next call (the server runs one a turn of its loop); bad requests are logged the first
  few times a session and then only at each tenfold count (`CountedLog`), the total when it ends.
"""

from __future__ import annotations

import logging
import re
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from vdevd.tcp_listener import CountedLog

log = logging.getLogger(__name__)

# RequestType [UMAC-CPU p.36]
VR_UPLOAD = 0xC0  #: PMAC to host
VR_DOWNLOAD = 0x40  #: host to PMAC

# Request [UMAC-CPU p.36, pcommx]
VR_PMAC_SENDLINE = 0xB0
VR_PMAC_GETLINE = 0xB1
VR_PMAC_FLUSH = 0xB3
VR_PMAC_GETMEM = 0xB4
VR_PMAC_SETMEM = 0xB5
VR_PMAC_SENDCTRLCHAR = 0xB6
VR_PMAC_SETBIT = 0xBA
VR_PMAC_SETBITS = 0xBB
VR_PMAC_PORT = 0xBE
VR_PMAC_GETRESPONSE = 0xBF
VR_PMAC_READREADY = 0xC2
VR_CTRL_RESPONSE = 0xC4
VR_PMAC_GETBUFFER = 0xC5
VR_PMAC_WRITEBUFFER = 0xC6
VR_PMAC_WRITEERROR = 0xC7
VR_FWDOWNLOAD = 0xCB
VR_IPADDRESS = 0xE0

ETHERNET_CMD_SIZE = 8
ETHERNET_DATA_SIZE = 1492  #: largest bData of a request
MAX_REPLY = 1400  #: largest reply; a longer response continues through GETBUFFER
HOST_PORT_SIZE = 8  #: host-port byte registers 0..7 [spec §2.11]
LOOPBACK_ADDRESS = bytes((127, 0, 0, 1))
#: pending output a session keeps (replies not fetched) before it is closed
MAX_PENDING = 1 << 20

REPLY_ACK = b"@"  #: one-byte acknowledgement: real units send 0x40 [EPICS-IP, bliss]
REPLY_EMPTY = b"\x00"  #: nothing to return
REPLY_INVALID = b"\x07"  #: BELL: request not understood
PORT_FAILURE = b"\x07ERR003\r"  #: stands in for the reply of a port that raised

CTRL_X = 0x18  #: cancel communication and flush the port queue [SRM p.263]
WRITE_ERROR_FLAG = 0x80  #: byte 3 of the WRITEBUFFER status [UMAC-CPU p.37]

_HEADER = struct.Struct(">BBHHH")
_DATA_REQUESTS = frozenset({VR_PMAC_GETRESPONSE, VR_PMAC_SENDLINE, VR_PMAC_SETMEM, VR_PMAC_SETBIT,
                            VR_PMAC_SETBITS, VR_PMAC_WRITEBUFFER, VR_FWDOWNLOAD})
_HANDLED = frozenset({VR_PMAC_GETRESPONSE, VR_PMAC_GETBUFFER, VR_PMAC_READREADY, VR_PMAC_FLUSH,
                      VR_PMAC_SENDLINE, VR_PMAC_GETLINE, VR_PMAC_SENDCTRLCHAR, VR_CTRL_RESPONSE,
                      VR_PMAC_GETMEM, VR_PMAC_SETMEM, VR_PMAC_SETBIT, VR_PMAC_SETBITS, VR_PMAC_PORT,
                      VR_PMAC_WRITEBUFFER, VR_PMAC_WRITEERROR, VR_FWDOWNLOAD, VR_IPADDRESS})
_REPLY_END = re.compile(rb"[\x06\n\x07\x02]")  # ACK, LF; BEL, STX (then up to the next CR)
_LINE_END = re.compile(rb"[\r\x06\n]")
_ERROR = re.compile(rb"\x07ERR(\d{3})")


class Port(Protocol):
    """One PMAC communications port (its own #/& addressing, I3/I6 framing, output queue) [spec §2.4]."""

    def command(self, line: str) -> bytes:
        """Execute one command line (no CR); return its whole framed response."""
        ...

    def control(self, ch: int) -> bytes:
        """Act on control character `ch` (1-26); return its text, b"" when it has none."""
        ...

    def dpram_read(self, offset: int, count: int) -> bytes:
        """DPRAM bytes at a host byte offset; ValueError when out of range."""
        ...

    def dpram_write(self, offset: int, data: bytes) -> None:
        """Write DPRAM bytes at a host byte offset; ValueError when out of range."""
        ...

    def host_port_read(self, offset: int) -> int:
        """Host-port byte register 0..7."""
        ...

    def host_port_write(self, offset: int, value: int) -> None:
        """Write host-port byte register 0..7."""
        ...

    def close(self) -> None:
        """The connection is gone: release per-port state (open buffers)."""
        ...


@dataclass(frozen=True, slots=True)
class Header:
    """The 8-byte request header [UMAC-CPU p.36]; wValue/wIndex/wLength are big-endian (`htons`)."""

    request_type: int
    request: int
    value: int = 0
    index: int = 0
    length: int = 0

    @classmethod
    def unpack(cls, data: bytes | bytearray) -> Header:
        return cls(*_HEADER.unpack_from(data))

    def pack(self) -> bytes:
        return _HEADER.pack(self.request_type, self.request, self.value, self.index, self.length)

    @property
    def data_length(self) -> int:
        """How many data bytes follow this header (see the module docstring)."""
        if self.request in _DATA_REQUESTS:
            return self.length
        if self.request == VR_IPADDRESS:
            return self.length if self.request_type == VR_DOWNLOAD else 0
        if self.request in _HANDLED:
            return 0
        return 0 if self.request_type & 0x80 else self.length


def packet(request_type: int, request: int, value: int = 0, index: int = 0, data: bytes = b"",
           length: int | None = None) -> bytes:
    """Encode one request; `length` defaults to len(data) (upload requests put a size there)."""
    return Header(request_type, request, value, index, len(data) if length is None else length).pack() + data


def control_character(value: int) -> int | None:
    """The control character (1-26) in wValue: `htons(ch)`, or `ch` in host byte order (EPICS-IP)."""
    for ch in (value, value >> 8):
        if 1 <= ch <= 26:
            return ch
    return None


class EthernetSession:
    """One Ethernet connection to the card: request parsing and the port's pending output [spec §3.2]."""

    def __init__(self, port: Port, *, ip_address: bytes = LOOPBACK_ADDRESS,
                 max_pending: int = MAX_PENDING) -> None:
        self.port = port
        self.ip_address = ip_address
        self.max_pending = max_pending
        #: set when the framing is lost or the pending output overflows; the server then closes
        #: the connection
        self.closed = False
        #: closed because the pending output passed `max_pending`
        self.overflowed = False
        self._inbox = bytearray()
        self._output = bytearray()
        self._write_status = bytes(4)
        self._bad = CountedLog()  # bad requests: logged the first few times, then tenfold
        self._handlers: dict[int, Callable[[Header, bytes], bytes]] = {
            VR_PMAC_GETRESPONSE: self._get_response,
            VR_PMAC_GETBUFFER: self._get_buffer,
            VR_PMAC_READREADY: self._read_ready,
            VR_PMAC_FLUSH: self._flush,
            VR_PMAC_SENDLINE: self._send_line,
            VR_PMAC_GETLINE: self._get_line,
            VR_PMAC_SENDCTRLCHAR: self._send_ctrl_char,
            VR_CTRL_RESPONSE: self._ctrl_response,
            VR_PMAC_GETMEM: self._get_mem,
            VR_PMAC_SETMEM: self._set_mem,
            VR_PMAC_SETBIT: self._set_bit,
            VR_PMAC_SETBITS: self._set_bits,
            VR_PMAC_PORT: self._host_port,
            VR_PMAC_WRITEBUFFER: self._write_buffer,
            VR_PMAC_WRITEERROR: self._write_error,
            VR_FWDOWNLOAD: self._fw_download,
            VR_IPADDRESS: self._ip_address,
        }

    @property
    def pending(self) -> bytes:
        """The port's output not yet fetched (by GETBUFFER/GETLINE)."""
        return bytes(self._output)

    @property
    def ready(self) -> bool:
        """A whole request waits in the input (`receive(b"", limit=1)` runs it)."""
        if self.closed or len(self._inbox) < ETHERNET_CMD_SIZE:
            return False
        size = Header.unpack(self._inbox).data_length
        return size > ETHERNET_DATA_SIZE or len(self._inbox) >= ETHERNET_CMD_SIZE + size

    def receive(self, data: bytes, limit: int | None = None) -> list[bytes]:
        """Feed raw TCP bytes; return the replies to the complete requests, one bytes per request,
        at most `limit` of them (the rest wait for the next call: `ready`)."""
        if self.closed:
            return []
        if not self._inbox and len(data) > ETHERNET_CMD_SIZE and data[1] == VR_PMAC_GETRESPONSE \
                and data[0] == VR_DOWNLOAD and len(data) == ETHERNET_CMD_SIZE + (data[6] << 8 | data[7]):
            # the common case, one whole GETRESPONSE in the segment: no header object, no buffering
            return [self._checked(self._response(data[ETHERNET_CMD_SIZE:]) or REPLY_EMPTY)]
        self._inbox += data
        replies: list[bytes] = []
        while len(self._inbox) >= ETHERNET_CMD_SIZE and (limit is None or len(replies) < limit):
            header = Header.unpack(self._inbox)
            size = header.data_length
            if size > ETHERNET_DATA_SIZE:
                log.warning("PMAC Ethernet request %s with %d data bytes: framing lost, closing",
                            header, size)
                self.closed = True
                self._inbox.clear()
                break
            end = ETHERNET_CMD_SIZE + size
            if len(self._inbox) < end:
                break
            payload = bytes(self._inbox[ETHERNET_CMD_SIZE:end])
            del self._inbox[:end]
            replies.append(self._checked(self._dispatch(header, payload)))
            if self.closed:
                break
        return replies

    def _checked(self, reply: bytes) -> bytes:
        """`reply`, the pending output checked against its bound (past it: closed)."""
        if len(self._output) > self.max_pending:
            self.closed = self.overflowed = True
            self._inbox.clear()
            self._output.clear()
        return reply

    def close_log(self) -> None:
        """The connection ends: say how many bad requests went unlogged, if any."""
        if self._bad.count > self._bad.logged:
            log.info("PMAC Ethernet: %d bad requests on the connection, %d of them logged",
                     self._bad.count, self._bad.logged)

    def _bad_request(self) -> str | None:
        """Count a bad request: None when it goes unlogged, else a suffix for its log line."""
        if not self._bad():
            return None
        if self._bad.count <= self._bad.first:
            return ""
        return f" (bad request {self._bad.count} of the connection; logged at each tenfold)"

    def _dispatch(self, header: Header, data: bytes) -> bytes:
        handler = self._handlers.get(header.request)
        if handler is None or header.request_type not in (VR_UPLOAD, VR_DOWNLOAD):
            if (more := self._bad_request()) is not None:
                log.info("PMAC Ethernet: unsupported request %s%s", header, more)
            return REPLY_INVALID
        try:
            reply = handler(header, data)
        except ValueError as exc:
            if (more := self._bad_request()) is not None:
                log.info("PMAC Ethernet request %s refused: %s%s", header, exc, more)
            return REPLY_INVALID
        except Exception:
            if (more := self._bad_request()) is not None:
                log.exception("PMAC Ethernet request %s failed%s", header, more)
            return REPLY_INVALID
        return reply or REPLY_EMPTY

    # -- ASCII [UMAC-CPU p.36] -------------------------------------------------------------------------

    def _run(self, data: bytes) -> bytes:
        """Run the command text of a request: cut at NUL, one port line per CR-separated line."""
        if b"\0" not in data and b"\r" not in data:  # one line, as clients send it
            return self._command(data.decode("latin-1"))
        text = data.split(b"\0", 1)[0].decode("latin-1")
        if text.endswith("\r"):
            text = text[:-1]
        return b"".join(self._command(line) for line in text.split("\r"))

    def _command(self, line: str) -> bytes:
        try:
            return self.port.command(line)
        except Exception:
            if (more := self._bad_request()) is not None:
                log.exception("PMAC port failed on command %r%s", line, more)
            return PORT_FAILURE

    def _control(self, ch: int) -> bytes:
        try:
            text = self.port.control(ch)
        except Exception:
            if (more := self._bad_request()) is not None:
                log.exception("PMAC port failed on control character %#04x%s", ch, more)
            return b""
        if ch == CTRL_X:
            self._output.clear()
        return text

    def _take(self, end: int) -> bytes:
        end = min(end, MAX_REPLY, len(self._output))
        taken = bytes(self._output[:end])
        del self._output[:end]
        return taken

    def _take_reply(self) -> bytes:
        """Up to an ACK or LF; after a BEL or STX only up to the next CR; at most 1400 bytes."""
        found = _REPLY_END.search(self._output, 0, MAX_REPLY)
        if found is None:
            return self._take(MAX_REPLY)
        if found.group() in (b"\x07", b"\x02"):
            cr = self._output.find(b"\r", found.end())
            return self._take(MAX_REPLY if cr < 0 else cr + 1)
        return self._take(found.end())

    def _get_response(self, header: Header, data: bytes) -> bytes:
        return self._response(data)

    def _response(self, data: bytes) -> bytes:
        """GETRESPONSE: earlier leftovers dropped, the reply up to its end (`_take_reply`)."""
        if self._output:
            self._output.clear()
        out = self._run(data)
        if len(out) < MAX_REPLY and out.endswith(b"\x06") \
                and _REPLY_END.search(out, 0, len(out) - 1) is None:
            return out  # one complete reply, the usual case: nothing is left pending
        self._output += out
        return self._take_reply()

    def _get_buffer(self, header: Header, data: bytes) -> bytes:
        return self._take_reply()

    def _read_ready(self, header: Header, data: bytes) -> bytes:
        return bytes((1 if self._output else 0, 0))

    def _flush(self, header: Header, data: bytes) -> bytes:
        self._output.clear()
        return REPLY_ACK

    def _send_line(self, header: Header, data: bytes) -> bytes:
        self._output += self._run(data)
        return REPLY_ACK

    def _get_line(self, header: Header, data: bytes) -> bytes:
        found = _LINE_END.search(self._output, 0, MAX_REPLY)
        return self._take(MAX_REPLY if found is None else found.end())

    def _send_ctrl_char(self, header: Header, data: bytes) -> bytes:
        self._output += self._control(_require_control(header.value))
        return REPLY_ACK

    def _ctrl_response(self, header: Header, data: bytes) -> bytes:
        text = self._control(_require_control(header.value))
        self._output += text[MAX_REPLY:]
        return text[:MAX_REPLY]

    # -- DPRAM and host port [UMAC-CPU p.36, pcommx] ---------------------------------------------------

    def _get_mem(self, header: Header, data: bytes) -> bytes:
        if header.length > MAX_REPLY:
            raise ValueError(f"GETMEM of {header.length} bytes (at most {MAX_REPLY})")
        return self.port.dpram_read(header.value, header.length)

    def _set_mem(self, header: Header, data: bytes) -> bytes:
        self.port.dpram_write(header.value, data)
        return REPLY_ACK

    def _set_bit(self, header: Header, data: bytes) -> bytes:
        mask = _word(_expect(data, 4))
        word = _word(self.port.dpram_read(header.value, 4))
        word = word | mask if header.index else word & mask
        self.port.dpram_write(header.value, word.to_bytes(4, "little"))
        return REPLY_ACK

    def _set_bits(self, header: Header, data: bytes) -> bytes:
        set_mask, clear_mask = _word(_expect(data, 8)[:4]), _word(data[4:])
        word = _word(self.port.dpram_read(header.value, 4))
        word = (word | set_mask) & ~clear_mask & 0xFFFFFFFF
        self.port.dpram_write(header.value, word.to_bytes(4, "little"))
        return REPLY_ACK

    def _host_port(self, header: Header, data: bytes) -> bytes:
        if not 0 <= header.value < HOST_PORT_SIZE:
            raise ValueError(f"host-port offset {header.value}")
        if header.request_type == VR_UPLOAD:
            return bytes((self.port.host_port_read(header.value) & 0xFF,))
        self.port.host_port_write(header.value, header.index & 0xFF)
        return REPLY_ACK

    # -- downloads and set-up [UMAC-CPU p.37] ----------------------------------------------------------

    def _write_buffer(self, header: Header, data: bytes) -> bytes:
        lines = data.split(b"\0")
        if lines[-1] == b"":
            lines.pop()
        status = bytes(4)
        for number, line in enumerate(lines, start=1):
            if not line:
                continue
            error = _ERROR.search(self._run(line))
            if error is not None:
                status = bytes((number & 0xFF, number >> 8, int(error[1]) & 0xFF, WRITE_ERROR_FLAG))
                break
        self._write_status = status
        return status

    def _write_error(self, header: Header, data: bytes) -> bytes:
        return self._write_status

    def _fw_download(self, header: Header, data: bytes) -> bytes:
        return REPLY_ACK

    def _ip_address(self, header: Header, data: bytes) -> bytes:
        if header.request_type == VR_DOWNLOAD:
            self.ip_address = _expect(data, 4)
        return self.ip_address


def _require_control(value: int) -> int:
    ch = control_character(value)
    if ch is None:
        raise ValueError(f"wValue {value:#06x} holds no control character")
    return ch


def _expect(data: bytes, size: int) -> bytes:
    """`data`, which must be exactly `size` bytes."""
    if len(data) != size:
        raise ValueError(f"{len(data)} data bytes, expected {size}")
    return data


def _word(data: bytes) -> int:
    """A DPRAM word or mask: little-endian ("Intel format") [spec §2.10]."""
    return int.from_bytes(data, "little")
