"""The card's Ethernet command port on TCP (README.md "Ethernet command channel"): a thin asyncio
layer around `CommandChannel`, on the daemon's loop.

Each connection gets its own `CommandChannel` (own input and trippoint) over the card's shared
interpreter. The listening, the connection limit (`max_connections`, by default MAX_CONNECTIONS:
the Ethernet controllers' handles A-H) and the idle timeout are vdevd/tcp_listener.py's.
Bounded: a command at most `channel.MAX_COMMAND` bytes, input behind a held trippoint at most
`channel.MAX_INPUT`. A slow, dead or flooding client never stalls the loop: writes never block;
a burst of commands runs `channel.MAX_BATCH` at a time, one batch per turn of the loop; and a
connection whose replies the client does not read (the transport's buffer past its high-water
mark), or whose input waits behind a trippoint or for its turn, stops being read until that
drains (TCP flow control does the rest).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

from vdevd.devices.galil.channel import CommandChannel
from vdevd.tcp_listener import WRITE_HIGH_WATER, Connection, TcpListener, parse_endpoint

__all__ = ["MAX_CONNECTIONS", "WRITE_HIGH_WATER", "EthernetServer", "parse_endpoint"]

log = logging.getLogger(__name__)

#: connections served at once by default: the eight handles (A-H) of Galil's Ethernet
#: controllers; one more is closed as it opens (`max_connections`)
MAX_CONNECTIONS = 8


class _Connection(Connection):
    """One TCP connection: bytes in, replies out, reading paused while it is backed up."""

    def __init__(self, server: EthernetServer) -> None:
        super().__init__(server.listener)
        self._server = server
        self.channel: CommandChannel | None = None
        self._write_paused = False
        self._reading = True
        self._turn: asyncio.Handle | None = None  # the next batch of a long burst, scheduled

    def opened(self) -> bool:
        assert self.transport is not None
        self.transport.set_write_buffer_limits(high=WRITE_HIGH_WATER)
        self.channel = self._server._open_channel()
        return True

    @property
    def busy(self) -> bool:
        """Held by a trippoint: waiting on the card, not idle."""
        return self.channel is not None and self.channel.held

    def received(self, data: bytes) -> None:
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
        assert self.channel is not None and self.transport is not None
        if reply and not self.transport.is_closing():
            self.transport.write(reply)
        self._server._touched()  # commands ran: a card at rest looks again at its next tick
        self._server._held(self, self.channel.held)
        if self.channel.more and self._turn is None:  # the rest of a burst at the loop's next turn
            self._turn = self._server.call_soon(self.serve)
        self._flow()

    def _flow(self) -> None:
        """Read while the replies go out and no input waits (behind a trippoint, or for its
        turn)."""
        assert self.channel is not None and self.transport is not None
        reading = not self._write_paused and not self.channel.input_full and not self.channel.more
        if reading != self._reading and not self.transport.is_closing():
            if reading:
                self.transport.resume_reading()
            else:
                self.transport.pause_reading()
            self._reading = reading

    def pause_writing(self) -> None:
        self._write_paused = True
        if self.channel is not None:
            self._flow()

    def resume_writing(self) -> None:
        self._write_paused = False
        if self.channel is not None:
            self._flow()

    def lost(self) -> None:
        if self._turn is not None:
            self._turn.cancel()
            self._turn = None
        if self.channel is not None:
            self.channel.close()  # a command cut mid-line and a held trippoint go
            self.channel = None
        self._server._waiting.discard(self)


class EthernetServer:
    """A listening Ethernet command port: one `CommandChannel` per connection from
    `open_channel()`; `touched()` after host input (the card looks again at its next tick)."""

    def __init__(self, open_channel: Callable[[], CommandChannel], touched: Callable[[], None],
                 call_soon: Callable[[Callable[[], None]], asyncio.Handle], *,
                 name: str = "Galil ethernet", max_connections: int = MAX_CONNECTIONS,
                 idle_timeout_s: float = 0.0) -> None:
        self._open_channel = open_channel
        self._touched = touched
        self.call_soon = call_soon  # the loop's: the next turn of a connection's burst
        self.listener = TcpListener(name, max_connections=max_connections,
                                    idle_timeout_s=idle_timeout_s)
        self._waiting: set[_Connection] = set()  # held by a trippoint: served every sample

    @classmethod
    async def start(cls, endpoint: str, open_channel: Callable[[], CommandChannel],
                    touched: Callable[[], None], *, name: str = "Galil ethernet",
                    max_connections: int = MAX_CONNECTIONS,
                    idle_timeout_s: float = 0.0) -> EthernetServer:
        """Listen on `endpoint` on the running loop (`StartError` when it cannot be bound)."""
        loop = asyncio.get_running_loop()
        self = cls(open_channel, touched, loop.call_soon, name=name,
                   max_connections=max_connections, idle_timeout_s=idle_timeout_s)
        await self.listener.listen(endpoint, lambda: _Connection(self))
        return self

    @property
    def endpoint(self) -> str:
        """The bound address, `tcp://127.0.0.1:NNNNN`."""
        return self.listener.endpoint

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
        return len(self.listener.connections)

    def close(self) -> None:
        """Stop listening and drop every connection."""
        self.listener.close()

    async def wait_closed(self) -> None:
        """After `close`: until the listener and every connection are gone."""
        await self.listener.wait_closed()

    def _held(self, connection: _Connection, held: bool) -> None:
        if held:
            self._waiting.add(connection)
        else:
            self._waiting.discard(connection)
