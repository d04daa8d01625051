"""The web view's HTTP and websocket server, on the daemon's event loop (aiohttp; issue 23 §3).

Routes: `/` the page and `/static/` its files (package data, no build step); `GET /api/layout`
the rack's layout (`state.describe`); `GET /api/state` the live state once; `POST /api/op` one
protocol request (`ops.Operations`); `POST /api/clock` `{"action": "run"|"pause"}` (`ClockRun`);
`GET /ws` a websocket that gets the layout, then the live state PUSH_HZ times a second.

The rules of the metrics endpoint (vdevd/http_health.py): a peer neither loopback nor in
`allow` is closed as it is accepted, before anything is read; at most MAX_CONNECTIONS
connections at once (websockets among them), a new one past it closed at accept (logged once
until there is room); a connection that sends no whole request within IDLE_TIMEOUT_S is
closed, and so is a websocket that answers no ping for as long or does not take a push within
it. At most MAX_CLIENTS websockets get pushes; the state is read once a push for all of them
and a slow client is sent only the latest. Nothing runs for the page while no websocket is
open; nothing at all runs on the rack's ticks.

Against other web sites in the user's browser: a request that changes something must be a
JSON `POST` (a cross-site form cannot send one without the browser asking first, which is not
answered), a request or websocket with an `Origin` must come from the page's own origin, and a
loopback page answers only to a loopback `Host` (an IP address or `localhost`: DNS rebinding).
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import ipaddress
import json
import logging
import socket
from collections.abc import Callable
from importlib import resources
from typing import Any

from aiohttp import WSMsgType, web

from vdevd.errors import ErrorCode, StartError, VdevError
from vdevd.http_health import split_listen
from vdevd.rack import Rack
from vdevd.security import is_loopback_host, loopback_or_in
from vdevd.web.config import WebConfig
from vdevd.web.ops import ClockRun, Operations
from vdevd.web.state import IrqWatch, describe, rack_state

log = logging.getLogger("vdevd.web")

#: connections served at once (page loads, requests and websockets)
MAX_CONNECTIONS = 32
#: websockets pushed the live state at once; past it a new one is refused (503)
MAX_CLIENTS = 8
#: wall seconds a connection may take to send a request, a websocket to answer a ping or take
#: a push
IDLE_TIMEOUT_S = 10.0
#: live state pushes a second
PUSH_HZ = 10.0
#: the largest request body (a request is a small JSON object)
MAX_BODY = 64 * 1024

_STATUS = {ErrorCode.BUSY: 503, ErrorCode.INTERNAL: 500, ErrorCode.TOO_LARGE: 413}
_JSON_HEADERS = {"Cache-Control": "no-store"}
#: the page loads nothing from elsewhere
_CSP = ("default-src 'self'; connect-src 'self'; img-src 'self' data:; style-src 'self'; "
        "script-src 'self'; frame-ancestors 'none'")


def _error(exc: VdevError) -> web.Response:
    return web.json_response({"error": {"code": str(exc.code), "message": exc.message}},
                             status=_STATUS.get(exc.code, 400), headers=_JSON_HEADERS)


class _Client:
    """One websocket: the latest state not yet sent to it, and the task that sends it."""

    def __init__(self, ws: web.WebSocketResponse) -> None:
        self.ws = ws
        self.latest: str | None = None
        self.ready = asyncio.Event()


class WebView:
    """The web view of the rack `rack_of()` returns, served on `cfg.listen`."""

    def __init__(self, cfg: WebConfig, rack_of: Callable[[], Rack]) -> None:
        self.cfg = cfg
        self.rack_of = rack_of
        self.ops = Operations(rack_of)
        self.clock = ClockRun(self.ops)
        self.watch = IrqWatch()
        self.clients: set[_Client] = set()
        self.url = ""
        self._networks = cfg.networks
        host, _ = split_listen(cfg.listen, "web.listen")
        self._loopback_only = is_loopback_host(host)
        self._runner: web.AppRunner | None = None
        self._sock: socket.socket | None = None
        self._accepting: asyncio.Task[None] | None = None
        self._pushing: asyncio.Task[None] | None = None
        self._full = False
        self._failing = False
        self.pushes = 0  # states read for the websockets (tests: none while none is open)

    # -- lifecycle -------------------------------------------------------------------------------
    async def start(self) -> WebView:
        """Bind and serve; a `StartError` naming `web.listen` when it cannot bind."""
        app = web.Application(client_max_size=MAX_BODY, middlewares=[self._guard])
        static = resources.files("vdevd.web") / "static"
        app.router.add_get("/", self._index)
        app.router.add_static("/static/", str(static), show_index=False, follow_symlinks=False)
        app.router.add_get("/api/layout", self._layout)
        app.router.add_get("/api/state", self._state)
        app.router.add_post("/api/op", self._op)
        app.router.add_post("/api/clock", self._clock)
        app.router.add_get("/ws", self._ws)
        self._sock = self._bind()
        runner = web.AppRunner(app, access_log=None, keepalive_timeout=IDLE_TIMEOUT_S,
                               handle_signals=False)
        await runner.setup()
        self._runner = runner
        self._accepting = asyncio.get_running_loop().create_task(self._accept(self._sock))
        log.info("web view on %s", self.url)
        return self

    def _bind(self) -> socket.socket:
        host, port = split_listen(self.cfg.listen, "web.listen")
        host = "127.0.0.1" if host == "localhost" else host
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((host, port))
            sock.listen(64)
            sock.setblocking(False)
        except OSError as exc:
            sock.close()
            raise StartError(f"web.listen {self.cfg.listen}: {exc.strerror or exc}") from None
        bound_host, bound_port = sock.getsockname()[:2]
        shown = f"[{bound_host}]" if family == socket.AF_INET6 else str(bound_host)
        self.url = f"http://{shown}:{bound_port}"
        return sock

    async def _accept(self, sock: socket.socket) -> None:
        """Accept connections, closing at once those of peers not allowed and those past
        MAX_CONNECTIONS; hand the others to aiohttp."""
        loop = asyncio.get_running_loop()
        assert self._runner is not None and self._runner.server is not None
        server = self._runner.server
        while True:
            try:
                conn, peer = await loop.sock_accept(sock)
            except OSError as exc:
                if exc.errno in (errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM):
                    await asyncio.sleep(0.1)  # the connection waits in the backlog
                    continue
                raise
            if not loopback_or_in(peer[0], self._networks):
                conn.close()
                continue
            if len(server.connections) >= MAX_CONNECTIONS:
                if not self._full:
                    self._full = True
                    log.warning("web view: %d connections open, the most it serves at once; "
                                "closing new ones until one ends", MAX_CONNECTIONS)
                conn.close()
                continue
            self._full = False
            try:
                await loop.connect_accepted_socket(server, conn)
            except OSError as exc:
                log.debug("connection from %s: %r", peer[0], exc)
                conn.close()

    async def stop(self) -> None:
        await self.clock.pause()
        for task in (self._accepting, self._pushing):
            if task is not None:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        for client in list(self.clients):
            await client.ws.close()
        if self._runner is not None:
            await self._runner.cleanup()
            self._runner = None

    # -- checks ----------------------------------------------------------------------------------
    @web.middleware
    async def _guard(self, request: web.Request,
                     handler: Callable[[web.Request], Any]) -> web.StreamResponse:
        header = request.headers.get("Host")
        if not header:  # (aiohttp would look the machine's name up instead: a blocking call)
            return web.Response(status=400, text="web view: a request needs a Host header\n")
        host = _host_name(header)
        if self._loopback_only and host != "localhost" and not _is_ip(host):
            return web.Response(status=421, text=f"web view: unknown host {host!r}: reach it by "
                                "its address or as localhost\n")
        origin = request.headers.get("Origin")
        if origin is not None and origin != f"http://{header}":
            return web.Response(status=403, text=f"web view: origin {origin} is not the page's\n")
        response: web.StreamResponse = await handler(request)
        if not isinstance(response, web.WebSocketResponse):
            response.headers.setdefault("Content-Security-Policy", _CSP)
            response.headers.setdefault("X-Content-Type-Options", "nosniff")
        return response

    # -- the page and its API --------------------------------------------------------------------
    async def _index(self, request: web.Request) -> web.StreamResponse:
        page = (resources.files("vdevd.web") / "static" / "index.html").read_bytes()
        return web.Response(body=page, content_type="text/html", charset="utf-8")

    async def _layout(self, request: web.Request) -> web.Response:
        return web.json_response(describe(self.rack_of()), headers=_JSON_HEADERS)

    async def _state(self, request: web.Request) -> web.Response:
        """The live state once; its interrupts are each line's latest (a fresh `IrqWatch`)."""
        return web.json_response(self._live(IrqWatch()), headers=_JSON_HEADERS)

    def _live(self, watch: IrqWatch) -> dict[str, Any]:
        return {**rack_state(self.rack_of(), watch), "running": self.clock.running,
                "run_error": self.clock.error}

    async def _body(self, request: web.Request) -> Any:
        """The request's JSON object (`malformed`, `too_large` as the protocol says them)."""
        if request.content_type != "application/json":
            raise VdevError(ErrorCode.MALFORMED, "send the request as application/json")
        try:
            async with asyncio.timeout(IDLE_TIMEOUT_S):
                raw = await request.read()
        except web.HTTPRequestEntityTooLarge:
            raise VdevError(ErrorCode.TOO_LARGE, f"a request body is at most {MAX_BODY} "
                            "bytes") from None
        except TimeoutError:
            raise VdevError(ErrorCode.MALFORMED, f"the body did not arrive within "
                            f"{IDLE_TIMEOUT_S:g} s") from None
        try:
            return json.loads(raw)
        except (ValueError, RecursionError) as exc:
            raise VdevError(ErrorCode.MALFORMED, f"not JSON: {exc}") from None

    async def _op(self, request: web.Request) -> web.Response:
        try:
            result = await self.ops.call(await self._body(request))
            text = json.dumps({"ok": result}, allow_nan=False)
        except VdevError as exc:
            return _error(exc)
        except (TypeError, ValueError) as exc:  # as the ZeroMQ server answers it
            return _error(VdevError(ErrorCode.INTERNAL, f"unencodable: {exc}"))
        return web.json_response(text=text, headers=_JSON_HEADERS)

    async def _clock(self, request: web.Request) -> web.Response:
        try:
            body = await self._body(request)
            action = body.get("action") if isinstance(body, dict) else None
            if action == "run":
                self.clock.start()
            elif action == "pause":
                await self.clock.pause()
            else:
                raise VdevError(ErrorCode.BAD_PARAM, f"clock: action {action!r} is not run or "
                                "pause (step: the sim op)")
        except VdevError as exc:
            return _error(exc)
        return web.json_response({"ok": {"running": self.clock.running}}, headers=_JSON_HEADERS)

    # -- the live state --------------------------------------------------------------------------
    async def _ws(self, request: web.Request) -> web.StreamResponse:
        if len(self.clients) >= MAX_CLIENTS:
            return _error(VdevError(ErrorCode.BUSY, f"the web view pushes to {MAX_CLIENTS} pages "
                                    "at once; close one"))
        ws = web.WebSocketResponse(heartbeat=IDLE_TIMEOUT_S, max_msg_size=4096)
        await ws.prepare(request)
        client = _Client(ws)
        self.clients.add(client)
        sender = asyncio.get_running_loop().create_task(self._send(client))
        try:
            await ws.send_json({"kind": "layout", **describe(self.rack_of())})
            if self._pushing is None or self._pushing.done():
                self.watch.poll(self.rack_of())  # from now on: the interrupts shown are new
                self._pushing = asyncio.get_running_loop().create_task(self._push())
            async for msg in ws:  # the page sends nothing; a close or an error ends it
                if msg.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                    break
        except ConnectionError:  # gone before the layout was sent
            pass
        finally:
            self.clients.discard(client)
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await sender
        return ws

    async def _push(self) -> None:
        """While a websocket is open: the state read once, PUSH_HZ times a second, for all."""
        while self.clients:
            try:
                payload = json.dumps({"kind": "state", **self._live(self.watch)})
            except Exception:  # a card's signal map failed: the pages keep their last state
                if not self._failing:  # logged once until a push succeeds
                    log.exception("web view: reading the rack's state")
                self._failing = True
                await asyncio.sleep(1 / PUSH_HZ)
                continue
            self._failing = False
            self.pushes += 1
            for client in self.clients:
                client.latest = payload
                client.ready.set()
            await asyncio.sleep(1 / PUSH_HZ)

    @staticmethod
    async def _send(client: _Client) -> None:
        """The latest state to one websocket; one that takes none within IDLE_TIMEOUT_S is
        closed."""
        while True:
            await client.ready.wait()
            client.ready.clear()
            payload, client.latest = client.latest, None
            if payload is None:
                continue
            try:
                async with asyncio.timeout(IDLE_TIMEOUT_S):
                    await client.ws.send_str(payload)
            except (TimeoutError, ConnectionError, RuntimeError):
                await client.ws.close()
                return


def _host_name(header: str) -> str:
    """The name or address of a Host header, without its port (`[::1]:8080` -> `::1`)."""
    if header.startswith("["):
        return header[1:].partition("]")[0]
    return header.rpartition(":")[0] if header.count(":") == 1 else header


def _is_ip(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


async def open_web(cfg: WebConfig | None, rack_of: Callable[[], Rack]) -> WebView | None:
    """The started web view of `[web]`, or None when the configuration has none."""
    return None if cfg is None else await WebView(cfg, rack_of).start()
