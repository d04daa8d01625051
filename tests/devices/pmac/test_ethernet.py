"""The PMAC Ethernet protocol (spec pmac.md §3.2): the session without I/O, then the TCP server driven
by an unmodified dls-pmaclib `PmacEthernetInterface` (§3.3)."""

from __future__ import annotations

import asyncio
import socket
import struct
import threading
import warnings
from collections.abc import Coroutine, Iterator
from typing import Any, TypeVar

import pytest
import uvloop

from vdevd.devices.pmac.ethernet import (
    ETHERNET_DATA_SIZE,
    MAX_REPLY,
    PORT_FAILURE,
    REPLY_ACK,
    REPLY_EMPTY,
    REPLY_INVALID,
    VR_CTRL_RESPONSE,
    VR_DOWNLOAD,
    VR_FWDOWNLOAD,
    VR_IPADDRESS,
    VR_PMAC_FLUSH,
    VR_PMAC_GETBUFFER,
    VR_PMAC_GETLINE,
    VR_PMAC_GETMEM,
    VR_PMAC_GETRESPONSE,
    VR_PMAC_PORT,
    VR_PMAC_READREADY,
    VR_PMAC_SENDCTRLCHAR,
    VR_PMAC_SENDLINE,
    VR_PMAC_SETBIT,
    VR_PMAC_SETBITS,
    VR_PMAC_SETMEM,
    VR_PMAC_WRITEBUFFER,
    VR_PMAC_WRITEERROR,
    VR_UPLOAD,
    EthernetSession,
    Header,
    packet,
)
from vdevd.devices.pmac.ethernet_server import EthernetServer, parse_endpoint

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # dls_pmacremote imports telnetlib
    from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

T = TypeVar("T")
GUARD = 5.0  # seconds; a guard against hangs, never a wait for timing

#: 500 lines of 6 bytes and an ACK: 3001 bytes; no CR at a 1400-byte chunk end (dls-pmaclib would
#: take a chunk ending in CR for an error reply, see test_chunk_boundary_is_exact_even_after_a_cr)
LONG = b"".join(b"%05d\r" % i for i in range(500)) + b"\x06"
STATUS_B = b"812000804001\r"
POSITIONS = b"0 0 0 0 0 0 0 0\r"


class FakePort:
    """A card port with canned replies, a dict-like DPRAM and eight host-port bytes."""

    REPLIES = {
        "i6=1 i3=2 ver": b"1.940\r\x06",
        "ver": b"1.940\r\x06",
        "cid": b"603382\r\x06",
        "i20 i21 i22 i23 ": b"$0\r$0\r$0\r$0\r\x06",
        "long": LONG,
        "bad": b"\x07ERR003\r",
        "i10 bad": b"3713707\r\x07ERR003\r",
        "quiet": b"",
        "i3=1 ver": b"\n1.940\r\n",
    }

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.controls: list[int] = []
        self.dpram = bytearray(0x4000)
        self.host_port = bytearray(8)
        self.closed = threading.Event()

    def command(self, line: str) -> bytes:
        self.lines.append(line)
        if line == "boom":
            raise RuntimeError("interpreter bug")
        return self.REPLIES.get(line, line.upper().encode("latin-1") + b"\r\x06")

    def control(self, ch: int) -> bytes:
        self.controls.append(ch)
        if ch == 0x05:
            raise RuntimeError("control bug")
        return {0x02: STATUS_B, 0x10: POSITIONS, 0x0E: b"x" * 2000}.get(ch, b"")

    def dpram_read(self, offset: int, count: int) -> bytes:
        if offset + count > len(self.dpram):
            raise ValueError("beyond the DPRAM")
        return bytes(self.dpram[offset:offset + count])

    def dpram_write(self, offset: int, data: bytes) -> None:
        if offset + len(data) > len(self.dpram):
            raise ValueError("beyond the DPRAM")
        self.dpram[offset:offset + len(data)] = data

    def host_port_read(self, offset: int) -> int:
        return self.host_port[offset]

    def host_port_write(self, offset: int, value: int) -> None:
        self.host_port[offset] = value

    def close(self) -> None:
        self.closed.set()


@pytest.fixture
def port() -> FakePort:
    return FakePort()


