"""vdevd/tcp_listener.py without sockets: the bad-input log budget, endpoints, and a port's
admission (allow-list, max_connections, one warning per episode) over fake transports."""

from __future__ import annotations

import logging
from typing import Any

import pytest

from vdevd.tcp_listener import Connection, CountedLog, TcpListener, parse_endpoint


def test_counted_log_logs_the_first_five_then_each_tenfold() -> None:
    budget = CountedLog()
    logged = [n for n in range(1, 5001) if budget()]
    assert logged == [1, 2, 3, 4, 5, 10, 100, 1000]
    assert (budget.count, budget.logged) == (5000, 8)


@pytest.mark.parametrize(("endpoint", "address"), [
    ("tcp://127.0.0.1:1025", ("127.0.0.1", 1025)), ("tcp://[::1]:*", ("::1", 0)),
    ("tcp://localhost:0", ("localhost", 0))])
def test_endpoints(endpoint: str, address: tuple[str, int]) -> None:
    assert parse_endpoint(endpoint) == address


def test_a_bad_endpoint_names_its_key() -> None:
    with pytest.raises(ValueError, match="^ethernet: 'udp://x:1' is not tcp://HOST:PORT$"):
        parse_endpoint("udp://x:1")


class FakeTransport:
    def __init__(self, peer: str) -> None:
        self.peer = peer
        self.closed = False

    def get_extra_info(self, name: str) -> Any:
        return (self.peer, 40000) if name == "peername" else None

    def is_closing(self) -> bool:
        return self.closed

    def close(self) -> None:
        self.closed = True


def open_one(listener: TcpListener, peer: str = "127.0.0.1") -> tuple[Connection, FakeTransport]:
    conn, transport = Connection(listener), FakeTransport(peer)
    conn.connection_made(transport)  # type: ignore[arg-type]
    return conn, transport


def test_past_max_connections_one_warning_per_episode(caplog: pytest.LogCaptureFixture) -> None:
    listener = TcpListener("pmac0 ethernet", max_connections=2)
    with caplog.at_level(logging.INFO, logger="vdevd.tcp"):
        held = [open_one(listener) for _ in range(2)]
        refused = [open_one(listener) for _ in range(30)]
        assert not any(t.closed for _, t in held) and all(t.closed for _, t in refused)
        for conn, _ in refused:
            conn.connection_lost(None)  # refused connections are not counted
        assert len(listener.connections) == 2
        held[0][0].connection_lost(None)
        assert not open_one(listener)[1].closed
        assert open_one(listener)[1].closed  # a second episode
    lines = [r.getMessage() for r in caplog.records]
    assert lines == [
        "pmac0 ethernet: 2 connections open (max_connections): refusing more, from "
        "127.0.0.1:40000 on",
        "pmac0 ethernet: accepting connections again; 30 refused meanwhile",
        "pmac0 ethernet: 2 connections open (max_connections): refusing more, from "
        "127.0.0.1:40000 on"]


def test_peers_outside_the_allow_list_are_closed_and_logged_by_the_budget(
        caplog: pytest.LogCaptureFixture) -> None:
    listener = TcpListener("pmac0 ethernet", allow=["10.0.0.0/8"])
    with caplog.at_level(logging.INFO, logger="vdevd.tcp"):
        assert all(open_one(listener, "192.168.1.1")[1].closed for _ in range(1000))
        assert not open_one(listener, "10.1.2.3")[1].closed
        assert not open_one(listener, "::ffff:10.1.2.4")[1].closed  # IPv4-mapped
    assert len(caplog.records) == 8
    assert listener.connections and len(listener.connections) == 2


def test_a_host_whose_every_address_is_not_bound_is_a_start_error() -> None:
    """A name that resolves to 127.0.0.1 and ::1 (`localhost` on most hosts), ::1's port taken
    by another process: serving 127.0.0.1 alone would send the clients that reach ::1 to the
    other process's card. The listener refuses to start instead (issue 22 §5)."""
    import asyncio
    import socket

    from vdevd.errors import StartError

    async def main() -> str:
        loop = asyncio.get_running_loop()
        with socket.socket(socket.AF_INET6) as taken:
            taken.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            taken.bind(("::1", 0))
            taken.listen()
            port = taken.getsockname()[1]
            both = [(socket.AF_INET, socket.SOCK_STREAM, 6, "", ("127.0.0.1", port)),
                    (socket.AF_INET6, socket.SOCK_STREAM, 6, "", ("::1", port, 0, 0))]

            async def getaddrinfo(*args: Any, **kwargs: Any) -> list[Any]:
                return both

            loop.getaddrinfo = getaddrinfo  # type: ignore[method-assign]
            listener = TcpListener("pmac0 ethernet")
            with pytest.raises(StartError) as err:
                await listener.listen(f"tcp://127.0.0.1:{port}", lambda: Connection(listener))
            assert listener._server is not None and not listener._server.is_serving()
            return f"{err.value}|{port}"

    message, port = asyncio.run(main()).split("|")
    assert message == f"ethernet: [::1]:{port} already in use"
