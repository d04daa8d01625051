"""The PMAC Ethernet port on TCP (spec pmac.md §3.2): a thin asyncio layer around `EthernetSession`.

Each connection opens its own card `Port` (own #/& addressing, I3/I6 framing, output queue) and
closes it when the connection goes. Replies go out one `transport.write` each, TCP_NODELAY set, so
a client that does one `recv` per request (dls-pmaclib) gets the whole reply. The listening, the
allow-list, the connection limit and the idle timeout are vdevd/tcp_listener.py's.

A flooding client never stalls the daemon (issue 22): one request runs per turn of the loop, the
scheduler's ticks and the other clients served between two requests, and the connection is not
read while requests wait their turn or while its replies are not read (the transport's buffer
past its high-water mark; TCP flow control does the rest). A session whose pending output passes
its bound (the card's `max_pending_kib`, default `MAX_PENDING`: SENDLINE replies never fetched)
is closed, logged once.
"""

from __future__ import annotations

import asyncio
import ipaddress
import logging
from collections.abc import Callable, Sequence

from vdevd.devices.pmac.ethernet import LOOPBACK_ADDRESS, MAX_PENDING, EthernetSession, Port
from vdevd.tcp_listener import (
    DEFAULT_IDLE_TIMEOUT_S,
    DEFAULT_MAX_CONNECTIONS,
    WRITE_HIGH_WATER,
    Connection,
    TcpListener,
    parse_endpoint,
    peer_ip,
)

__all__ = ["EthernetServer", "parse_endpoint"]

log = logging.getLogger(__name__)


class _Connection(Connection):
    """One TCP connection: a session on its own card port, one request per turn of the loop."""

    def __init__(self, server: EthernetServer) -> None:
        super().__init__(server.listener)
        self._server = server
        self._session: EthernetSession | None = None
        self._write_paused = False
        self._reading = True
        self._turn: asyncio.Handle | None = None  # the next request of a burst, scheduled
        self._eof = False

    def opened(self) -> bool:
        assert self.transport is not None
        self.transport.set_write_buffer_limits(high=WRITE_HIGH_WATER)
        try:
            port = self._server._open_port()
        except Exception:
            log.exception("PMAC Ethernet: could not open a port for %s", self.peer_name)
            return False
        local = peer_ip(self.transport.get_extra_info("sockname")[0])
        ip = local.packed if isinstance(local, ipaddress.IPv4Address) else LOOPBACK_ADDRESS
        self._session = EthernetSession(port, ip_address=ip, max_pending=self._server.max_pending)
        return True

    def received(self, data: bytes) -> None:
        self._serve(data)

    def eof_received(self) -> bool:
        """The client sent all it will: the requests it sent run before the connection closes."""
        self._eof = True
        return self._session is not None and self._session.ready

    def _serve(self, data: bytes = b"") -> None:
        """One request (of `data` and what waits), its reply sent; the next at the loop's next
        turn."""
        self._turn = None
        session, transport = self._session, self.transport
        if session is None or transport is None or transport.is_closing():
            return
        for reply in session.receive(data, limit=1):
            transport.write(reply)
        if session.closed or (self._eof and not session.ready):
            if session.overflowed:
                log.warning("%s: connection from %s closed: its pending output passed %d bytes "
                            "(replies never fetched)", self.listener.name, self.peer_name,
                            session.max_pending)
            transport.close()
            return
        if session.ready and self._turn is None:
            self._turn = self._server._call_soon(self._serve)
        self._flow()

    def _flow(self) -> None:
        """Read while the replies go out and no request waits for its turn."""
        session, transport = self._session, self.transport
        if session is None or transport is None or transport.is_closing():
            return
        reading = not self._write_paused and not session.ready
        if reading != self._reading:
            if reading:
                transport.resume_reading()
            else:
                transport.pause_reading()
            self._reading = reading

    def pause_writing(self) -> None:
        self._write_paused = True
        self._flow()

    def resume_writing(self) -> None:
        self._write_paused = False
        self._flow()

    def lost(self) -> None:
        if self._turn is not None:
            self._turn.cancel()
            self._turn = None
        session, self._session = self._session, None
        if session is None:
            return
        session.close_log()
        try:
            session.port.close()
        except Exception:
            log.exception("PMAC Ethernet: port.close() failed")


class EthernetServer:
    """A listening PMAC Ethernet port, one `EthernetSession` and card `Port` per connection."""

    def __init__(self, open_port: Callable[[], Port], allow: Sequence[str] = (), *,
                 name: str = "PMAC ethernet", max_connections: int = DEFAULT_MAX_CONNECTIONS,
                 idle_timeout_s: float = DEFAULT_IDLE_TIMEOUT_S,
                 max_pending: int = MAX_PENDING) -> None:
        self._open_port = open_port
        self.max_pending = max_pending
        self.listener = TcpListener(name, allow=allow, max_connections=max_connections,
                                    idle_timeout_s=idle_timeout_s)
        self._call_soon: Callable[[Callable[[], None]], asyncio.Handle] = (
            lambda callback: asyncio.get_running_loop().call_soon(callback))

    @classmethod
    async def start(cls, endpoint: str, open_port: Callable[[], Port], *,
                    allow: Sequence[str] = (), name: str = "PMAC ethernet",
                    max_connections: int = DEFAULT_MAX_CONNECTIONS,
                    idle_timeout_s: float = DEFAULT_IDLE_TIMEOUT_S,
                    max_pending: int = MAX_PENDING) -> EthernetServer:
        """Listen on `endpoint` on the running loop; if `allow` is given, only those peers (IPs
        or CIDR). `StartError` when it cannot be bound."""
        self = cls(open_port, allow, name=name, max_connections=max_connections,
                   idle_timeout_s=idle_timeout_s, max_pending=max_pending)
        self._call_soon = asyncio.get_running_loop().call_soon
        await self.listener.listen(endpoint, lambda: _Connection(self))
        return self

    @property
    def endpoint(self) -> str:
        """The bound address, `tcp://127.0.0.1:NNNNN`."""
        return self.listener.endpoint

    @property
    def connections(self) -> int:
        """Open connections (the metrics endpoint)."""
        return len(self.listener.connections)

    def close(self) -> None:
        """Stop listening and drop every connection (each port is closed as its connection goes)."""
        self.listener.close()

    async def wait_closed(self) -> None:
        """After `close`: until the listener and every connection are gone."""
        await self.listener.wait_closed()
