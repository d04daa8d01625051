"""A card's TCP port, the part every card's port shares (the Galil's DMC command port, the PMAC's
Ethernet protocol port): the endpoint, the allow-list, the connection limit and idle timeout,
TCP_NODELAY, closing, and logging a flood cannot turn into a flood of lines (issue 22).

A port is a `TcpListener` and one `Connection` (a subclass the card's port defines) per client:
`opened`, `received`, `lost` are the card's; admission, accounting and the idle timer are here.

* A port that cannot be bound is a `StartError` naming its key (`ethernet: 127.0.0.1:1025 already
  in use`); the rack adds the card (`card[2] (pmac0) ...`) and the daemon exits 2 before it says
  ready.
* `max_connections` are served at once; one more is closed as it opens. Refusals are logged once
  per episode: the first refusal says so, the next connection accepted says how many were refused.
* A connection that sends nothing for `idle_timeout_s` (and is not `busy`) is closed, logged.
* A peer outside the allow-list is closed as it opens; those refusals are logged by `CountedLog`.
"""

from __future__ import annotations

import asyncio
import errno
import ipaddress
import logging
import os
import re
import socket
from collections.abc import Callable, Sequence
from typing import Any, cast

from vdevd.devices.options import Option
from vdevd.errors import StartError
from vdevd.security import peer_ip

log = logging.getLogger("vdevd.tcp")


#: connections a port serves at once, unless its card says otherwise
DEFAULT_MAX_CONNECTIONS = 64
#: seconds without input after which a connection is closed (0: never)
DEFAULT_IDLE_TIMEOUT_S = 600.0
#: replies buffered for a client that does not read before its connection stops being read
WRITE_HIGH_WATER = 64 * 1024

_ENDPOINT = re.compile(r"tcp://(?:\[(?P<v6>[^\]]+)\]|(?P<host>[^:/\[\]]+)):(?P<port>\*|\d+)")


def parse_endpoint(endpoint: str, key: str = "ethernet") -> tuple[str, int]:
    """`tcp://HOST:PORT` -> (host, port); `*` or 0 asks for any free port. ValueError naming
    `key` otherwise."""
    match = _ENDPOINT.fullmatch(endpoint)
    if match is None:
        raise ValueError(f"{key}: {endpoint!r} is not tcp://HOST:PORT")
    port = 0 if match["port"] == "*" else int(match["port"])
    if port > 65535:  # the socket would take it modulo 65536
        raise ValueError(f"{key}: {endpoint!r}: the port is over 65535")
    return match["v6"] or match["host"], port


def check_endpoint(endpoint: str, where: str) -> None:
    """A card's `ethernet` key at configuration time: ValueError naming `{where}.ethernet`
    unless it is tcp://HOST:PORT with PORT 0..65535."""
    try:
        parse_endpoint(endpoint)
    except ValueError:
        raise ValueError(f"{where}.ethernet: {endpoint!r} is not tcp://HOST:PORT "
                         "(PORT 0..65535; empty: off)") from None


def listener_options(max_connections: int = DEFAULT_MAX_CONNECTIONS) -> dict[str, Option]:
    """The keys of a card's TCP port, for the card's option declaration (`vdevd types`)."""
    return {
        "max_connections": Option(int, max_connections, min=1, max=1024,
                                  help="connections the TCP port serves at once; one more is "
                                       "closed as it opens"),
        "idle_timeout_s": Option(float, DEFAULT_IDLE_TIMEOUT_S, min=0, max=86_400,
                                 help="seconds without input after which a connection of the "
                                      "TCP port is closed; 0: never"),
    }


class CountedLog:
    """Whether the nth occurrence of something gets a log line: the first `first`, then only the
    10th, 100th, 1000th ... (5,000 bad packets: 8 lines)."""

    def __init__(self, first: int = 5) -> None:
        self.first = first
        self.count = 0
        self.logged = 0

    def __call__(self) -> bool:
        """Count one; whether to log it."""
        self.count += 1
        n = self.count
        if n > self.first:
            while n % 10 == 0:
                n //= 10
            if n != 1:
                return False
        self.logged += 1
        return True


class Connection(asyncio.Protocol):
    """One client of a `TcpListener`: admitted (or closed) as it opens, its idle timer kept,
    accounted for until it goes. A card's port overrides `opened`, `received`, `lost`, `busy`."""

    def __init__(self, listener: TcpListener) -> None:
        self.listener = listener
        self.transport: asyncio.Transport | None = None
        self.peer: Any = None
        self.admitted = False
        self._last_input = 0.0  # the loop's time of the last input (or of the admission)
        self._idle_timer: asyncio.TimerHandle | None = None

    # -- the card's part ---------------------------------------------------------------------------
    def opened(self) -> bool:
        """Admitted: set up what the connection serves; False closes it."""
        return True

    def received(self, data: bytes) -> None:
        """Bytes from the client."""

    def lost(self) -> None:
        """The connection went: release what `opened` set up."""

    @property
    def peer_name(self) -> str:
        """`HOST:PORT` of the client, for log lines."""
        return _peer(self.peer)

    @property
    def busy(self) -> bool:
        """Waiting on the card, not on the client (a held trippoint): not idle."""
        return False

    # -- asyncio -----------------------------------------------------------------------------------
    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = cast(asyncio.Transport, transport)
        self.peer = transport.get_extra_info("peername")
        if not self.listener._admit(self):
            transport.close()
            return
        self.admitted = True
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        loop = self.listener.loop
        if loop is not None and self.listener.idle_timeout_s > 0:
            self._last_input = loop.time()
            self._idle_timer = loop.call_later(self.listener.idle_timeout_s, self._idle)
        if not self.opened():
            transport.close()

    def data_received(self, data: bytes) -> None:
        if not self.admitted:
            return
        loop = self.listener.loop
        if self._idle_timer is not None and loop is not None:
            self._last_input = loop.time()
        self.received(data)

    def connection_lost(self, exc: Exception | None) -> None:
        if self._idle_timer is not None:
            self._idle_timer.cancel()
            self._idle_timer = None
        if self.admitted:
            self.admitted = False
            try:
                self.lost()
            finally:
                self.listener._lost(self)

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()

    # -- the idle timer: one a connection, moved on lazily (at most once per timeout) -----------
    def _idle(self) -> None:
        self._idle_timer = None
        loop, timeout = self.listener.loop, self.listener.idle_timeout_s
        if loop is None or self.transport is None or self.transport.is_closing():
            return
        now = loop.time()
        if self.busy:
            self._last_input = now
        left = self._last_input + timeout - now
        if left > 0:
            self._idle_timer = loop.call_later(left, self._idle)
            return
        log.info("%s: connection from %s closed, idle for %gs (idle_timeout_s)",
                 self.listener.name, self.peer_name, timeout)
        self.transport.close()


