"""The optional HTTP endpoint: Prometheus metrics, `/healthz` and `/readyz` (issue 22).

`[metrics] listen = "127.0.0.1:9750"` turns it on (off by default). It runs on threads of its
own, never on the rack's event loop, so it answers whatever the ZeroMQ endpoint requires (CURVE
or not) and tells when the loop itself no longer answers:

- `/healthz`: 200 while the process is alive and its event loop responsive. Each probe posts a
  heartbeat to the loop and answers at once from the last one: 503 when a heartbeat posted more
  than `unresponsive_s` ago has not run yet (`Liveness`).
- `/readyz`: 200 once every listener is bound and the cards started (when the daemon announces
  READY), 503 before and while stopping.
- `/metrics` (and `/`): the Prometheus text format (vdevd/prom.py), read on the loop at scrape
  time only; 503 when the loop does not answer within 2 s.

Like the ZeroMQ endpoint it listens on loopback unless told otherwise: a non-loopback `listen`
needs `allow`, the networks that may connect (loopback always may); any other peer's
connection is closed as it is accepted. At most MAX_CONNECTIONS connections are served at once,
each closed after IDLE_TIMEOUT_S of silence, so that idle or slow clients cannot hold threads
and file descriptors (or keep a probe out) for long.
"""

from __future__ import annotations

import asyncio
import errno
import ipaddress
import logging
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterable
from contextlib import suppress
from dataclasses import dataclass
from socketserver import ThreadingMixIn
from typing import TYPE_CHECKING, Any
from wsgiref.simple_server import WSGIRequestHandler, WSGIServer

from vdevd.errors import StartError
from vdevd.security import IPNetwork, is_loopback_host, loopback_or_in

if TYPE_CHECKING:
    from vdevd.rack import Rack

log = logging.getLogger("vdevd.http")

DEFAULT_LISTEN = "127.0.0.1:9750"
DEFAULT_UNRESPONSIVE_S = 5.0
_KEYS = ("listen", "allow", "unresponsive_s")


@dataclass(frozen=True)
class MetricsConfig:
    """`[metrics]`: where the HTTP endpoint listens, who may connect from off the machine, and
    how long the loop may keep a heartbeat waiting before `/healthz` fails."""

    listen: str = DEFAULT_LISTEN
    allow: tuple[str, ...] = ()
    unresponsive_s: float = DEFAULT_UNRESPONSIVE_S

    @property
    def networks(self) -> tuple[IPNetwork, ...]:
        return tuple(ipaddress.ip_network(a, strict=False) for a in self.allow)


def split_listen(listen: str, key: str = "metrics.listen") -> tuple[str, int]:
    """("host", port) of `host:port` or `[v6]:port`; ValueError naming `key`."""
    host, sep, port = listen.rpartition(":")
    host = host.strip("[]") if host.startswith("[") else host
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"{key}: {listen!r} is not host:port (e.g. \"127.0.0.1:9750\")")
    try:
        ipaddress.ip_address(host)
    except ValueError:
        if host != "localhost":
            raise ValueError(f"{key}: {host!r} is not an IP address") from None
    return host, int(port)


def parse_listener(table: Any, where: str, keys: tuple[str, ...],
                   default_listen: str) -> tuple[str, tuple[str, ...]]:
    """The `listen` and `allow` of an HTTP endpoint's table (`[metrics]`, `[web]`), checked
    (ValueError naming the key): no key outside `keys`, `listen` host:port, `allow` a list of IP
    networks, required when `listen` is not loopback."""
    if not isinstance(table, dict):
        raise ValueError(f"{where}: must be a table")
    for key in table:
        if key not in keys:
            raise ValueError(f"{where}.{key}: unknown key (keys: {', '.join(keys)})")
    listen = table.get("listen", default_listen)
    if not isinstance(listen, str):
        raise ValueError(f"{where}.listen: expected a string, got {listen!r}")
    host, _ = split_listen(listen, f"{where}.listen")
    allow = table.get("allow", [])
    if not isinstance(allow, list) or not all(isinstance(a, str) for a in allow):
        raise ValueError(f"{where}.allow: expected a list of networks, got {allow!r}")
    for a in allow:
        try:
            ipaddress.ip_network(a, strict=False)
        except ValueError:
            raise ValueError(f"{where}.allow: {a!r} is not an IP network (\"10.0.0.0/8\")") from None
    if not is_loopback_host(host) and not allow:
        raise ValueError(f"{where}.listen: {listen!r} is not loopback; name the networks that may "
                         f"connect in {where}.allow (e.g. [\"10.0.0.0/8\"])")
    return listen, tuple(allow)


