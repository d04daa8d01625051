"""Assemble a daemon from a configuration and run it on uvloop until SIGINT/SIGTERM."""

from __future__ import annotations

import asyncio
import json
import logging
import os
import signal
import socket
import tempfile
from contextlib import suppress
from pathlib import Path
from typing import Any

import zmq

from vdevd.config import Config
from vdevd.devices import card_class
from vdevd.devices.base import CardContext
from vdevd.errors import StartError
from vdevd.http_health import open_health
from vdevd.nvram import NvramStore
from vdevd.rack import Rack
from vdevd.server import Publisher, Server
from vdevd.shm import Segment

log = logging.getLogger("vdevd")


def build_rack(cfg: Config, memory: Segment | None = None) -> Rack:
    """The cards of `cfg` on one rack (not yet attached to a loop or sockets), publishing
    through a `Publisher` that `Server.start` binds; their passive regions on `memory` (the
    rack removes it at `stop`; here too if a card cannot be built)."""
    try:
        nvram = NvramStore(cfg.state_dir) if cfg.state_dir else None
        rack = Rack([], cfg.clock, sink=Publisher(heartbeat_ns=round(cfg.heartbeat_s * 1e9)),
                    wake_ns=cfg.wake_us * 1000, waker=cfg.waker, skip_quiet=cfg.skip_quiet,
                    memory=memory, max_scheduled_per_client=cfg.max_scheduled_per_client,
                    max_scheduled=cfg.max_scheduled)
        for spec in cfg.cards:
            ctx = CardContext(emit=rack.emit, nvram=nvram, memory=memory)
            rack.add_card(card_class(spec.type)(spec.name, spec.options, ctx))
    except BaseException:
        if memory is not None:
            memory.close()
        raise
    return rack


def shared_memory(cfg: Config) -> Segment | None:
    """The daemon's shared segment in `[server] shm_dir`, named after its endpoint (a stale one
    replaced); None when the configuration turns it off or the directory cannot hold it."""
    return Segment.create(cfg.shm_dir, cfg.endpoint) if cfg.shm_dir else None


def build_server(cfg: Config, ctx: zmq.Context | None = None) -> Server:
    """A server of the rack of `cfg`, its passive regions in the daemon's shared segment."""
    rack = build_rack(cfg, shared_memory(cfg))
    try:
        server = Server(rack, cfg.endpoint, cfg.events, ctx=ctx, curve=cfg.curve,
                        open_networks=cfg.open_networks)
    except BaseException:
        rack.stop()
        raise
    server.new_memory = lambda: shared_memory(cfg)  # a snapshot loaded: its segment
    return server


def sd_notify(message: str) -> None:
    """systemd readiness/watchdog notification (no-op outside systemd)."""
    addr = os.environ.get("NOTIFY_SOCKET")
    if not addr:
        return
    if addr.startswith("@"):
        addr = "\0" + addr[1:]
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as s, suppress(OSError):
        s.sendto(message.encode(), addr)


def write_ready_file(path: str | os.PathLike[str], info: dict[str, Any]) -> None:
    """Write `info` as JSON to `path` atomically (temporary file in the same directory, fsync,
    rename): a reader sees no file or the whole file, never part of it. A `StartError` naming
    `path` (not the temporary file) when it cannot be written."""
    target = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", dir=target.parent or Path("."))
    except OSError as exc:
        raise StartError(f"ready file {path}: {exc.strerror or exc}") from None
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(info, f, indent=1)
            f.write("\n")
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except OSError as exc:
        with suppress(OSError):
            os.unlink(tmp)
        raise StartError(f"ready file {path}: {exc.strerror or exc}") from None
    except BaseException:
        with suppress(OSError):
            os.unlink(tmp)
        raise


async def serve(cfg: Config, stop: asyncio.Event | None = None,
                ready_file: str | os.PathLike[str] | None = None) -> None:
    """Run until `stop` is set or SIGINT/SIGTERM arrives. Readiness (`ready_file`, then systemd's
    READY=1) is announced once every listener is bound: the cards' ports, PUB, the endpoint; a
    listener that cannot be bound raises (`StartError`, `zmq.ZMQError`) and nothing is announced.
    The ready file is removed when the daemon stops, before its listeners close."""
    loop = asyncio.get_running_loop()
    stop = stop or asyncio.Event()
    server = build_server(cfg)
    for sig in (signal.SIGINT, signal.SIGTERM):
        with suppress(NotImplementedError, RuntimeError, ValueError):
            loop.add_signal_handler(sig, stop.set)
    watchdog = None
    written = False
    health = None
    web = None
    try:
        health = open_health(cfg.metrics, server.rack, loop)  # /healthz answers during start
        if health is not None:
            server.on_swap.append(health.follow)  # a snapshot loaded: its rack's metrics
        # before the clock starts: a rack with no card compiles the motion core here, which
        # would otherwise hold the first scheduler pass (a false stall at every start)
        core = server.rack.stats()["motion_core"]
        await server.start(loop)
        cards = ", ".join(f"{c.name} ({c.type_name})" for c in server.rack.cards.values())
        if not cards:
            cards = "none"
            log.warning("the configuration has no [[card]]: the rack is empty")
        log.info("listening on %s, events on %s, clock %s, motion core %s; cards: %s",
                 server.endpoint, server.events, cfg.clock, core, cards)
        if cfg.web is not None:
            from vdevd.web.app import open_web  # aiohttp only for a daemon with a web view

            web = await open_web(cfg.web, lambda: server.rack)
        if ready_file is not None:
            listeners = server.listeners()
            if health is not None:
                listeners["metrics"] = health.url
            if web is not None:
                listeners["web"] = web.url
            write_ready_file(ready_file, listeners)
            written = True
        if health is not None:
            health.ready = True
        sd_notify("READY=1")
        if os.environ.get("WATCHDOG_USEC"):
            watchdog = asyncio.create_task(_watchdog())
        await stop.wait()
    finally:
        if watchdog is not None:
            watchdog.cancel()
        if written and ready_file is not None:
            with suppress(OSError):
                os.unlink(ready_file)
        sd_notify("STOPPING=1")
        if health is not None:
            health.ready = False
        if web is not None:
            await web.stop()
        await server.stop()
        if health is not None:
            health.stop()
        log.info("stopped")


async def _watchdog() -> None:
    """Ping systemd's watchdog at half its interval while the loop is alive."""
    interval = int(os.environ["WATCHDOG_USEC"]) / 2e6
    while True:
        sd_notify("WATCHDOG=1")
        await asyncio.sleep(interval)


def run(cfg: Config, ready_file: str | None = None) -> None:
    """Blocking entry point: uvloop when available."""
    try:
        import uvloop
    except ImportError:  # pragma: no cover - uvloop is a dependency on POSIX
        asyncio.run(serve(cfg, ready_file=ready_file))
        return
    uvloop.run(serve(cfg, ready_file=ready_file))