class TcpListener:
    """A listening card port: its connections accounted for, at most `max_connections` at once,
    each closed after `idle_timeout_s` without input; only peers in `allow` when it is given.
    `name` heads its log lines (`pmac0 ethernet`)."""

    def __init__(self, name: str, *, allow: Sequence[str] = (),
                 max_connections: int = DEFAULT_MAX_CONNECTIONS,
                 idle_timeout_s: float = DEFAULT_IDLE_TIMEOUT_S) -> None:
        self.name = name
        self.allow = tuple(ipaddress.ip_network(a, strict=False) for a in allow)
        self.max_connections = max_connections
        self.idle_timeout_s = idle_timeout_s
        self.loop: asyncio.AbstractEventLoop | None = None
        self.connections: set[Connection] = set()
        self._server: asyncio.Server | None = None
        self._idle = asyncio.Event()
        self._idle.set()
        self._refused = 0  # connections refused in the current episode (the port full)
        self._outsiders = CountedLog()

    async def listen(self, endpoint: str, make: Callable[[], Connection],
                     key: str = "ethernet") -> None:
        """Listen on `endpoint` on the running loop, on every address its host names (`localhost`:
        127.0.0.1 and ::1); an address that cannot be bound is a `StartError` naming `key` and
        the address (`ethernet: 127.0.0.1:1025 already in use`), not a port served on the other
        addresses only while another process has this one."""
        host, port = parse_endpoint(endpoint, key)
        self.loop = loop = asyncio.get_running_loop()
        try:
            self._server = await loop.create_server(make, host, port)
        except OSError as exc:
            raise StartError(f"{key}: {_where(host, port)} {_reason(exc.errno, exc)}") from None
        bound = {(s.family, s.getsockname()[0]) for s in self._server.sockets}
        try:
            wanted = await loop.getaddrinfo(host, port, type=socket.SOCK_STREAM,
                                            flags=socket.AI_PASSIVE)
        except OSError:
            return
        for family, _, _, _, address in wanted:
            if (family, address[0]) not in bound:
                code = _bind_error(family, address)
                if code is not None and code != errno.EADDRNOTAVAIL:  # not: a family disabled
                    self._server.close()
                    raise StartError(f"{key}: {_where(str(address[0]), port)} {_reason(code)}")

    @property
    def endpoint(self) -> str:
        """The bound address, `tcp://127.0.0.1:NNNNN`."""
        assert self._server is not None
        host, port = self._server.sockets[0].getsockname()[:2]
        return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"

    def close(self) -> None:
        """Stop listening and drop every connection."""
        if self._server is not None:
            self._server.close()
        for connection in list(self.connections):
            connection.close()

    async def wait_closed(self) -> None:
        """After `close`: until the listener and every connection are gone."""
        if self._server is not None:
            await self._server.wait_closed()
        await self._idle.wait()

    def _admit(self, connection: Connection) -> bool:
        peer = connection.peer
        if self.allow:
            ip = peer_ip(peer[0]) if peer else None
            if ip is None or not any(ip in network for network in self.allow):
                if self._outsiders():
                    log.warning("%s: connection from %s refused (not in the allow-list; %d so "
                                "far)", self.name, ip, self._outsiders.count)
                return False
        if len(self.connections) >= self.max_connections:
            if not self._refused:
                log.warning("%s: %d connections open (max_connections): refusing more, from "
                            "%s on", self.name, len(self.connections), connection.peer_name)
            self._refused += 1
            return False
        if self._refused:
            log.info("%s: accepting connections again; %d refused meanwhile", self.name,
                     self._refused)
            self._refused = 0
        self.connections.add(connection)
        self._idle.clear()
        return True

    def _lost(self, connection: Connection) -> None:
        self.connections.discard(connection)
        if not self.connections:
            self._idle.set()


def _where(host: str, port: int) -> str:
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def _reason(code: int | None, exc: OSError | None = None) -> str:
    """`already in use`, or the system's text for `code`, lower case."""
    if code == errno.EADDRINUSE:
        return "already in use"
    text = os.strerror(code) if code else str(exc)
    return text[:1].lower() + text[1:]


def _bind_error(family: int, address: Any) -> int | None:
    """Why a listening socket of `family` cannot bind `address` (an errno), None if it can."""
    try:
        with socket.socket(family, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind(address)
    except OSError as exc:
        return exc.errno
    return None


def _peer(peer: Any) -> str:
    return f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) and len(peer) >= 2 else str(peer)