@pytest.fixture
def session(port: FakePort) -> EthernetSession:
    return EthernetSession(port)


def ask(session: EthernetSession, data: bytes) -> bytes:
    """Feed one whole request; it must produce exactly one reply."""
    replies = session.receive(data)
    assert len(replies) == 1, replies
    return replies[0]


def get_response(line: bytes) -> bytes:
    """A GETRESPONSE packet exactly as dls-pmaclib builds it (wLength in one byte)."""
    return struct.pack("8B", 0x40, 0xBF, 0, 0, 0, 0, 0, len(line)) + line


GETBUFFER = struct.pack("8B", 0xC0, 0xC5, 0, 0, 0, 0, 0x08, 0)  # dls-pmaclib's, wLength 2048


# -- header and framing ----------------------------------------------------------------------------------


def test_header_is_big_endian_and_matches_the_dls_pmaclib_test_packet() -> None:
    assert get_response(b"cmd") == b"@\xbf\x00\x00\x00\x00\x00\x03cmd"
    assert packet(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, data=b"cmd") == b"@\xbf\x00\x00\x00\x00\x00\x03cmd"
    assert Header.unpack(b"\xc0\xb4\x01\x02\x00\x03\x05\x78") == Header(0xC0, 0xB4, 0x0102, 3, 1400)


def test_packet_split_into_single_bytes_is_answered_once_complete(session: EthernetSession) -> None:
    data = get_response(b"ver")
    for byte in data[:-1]:
        assert session.receive(bytes((byte,))) == []
    assert session.receive(data[-1:]) == [b"1.940\r\x06"]


def test_coalesced_packets_get_one_reply_each_in_order(session: EthernetSession) -> None:
    data = get_response(b"cid") + packet(VR_UPLOAD, VR_PMAC_READREADY, length=2) + get_response(b"ver")
    assert session.receive(data + get_response(b"v")[:5]) == [b"603382\r\x06", b"\x00\x00", b"1.940\r\x06"]
    assert session.receive(get_response(b"v")[5:]) == [b"V\r\x06"]


# -- GETRESPONSE / GETBUFFER -------------------------------------------------------------------------------


def test_getresponse_runs_the_line_and_returns_the_framed_response(session: EthernetSession,
                                                                   port: FakePort) -> None:
    assert ask(session, get_response(b"i6=1 i3=2 ver")) == b"1.940\r\x06"
    assert ask(session, get_response(b"bad")) == b"\x07ERR003\r"
    assert ask(session, get_response(b"i10 bad")) == b"3713707\r\x07ERR003\r"
    assert port.lines == ["i6=1 i3=2 ver", "bad", "i10 bad"]


def test_getresponse_passes_control_characters_inside_the_line_to_the_port(session: EthernetSession,
                                                                           port: FakePort) -> None:
    assert ask(session, get_response(b"\x18#1j/")) == b"\x18#1J/\r\x06"
    assert port.lines == ["\x18#1j/"]


def test_getresponse_text_is_cut_at_nul_and_split_at_cr(session: EthernetSession, port: FakePort) -> None:
    assert ask(session, get_response(b"ver\r")) == b"1.940\r\x06"
    assert ask(session, get_response(b"cid\rver\0junk")) == b"603382\r\x06"
    assert session.pending == b"1.940\r\x06"
    assert port.lines == ["ver", "cid", "ver"]


def test_long_response_is_1400_bytes_then_getbuffer_chunks(session: EthernetSession) -> None:
    first = ask(session, get_response(b"long"))
    assert len(first) == MAX_REPLY
    second = ask(session, GETBUFFER)
    third = ask(session, GETBUFFER)
    assert (len(second), len(third)) == (MAX_REPLY, len(LONG) - 2 * MAX_REPLY)
    assert first + second + third == LONG
    assert ask(session, GETBUFFER) == REPLY_EMPTY


def test_chunk_boundary_is_exact_even_after_a_cr(session: EthernetSession, port: FakePort) -> None:
    port.REPLIES = {**port.REPLIES, "tens": b"123456789\r" * 200 + b"\x06"}
    first = ask(session, get_response(b"tens"))
    assert len(first) == MAX_REPLY and first.endswith(b"\r")


