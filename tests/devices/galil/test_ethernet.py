"""The Ethernet command port's connection handling (vdevd/devices/galil/ethernet.py) over a fake
transport: bounded connections, reading paused while a connection is backed up, trippoints
served at samples; and the card's `address`, `serial`, `ethernet` keys. No sockets."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from tests.devices.galil.test_firmware import Rig
from vdevd.devices.base import CardContext
from vdevd.devices.galil.card import GalilCard
from vdevd.devices.galil.channel import MAX_BATCH, MAX_INPUT, CommandChannel
from vdevd.devices.galil.ethernet import MAX_CONNECTIONS, EthernetServer, _Connection, parse_endpoint


class FakeHandle:
    def cancel(self) -> None:
        pass


class FakeTransport:
    """What _Connection uses of an asyncio transport."""

    def __init__(self) -> None:
        self.sent = b""
        self.reading = True
        self.closed = False

    def get_extra_info(self, name: str) -> Any:
        return ("127.0.0.1", 1) if name == "peername" else None

    def set_write_buffer_limits(self, high: int) -> None:
        pass

    def write(self, data: bytes) -> None:
        self.sent += data

    def is_closing(self) -> bool:
        return self.closed

    def close(self) -> None:
        self.closed = True

    def pause_reading(self) -> None:
        assert self.reading
        self.reading = False

    def resume_reading(self) -> None:
        assert not self.reading
        self.reading = True


class Port:
    """An EthernetServer (not listening) over a firmware, its connections on fake transports."""

    def __init__(self) -> None:
        self.rig = Rig()
        self.touches = 0
        self.turns: list[Callable[[], None]] = []
        self.server = EthernetServer(lambda: CommandChannel(self.rig.fw), self._touched,
                                     self._call_soon)

    def _call_soon(self, callback: Callable[[], None]) -> Any:
        self.turns.append(callback)
        return FakeHandle()

    def run_turns(self) -> int:
        """The loop's turns until none is scheduled; how many ran."""
        n = 0
        while self.turns:
            self.turns.pop(0)()
            n += 1
        return n

    def _touched(self) -> None:
        self.touches += 1

    def open(self) -> tuple[_Connection, FakeTransport]:
        conn, transport = _Connection(self.server), FakeTransport()
        conn.connection_made(transport)  # type: ignore[arg-type]
        return conn, transport

    def sample(self) -> None:
        self.rig.sample()
        if self.server.held:
            self.server.serve()


def test_a_connection_past_the_bound_is_closed_as_it_opens() -> None:
    port = Port()
    opened = [port.open() for _ in range(MAX_CONNECTIONS)]
    assert not any(t.closed for _, t in opened)
    extra, transport = port.open()
    assert transport.closed
    extra.data_received(b"TPX\r")
    assert transport.sent == b""
    extra.connection_lost(None)
    opened[0][0].connection_lost(None)
    assert not port.open()[1].closed  # a freed handle serves again


def test_input_behind_a_trippoint_pauses_reading_until_it_is_decoded() -> None:
    port = Port()
    conn, transport = port.open()
    conn.data_received(b"WT 20;")
    assert port.server.held and port.touches == 1
    flood = b"MG 1;" * (MAX_INPUT // 5 + 1)
    conn.data_received(flood)
    assert not transport.reading  # MAX_INPUT held: no more is read
    assert transport.sent == b""
    for _ in range(25):
        port.sample()
    assert not port.server.held
    turns = port.run_turns()  # the burst, MAX_BATCH commands a turn of the loop
    assert turns >= (MAX_INPUT // 5 + 1) // MAX_BATCH
    assert transport.reading
    assert transport.sent == b":" + port.rig.send(b"MG 1\r") * (MAX_INPUT // 5 + 1)


def test_a_burst_runs_in_turns_of_the_loop_reading_paused_meanwhile() -> None:
    port = Port()
    conn, transport = port.open()
    conn.data_received(b"MG 1;" * (3 * MAX_BATCH))
    reply = port.rig.send(b"MG 1\r")
    assert transport.sent == reply * MAX_BATCH and not transport.reading
    assert len(port.turns) == 1
    assert port.run_turns() == 2
    assert transport.sent == reply * (3 * MAX_BATCH) and transport.reading


def test_replies_the_client_does_not_read_pause_reading() -> None:
    port = Port()
    conn, transport = port.open()
    conn.pause_writing()
    assert not transport.reading
    conn.resume_writing()
    assert transport.reading


def test_a_lost_connection_releases_its_trippoint() -> None:
    port = Port()
    conn, _ = port.open()
    conn.data_received(b"WT 1000;")
    assert port.server.held
    conn.connection_lost(None)
    assert not port.server.held


@pytest.mark.parametrize("endpoint", ["tcp://127.0.0.1:0", "tcp://127.0.0.1:*", "tcp://[::1]:5000"])
def test_endpoints(endpoint: str) -> None:
    host, number = parse_endpoint(endpoint)
    assert host in ("127.0.0.1", "::1") and number in (0, 5000)


def card(**options: Any) -> GalilCard:
    return GalilCard("galil0", options, CardContext(emit=lambda event: None))


def test_the_card_info_carries_the_address_revision_serial_and_endpoint() -> None:
    info = card(axes=3, address="192.168.0.42", serial=77).describe()
    assert (info["address"], info["revision"], info["serial"], info["ethernet"]) == (
        "192.168.0.42", "DMC1338 Rev 1.1a", 77, "")
    assert card().describe()["address"] is None


@pytest.mark.parametrize(("options", "message"), [
    ({"address": "1.2.3.4 --direct"}, "is not a gclib address"),
    ({"address": "-a"}, "is not a gclib address"),
    ({"address": "a,b"}, "is not a gclib address"),
    ({"ethernet": "tcp://0.0.0.0:23"}, "is not loopback"),
    ({"ethernet": "udp://127.0.0.1:23"}, "is not tcp://HOST:PORT"),
    ({"serial": -1}, "below the minimum"),
])
def test_bad_keys_are_configuration_errors(options: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        card(**options)
