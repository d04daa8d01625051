"""A Galil command longer than the 512-character command FIFO holds (issue 22 §6) on a live
lockstep daemon: the card answers it `?`, TC 5 "Input buffer full", drops it through its
terminator and goes on serving, as the Ethernet channel does; the clients (DMC library, gclib)
refuse to send it, and send a command of 511 characters, which fits with its terminator."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import galil, gclib
from vdevclient._galil_bus import DmcBus, fifo_pieces, too_long
from vdevmaps.galil import FIFO_SIZE

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread

LONG = "MG " + "1+" * 300 + "1"  # the issue's: 604 characters
FITS = "MG " + "1+" * 253 + "11"  # 511 characters: 253 + 11


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        yield d


@pytest.fixture
def bus(daemon: DaemonThread) -> Iterator[DmcBus]:
    """The register-level exchange of the DMC library, without its checks: what any host may
    write into the FIFO."""
    with vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as rack:
        yield DmcBus(rack, "galil0")


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[gclib.py]:
    conn = gclib.py()
    conn.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


def test_the_card_answers_an_overlong_line_with_tc5_and_keeps_serving(bus: DmcBus) -> None:
    assert len(FITS) == FIFO_SIZE - 1 == 511
    reply = bus.command(LONG.encode() + b"\r", 1)
    assert not reply.timed_out and reply.data == b"?"
    assert bus.command(b"TC1\r", 1).data == b"5 Input buffer full\r\n:"
    assert bus.command(b"MG 1\r", 1).data == b" 0000000001.0000\r\n:"
    # a line of 512 characters and no terminator among them: the FIFO full, no command in it
    assert bus.command(b"MG " + b"1" * 509 + b";MG 2\r", 2).data == b"? 0000000002.0000\r\n:"
    # the commands after the over-long one on the same line run
    assert bus.command(LONG.encode() + b";MG 3\r", 2).data == b"? 0000000003.0000\r\n:"
    assert bus.command(FITS.encode() + b"\r", 1).data == b" 0000000264.0000\r\n:"


def test_the_dmc_library_refuses_a_command_the_fifo_cannot_take(daemon: DaemonThread) -> None:
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCNOERROR
    try:
        buf = ctypes.create_string_buffer(256)
        assert galil.DMCCommand(h, LONG, buf, 256) == galil.DMCERROR_ARGUMENT
        assert galil.DMCCommand(h, "MG 1;" + LONG, buf, 256) == galil.DMCERROR_ARGUMENT
        assert galil.DMCFastCommand(h, LONG) == galil.DMCERROR_ARGUMENT
        assert galil.DMCCommand(h, FITS, buf, 256) == galil.DMCNOERROR
        assert buf.value.strip() == b"0000000264.0000\r\n:"
        # a line of 200 short commands (1000 bytes, 3800 bytes of replies): sent in pieces the
        # FIFO holds, each once the replies of the one before have come
        big = ctypes.create_string_buffer(8192)
        assert galil.DMCCommand(h, ";".join(["MG 1"] * 200), big, 8192) == galil.DMCNOERROR
        assert big.value == b" 0000000001.0000\r\n:" * 200
        assert galil.DMCCommand(h, "TC1", buf, 256) == galil.DMCNOERROR
        assert buf.value.startswith(b"0")  # nothing went wrong on the card
    finally:
        galil.DMCClose(h)


def test_gcommand_refuses_a_command_the_fifo_cannot_take_and_keeps_working(g: gclib.py) -> None:
    with pytest.raises(gclib.GclibError, match="value passed to function was bad or out of range"):
        g.GCommand(LONG)
    assert g.GCommand("MG 1") == "0000000001.0000"
    assert g.GCommand(FITS) == "0000000264.0000"
    assert g.GCommand("TC1").startswith("0")


@pytest.mark.parametrize("sizes", [[4] * 200, [511, 5, 300, 300], [100] * 11, [511] * 3, [1]])
def test_fifo_pieces_cut_a_line_after_terminators_into_pieces_the_fifo_holds(
        sizes: list[int]) -> None:
    line = b"".join(b"M" * (n - 1) + b";" for n in sizes)
    pieces = fifo_pieces(line)
    assert b"".join(pieces) == line
    assert all(len(p) <= FIFO_SIZE and p.endswith(b";") for p in pieces)
    for piece, after in zip(pieces, pieces[1:], strict=False):  # full: the next command would not fit
        assert len(piece) + after.index(b";") + 1 > FIFO_SIZE


def test_too_long_is_a_command_longer_than_511_characters() -> None:
    assert not too_long(b"M" * 511 + b"\r")
    assert too_long(b"M" * 512 + b"\r")
    assert too_long(b"MG 1;" + b"M" * 512)
    assert not too_long(b"MG 1;" * 500)
