"""PComm's binary rotary buffer functions through a real daemon (lockstep clock): the ring at
ROT_CLIENT_START, lines taken by the card each servo cycle while I45 = 1 and handed to the
coordinate system's rotary buffer (here a sink standing in for it: the rotary buffers themselves
are rotary.py's), DprBufBsy when the ring or the buffer is full, DprCmdErr for a refused line
[PComm32 dpr.h rotbuf; PMAC1 DPRAM UM p.30; README "Binary rotary buffer"]."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import pcomm
from vdevmaps.pmac import ROT_CLIENT_SIZE

from tests.devices.pmac.conftest import Pmac, card_config
from tests.devices.pmac.test_dpram_rotary import Sink
from vdevd.testing import DaemonThread

DEVICE = 0


@pytest.fixture
def rig() -> Iterator[tuple[Pmac, Sink]]:
    cfg = card_config(plant="ideal", device=DEVICE)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        host = Pmac(rack)
        sink = Sink()
        d.server.rack.cards["pmac0"].binrot.on_rotary_line = sink
        assert pcomm.OpenPmacDevice(DEVICE, endpoint=d.endpoint)
        try:
            yield host, sink
        finally:
            pcomm.ClosePmacDevice(DEVICE)
            host.close()


def test_lines_go_through_the_ring_to_the_rotary_buffer(rig: tuple[Pmac, Sink]) -> None:
    host, sink = rig
    dev = DEVICE
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X1", 0) == pcomm.DprBufErr  # no ring yet
    assert pcomm.PmacDPRRotBufInit(dev, 0) == pcomm.DprOk  # C.S. 1
    assert pcomm.PmacGetResponseA(dev, None, 0, "I45").text == "1\r"
    lines = [f"X{k} Y{2 * k}" for k in range(200)]  # ~3 words each: the ring wraps
    sent = 0
    while sent < len(lines):
        rc = pcomm.PmacDPRAsciiStrToRotA(dev, lines[sent], 0)
        if rc == pcomm.DprBufBsy:
            host.step(1)  # the card takes what waits in its next servo cycle
            continue
        assert rc == pcomm.DprOk
        sent += 1
    host.step(len(lines) // 16)  # at most LINES_PER_CYCLE (16) lines a servo cycle
    assert sink.lines == [(1, line) for line in lines]
    sink.room = len(lines)  # the C.S.'s rotary buffer is full: bit 14, the host waits
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X-1", 0) == pcomm.DprOk
    host.step(1)
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X-2", 0) == pcomm.DprBufBsy
    sink.room += 2
    host.step(1)
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X-2", 0) == pcomm.DprOk
    host.step(1)
    assert sink.lines[-2:] == [(1, "X-1"), (1, "X-2")]


def test_a_refused_line_is_reported_once_and_transfer_stops_with_i45_0(
        rig: tuple[Pmac, Sink]) -> None:
    host, sink = rig
    dev = DEVICE
    assert pcomm.PmacDPRRotBufChange(dev, 1, 7) == pcomm.DprBufErr  # odd size
    assert pcomm.PmacDPRRotBufChange(dev, 1, 2 * ROT_CLIENT_SIZE) == pcomm.DprOk  # C.S. 2
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X1", 0) == pcomm.DprBufErr  # not C.S. 1's ring
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "BAD", 1) == pcomm.DprOk
    host.step(1)
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X1", 1) == pcomm.DprCmdErr  # the card's ERR003
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X1", 1) == pcomm.DprOk
    host.step(1)
    assert sink.lines == [(2, "X1")]
    assert pcomm.PmacDPRRotBuf(dev, False) == pcomm.DprOk
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X2", 1) == pcomm.DprOk
    host.step(5)
    assert sink.lines == [(2, "X1")]  # I45 = 0: the line waits in the ring
    assert pcomm.PmacDPRRotBuf(dev, True) == pcomm.DprOk
    host.step(1)
    assert sink.lines == [(2, "X1"), (2, "X2")]
    assert pcomm.PmacDPRRotBufRemove(dev, 1) == pcomm.DprOk
    assert pcomm.PmacDPRAsciiStrToRotA(dev, "X3", 1) == pcomm.DprBufErr
