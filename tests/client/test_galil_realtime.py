"""The Galil clients on a realtime daemon (the issue: "works in both clock modes"): the same
calls as in lockstep, with simulated time following wall time. Nothing here asserts a duration;
a short move makes the test wait a few tens of milliseconds for the card."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from dataclasses import replace

import pytest
from vdevclient import galil, gclib

from tests.client.galil import GALIL, card, rack_config, round_trips
from vdevd.testing import DaemonThread

OK = galil.DMCNOERROR


@pytest.fixture(params=["arrival", "sample"])
def daemon(request: pytest.FixtureRequest) -> Iterator[DaemonThread]:
    cfg = replace(rack_config(card(GALIL, "galil0", decode=request.param)), clock="realtime")
    with DaemonThread(cfg) as d:
        yield d


def test_dmc_command_in_realtime_is_one_round_trip(daemon: DaemonThread,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint) == OK
    buf = ctypes.create_string_buffer(256)
    with round_trips(monkeypatch) as trips:
        assert galil.DMCCommand(h, b"TPX", buf, 256) == OK
    assert buf.value == b"0000000000\r\n:"
    assert trips.count == 1
    assert galil.DMCCommand(h, b"PR 100;BGX;AMX", buf, 256) == OK  # AM holds until the move ends
    assert buf.value == b":::"
    assert galil.DMCCommand(h, b"RPX", buf, 256) == OK
    assert buf.value == b"0000000100\r\n:"
    assert galil.DMCClose(h) == OK


def test_gclib_in_realtime(daemon: DaemonThread) -> None:
    g = gclib.py()
    g.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    g.GCommand("PR ,-50")
    g.GCommand("BG Y")
    g.GMotionComplete("Y")
    assert g.GCommand("RP Y") == "-0000000050"
    with pytest.raises(gclib.GclibError):
        g.GCommand("bg")
    g.GClose()
