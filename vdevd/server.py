"""The ZeroMQ server: moves bytes between the sockets and the rack, nothing else (DESIGN.md).

ROUTER for requests, PUB for interrupts and events, both on the one event loop. The ROUTER is
drained from `loop.add_reader` with NOBLOCK (no future per message): limits.md measured this at
~95k msg/s against ~40k for zmq.asyncio. `start` binds in readiness order: the cards' own ports,
then PUB, then the ROUTER last, so a client that reaches the endpoint finds everything else up.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from typing import Any

import msgpack
import zmq

from vdevd import protocol, snapshot
from vdevd.card_ports import PORT_KEYS
from vdevd.errors import ErrorCode, VdevError
from vdevd.heartbeat import PERIOD_NS as HEARTBEAT_NS
from vdevd.heartbeat import TOPIC as HEARTBEAT_TOPIC
from vdevd.heartbeat import Heartbeat
from vdevd.irq import IrqEvent
from vdevd.metrics import OP_TAGS
from vdevd.rack import Rack
from vdevd.security import CurveConfig, allow_networks, peer_ip, secure
from vdevd.shm import Segment

log = logging.getLogger("vdevd.server")

#: messages served per readable callback before yielding to the scheduler
DRAIN_BUDGET = 256
# pyzmq's constants are enums: an operation on one builds a new enum member (~2 us), so the hot
# path uses their plain int values
_NOBLOCK = int(zmq.NOBLOCK)
_NOBLOCK_MORE = int(zmq.NOBLOCK | zmq.SNDMORE)
_EVENTS = int(zmq.EVENTS)
_POLLIN = int(zmq.POLLIN)
_READ_TAG = OP_TAGS["read"]


def _bind(sock: zmq.Socket, endpoint: str, key: str) -> None:
    """Bind `sock`; when it cannot be, the `ZMQError` names the configuration key (`vdevd
    serve` exits 1 on it: a port in use may be free at a restart)."""
    try:
        sock.bind(endpoint)
    except zmq.ZMQError as exc:
        reason = zmq.strerror(exc.errno) if exc.errno is not None else str(exc)
        raise zmq.ZMQError(exc.errno, f"{key} {endpoint}: {reason}") from None


class Publisher:
    """The rack's event sink (`vdevd.rack.EventSink`) on the PUB socket: events are dropped until
    the server binds it, as a PUB socket drops them while no one subscribes. `heartbeat_ns`:
    the period of the heartbeat the server publishes through it (0: none)."""

    def __init__(self, heartbeat_ns: int = HEARTBEAT_NS) -> None:
        self._sock: zmq.Socket | None = None
        self.endpoint = ""
        self.heartbeat_ns = heartbeat_ns

    def attach(self, sock: zmq.Socket) -> None:
        """Publish on `sock`, bound already."""
        self._sock = sock
        self.endpoint = sock.getsockopt_string(zmq.LAST_ENDPOINT)

    def publish(self, event: IrqEvent) -> None:
        self._send(event.card, {"kind": "irq", **event.as_dict()})

    def sync(self, card: str) -> None:
        self._send(card, {"kind": "sync", "card": card})

    def heartbeat(self, seq: int) -> None:
        """A heartbeat (PROTOCOL.md "Heartbeat") on its own topic."""
        self._send(HEARTBEAT_TOPIC, {"kind": "heartbeat", "seq": seq,
                                     "period_ns": self.heartbeat_ns})

    def _send(self, topic: str, body: dict[str, Any]) -> None:
        if self._sock is None:
            return
        try:
            self._sock.send_multipart([topic.encode(), protocol.encode_event(body)], zmq.NOBLOCK)
        except zmq.ZMQError as exc:
            log.debug("event dropped: %s", exc)


class Server:
    """Serves one rack on a ROUTER endpoint and publishes its events on a PUB endpoint; the
    rack's sink must be a `Publisher` (as `daemon.build_rack` and `testing.rack_of` make it)."""

    def __init__(
        self,
        rack: Rack,
        endpoint: str,
        events: str,
        *,
        ctx: zmq.Context | None = None,
        curve: CurveConfig | None = None,
        open_networks: tuple[str, ...] = (),
    ) -> None:
        """`curve`: serve with CURVE; else `open_networks`: serve only peers on these networks
        (and loopback) without it (`[security] allow_unauthenticated_networks`)."""
        if not isinstance(rack.sink, Publisher):
            raise TypeError("a served rack publishes through a server.Publisher sink")
        self.rack = rack
        self.publisher = rack.sink
        self._bind_to = (endpoint, events)
        self.ctx = ctx or zmq.Context.instance()
        self.router = self.ctx.socket(zmq.ROUTER)
        self.pub = self.ctx.socket(zmq.PUB)
        for sock, url in ((self.router, endpoint), (self.pub, events)):
            sock.linger = 0
            # an IPv6 address (tcp://[::1]:PORT) needs it; not set otherwise, where it would
            # report an IPv4 endpoint as IPv4-mapped IPv6 (tcp://[::ffff:127.0.0.1]:PORT)
            sock.ipv6 = url.startswith("tcp://[")
        self.router.setsockopt(zmq.MAXMSGSIZE, protocol.HARD_MAX_MESSAGE)
        self.router.setsockopt(zmq.ROUTER_HANDOVER, 1)
        self._auth = secure(self.ctx, [self.router, self.pub], curve) if curve else (
            allow_networks(self.ctx, [self.router, self.pub], open_networks)
            if open_networks else None)
        #: the bound endpoints, once `start` has bound them
        self.endpoint = ""
        self.events = ""
        self._reading = False
        self._last_frame: zmq.Frame | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._drain_scheduled = False
        self._draining = False
        self._pack = msgpack.Packer(use_bin_type=True).pack  # this server's, for read replies
        self._heartbeat = Heartbeat(self.publisher)
        self._tasks: set[asyncio.Task[None]] = set()
        #: the shared segment a restored rack's regions take (`daemon.shared_memory` of the
        #: configuration; the default: none, private memory)
        self.new_memory: Callable[[], Segment | None] = _no_memory
        #: told of each rack swapped in (`swap`): what reports the rack follows it
        self.on_swap: list[Callable[[Rack], None]] = []
        rack.on_restore = self.restore
        # pyzmq's own send, without the Python wrapper of zmq.Socket (routing ids, groups and
        # Frame objects, none used here) that costs ~0.5 us a frame
        self._router_send = super(zmq.Socket, self.router).send  # type: ignore[misc]

    # -- lifecycle --------------------------------------------------------------------------------
    async def start(self, loop: asyncio.AbstractEventLoop) -> None:
        """Start the rack's clock, then bind every listener in readiness order: the cards' own
        ports (`Rack.open_services`), the PUB socket, the ROUTER last; then serve requests."""
        self._loop = loop
        self.rack.start(loop)
        await self.rack.open_services()
        endpoint, events = self._bind_to
        _bind(self.pub, events, "server.events")
        self.publisher.attach(self.pub)
        self.events = self.publisher.endpoint
        self._heartbeat.start(loop)
        _bind(self.router, endpoint, "server.endpoint")
        self.endpoint = self.router.getsockopt_string(zmq.LAST_ENDPOINT)
        loop.add_reader(self.router.getsockopt(zmq.FD), self._on_readable)
        self._reading = True
        self._on_readable()  # anything queued before the reader was added

    def listeners(self) -> dict[str, Any]:
        """Every bound listener (the `--ready-file` contents): the endpoint, the events, and
        each card's own (`Card.listeners`)."""
        return {"endpoint": self.endpoint, "events": self.events,
                "cards": {c.name: c.listeners() for c in self.rack.cards.values()}}

    async def stop(self) -> None:
        """Close the cards' own ports, stop the clock, close the sockets (what was started)."""
        self._heartbeat.stop()
        await self.rack.close_services()
        self.rack.stop()
        if self._loop is not None and self._reading:
            self._loop.remove_reader(self.router.getsockopt(zmq.FD))
            self._reading = False
        self.router.close()
        self.pub.close()
        if self._auth is not None:
            self._auth.stop()

    # -- swapping the rack (a reset, a snapshot loaded) ----------------------------------------
    async def swap(self, rack: Rack, bound: dict[str, dict[str, str]] | None = None) -> None:
        """Serve `rack` in place of the rack served, on the same endpoints: the old rack's card
        ports close and its clock stops (unless `bound`, the ports it had bound, is given: it
        was stopped already), the new one's clock starts and its cards listen on the ports the
        old ones had bound (a card's port option is an attribute of the same name,
        `card_ports.PORT_KEYS`). Clients keep their connection, not their shared memory."""
        old = self.rack
        if bound is None:
            bound = {name: card.listeners() for name, card in old.cards.items()}
            await old.close_services()
            old.stop()
        for name, ports in bound.items():
            card = rack.cards.get(name)
            for key, endpoint in ports.items():
                if card is not None and key in PORT_KEYS and hasattr(card, key):
                    setattr(card, key, endpoint)
        if not isinstance(rack.sink, Publisher):
            raise TypeError("a served rack publishes through a server.Publisher sink")
        if rack.sink is not self.publisher:
            rack.sink.attach(self.pub)
        self.rack, self.publisher = rack, rack.sink
        rack.on_restore = self.restore
        assert self._loop is not None
        rack.start(self._loop)
        await rack.open_services()
        for follow in self.on_swap:
            follow(rack)

    def restore(self, data: bytes, reply: Callable[[Any], None]) -> None:
        """`snapshot load` (Rack.op_snapshot): a new rack from the snapshot, swapped in; the
        reply once it serves. A snapshot that does not load leaves the rack served as it was."""
        memory = self.new_memory()
        try:
            rack = self.rack.restore(data, memory)
        except Exception as exc:
            if memory is not None:
                memory.close()
            reply(exc if isinstance(exc, VdevError) else self.rack._internal(exc, "snapshot load"))
            return

        async def swap() -> None:
            old = self.rack
            try:
                await self.swap(rack)
                _drop_waits(old)
                # after the old cards' writers have flushed: the NV images of the snapshot
                await asyncio.to_thread(snapshot.write_nv_images, rack)
            except Exception as exc:  # a card port taken meanwhile: the rack serves without it
                log.exception("swapping in a restored rack")
                reply(VdevError(ErrorCode.INTERNAL, f"snapshot load: {exc}"))
                return
            log.info("rack restored from a snapshot at %d ns", rack.now_ns)
            reply({"now_ns": rack.now_ns, "cards": list(rack.cards)})

        assert self._loop is not None
        self._tasks.add(task := self._loop.create_task(swap()))
        task.add_done_callback(self._tasks.discard)

    # -- requests ---------------------------------------------------------------------------------
    def _on_readable(self) -> None:
        self._drain_scheduled = False
        recv, events = self._recv, self.router.getsockopt
        self._draining = True
        try:
            try:  # woken up: most likely a message is there, so try it without asking first
                frames = recv(_NOBLOCK)
            except zmq.Again:
                return
            self._serve(frames)
            for _ in range(DRAIN_BUDGET):
                # then ask ZMQ_EVENTS, which costs half of a recv that raises Again
                if not events(_EVENTS) & _POLLIN:
                    return
                self._serve(recv(_NOBLOCK))
            self._schedule_drain()  # budget spent: let the scheduler run, then go on
        finally:
            self._draining = False

    def _serve(self, frames: list[bytes]) -> None:
        """Handle one message; a bug met on the way is logged and counted, and the drain goes
        on (an exception leaving the callback would leave queued messages unread until the
        next readable edge)."""
        try:
            self._handle(frames)
        except Exception:
            self.rack.errors += 1
            log.exception("internal error serving a request")

    def _recv(self, flags: int) -> list[bytes]:
        """One whole message. Like recv_multipart, but asking each frame's `more` flag instead
        of ZMQ_RCVMORE: a socket option costs more than the receive itself."""
        recv = self.router.recv
        frames = [recv(flags)]  # the peer's identity; a ROUTER message always has a body
        while True:
            frame = recv(flags, copy=False)
            frames.append(frame.bytes)
            if not frame.more:
                self._last_frame = frame  # what the transport tells of the peer (`_peer_local`)
                return frames

    def _peer_local(self) -> bool:
        """The sender of the message being served is on this machine: an ipc:// or inproc://
        endpoint, or a TCP peer whose address is loopback (decision 0010)."""
        scheme = self.endpoint.partition("://")[0]
        if scheme in ("ipc", "inproc"):
            return True
        if scheme != "tcp" or self._last_frame is None:
            return False
        try:
            return peer_ip(str(self._last_frame.get("Peer-Address"))).is_loopback  # ::ffff:127.0.0.1 too
        except (zmq.ZMQError, ValueError):
            return False

    def _schedule_drain(self) -> None:
        if not self._drain_scheduled and self._loop is not None:
            self._drain_scheduled = True
            self._loop.call_soon(self._on_readable)

    def _handle(self, frames: list[bytes]) -> None:
        t0 = time.perf_counter_ns()
        envelope, payload = frames[:-1], frames[-1]
        try:
            msg = protocol.unpack_message(payload)
            read = protocol.read_fields(msg)
            if read is not None:
                self._send(envelope, self._read(*read))
                self.rack.latency.add(time.perf_counter_ns() - t0, _READ_TAG)
                return
            req = protocol.request_from(msg)
            req.client = envelope[0]
            if req.op == "hello":
                req.local = self._peer_local()
        except VdevError as exc:
            self.rack.errors += 1
            self._send(envelope, protocol.encode_error(getattr(exc, "req_id", None), exc.code,
                                                       exc.message))
            return
        req_id = req.id

        def reply(result: Any) -> None:
            if isinstance(result, VdevError):
                body = protocol.encode_error(req_id, result.code, result.message)
            else:
                try:
                    body = protocol.encode_ok(req_id, result, self._pack)
                except (TypeError, ValueError, OverflowError) as exc:
                    body = protocol.encode_error(req_id, ErrorCode.INTERNAL, f"unencodable: {exc}")
                body = _within_limit(req_id, body)
            self._send(envelope, body)

        self.rack.execute(req, reply)
        self.rack.latency.add(time.perf_counter_ns() - t0, OP_TAGS[req.op])

    def _read(self, req_id: Any, card: str, region: str, offset: int, size: int) -> bytes:
        """The reply to a register read (the hot path)."""
        try:
            return _within_limit(req_id, protocol.encode_ok(
                req_id, self.rack.read(card, region, offset, size), self._pack))
        except VdevError as exc:
            return protocol.encode_error(req_id, exc.code, exc.message)
        except Exception as exc:  # a bug in a card's read hook: report it, keep serving
            self.rack.errors += 1
            log.exception("internal error serving read")
            return protocol.encode_error(req_id, ErrorCode.INTERNAL, f"{type(exc).__name__}: {exc}")

    def _send(self, envelope: list[bytes], body: bytes) -> None:
        """The reply, frame by frame: send_multipart costs ~3 us more per message, and on a
        core shared with the ZeroMQ I/O thread that delay lands on the round trip."""
        send = self._router_send
        try:
            for frame in envelope:
                send(frame, _NOBLOCK_MORE)
            send(body, _NOBLOCK)
        except zmq.ZMQError as exc:  # peer gone or its queue full: drop the reply, keep serving
            log.debug("reply dropped: %s", exc)
        if not self._draining:
            # an edge-triggered FD may have swallowed a readable edge while we sent
            self._schedule_drain()


def _drop_waits(rack: Rack) -> None:
    """Answer the waits pending on a rack no longer served (`busy`): their clients need not
    wait for their timeouts."""
    pending, rack.waits.pending = rack.waits.pending, []
    for waiter in pending:
        waiter.reply(VdevError(ErrorCode.BUSY, "the rack was replaced (snapshot load): the wait "
                               "is dropped"))


def _no_memory() -> Segment | None:
    return None


def _within_limit(req_id: Any, body: bytes) -> bytes:
    """The reply, or a `too_large` error in its place when it exceeds the maximum message."""
    if len(body) <= protocol.MAX_MESSAGE:
        return body
    return protocol.encode_error(req_id, ErrorCode.TOO_LARGE,
                                 f"reply of {len(body)} bytes exceeds {protocol.MAX_MESSAGE}")