def test_getbuffer_with_nothing_pending_answers_nul(session: EthernetSession) -> None:
    assert ask(session, GETBUFFER) == REPLY_EMPTY


def test_getbuffer_returns_one_reply_at_a_time(session: EthernetSession) -> None:
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"i10 bad")) == REPLY_ACK
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"cid")) == REPLY_ACK
    assert ask(session, GETBUFFER) == b"3713707\r\x07ERR003\r"
    assert ask(session, GETBUFFER) == b"603382\r\x06"


def test_getbuffer_stops_at_lf_as_the_manual_says_for_i3_1(session: EthernetSession) -> None:
    assert ask(session, get_response(b"i3=1 ver")) == b"\n"
    assert ask(session, GETBUFFER) == b"1.940\r\n"


def test_getresponse_discards_output_left_by_earlier_requests(session: EthernetSession) -> None:
    ask(session, get_response(b"long"))
    assert ask(session, get_response(b"cid")) == b"603382\r\x06"
    assert session.pending == b""


def test_getresponse_of_an_empty_response_answers_nul(session: EthernetSession) -> None:
    assert ask(session, get_response(b"quiet")) == REPLY_EMPTY


def test_port_bug_answers_err003_and_the_session_continues(session: EthernetSession,
                                                           caplog: pytest.LogCaptureFixture) -> None:
    assert ask(session, get_response(b"boom")) == PORT_FAILURE
    assert "interpreter bug" in caplog.text
    assert ask(session, get_response(b"ver")) == b"1.940\r\x06"


# -- READREADY, FLUSH, SENDLINE, GETLINE --------------------------------------------------------------------


def test_readready_reports_pending_output(session: EthernetSession) -> None:
    readready = packet(VR_UPLOAD, VR_PMAC_READREADY, length=2)
    assert ask(session, readready) == b"\x00\x00"
    ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"cid"))
    assert ask(session, readready) == b"\x01\x00"


def test_flush_discards_pending_output_and_answers_at_sign(session: EthernetSession) -> None:
    ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"cid"))
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_FLUSH, value=10)) == b"@"
    assert session.pending == b""


def test_sendline_queues_output_and_answers_one_byte(session: EthernetSession, port: FakePort) -> None:
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"#1j+")) == REPLY_ACK
    assert port.lines == ["#1j+"]
    assert session.pending == b"#1J+\r\x06"


def test_getline_returns_one_line_at_a_time(session: EthernetSession) -> None:
    ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"i20 i21 i22 i23 "))
    getline = packet(VR_UPLOAD, VR_PMAC_GETLINE)
    assert [ask(session, getline) for _ in range(6)] == [b"$0\r"] * 4 + [b"\x06", REPLY_EMPTY]


# -- control characters ------------------------------------------------------------------------------------


def test_ctrl_response_answers_the_text_for_htons_and_host_order_wvalue(session: EthernetSession,
                                                                        port: FakePort) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_CTRL_RESPONSE, value=0x02)) == STATUS_B
    assert ask(session, packet(VR_UPLOAD, VR_CTRL_RESPONSE, value=0x1000)) == POSITIONS  # EPICS
    assert port.controls == [0x02, 0x10]


def test_ctrl_response_without_text_answers_one_byte(session: EthernetSession, port: FakePort) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_CTRL_RESPONSE, value=0x0B)) == REPLY_EMPTY
    assert port.controls == [0x0B]


def test_ctrl_response_longer_than_1400_continues_through_getbuffer(session: EthernetSession) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_CTRL_RESPONSE, value=0x0E)) == b"x" * MAX_REPLY
    assert ask(session, GETBUFFER) == b"x" * 600


def test_sendctrlchar_queues_the_text_and_answers_one_byte(session: EthernetSession) -> None:
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDCTRLCHAR, value=0x02)) == REPLY_ACK
    assert ask(session, GETBUFFER) == STATUS_B


def test_ctrl_x_discards_pending_output(session: EthernetSession, port: FakePort) -> None:
    ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"cid"))
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SENDCTRLCHAR, value=0x18)) == REPLY_ACK
    assert session.pending == b"" and port.controls == [0x18]


