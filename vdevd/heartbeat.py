"""The events socket's heartbeat (PROTOCOL.md "Heartbeat"): a `heartbeat` event on its own topic
every period of wall time, from the event loop, so a subscriber that hears nothing for three
periods knows the daemon is gone or its loop is held, whatever the clock mode."""

from __future__ import annotations

import asyncio
from typing import Protocol

#: the default period, wall ns (`[server] heartbeat_s`)
PERIOD_NS = 2_000_000_000
#: the topic of heartbeat events: not a card name (those are letters, digits, - and _), and no
#: card name is a prefix of it, so a subscription to a card does not receive it
TOPIC = ".heartbeat"


class Beating(Protocol):
    """What publishes the heartbeat (`server.Publisher`)."""

    heartbeat_ns: int

    def heartbeat(self, seq: int) -> None:
        """Publish heartbeat number `seq`."""


class Heartbeat:
    """Calls `sink.heartbeat` every `sink.heartbeat_ns` of wall time on the loop, from `start`
    until `stop` (none when the period is 0)."""

    def __init__(self, sink: Beating) -> None:
        self._sink = sink
        self._loop: asyncio.AbstractEventLoop | None = None
        self._timer: asyncio.TimerHandle | None = None
        self.seq = 0

    def start(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        if self._sink.heartbeat_ns > 0:
            self._beat()

    def _beat(self) -> None:
        assert self._loop is not None
        self.seq += 1
        self._sink.heartbeat(self.seq)
        self._timer = self._loop.call_later(self._sink.heartbeat_ns / 1e9, self._beat)

    def stop(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
