"""Coordinate systems of the Turbo PMAC through its clients, against a real daemon (lockstep):
vdevclient.pcomm `PmacGetResponseA` and dls-pmaclib over Ethernet; the queries the EPICS pmac
driver makes (`&1#1->`, `I5113`, `&1??`) [spec pmac.md §2.8, §3.3, §3.4]."""

from __future__ import annotations

import ctypes
import warnings
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import pcomm

from tests.client.galil import card, rack_config
from vdevd.testing import DaemonThread

with warnings.catch_warnings():  # dls-pmaclib imports telnetlib (deprecated in 3.11)
    warnings.simplefilter("ignore", DeprecationWarning)
    from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

DEVICE = 0
ACK = "\x06"


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card("pmac-turbo", "pmac0", device=DEVICE, ethernet="tcp://127.0.0.1:*",
                           plant="ideal"))
    with DaemonThread(cfg) as d:
        yield d


@pytest.fixture
def dev(daemon: DaemonThread) -> Iterator[int]:
    assert pcomm.OpenPmacDevice(DEVICE, endpoint=daemon.endpoint)
    try:
        yield DEVICE
    finally:
        pcomm.ClosePmacDevice(DEVICE)


@pytest.fixture
def dls(rack: vdevclient.Rack) -> Iterator[PmacEthernetInterface]:
    info = next(c for c in rack.info["cards"] if c["name"] == "pmac0")
    host, port = str(info["ethernet"]).removeprefix("tcp://").rsplit(":", 1)
    pmac = PmacEthernetInterface()
    pmac.setConnectionParams(host, int(port))
    assert pmac.connect() is None
    try:
        yield pmac
    finally:
        pmac.disconnect()


def response(dev: int, command: str) -> tuple[int, str]:
    buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)
    rc = pcomm.PmacGetResponseA(dev, buf, ctypes.sizeof(buf), command)
    return int(rc), rc.text


def test_pcomm_defines_axes_and_reads_them_back_as_epics_asks(dev: int) -> None:
    assert response(dev, "&1#1->1000X+500Y+10")[0] == pcomm.COMM_EOT
    assert response(dev, "&1#2->I")[0] == pcomm.COMM_EOT
    assert response(dev, "&1#1->")[1] == "1000X+500Y+10\r"
    assert response(dev, "&1#2->")[1] == "I\r"
    assert response(dev, "&2#1->")[1] == "0\r"
    w2 = int(response(dev, "#1?")[1][6:12], 16)
    assert w2 & (1 << 15) and (w2 >> 20) + 1 == 1


def test_pcomm_refused_definition_is_err003_and_the_card_serves_on(dev: int) -> None:
    response(dev, "&1#1->1000X")
    rc, text = response(dev, "&3#1->1000Z")
    assert rc & pcomm.COMM_ERROR and "ERR003" in text
    assert response(dev, "&1#1-> &3#1->")[1] == "1000X\r0\r"


def test_dls_pmaclib_epics_queries_and_timers(dls: PmacEthernetInterface,
                                               rack: vdevclient.Rack) -> None:
    assert dls.sendCommand("&1#3->100Z")[0] == ACK
    assert dls.sendCommand("&1#3->")[0] == "100Z\r" + ACK
    assert dls.sendCommand("I5113")[0] == "0\r" + ACK
    assert dls.sendCommand("I5111=1000")[0] == ACK
    rack.sim.step(ticks=400, card="pmac0")
    left = int(dls.sendCommand("I5111")[0].split("\r")[0])
    assert left == 600
    status = dls.sendCommand("&1??")[0].split("\r")[0]
    assert len(status) == 18 and int(status[:6], 16) & 1 == 0   # no program running


def test_dls_pmaclib_kill_and_abort_in_cs_context(dls: PmacEthernetInterface,
                                                   rack: vdevclient.Rack) -> None:
    dls.sendCommand("#1J/ #2J/")
    dls.sendCommand("&1#1->X &2#2->Y")
    dls.sendCommand("&1K")
    w1 = [int(dls.sendCommand(f"#{m}?")[0][:6], 16) for m in (1, 2)]
    assert w1[0] & (1 << 18) and not w1[1] & (1 << 18)       # only C.S. 1's motor is open loop
    assert dls.sendCommand("&1B1R")[0].startswith("\x07ERR015")  # no program buffer
    assert dls.sendCommand("&2#2->")[0] == "1Y\r" + ACK
