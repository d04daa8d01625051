"""Fixtures of the Turbo PMAC tests: a real daemon (lockstep clock) holding one `pmac-turbo` card
`pmac0` with its Ethernet protocol on a free loopback port, and `Pmac`, a host that reaches it
the raw ways: the DPRAM ASCII handshake through vdevclient, and dls-pmaclib over Ethernet.

    def test_cid(pmac: Pmac) -> None:
        assert pmac.dls().sendCommand("cid")[0] == "603382\\r\\x06"
"""

from __future__ import annotations

import struct
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import vdevclient
from vdevmaps.pmac import CARD_TYPE, CMD_BUFFER, CMD_CONTROL, RESP_BUFFER, RESP_CONTROL

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class
from vdevd.testing import DaemonThread

with warnings.catch_warnings():  # dls-pmaclib imports telnetlib (deprecated in 3.11)
    warnings.simplefilter("ignore", DeprecationWarning)
    from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

CARD = "pmac0"
LOOPBACK = "tcp://127.0.0.1:*"
#: the servo period rounded to ns (hello's period_ns); exact: I10 x 10^6 / 2^23 ns [PMAC1-SRM p.46]
PERIOD_NS = 442_708


def card_config(**options: Any) -> Config:
    defaults = {key: opt.default for key, opt in card_class(CARD_TYPE).options.items()}
    return Config(endpoint=LOOPBACK, events=LOOPBACK, clock="lockstep",
                  cards=[CardSpec(CARD_TYPE, CARD, {**defaults, "ethernet": LOOPBACK, **options})])


class Pmac:
    """A host of the card: lockstep stepping, the backdoor, the DPRAM ASCII channel, Ethernet."""

    def __init__(self, rack: vdevclient.Rack) -> None:
        self.rack = rack
        self.card = rack.card(CARD)
        info = next(c for c in rack.info["cards"] if c["name"] == CARD)
        self.ethernet = str(info["ethernet"])
        self._dls: list[PmacEthernetInterface] = []

    def step(self, ticks: int) -> int:
        return self.rack.sim.step(ticks=ticks, card=CARD)

    def step_ms(self, ms: float) -> int:
        return self.step(round(ms * 1e6 / PERIOD_NS))

    def control(self, action: str, **params: Any) -> Any:
        return self.card.control(action, **params)

    # -- Ethernet through dls-pmaclib, unmodified ----------------------------------------------------
    def dls(self) -> PmacEthernetInterface:
        host, port = self.ethernet.removeprefix("tcp://").rsplit(":", 1)
        pmac = PmacEthernetInterface()
        pmac.setConnectionParams(host, int(port))
        error = pmac.connect()
        assert error is None, error
        self._dls.append(pmac)
        return pmac

    def close(self) -> None:
        for pmac in self._dls:
            pmac.disconnect()

    # -- the DPRAM ASCII channel, by hand ----------------------------------------------------------
    def dpram_lines(self, line: str) -> list[tuple[int, str]]:
        """Send `line` through the DPRAM handshake; every (control word, text) the card posts up to
        its ACK or error word, acknowledging each."""
        region = self.card.region("dpram")
        assert region.read(CMD_CONTROL, 2) == b"\0\0"
        region.write(CMD_BUFFER, line.encode() + b"\0")
        region.write(CMD_CONTROL, struct.pack("<H", 1))
        posted = []
        for _ in range(1000):
            control, count = struct.unpack("<HH", region.read(RESP_CONTROL, 4))
            assert control, "the card posted nothing"
            text = region.read(RESP_BUFFER, count).split(b"\0", 1)[0].decode()
            posted.append((control, text))
            region.write(RESP_CONTROL, b"\0\0")
            if control != 0x0D:
                return posted
        raise AssertionError("no end of reply")


@contextmanager
def pmac_card(state_dir: Path | None = None, **options: Any) -> Iterator[Pmac]:
    """A daemon of its own with `pmac0` configured by `options`; two of these on one `state_dir`,
    one after the other, are a power cycle."""
    cfg = card_config(**options)
    if state_dir is not None:
        cfg.state_dir = str(state_dir)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        host = Pmac(rack)
        try:
            yield host
        finally:
            host.close()


@contextmanager
def pcomm_device(device: int = 0, **options: Any) -> Iterator[Pmac]:
    """A daemon of its own with `pmac0` (`options`, the PComm `device` number) and
    `vdevclient.pcomm` device `device` opened on it; the host-side handle for stepping."""
    from vdevclient import pcomm

    cfg = card_config(device=device, **options)
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        host = Pmac(rack)
        assert pcomm.OpenPmacDevice(device, endpoint=d.endpoint)
        try:
            yield host
        finally:
            pcomm.ClosePmacDevice(device)
            host.close()


def step_to(host: Pmac, seconds: float, now: list[int]) -> None:
    """Step the lockstep clock to `seconds` after a start (`now`: the servo cycles run since
    that start, kept up to date); nothing when that time has passed."""
    n = round(seconds / (PERIOD_NS / 1e9)) - now[0]
    if n > 0:
        host.step(n)
        now[0] += n


def pcomm_ask(device: int, command: str, size: int = 256) -> str:
    """PmacGetResponseA of one command: the reply without its CR/ACK framing."""
    import ctypes

    from vdevclient import pcomm

    out = ctypes.create_string_buffer(size)
    pcomm.PmacGetResponseA(device, out, size, command)
    return out.value.decode("latin-1").strip("\r\x06")


@pytest.fixture
def pmac() -> Iterator[Pmac]:
    with pmac_card(plant="ideal") as host:
        yield host


@pytest.fixture
def pmac_servo() -> Iterator[Pmac]:
    with pmac_card() as host:
        yield host