def parse_metrics(table: Any, where: str = "metrics") -> MetricsConfig:
    """`[metrics]` checked (ValueError naming the key): `listen` and `allow` as
    `parse_listener` checks them, `unresponsive_s` 0.1..600."""
    listen, allow = parse_listener(table, where, _KEYS, DEFAULT_LISTEN)
    limit = table.get("unresponsive_s", DEFAULT_UNRESPONSIVE_S)
    if isinstance(limit, bool) or not isinstance(limit, int | float) or not 0.1 <= limit <= 600:
        raise ValueError(f"{where}.unresponsive_s: {limit!r} is not a number in 0.1..600")
    return MetricsConfig(listen, tuple(allow), float(limit))


class Liveness:
    """Whether an event loop still runs its callbacks, asked from another thread.

    A probe posts a heartbeat (unless one is still waiting) and answers at once: the loop is
    unresponsive when the heartbeat waiting was posted more than `limit_s` ago. Nothing runs on
    the loop between probes."""

    def __init__(self, loop: asyncio.AbstractEventLoop, limit_s: float,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.loop = loop
        self.limit_s = limit_s
        self._clock = clock
        self._lock = threading.Lock()
        self._posted: float | None = None  # when the heartbeat not yet run was posted
        self.last_beat: float | None = None  # when the loop last ran one

    def probe(self) -> tuple[bool, float]:
        """(responsive, seconds the waiting heartbeat has waited)."""
        now = self._clock()
        with self._lock:
            posted = self._posted
            if posted is None:
                self._posted = now
        if posted is None:
            try:
                self.loop.call_soon_threadsafe(self._beat)
            except RuntimeError:  # the loop is closed
                return False, float("inf")
            return True, 0.0
        waited = now - posted
        return waited <= self.limit_s, waited

    def _beat(self) -> None:
        with self._lock:
            self._posted = None
            self.last_beat = self._clock()


#: connections served at once (probes and scrapes take one each, briefly); past it a new one
#: is closed as it is accepted, logged once until the endpoint has room again
MAX_CONNECTIONS = 32
#: wall seconds a connection may stay silent while its request is read or its reply written
#: (a client that opens a connection and sends nothing, or a header a byte at a time, is closed)
IDLE_TIMEOUT_S = 10.0


class _Quiet(WSGIRequestHandler):
    timeout = IDLE_TIMEOUT_S  # the connection's socket timeout (StreamRequestHandler)

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("%s " + format, self.client_address[0], *args)


class _Server(ThreadingMixIn, WSGIServer):
    """A thread a connection, at most MAX_CONNECTIONS at once; a peer `allows` refuses is
    closed at accept, before any thread or read."""

    daemon_threads = True

    def __init__(self, address: tuple[str, int], allows: Callable[[str], bool]) -> None:
        self._allows = allows
        self._slots = threading.BoundedSemaphore(MAX_CONNECTIONS)
        self._full = False  # refusing for want of room (logged once until there is room)
        super().__init__(address, _Quiet)

    def get_request(self) -> tuple[socket.socket, Any]:
        try:
            return super().get_request()
        except OSError as exc:
            if exc.errno in (errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM):
                time.sleep(0.1)  # the connection waits in the backlog: do not spin on it
            raise

    def verify_request(self, request: Any, client_address: Any) -> bool:
        if not self._allows(str(client_address[0])):
            return False
        if not self._slots.acquire(blocking=False):
            if not self._full:
                self._full = True
                log.warning("metrics endpoint: %d connections open, the most it serves at once; "
                            "closing new ones until one ends", MAX_CONNECTIONS)
            return False
        self._full = False
        return True

    def process_request(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request(request, client_address)
        except BaseException:
            self._slots.release()  # no thread took the slot
            raise

    def handle_error(self, request: Any, client_address: Any) -> None:
        """A connection that failed (timed out, reset by its peer): a debug line, not a
        traceback on stderr."""
        log.debug("connection from %s: %r", client_address[0], sys.exc_info()[1])

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._slots.release()


class HealthServer:
    """The HTTP endpoint of one served rack, on a thread of its own (threads per request)."""

    def __init__(self, cfg: MetricsConfig, rack: Rack, loop: asyncio.AbstractEventLoop) -> None:
        from prometheus_client import make_wsgi_app

        from vdevd.prom import RackCollector, registry_of

        self.cfg = cfg
        self.liveness = Liveness(loop, cfg.unresponsive_s)
        self.ready = False
        self._networks = cfg.networks
        self._collector = RackCollector(rack, loop)
        self._metrics = make_wsgi_app(registry_of(rack, loop, self._collector))
        self._httpd: WSGIServer | None = None
        self._thread: threading.Thread | None = None
        self._stopping = False
        self.url = ""

    def follow(self, rack: Rack) -> None:
        """Report `rack` from now on (the server swapped it in: a snapshot loaded, a reset)."""
        self._collector.rack = rack

    def start(self) -> HealthServer:
        """Bind and serve; a `StartError` naming `metrics.listen` when it cannot bind."""
        host, port = split_listen(self.cfg.listen)
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        server_class = type("_Server", (_Server,), {"address_family": family})
        try:
            httpd = server_class((host, port), self._allows)
        except OSError as exc:
            raise StartError(f"metrics.listen {self.cfg.listen}: "
                             f"{exc.strerror or exc}") from None
        httpd.set_app(self._app)
        self._httpd = httpd
        bound_host, bound_port = httpd.server_address[:2]
        shown = f"[{bound_host}]" if family == socket.AF_INET6 else str(bound_host)
        self.url = f"http://{shown}:{bound_port}"
        self._thread = threading.Thread(target=self._serve, args=(httpd,), name="vdevd-http",
                                        daemon=True)
        self._thread.start()
        log.info("metrics and health on %s (/metrics, /healthz, /readyz)", self.url)
        return self

    def _serve(self, httpd: WSGIServer) -> None:
        """Accept until `stop`: blocked in accept between requests (no polling at rest)."""
        while not self._stopping:
            httpd.handle_request()

    def stop(self) -> None:
        self.ready = False
        self._stopping = True
        if self._httpd is not None:
            with suppress(OSError):  # wakes the accept the thread is blocked in
                self._httpd.socket.shutdown(socket.SHUT_RDWR)
        if self._thread is not None:
            self._thread.join(5)
        if self._httpd is not None:
            self._httpd.server_close()
            self._httpd = None

    def _allows(self, peer: str) -> bool:
        return loopback_or_in(peer, self._networks)

    def _app(self, environ: dict[str, Any],
             start_response: Callable[..., Any]) -> Iterable[bytes]:
        path = environ.get("PATH_INFO", "/")
        if path == "/healthz":
            ok, waited = self.liveness.probe()
            if ok:
                return _text(start_response, "200 OK", "ok\n")
            return _text(start_response, "503 Service Unavailable",
                         f"event loop unresponsive for {waited:.1f} s\n")
        if path == "/readyz":
            if self.ready:
                return _text(start_response, "200 OK", "ready\n")
            return _text(start_response, "503 Service Unavailable", "not ready\n")
        if path in ("/metrics", "/"):
            try:
                return self._metrics(environ, start_response)
            except TimeoutError:
                return _text(start_response, "503 Service Unavailable",
                             "event loop did not answer\n")
        return _text(start_response, "404 Not Found", "not found (/metrics, /healthz, /readyz)\n")


def _text(start_response: Callable[..., Any], status: str, body: str) -> list[bytes]:
    data = body.encode()
    start_response(status, [("Content-Type", "text/plain; charset=utf-8"),
                            ("Content-Length", str(len(data)))])
    return [data]


def open_health(cfg: MetricsConfig | None, rack: Rack,
                loop: asyncio.AbstractEventLoop) -> HealthServer | None:
    """The started endpoint of `[metrics]`, or None when the configuration has none."""
    return None if cfg is None else HealthServer(cfg, rack, loop).start()