def test_control_bug_or_non_control_character_is_refused_politely(session: EthernetSession,
                                                                  caplog: pytest.LogCaptureFixture) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_CTRL_RESPONSE, value=0x05)) == REPLY_EMPTY
    assert "control bug" in caplog.text
    assert ask(session, packet(VR_UPLOAD, VR_CTRL_RESPONSE, value=0x41)) == REPLY_INVALID


# -- DPRAM and host port -------------------------------------------------------------------------------------


def test_setmem_then_getmem_round_trip(session: EthernetSession, port: FakePort) -> None:
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SETMEM, value=0x0EA0, data=b"ver\0")) == REPLY_ACK
    assert port.dpram[0x0EA0:0x0EA4] == b"ver\0"
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_GETMEM, value=0x0EA0, length=4)) == b"ver\0"


def test_setmem_with_upload_requesttype_as_pcommx_sends_it(session: EthernetSession, port: FakePort) -> None:
    data = packet(VR_UPLOAD, VR_PMAC_SETMEM, value=0x10, data=b"\x01\x02") + GETBUFFER
    assert session.receive(data) == [REPLY_ACK, REPLY_EMPTY]
    assert port.dpram[0x10:0x12] == b"\x01\x02"


def test_getmem_out_of_range_or_too_long_answers_bell(session: EthernetSession) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_GETMEM, value=0x3FFE, length=4)) == REPLY_INVALID
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_GETMEM, value=0, length=MAX_REPLY + 1)) == REPLY_INVALID
    assert len(ask(session, packet(VR_UPLOAD, VR_PMAC_GETMEM, value=0, length=MAX_REPLY))) == MAX_REPLY


def test_setbit_ors_or_ands_a_little_endian_word(session: EthernetSession, port: FakePort) -> None:
    port.dpram[0x100:0x104] = (0x00FF00F0).to_bytes(4, "little")
    set_bit = packet(VR_DOWNLOAD, VR_PMAC_SETBIT, value=0x100, index=1, data=(1 << 24).to_bytes(4, "little"))
    assert ask(session, set_bit) == REPLY_ACK
    assert int.from_bytes(port.dpram[0x100:0x104], "little") == 0x01FF00F0
    clear = (~(1 << 4) & 0xFFFFFFFF).to_bytes(4, "little")  # pcommx complements the mask to clear
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SETBIT, value=0x100, index=0, data=clear)) == b"@"
    assert int.from_bytes(port.dpram[0x100:0x104], "little") == 0x01FF00E0


def test_setbits_sets_then_clears(session: EthernetSession, port: FakePort) -> None:
    port.dpram[0x200:0x204] = (0xF0F0F0F0).to_bytes(4, "little")
    masks = (0x0000000F).to_bytes(4, "little") + (0xF0000000).to_bytes(4, "little")
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SETBITS, value=0x200, data=masks)) == REPLY_ACK
    assert int.from_bytes(port.dpram[0x200:0x204], "little") == 0x00F0F0FF


def test_setbit_with_wrong_mask_length_answers_bell(session: EthernetSession) -> None:
    short = packet(VR_DOWNLOAD, VR_PMAC_SETBIT, value=0, index=1, data=b"\x01")
    assert ask(session, short) == REPLY_INVALID
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_SETBITS, value=0, data=b"\x01" * 4)) == REPLY_INVALID


def test_port_writes_and_reads_a_host_port_byte(session: EthernetSession, port: FakePort) -> None:
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_PORT, value=7, index=0x41)) == REPLY_ACK
    assert port.host_port[7] == 0x41
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_PORT, value=7)) == b"\x41"
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_PORT, value=8)) == REPLY_INVALID


# -- WRITEBUFFER, WRITEERROR, FWDOWNLOAD, IPADDRESS ---------------------------------------------------------


def test_writebuffer_runs_every_line_and_answers_zero_status(session: EthernetSession,
                                                             port: FakePort) -> None:
    data = b"OPEN PLC 1 CLEAR\0P1=P1+1\0CLOSE\0"
    assert ask(session, packet(VR_DOWNLOAD, VR_PMAC_WRITEBUFFER, data=data)) == bytes(4)
    assert port.lines == ["OPEN PLC 1 CLEAR", "P1=P1+1", "CLOSE"]
    assert session.pending == b""


