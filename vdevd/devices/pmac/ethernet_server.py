"""The PMAC Ethernet port on TCP (spec pmac.md §3.2): a thin asyncio layer around `EthernetSession`.

Each connection opens its own card `Port` (own #/& addressing, I3/I6 framing, output queue) and
closes it when the connection goes. Replies go out one `transport.write` each, TCP_NODELAY set, so
a client that does one `recv` per request (dls-pmaclib) gets the whole reply.
"""

from __future__ import annotations

import asyncio
import ipaddress
import logging
import re
import socket
from collections.abc import Callable, Sequence
from typing import cast

from vdevd.devices.pmac.ethernet import LOOPBACK_ADDRESS, EthernetSession, Port

log = logging.getLogger(__name__)

_ENDPOINT = re.compile(r"tcp://(?:\[(?P<v6>[^\]]+)\]|(?P<host>[^:/\[\]]+)):(?P<port>\*|\d+)")

IPNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network


def parse_endpoint(endpoint: str) -> tuple[str, int]:
    """`tcp://HOST:PORT` -> (host, port); `*` or 0 asks for any free port."""
    match = _ENDPOINT.fullmatch(endpoint)
    if match is None:
        raise ValueError(f"PMAC Ethernet endpoint {endpoint!r} is not tcp://HOST:PORT")
    port = match["port"]
    return match["v6"] or match["host"], 0 if port == "*" else int(port)


def _ip(address: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address:
    ip = ipaddress.ip_address(address.split("%", 1)[0])
    if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
        return ip.ipv4_mapped
    return ip


class _Connection(asyncio.Protocol):
    """One TCP connection: the allow-list check, then bytes in and replies out."""

    def __init__(self, server: EthernetServer) -> None:
        self._server = server
        self._transport: asyncio.Transport | None = None
        self._session: EthernetSession | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self._transport = cast(asyncio.Transport, transport)
        self._server._opened(self)
        peer = _ip(transport.get_extra_info("peername")[0])
        if not self._server._allows(peer):
            log.warning("PMAC Ethernet: connection from %s refused (not in the allow-list)", peer)
            transport.close()
            return
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        local = _ip(transport.get_extra_info("sockname")[0])
        try:
            port = self._server._open_port()
        except Exception:
            log.exception("PMAC Ethernet: could not open a port for %s", peer)
            transport.close()
            return
        ip = local.packed if isinstance(local, ipaddress.IPv4Address) else LOOPBACK_ADDRESS
        self._session = EthernetSession(port, ip_address=ip)

    def data_received(self, data: bytes) -> None:
        if self._session is None or self._transport is None:
            return
        for reply in self._session.receive(data):
            self._transport.write(reply)
        if self._session.closed:
            self._transport.close()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._session is not None:
            try:
                self._session.port.close()
            except Exception:
                log.exception("PMAC Ethernet: port.close() failed")
            self._session = None
        self._server._lost(self)

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()


class EthernetServer:
    """A listening PMAC Ethernet port, one `EthernetSession` and card `Port` per connection."""

    def __init__(self, open_port: Callable[[], Port], allow: Sequence[IPNetwork]) -> None:
        self._open_port = open_port
        self._allow = tuple(allow)
        self._server: asyncio.Server | None = None
        self._connections: set[_Connection] = set()
        self._idle = asyncio.Event()
        self._idle.set()

    @classmethod
    async def start(cls, endpoint: str, open_port: Callable[[], Port], *,
                    allow: Sequence[str] = ()) -> EthernetServer:
        """Listen on `endpoint` on the running loop; if `allow` is given, only those peers (IPs or CIDR)."""
        host, port = parse_endpoint(endpoint)
        self = cls(open_port, [ipaddress.ip_network(a, strict=False) for a in allow])
        loop = asyncio.get_running_loop()
        self._server = await loop.create_server(lambda: _Connection(self), host, port)
        return self

    @property
    def endpoint(self) -> str:
        """The bound address, `tcp://127.0.0.1:NNNNN`."""
        assert self._server is not None
        host, port = self._server.sockets[0].getsockname()[:2]
        return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"

    @property
    def connections(self) -> int:
        """Open connections (the metrics endpoint)."""
        return len(self._connections)

    def close(self) -> None:
        """Stop listening and drop every connection (each port is closed as its connection goes)."""
        if self._server is not None:
            self._server.close()
        for connection in list(self._connections):
            connection.close()

    async def wait_closed(self) -> None:
        """After `close`: until the listener and every connection are gone."""
        if self._server is not None:
            await self._server.wait_closed()
        await self._idle.wait()

    def _allows(self, peer: ipaddress.IPv4Address | ipaddress.IPv6Address) -> bool:
        return not self._allow or any(peer in network for network in self._allow)

    def _opened(self, connection: _Connection) -> None:
        self._connections.add(connection)
        self._idle.clear()

    def _lost(self, connection: _Connection) -> None:
        self._connections.discard(connection)
        if not self._connections:
            self._idle.set()
