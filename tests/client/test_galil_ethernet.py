"""The DMC-13X8 card's Ethernet command channel (`ethernet = "tcp://..."`, README.md "Ethernet
command channel") on a real lockstep daemon: the DMC ASCII protocol on TCP, answered with the bytes
the command FIFO gives, bounded in connections and command length."""

from __future__ import annotations

import ctypes
import socket
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import galil

from tests.client.galil import GALIL, card, rack_config
from vdevd.devices.galil.channel import MAX_COMMAND
from vdevd.devices.galil.ethernet import MAX_CONNECTIONS, parse_endpoint
from vdevd.testing import DaemonThread

WAIT_S = 10.0  # socket read time-out (wall): only a guard against a hang, never asserted


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0", ethernet="tcp://127.0.0.1:0"))) as d:
        yield d


@pytest.fixture
def rack(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as r:
        yield r


@pytest.fixture
def port(rack: vdevclient.Rack) -> tuple[str, int]:
    """The bound port, as the card info of `hello` reports it (port 0: an ephemeral one)."""
    info = next(c for c in rack.info["cards"] if c["name"] == "galil0")
    host, number = parse_endpoint(info["ethernet"])
    assert number != 0
    return host, number


@pytest.fixture
def fifo(daemon: DaemonThread) -> Iterator[ctypes.c_long]:
    """The card's command FIFO, through the DMC library."""
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCNOERROR
    yield h
    galil.DMCClose(h)


def fifo_command(h: ctypes.c_long, line: str) -> bytes:
    buf = ctypes.create_string_buffer(4096)
    galil.DMCCommand(h, line, buf, ctypes.sizeof(buf))
    return buf.value


def connect(port: tuple[str, int]) -> socket.socket:
    s = socket.create_connection(port, timeout=WAIT_S)
    s.settimeout(WAIT_S)
    return s


def ask(s: socket.socket, data: bytes, answers: int = 1) -> bytes:
    """Send `data`, read until `answers` replies (each ends ':' or '?') have come."""
    s.sendall(data)
    got = b""
    while got.count(b":") + got.count(b"?") < answers:
        chunk = s.recv(4096)
        assert chunk, f"connection closed after {got!r}"
        got += chunk
    return got


def test_tpx_and_mg_answer_the_bytes_the_fifo_gives(port: tuple[str, int], fifo: ctypes.c_long) -> None:
    fifo_command(fifo, "DP 1234")
    with connect(port) as s:
        assert ask(s, b"TPX\r") == fifo_command(fifo, "TPX") == b"0000001234\r\n:"
        assert ask(s, b"MG _BGX\r") == fifo_command(fifo, "MG _BGX")
        assert ask(s, b"MG _BGX\r").endswith(b"0.0000\r\n:")


def test_a_bad_command_answers_a_question_mark_and_tc1_says_why(port: tuple[str, int]) -> None:
    with connect(port) as s:
        assert ask(s, b"XYZ\r") == b"?"
        assert ask(s, b"TC1\r") == b"1 Unrecognized command\r\n:"


def test_commands_separated_by_semicolons_in_one_packet(port: tuple[str, int], fifo: ctypes.c_long) -> None:
    with connect(port) as s:
        assert ask(s, b"DP 5,6;TPX;TPY;XYZ;MG 3\r", answers=5) == (
            b":" + fifo_command(fifo, "TPX") + fifo_command(fifo, "TPY") + b"?"
            + fifo_command(fifo, "MG 3"))


def test_a_trippoint_on_the_port_holds_it_not_the_fifo(port: tuple[str, int], fifo: ctypes.c_long,
                                                      rack: vdevclient.Rack) -> None:
    """AMX on the connection: its reply comes at the move's end; the FIFO answers meanwhile."""
    with connect(port) as s:
        assert ask(s, b"PR 3000;BGX;AMX;MG 7\r", answers=2) == b"::"
        assert fifo_command(fifo, "MG _BGX").endswith(b"1.0000\r\n:")
        rack.sim.step(seconds=2.0)  # the move (default SP 25000, AC/DC 256000) is long over
        assert ask(s, b"", answers=2) == b":" + fifo_command(fifo, "MG 7")
        assert fifo_command(fifo, "RPX") == b"0000003000\r\n:"


def test_a_client_that_disconnects_mid_line_leaves_nothing_behind(port: tuple[str, int],
                                                                  fifo: ctypes.c_long) -> None:
    with connect(port) as s:
        s.sendall(b"DP 99")
    with connect(port) as s:
        assert ask(s, b"\rTPX\r", answers=2) == b":0000000000\r\n:"  # DP 99 never ran
    assert fifo_command(fifo, "TPX") == b"0000000000\r\n:"


def test_connections_are_bounded(port: tuple[str, int]) -> None:
    """MAX_CONNECTIONS (the controllers' 8 handles) are served; one more is closed at once."""
    open_ = [connect(port) for _ in range(MAX_CONNECTIONS)]
    try:
        for s in open_:
            assert ask(s, b"MG 1\r").endswith(b":")
        extra = connect(port)
        assert extra.recv(16) == b""  # closed by the card
        extra.close()
        open_.pop().close()
        for _ in range(50):  # the card sees the close on its loop: retry until it has
            again = connect(port)
            again.sendall(b"MG 2\r")
            reply = again.recv(64)
            again.close()
            if reply:
                break
        assert reply.endswith(b"2.0000\r\n:")
    finally:
        for s in open_:
            s.close()


def test_a_command_longer_than_the_bound_is_refused_and_the_port_keeps_serving(
        port: tuple[str, int]) -> None:
    with connect(port) as s:
        assert ask(s, b"MG " + b"1" * (2 * MAX_COMMAND) + b"\r") == b"?"
        assert ask(s, b"TC1\r") == b"5 Input buffer full\r\n:"
        assert ask(s, b"TPX\r") == b"0000000000\r\n:"


def test_a_client_that_never_reads_does_not_stall_the_daemon(port: tuple[str, int],
                                                             fifo: ctypes.c_long) -> None:
    """A flood of commands whose replies are never read: the card stops reading that connection
    and keeps serving the others and its FIFO."""
    with connect(port) as slow, connect(port) as s:
        slow.setblocking(False)
        flood = b"MG 1;" * 20_000
        sent = 0
        for _ in range(200):
            try:
                sent += slow.send(flood[sent:])
            except BlockingIOError:
                break
            if sent == len(flood):
                break
        assert ask(s, b"MG 5\r") == fifo_command(fifo, "MG 5")


def test_wt_on_the_port_waits_card_time_while_the_card_is_otherwise_at_rest(
        port: tuple[str, int], rack: vdevclient.Rack, fifo: ctypes.c_long) -> None:
    """WT 500 [M Ch6 WT]: the reply after 500 ms of card time, not before; the connection's held
    trippoint keeps a card with nothing else to do from skipping its samples (decision 0008)."""
    with connect(port) as s:
        # MG 5's reply says the daemon has the WT (it runs before the step below starts)
        assert ask(s, b"MG 5;WT 500;MG 9\r") == fifo_command(fifo, "MG 5")
        rack.sim.step(seconds=0.4)
        assert fifo_command(fifo, "MG 1").endswith(b"1.0000\r\n:")  # the FIFO is not held
        s.setblocking(False)  # a reply made during the step would be here already (loopback)
        with pytest.raises(BlockingIOError):
            s.recv(16)  # 400 ms: nothing yet
        s.setblocking(True)
        s.settimeout(WAIT_S)
        rack.sim.step(seconds=0.2)
        assert ask(s, b"", answers=2) == b":" + fifo_command(fifo, "MG 9")


def test_rs_on_the_fifo_releases_a_trippoint_held_on_the_port(port: tuple[str, int], rack: vdevclient.Rack,
                                                               fifo: ctypes.c_long) -> None:
    """RS: the held AM goes without a reply (as a trippoint held on the FIFO does); the commands
    behind it run at the next sample."""
    with connect(port) as s:
        assert ask(s, b"PR 900000;BGX;AMX;MG 4\r", answers=2) == b"::"
        rack.sim.step(seconds=0.1)
        assert fifo_command(fifo, "RS") == b":"
        rack.sim.step(seconds=0.01)
        assert ask(s, b"", answers=1) == fifo_command(fifo, "MG 4")
        assert fifo_command(fifo, "MG _BGX").endswith(b"0.0000\r\n:")
