"""Assemble a daemon from a configuration and run it on uvloop until SIGINT/SIGTERM."""

from __future__ import annotations

import asyncio
import logging
import os
import signal
import socket
from contextlib import suppress

import zmq

from vdevd.config import Config
from vdevd.devices import card_class
from vdevd.devices.base import CardContext
from vdevd.nvram import NvramStore
from vdevd.rack import Rack
from vdevd.server import Server

log = logging.getLogger("vdevd")


def build_rack(cfg: Config) -> Rack:
    """The cards of `cfg` on one rack (not yet attached to a loop or sockets)."""
    nvram = NvramStore(cfg.state_dir) if cfg.state_dir else None
    rack = Rack([], cfg.clock, wake_ns=cfg.wake_us * 1000, waker=cfg.waker)
    for spec in cfg.cards:
        ctx = CardContext(emit=rack.emit, nvram=nvram)
        rack.add_card(card_class(spec.type)(spec.name, spec.options, ctx))
    return rack


def build_server(cfg: Config, ctx: zmq.Context | None = None) -> Server:
    return Server(build_rack(cfg), cfg.endpoint, cfg.events, ctx=ctx, curve=cfg.curve)


def sd_notify(message: str) -> None:
    """systemd readiness/watchdog notification (no-op outside systemd)."""
    addr = os.environ.get("NOTIFY_SOCKET")
    if not addr:
        return
    if addr.startswith("@"):
        addr = "\0" + addr[1:]
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as s, suppress(OSError):
        s.sendto(message.encode(), addr)


async def serve(cfg: Config, stop: asyncio.Event | None = None) -> None:
    """Run until `stop` is set or SIGINT/SIGTERM arrives."""
    loop = asyncio.get_running_loop()
    stop = stop or asyncio.Event()
    server = build_server(cfg)
    for sig in (signal.SIGINT, signal.SIGTERM):
        with suppress(NotImplementedError, RuntimeError, ValueError):
            loop.add_signal_handler(sig, stop.set)
    server.start(loop)
    cards = ", ".join(f"{c.name} ({c.type_name})" for c in server.rack.cards.values())
    if not cards:
        cards = "none"
        log.warning("the configuration has no [[card]]: the rack is empty")
    log.info("listening on %s, events on %s, clock %s; cards: %s",
             server.endpoint, server.events, cfg.clock, cards)
    await server.rack.open_services()
    sd_notify("READY=1")
    watchdog = asyncio.create_task(_watchdog()) if os.environ.get("WATCHDOG_USEC") else None
    try:
        await stop.wait()
    finally:
        if watchdog is not None:
            watchdog.cancel()
        sd_notify("STOPPING=1")
        await server.rack.close_services()
        server.close()
        log.info("stopped")


async def _watchdog() -> None:
    """Ping systemd's watchdog at half its interval while the loop is alive."""
    interval = int(os.environ["WATCHDOG_USEC"]) / 2e6
    while True:
        sd_notify("WATCHDOG=1")
        await asyncio.sleep(interval)


def run(cfg: Config) -> None:
    """Blocking entry point: uvloop when available."""
    try:
        import uvloop
    except ImportError:  # pragma: no cover - uvloop is a dependency on POSIX
        asyncio.run(serve(cfg))
        return
    uvloop.run(serve(cfg))