def test_writebuffer_stops_at_the_first_error_with_its_1_based_line(session: EthernetSession,
                                                                    port: FakePort) -> None:
    data = b"OPEN PLC 1 CLEAR\0P1=P1+1\0bad\0CLOSE\0"
    status = ask(session, packet(VR_DOWNLOAD, VR_PMAC_WRITEBUFFER, data=data))
    assert status == bytes((3, 0, 3, 0x80))
    assert port.lines == ["OPEN PLC 1 CLEAR", "P1=P1+1", "bad"]
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_WRITEERROR)) == status


def test_writeerror_before_any_writebuffer_is_all_zero(session: EthernetSession) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_PMAC_WRITEERROR)) == bytes(4)


def test_fwdownload_is_accepted_and_discarded(session: EthernetSession, port: FakePort) -> None:
    assert ask(session, packet(VR_DOWNLOAD, VR_FWDOWNLOAD, value=1, data=bytes(range(200)))) == REPLY_ACK
    assert port.lines == []


def test_ipaddress_reads_the_address_and_keeps_a_new_one(session: EthernetSession) -> None:
    assert ask(session, packet(VR_UPLOAD, VR_IPADDRESS, length=4)) == bytes((127, 0, 0, 1))
    new = bytes((192, 168, 0, 200))
    assert ask(session, packet(VR_DOWNLOAD, VR_IPADDRESS, data=new)) == new
    assert ask(session, packet(VR_UPLOAD, VR_IPADDRESS)) == new
    assert ask(session, packet(VR_DOWNLOAD, VR_IPADDRESS, data=b"\x01")) == REPLY_INVALID


# -- malformed requests ------------------------------------------------------------------------------------


def test_unknown_request_answers_bell_and_consumes_its_data(session: EthernetSession) -> None:
    data = packet(VR_DOWNLOAD, 0xA0, data=b"xyz") + get_response(b"ver")
    assert session.receive(data) == [REPLY_INVALID, b"1.940\r\x06"]
    assert session.receive(packet(VR_UPLOAD, 0xA1, length=500) + get_response(b"cid")) == [
        REPLY_INVALID, b"603382\r\x06"]


def test_bad_requesttype_answers_bell(session: EthernetSession, port: FakePort) -> None:
    assert session.receive(packet(0x41, VR_PMAC_GETRESPONSE, data=b"ver") + GETBUFFER) == [
        REPLY_INVALID, REPLY_EMPTY]
    assert port.lines == []


def test_data_longer_than_the_ethernet_limit_closes_the_session(session: EthernetSession) -> None:
    header = Header(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, length=ETHERNET_DATA_SIZE + 1).pack()
    assert session.receive(get_response(b"ver") + header + b"ver") == [b"1.940\r\x06"]
    assert session.closed
    assert session.receive(get_response(b"ver")) == []


def test_getbuffer_wlength_is_not_a_data_length(session: EthernetSession) -> None:
    assert session.receive(packet(VR_UPLOAD, VR_PMAC_GETBUFFER, length=0xFFFF)) == [REPLY_EMPTY]
    assert not session.closed


# -- the TCP server with dls-pmaclib ------------------------------------------------------------------------


class LoopThread:
    """An asyncio loop in a background thread running one EthernetServer of FakePorts."""

    def __init__(self, allow: tuple[str, ...] = (), loop: str = "asyncio") -> None:
        self.ports: list[FakePort] = []
        self.loop = uvloop.new_event_loop() if loop == "uvloop" else asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.server = self.call(EthernetServer.start("tcp://127.0.0.1:*", self.open_port, allow=allow))

    def open_port(self) -> FakePort:
        port = FakePort()
        self.ports.append(port)
        return port

    def call(self, coro: Coroutine[Any, Any, T]) -> T:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(GUARD)

    @property
    def address(self) -> tuple[str, int]:
        host, port = parse_endpoint(self.server.endpoint)
        return host, port

    def stop(self) -> None:
        async def shutdown() -> None:
            self.server.close()
            await self.server.wait_closed()

        self.call(shutdown())
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(GUARD)
        self.loop.close()


@pytest.fixture(params=["asyncio", "uvloop"])
def served(request: pytest.FixtureRequest) -> Iterator[LoopThread]:
    served = LoopThread(loop=request.param)
    yield served
    served.stop()


