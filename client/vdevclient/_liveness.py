"""A subscriber's watch on the daemon's heartbeat (proto/PROTOCOL.md "Heartbeat"): every message
on the events socket proves the daemon alive; three heartbeat periods without one mean it is gone
(stopped, killed, or its event loop held), and `receive` raises `DaemonGone` instead of waiting
for ever."""

from __future__ import annotations

import time

import zmq

from vdevclient.errors import DaemonGone

#: the topic of the daemon's heartbeat events (vdevd/heartbeat.py)
HEARTBEAT_TOPIC = b".heartbeat"
#: heartbeat periods of silence after which the daemon is taken for gone
MISSED_BEATS = 3


class Liveness:
    """Receives from a SUB socket subscribed to HEARTBEAT_TOPIC; `period_ns` 0 (a daemon
    without the `heartbeat` capability) watches nothing."""

    def __init__(self, sub: zmq.Socket[bytes], period_ns: int, endpoint: str) -> None:
        self._sub = sub
        self._silence_s = MISSED_BEATS * period_ns / 1e9
        self._endpoint = endpoint
        self._heard = time.monotonic()
        if period_ns > 0:
            sub.setsockopt(zmq.SUBSCRIBE, HEARTBEAT_TOPIC)

    def receive(self, timeout_s: float | None) -> tuple[bytes, bytes] | None:
        """The next (topic, body) other than a heartbeat; None after `timeout_s` without one
        (None: no limit); `DaemonGone` once the daemon has been silent too long."""
        sub, silence = self._sub, self._silence_s
        end = None if timeout_s is None else time.monotonic() + timeout_s
        while True:
            now = time.monotonic()
            waits = [] if end is None else [end - now]
            if silence:
                waits.append(self._heard + silence - now)
            if sub.poll(None if not waits else max(0, int(min(waits) * 1000) + 1)):
                topic, body = sub.recv_multipart()
                self._heard = time.monotonic()
                if topic != HEARTBEAT_TOPIC:
                    return topic, body
                continue
            now = time.monotonic()
            if silence and now - self._heard >= silence:
                raise DaemonGone(f"no heartbeat from the daemon on {self._endpoint} for "
                                 f"{now - self._heard:.1f} s: it has stopped, or it hangs")
            if end is not None and now >= end:
                return None
