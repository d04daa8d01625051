"""The card's Ethernet command port on TCP (README.md "Ethernet command channel"): a thin asyncio
layer around `CommandChannel`, on the daemon's loop.

Each connection gets its own `CommandChannel` (own input and trippoint) over the card's shared
interpreter. Bounded: at most MAX_CONNECTIONS connections (the Ethernet controllers' handles
A-H), a command at most `channel.MAX_COMMAND` bytes, input behind a held trippoint at most
`channel.MAX_INPUT`. A slow, dead or flooding client never stalls the loop: writes never block;
a burst of commands runs `channel.MAX_BATCH` at a time, one batch per turn of the loop; and a
connection whose replies the client does not read (the transport's buffer past its high-water
mark), or whose input waits behind a trippoint or for its turn, stops being read until that
drains (TCP flow control does the rest).
"""

from __future__ import annotations

import asyncio
import logging
import re
import socket
from collections.abc import Callable
from typing import cast

from vdevd.devices.galil.channel import CommandChannel

log = logging.getLogger(__name__)

#: connections served at once: the eight handles (A-H) of Galil's Ethernet controllers; one more
#: is closed as it opens
MAX_CONNECTIONS = 8
#: replies buffered for a client that does not read before its connection stops being read
WRITE_HIGH_WATER = 64 * 1024

_ENDPOINT = re.compile(r"tcp://(?:\[(?P<v6>[^\]]+)\]|(?P<host>[^:/\[\]]+)):(?P<port>\*|\d+)")


def parse_endpoint(endpoint: str) -> tuple[str, int]:
    """`tcp://HOST:PORT` -> (host, port); `*` or 0 asks for any free port."""
    match = _ENDPOINT.fullmatch(endpoint)
    if match is None:
        raise ValueError(f"ethernet: {endpoint!r} is not tcp://HOST:PORT")
    port = match["port"]
    return match["v6"] or match["host"], 0 if port == "*" else int(port)


class _Connection(asyncio.Protocol):
    """One TCP connection: bytes in, replies out, reading paused while it is backed up."""

    def __init__(self, server: EthernetServer) -> None:
        self._server = server
        self._transport: asyncio.Transport | None = None
        self.channel: CommandChannel | None = None
        self._write_paused = False
        self._reading = True
        self._turn: asyncio.Handle | None = None  # the next batch of a long burst, scheduled

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self._transport = cast(asyncio.Transport, transport)
        if not self._server._opened(self):
            log.warning("Galil Ethernet: connection from %s refused (%d connections open)",
                        transport.get_extra_info("peername"), MAX_CONNECTIONS)
            transport.close()
            return
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._transport.set_write_buffer_limits(high=WRITE_HIGH_WATER)
        self.channel = self._server._open_channel()

    def data_received(self, data: bytes) -> None:
        if self.channel is None:
            return
        self._send(self.channel.receive(data))

    def serve(self) -> None:
        """A sample, or the next turn of a burst: the held trippoint satisfied, the commands
        behind it run (MAX_BATCH at a time)."""
        self._turn = None
        if self.channel is not None:
            self._send(self.channel.serve())

    def _send(self, reply: bytes) -> None:
        assert self.channel is not None and self._transport is not None
        if reply and not self._transport.is_closing():
            self._transport.write(reply)
        self._server._touched()  # commands ran: a card at rest looks again at its next tick
        self._server._held(self, self.channel.held)
        if self.channel.more and self._turn is None:  # the rest of a burst at the loop's next turn
            self._turn = self._server.call_soon(self.serve)
        self._flow()

    def _flow(self) -> None:
        """Read while the replies go out and no input waits (behind a trippoint, or for its
        turn)."""
        assert self.channel is not None and self._transport is not None
        reading = not self._write_paused and not self.channel.input_full and not self.channel.more
        if reading != self._reading and not self._transport.is_closing():
            if reading:
                self._transport.resume_reading()
            else:
                self._transport.pause_reading()
            self._reading = reading

    def pause_writing(self) -> None:
        self._write_paused = True
        if self.channel is not None:
            self._flow()

    def resume_writing(self) -> None:
        self._write_paused = False
        if self.channel is not None:
            self._flow()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._turn is not None:
            self._turn.cancel()
            self._turn = None
        if self.channel is not None:
            self.channel.close()  # a command cut mid-line and a held trippoint go
            self.channel = None
        self._server._lost(self)

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()


class EthernetServer:
    """A listening Ethernet command port: one `CommandChannel` per connection from
    `open_channel()`; `touched()` after host input (the card looks again at its next tick)."""

    def __init__(self, open_channel: Callable[[], CommandChannel], touched: Callable[[], None],
                 call_soon: Callable[[Callable[[], None]], asyncio.Handle]) -> None:
        self._open_channel = open_channel
        self._touched = touched
        self.call_soon = call_soon  # the loop's: the next turn of a connection's burst
        self._server: asyncio.Server | None = None
        self._connections: set[_Connection] = set()
        self._waiting: set[_Connection] = set()  # held by a trippoint: served every sample
        self._idle = asyncio.Event()
        self._idle.set()

    @classmethod
    async def start(cls, endpoint: str, open_channel: Callable[[], CommandChannel],
                    touched: Callable[[], None]) -> EthernetServer:
        """Listen on `endpoint` on the running loop."""
        host, port = parse_endpoint(endpoint)
        loop = asyncio.get_running_loop()
        self = cls(open_channel, touched, loop.call_soon)
        self._server = await loop.create_server(lambda: _Connection(self), host, port)
        return self

    @property
    def endpoint(self) -> str:
        """The bound address, `tcp://127.0.0.1:NNNNN`."""
        assert self._server is not None
        host, port = self._server.sockets[0].getsockname()[:2]
        return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"

    @property
    def held(self) -> bool:
        """Some connection waits on a trippoint (the card is not at rest)."""
        return bool(self._waiting)

    def serve(self) -> None:
        """At a sample: the connections held by a trippoint look at it again."""
        for connection in list(self._waiting):
            connection.serve()

    def reset(self) -> None:
        """RS: every connection's held trippoint goes without a reply, as the FIFO's does (the
        connections stay); the commands behind it run at the next sample (not from inside the
        RS, which may come from one of the connections)."""
        for connection in self._waiting:
            if connection.channel is not None:
                connection.channel.reset()

    @property
    def connections(self) -> int:
        """Open connections (the metrics endpoint)."""
        return len(self._connections)

    def close(self) -> None:
        """Stop listening and drop every connection."""
        if self._server is not None:
            self._server.close()
        for connection in list(self._connections):
            connection.close()

    async def wait_closed(self) -> None:
        """After `close`: until the listener and every connection are gone."""
        if self._server is not None:
            await self._server.wait_closed()
        await self._idle.wait()

    def _opened(self, connection: _Connection) -> bool:
        if len(self._connections) >= MAX_CONNECTIONS:
            return False
        self._connections.add(connection)
        self._idle.clear()
        return True

    def _held(self, connection: _Connection, held: bool) -> None:
        if held:
            self._waiting.add(connection)
        else:
            self._waiting.discard(connection)

    def _lost(self, connection: _Connection) -> None:
        self._waiting.discard(connection)
        self._connections.discard(connection)
        if not self._connections:
            self._idle.set()