@pytest.fixture
def pmac(served: LoopThread) -> Iterator[PmacEthernetInterface]:
    pmac = PmacEthernetInterface(timeout=GUARD)
    pmac.setConnectionParams(*served.address)
    assert pmac.connect() is None
    yield pmac
    pmac.disconnect()


def test_endpoint_is_the_bound_loopback_port(served: LoopThread) -> None:
    host, port = served.address
    assert host == "127.0.0.1" and port > 0
    assert parse_endpoint("tcp://[::1]:1025") == ("::1", 1025)
    with pytest.raises(ValueError):
        parse_endpoint("udp://127.0.0.1:1025")


def test_dls_pmaclib_connects_with_its_ver_check(served: LoopThread, pmac: PmacEthernetInterface) -> None:
    assert served.ports[0].lines == ["i6=1 i3=2 ver"]


def test_dls_pmaclib_send_command_and_model_queries(pmac: PmacEthernetInterface) -> None:
    assert pmac.sendCommand("#1j/") == ("#1J/\r\x06", True)
    assert pmac.getPmacModel() == "Geo Brick (3U Turbo PMAC2)"
    assert pmac.getNumberOfAxes() == 8


def test_dls_pmaclib_gets_a_long_reply_whole_through_getbuffer(pmac: PmacEthernetInterface) -> None:
    assert pmac.sendCommand("long") == (LONG.decode(), True)


def test_dls_pmaclib_sees_error_replies_as_sent(pmac: PmacEthernetInterface) -> None:
    assert pmac.sendCommand("bad") == ("\x07ERR003\r", True)


def test_port_bug_is_answered_and_the_server_keeps_serving(served: LoopThread, pmac: PmacEthernetInterface,
                                                          caplog: pytest.LogCaptureFixture) -> None:
    assert pmac.sendCommand("boom") == ("\x07ERR003\r", True)
    assert pmac.sendCommand("ver") == ("1.940\r\x06", True)
    assert "interpreter bug" in caplog.text


def test_each_connection_has_its_own_port_closed_on_disconnect(served: LoopThread) -> None:
    clients = [PmacEthernetInterface(timeout=GUARD) for _ in range(2)]
    for client in clients:
        client.setConnectionParams(*served.address)
        assert client.connect() is None
    assert clients[1].sendCommand("cid") == ("603382\r\x06", True)
    assert [p.lines for p in served.ports] == [["i6=1 i3=2 ver"], ["i6=1 i3=2 ver", "cid"]]
    clients[0].disconnect()
    assert served.ports[0].closed.wait(GUARD)
    assert not served.ports[1].closed.is_set()
    clients[1].disconnect()
    assert served.ports[1].closed.wait(GUARD)


def recv_exactly(sock: socket.socket, size: int) -> bytes:
    data = b""
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            break
        data += chunk
    return data


def test_raw_coalesced_requests_over_tcp(served: LoopThread) -> None:
    with socket.create_connection(served.address, timeout=GUARD) as sock:
        sock.sendall(get_response(b"cid") + packet(VR_UPLOAD, VR_PMAC_READREADY, length=2) + GETBUFFER)
        assert recv_exactly(sock, 8 + 2 + 1) == b"603382\r\x06" + b"\x00\x00" + REPLY_EMPTY


def test_lost_framing_closes_the_connection(served: LoopThread) -> None:
    with socket.create_connection(served.address, timeout=GUARD) as sock:
        sock.sendall(Header(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, length=0xFFFF).pack())
        assert sock.recv(16) == b""
    assert served.ports[0].closed.wait(GUARD)


def test_peer_not_in_allow_list_is_closed_at_once() -> None:
    served = LoopThread(allow=("10.1.2.3", "192.168.0.0/24"))
    try:
        with socket.create_connection(served.address, timeout=GUARD) as sock:
            assert sock.recv(16) == b""  # nothing sent: a request racing the close would get a reset
        assert served.ports == []
    finally:
        served.stop()


def test_peer_in_allow_list_is_served() -> None:
    served = LoopThread(allow=("127.0.0.0/8",))
    try:
        with socket.create_connection(served.address, timeout=GUARD) as sock:
            sock.sendall(get_response(b"ver"))
            assert recv_exactly(sock, 7) == b"1.940\r\x06"
    finally:
        served.stop()
