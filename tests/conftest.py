"""Shared fixtures: a real daemon (sockets, scheduler, cards) on free loopback ports, lockstep."""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator
from typing import Any

import msgpack
import pytest
import vdevclient
import zmq

from vdevd.config import CardSpec, Config
from vdevd.devices import card_class
from vdevd.testing import DaemonThread

LOOPBACK = "tcp://127.0.0.1:*"


def free_endpoint() -> str:
    """A loopback TCP endpoint on a port free now (for a daemon in another process)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp://127.0.0.1:{s.getsockname()[1]}"


def rack_config(clock: str = "lockstep", **card_options: Any) -> Config:
    """One generic-servo card `servo0` (4 axes, ideal plant unless told) on free ports."""
    options = {key: opt.default for key, opt in card_class("generic-servo").options.items()}
    options.update({"plant": "ideal", **card_options})
    return Config(endpoint=LOOPBACK, events=LOOPBACK, clock=clock,  # type: ignore[arg-type]
                  cards=[CardSpec("generic-servo", "servo0", options)])


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config()) as d:
        yield d


@pytest.fixture
def rack(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as r:
        yield r


class RawClient:
    """A bare DEALER socket speaking msgpack, for protocol-level tests."""

    def __init__(self, endpoint: str) -> None:
        self.sock = zmq.Context.instance().socket(zmq.DEALER)
        self.sock.linger = 0
        self.sock.rcvtimeo = 10_000
        self.sock.connect(endpoint)

    def send_raw(self, body: bytes) -> dict[str, Any]:
        self.sock.send(body)
        return msgpack.unpackb(self.sock.recv(), raw=False, strict_map_key=False)  # type: ignore[no-any-return]

    def call(self, **request: Any) -> dict[str, Any]:
        request.setdefault("id", 1)
        return self.send_raw(msgpack.packb(request, use_bin_type=True))

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def raw(daemon: DaemonThread) -> Iterator[RawClient]:
    client = RawClient(daemon.endpoint)
    yield client
    client.close()


def error_code(reply: dict[str, Any]) -> str:
    assert "error" in reply, f"expected an error reply, got {reply!r}"
    return reply["error"]["code"]  # type: ignore[no-any-return]


Factory = Callable[..., DaemonThread]
