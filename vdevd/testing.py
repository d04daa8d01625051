"""Run a daemon inside the current process, on its own thread and event loop (for pytest runs).

    with DaemonThread(config) as d:
        rack = vdevclient.connect(d.endpoint)

The daemon is the real one (sockets, scheduler, cards); only the process is shared.
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import zmq

from vdevd.config import Config, default_config
from vdevd.daemon import build_rack, shared_memory
from vdevd.devices.base import Card, CardContext
from vdevd.http_health import HealthServer, open_health
from vdevd.rack import Rack
from vdevd.server import Publisher, Server

if TYPE_CHECKING:
    from vdevd.web.app import WebView


def rack_of(*cards: Callable[[CardContext], Card], mode: str = "lockstep") -> Rack:
    """A rack of a test's own cards, each made by `card(ctx)` with the rack's interrupt sink,
    for `DaemonThread(rack=...)`: `rack_of(lambda ctx: MyCard("c0", ctx))`."""
    rack = Rack([], mode, sink=Publisher())  # type: ignore[arg-type]
    for make in cards:
        rack.add_card(make(CardContext(emit=rack.emit)))
    return rack


class DaemonThread:
    """A real vdevd on a background thread; `endpoint` and `events` are set once started."""

    def __init__(self, cfg: Config | None = None, *, clock: str = "lockstep",
                 endpoint: str = "tcp://127.0.0.1:*", events: str = "tcp://127.0.0.1:*",
                 rack: Rack | None = None) -> None:
        """`cfg` as it is; without one, the default rack with `clock` and the endpoints. `rack`:
        serve these cards (already built, e.g. a test's own Card classes) instead of the
        configuration's; its clock mode is its own."""
        self.cfg = cfg or default_config()
        if cfg is None:
            self.cfg.clock = clock  # type: ignore[assignment]
            self.cfg.endpoint, self.cfg.events = endpoint, events
            self.cfg.cards = [  # listeners of the cards on free ports too
                replace(spec, options={**spec.options, "ethernet": "tcp://127.0.0.1:*"})
                if spec.options.get("ethernet") else spec for spec in self.cfg.cards]
        self._rack = rack
        self.endpoint = ""
        self.events = ""
        self.server: Server | None = None
        #: the `[metrics]` HTTP endpoint (its `url`), when the configuration has one
        self.health: HealthServer | None = None
        #: the `[web]` view (its `url`), when the configuration has one
        self.web: WebView | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._ctx = zmq.Context()
        self._thread = threading.Thread(target=self._main, name="vdevd-test", daemon=True)

    def start(self) -> DaemonThread:
        """Start serving; what keeps `vdevd serve` from starting (a card's port in use:
        `StartError`, an endpoint in use: `zmq.ZMQError`) is raised here."""
        self._thread.start()
        self._ready.wait(10)
        if self._error is not None:
            self._thread.join(10)
            self._ctx.term()
            raise self._error
        return self

    def _main(self) -> None:
        import uvloop

        try:
            uvloop.run(self._serve())
        except BaseException as exc:  # reported to start()
            self._error = exc
            self._ready.set()

    async def _serve(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        rack = self._rack if self._rack is not None else build_rack(self.cfg,
                                                                      shared_memory(self.cfg))
        try:
            self.server = Server(rack, self.cfg.endpoint, self.cfg.events, ctx=self._ctx,
                                 curve=self.cfg.curve, open_networks=self.cfg.open_networks)
        except BaseException:
            rack.stop()
            raise
        if self._rack is None:  # a snapshot loaded: its shared segment
            self.server.new_memory = lambda: shared_memory(self.cfg)
        try:
            self.health = open_health(self.cfg.metrics, rack, self._loop)
            if self.health is not None:
                self.server.on_swap.append(self.health.follow)
            await self.server.start(self._loop)
            self.endpoint, self.events = self.server.endpoint, self.server.events
            if self.cfg.web is not None:
                from vdevd.web.app import open_web

                server = self.server
                self.web = await open_web(self.cfg.web, lambda: server.rack)
            if self.health is not None:
                self.health.ready = True
            self._ready.set()
            await self._stop.wait()
        finally:
            if self.web is not None:
                await self.web.stop()
            await self.server.stop()
            if self.health is not None:
                self.health.stop()

    def listeners(self) -> dict[str, Any]:
        """Every bound listener (`Server.listeners`: the endpoint, the events, the cards' own)."""
        if self.server is None:
            raise RuntimeError("the daemon is not running")
        return self.server.listeners()

    def reset(self, timeout: float = 30.0) -> None:
        """Serve a fresh rack of the configuration in place of the one served: every card at
        power-on (its saved flash image, if any, restored), simulated time 0, no pending waits;
        on the same endpoints and card ports. Clients connected before keep their connection but
        not their shared memory mapping (the segment is new): reconnect after a reset."""
        if self._rack is not None:
            raise RuntimeError("a rack of the test's own cards cannot be rebuilt (rack_of)")
        if self._loop is None or self.server is None:
            raise RuntimeError("the daemon is not running")
        asyncio.run_coroutine_threadsafe(self._reset(), self._loop).result(timeout)

    async def _reset(self) -> None:
        assert self.server is not None and self._loop is not None
        server, old = self.server, self.server.rack
        bound = server.listeners()["cards"]  # each card's ports as bound: the new rack's too
        await old.close_services()  # its flash written: the new rack loads it
        old.stop()
        cfg = replace(self.cfg, cards=[
            replace(spec, options={**spec.options, **bound.get(spec.name, {})})
            for spec in self.cfg.cards])
        rack = build_rack(cfg, shared_memory(cfg))
        await server.swap(rack, bound)

    def restore(self, data: bytes, timeout: float = 30.0) -> None:
        """Serve the rack of the snapshot `data` (`Rack.snapshot`) in place of the one served,
        as a `snapshot load` request does; `VdevError` (`bad_snapshot`) when it does not load,
        the rack served then untouched."""
        if self._loop is None or self.server is None:
            raise RuntimeError("the daemon is not running")
        asyncio.run_coroutine_threadsafe(self._restore(data), self._loop).result(timeout)

    async def _restore(self, data: bytes) -> None:
        assert self.server is not None
        done: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self.server.restore(data, done.set_result)
        result = await done
        if isinstance(result, Exception):
            raise result

    def snapshot(self, timeout: float = 30.0) -> bytes:
        """The snapshot of the rack served (`Rack.snapshot`), taken on the daemon's loop."""
        if self._loop is None or self.server is None:
            raise RuntimeError("the daemon is not running")

        async def take() -> bytes:
            assert self.server is not None
            return self.server.rack.snapshot()

        return asyncio.run_coroutine_threadsafe(take(), self._loop).result(timeout)

    def stop(self) -> None:
        if self._loop is not None and self._stop is not None and self._thread.is_alive():
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(10)
        self._ctx.term()

    def __enter__(self) -> DaemonThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
