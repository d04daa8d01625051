"""The client core: a synchronous ZeroMQ client of wire protocol v1 (proto/PROTOCOL.md).

`connect()` -> `Rack` -> `Card` -> `Region` (register access), `Card.irq` (interrupts),
`Rack.sim` (the clock), `Rack.control` (the backdoor). One `Rack` is one DEALER socket: use it
from one thread at a time.

On the daemon's machine, `Region` reads and writes the passive ranges of a region (memory the card
only polls or publishes, no hook) through the daemon's shared memory, with no round trip
(decision 0010); everything else, and everything of a remote client, is a request.
"""

from __future__ import annotations

import bisect
import itertools
import logging
import mmap
import os
import struct
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import msgpack
import zmq

from vdevclient._curve import curve_keys
from vdevclient._liveness import Liveness
from vdevclient.errors import RackClosed, RemoteError, RequestTooLarge, VdevTimeout

log = logging.getLogger("vdevclient")

DEFAULT_ENDPOINT = "tcp://127.0.0.1:5555"
PROTOCOL_VERSION = 1
MAX_MESSAGE = 1 << 20  # protocol v1's request size limit until `hello` reports the daemon's
_NS = 1_000_000_000
_MAX_SPAN_S = 86_400.0  # the longest step or wait the protocol allows


def connect(
    endpoint: str | None = None,
    events: str | None = None,
    timeout: float = 10.0,
    *,
    server_key: str | None = None,
    client_key: str | None = None,
    shm: bool | None = None,
) -> Rack:
    """Connect to a daemon: `endpoint` defaults to $VDEVD_ENDPOINT, else tcp://127.0.0.1:5555;
    `events` to $VDEVD_EVENTS, else what `hello` reports. `timeout` is in wall seconds.

    For a CURVE-secured daemon, `server_key` is the server's public certificate file and
    `client_key` this client's secret certificate file ($VDEVD_SERVER_KEY, $VDEVD_CLIENT_KEY):
    both or neither, else `ConfigurationError` naming the one missing or unusable.

    `shm`: access passive memory through the daemon's shared memory when the daemon offers it
    (a client on its machine); default true unless $VDEVD_SHM is 0, no, off or false.
    """
    endpoint = endpoint or os.environ.get("VDEVD_ENDPOINT") or DEFAULT_ENDPOINT
    events = events or os.environ.get("VDEVD_EVENTS") or None
    curve = curve_keys(
        ("server_key", server_key) if server_key else
        ("$VDEVD_SERVER_KEY", os.environ.get("VDEVD_SERVER_KEY") or None),
        ("client_key", client_key) if client_key else
        ("$VDEVD_CLIENT_KEY", os.environ.get("VDEVD_CLIENT_KEY") or None))
    if shm is None:
        shm = os.environ.get("VDEVD_SHM", "1").strip().lower() not in _OFF
    return Rack(endpoint, events, timeout, curve=curve, shm=shm)


_OFF = ("0", "no", "off", "false")
#: the first byte of the daemon's shared memory while the daemon serves it (PROTOCOL.md)
_LIVE = 1


_ID_KEY = msgpack.packb("id")
_MAX_PREPARED_FIELDS = 14  # with the id, a msgpack fixmap (at most 15 fields)


#: (op, rep) -> the kind of a compact access (PROTOCOL.md "Compact accesses")
_COMPACT_KINDS = {("read", False): "r", ("write", False): "w", ("read", True): "R",
                  ("write", True): "W"}


def compact(op: dict[str, Any]) -> dict[str, Any] | list[Any]:
    """A batch op as the daemon takes it in fewest bytes: a plain read or write (card, region,
    offset, size or data, rep) as its compact array, anything else as it is."""
    rep, name = op.get("rep", False), op.get("op")
    kind = _COMPACT_KINDS.get((name, rep)) if type(rep) is bool and type(name) is str else None
    if kind is None or op.keys() - {"rep"} != _ACCESS_FIELDS[kind]:
        return op
    return [kind, op["card"], op["region"], op["offset"], op["size" if kind in "rR" else "data"]]


_ACCESS_FIELDS = {kind: frozenset({"op", "card", "region", "offset", "size" if kind in "rR" else "data"})
                  for kind in "rwRW"}


@dataclass(frozen=True, slots=True)
class Prepared:
    """A request packed by `Rack.prepare`: its op, its map's header (counting the id `call`
    appends) and fields, and the map itself (to look at; changing it changes nothing sent)."""

    op: str
    fields: bytes
    message: dict[str, Any]


class _Record(Mapping[str, Any]):
    """Lets a frozen dataclass be read as a mapping of its fields: `info["name"]` is `info.name`."""

    __dataclass_fields__: ClassVar[dict[str, Any]]

    def __getitem__(self, key: str) -> Any:
        if key not in self.__dataclass_fields__:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(self.__dataclass_fields__)

    def __len__(self) -> int:
        return len(self.__dataclass_fields__)


@dataclass(frozen=True)
class RegionInfo(_Record):
    """A bus region as `hello` describes it."""

    name: str
    size: int
    widths: tuple[int, ...]
    endian: str
    aligned: bool = True
    block: bool = True
    #: the (start, end) ranges with no hook, which a local client maps (decision 0010)
    passive: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True)
class CardInfo(_Record):
    """A card as `hello` describes it; `regions` are RegionInfo, `irq` the line names."""

    name: str
    type: str
    endian: str
    period_ns: int
    regions: tuple[RegionInfo, ...]
    irq: tuple[str, ...]
    controls: dict[str, Any]


class Rack:
    """A connection to one daemon."""

    def __init__(self, endpoint: str, events: str | None = None, timeout: float = 10.0,
                 curve: tuple[str, str] | None = None, shm: bool = True) -> None:
        """`shm`: map the daemon's shared memory when `hello` offers it (see `connect`)."""
        self.endpoint = endpoint
        self.timeout = timeout
        self.curve = curve
        self._ctx: zmq.Context[zmq.Socket[bytes]] = zmq.Context.instance()
        self._sock = self.socket(zmq.DEALER)
        # pyzmq's own send, without zmq.Socket's Python wrapper (routing ids, groups): ~0.5 us
        self._send = super(zmq.Socket, self._sock).send
        self._rcvtimeo = -1
        self._ids = itertools.count(1)
        self._packb = msgpack.Packer(use_bin_type=True).pack
        self._cards: dict[str, Card] = {}
        self.sim = Sim(self)
        self.max_message = MAX_MESSAGE
        try:
            self._sock.connect(endpoint)
            self.info = self.request("hello", client="vdevclient")
        except BaseException:
            self._sock.close()
            raise
        self.max_message = self.info["max_message"]
        #: the daemon takes a batch's reads and writes as arrays (PROTOCOL.md "Compact accesses")
        self.compact = "batch.compact" in self.info.get("capabilities", ())
        self.events_endpoint: str = events or self.info.get("events", "")
        #: the period of the daemon's heartbeat on the events socket (0: it sends none)
        self.heartbeat_ns: int = int(self.info.get("heartbeat_ns", 0))
        self._infos = {c["name"]: _card_info(c) for c in self.info["cards"]}
        #: the daemon's shared memory, mapped (None: every access is a request)
        self.shm: mmap.mmap | None = _map_segment(self.info.get("shm")) if shm else None
        self._shm_regions: dict[str, dict[str, int]] = (
            self.info["shm"]["regions"] if self.shm is not None else {})

    def mapping(self, card: str, region: str) -> tuple[mmap.mmap, int] | None:
        """The shared memory and where `card`'s `region` starts in it; None when not mapped."""
        offset = self._shm_regions.get(card, {}).get(region)
        if self.shm is None or offset is None:
            return None
        return self.shm, offset

    # -- plumbing ---------------------------------------------------------------------------------
    def request(self, op: str, /, *, _wait_s: float = 0.0, **fields: Any) -> Any:
        """Send one request and return its result; RemoteError for an error reply."""
        fields["op"] = op
        return self.call(fields, _wait_s)

    def call(self, message: dict[str, Any] | Prepared, wait_s: float = 0.0) -> Any:
        """Send one request map (its `id` is set here), or a request `prepare`d before, and
        return the result; RequestTooLarge, without sending it, when its body exceeds the
        daemon's `max_message`."""
        req_id = next(self._ids)
        if type(message) is Prepared:
            op = message.op
            body = message.fields + _ID_KEY + self._packb(req_id)
        else:
            message["id"] = req_id  # type: ignore[index]
            op = message["op"]  # type: ignore[index]
            body = self._packb(message)
        if len(body) > self.max_message:
            raise RequestTooLarge(op, len(body), self.max_message)
        try:
            self._send(body)
        except zmq.ZMQError:
            if self._sock.closed:
                raise RackClosed(f"{op}: the connection to {self.endpoint} is closed") from None
            raise
        # what follows overlaps the round trip
        deadline_ms = int((self.timeout + wait_s) * 1000)
        if deadline_ms != self._rcvtimeo:  # a socket option costs ~5 us: set it on change only
            self._sock.rcvtimeo = self._rcvtimeo = deadline_ms
        while True:
            try:
                raw = self._sock.recv()
            except zmq.Again:
                raise VdevTimeout(f"{op}: no reply from {self.endpoint} "
                                  f"in {deadline_ms} ms") from None
            reply = msgpack.unpackb(raw)
            if reply.get("id") != req_id:
                continue  # the late reply of an earlier request that timed out
            if "error" in reply:
                err = reply["error"]
                raise RemoteError(err.get("code", "?"), err.get("message", ""))
            return reply.get("ok")

    def prepare(self, message: dict[str, Any]) -> Prepared:
        """`message` (a request map without `id`, of at most 14 fields) packed once, for a
        client that sends the same request again and again: `call` then adds only the id."""
        if "id" in message or len(message) > _MAX_PREPARED_FIELDS:
            raise ValueError(f"a prepared request has no id and at most {_MAX_PREPARED_FIELDS} "
                             "fields")
        sent = message
        if message.get("op") == "batch" and self.compact:
            sent = {**message, "ops": [compact(op) for op in message["ops"]]}
        packed = self._packb(sent)  # a fixmap: its first byte is 0x80 + the field count
        return Prepared(str(message["op"]), bytes((packed[0] + 1,)) + packed[1:], message)

    def subscriber(self, topics: Sequence[str]) -> tuple[zmq.Socket[bytes], Liveness]:
        """A SUB socket on the events endpoint subscribed to `topics` (card names), and the
        watch on the daemon's heartbeat that receives from it (`Liveness.receive`)."""
        if not self.events_endpoint:
            raise RuntimeError("the daemon reported no events endpoint")
        sub = self.socket(zmq.SUB)
        try:
            sub.connect(self.events_endpoint)
            for topic in topics:
                sub.setsockopt(zmq.SUBSCRIBE, topic.encode())
            return sub, Liveness(sub, self.heartbeat_ns, self.events_endpoint)
        except BaseException:
            sub.close()
            raise

    def socket(self, kind: int) -> zmq.Socket[bytes]:
        """A socket of this connection's context, with its CURVE keys when it has them."""
        keys = None
        if self.curve is not None:  # read before the socket exists: a bad file leaks none
            import zmq.auth

            server_public, _ = zmq.auth.load_certificate(self.curve[0])
            public, secret = zmq.auth.load_certificate(self.curve[1])
            if secret is None:
                raise ValueError(f"{self.curve[1]} holds no secret key")
            keys = (server_public, public, secret)
        sock = self._ctx.socket(kind)
        sock.linger = 0
        sock.ipv6 = True  # a daemon on tcp://[::1]:PORT too
        if keys is not None:
            sock.curve_serverkey, sock.curve_publickey, sock.curve_secretkey = keys
        return sock

    def close(self) -> None:
        """Close the connection and its subscriptions; later requests raise RackClosed. Closing
        again does nothing."""
        for card in self._cards.values():
            card.irq.close()
        self._sock.close()
        if self.shm is not None:
            self.shm.close()  # nothing exports it: its users copy out (Region)

    def __enter__(self) -> Rack:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the rack ---------------------------------------------------------------------------------
    def cards(self) -> list[CardInfo]:
        return list(self._infos.values())

    def card(self, name: str) -> Card:
        if name not in self._infos:
            raise KeyError(f"no card {name!r} (cards: {', '.join(self._infos)})")
        if name not in self._cards:
            self._cards[name] = Card(self, self._infos[name])
        return self._cards[name]

    def control(self, card: str, action: str, *, at_ns: int | None = None,
                after_ns: int | None = None, **params: Any) -> Any:
        """Run a backdoor action now, or at simulated time `at_ns` / `after_ns` from now."""
        extra: dict[str, Any] = {}
        if at_ns is not None:
            extra["at_ns"] = at_ns
        if after_ns is not None:
            extra["after_ns"] = after_ns
        return self.request("control", card=card, action=action, params=params, **extra)

    def stats(self) -> dict[str, Any]:
        return self.request("stats")

    def batch(self, ops: Sequence[dict[str, Any]]) -> list[Any]:
        """Run ops (built by `Region.read_op` etc.) atomically between ticks; a wait op
        suspends the rest until it fires, and ops after a timed-out wait give None."""
        wait_s = sum(op.get("timeout_ns", 0) for op in ops if op.get("op") == "wait") / _NS
        return self.request("batch", _wait_s=wait_s, ops=list(ops))

    def snapshot(self) -> bytes:
        """The daemon's rack as a snapshot file (every card's state and the clock)."""
        from vdevclient import snapshot

        return snapshot.save(self)

    def restore(self, data: bytes) -> dict[str, Any]:
        """Serve the snapshot `data` in place of the daemon's rack (`bad_snapshot` when it
        does not load); reconnect to map the new shared memory."""
        from vdevclient import snapshot

        return snapshot.load(self, data)


class Sim:
    """The daemon's clock."""

    def __init__(self, rack: Rack) -> None:
        self._rack = rack

    @property
    def mode(self) -> str:
        return self._rack.request("sim", action="now")["mode"]

    def now_ns(self) -> int:
        return self._rack.request("sim", action="now")["now_ns"]

    def step(self, ns: int | None = None, ticks: int | None = None,
             seconds: float | None = None, card: str | None = None) -> int:
        """Advance lockstep time by exactly one of ns, ticks (of the rack's shortest period, or
        of `card`'s) or seconds; returns the new time in ns."""
        fields: dict[str, Any] = {}
        if ns is not None:
            fields["ns"] = int(ns)
        if ticks is not None:
            fields["ticks"] = int(ticks)
        if seconds is not None:
            fields["seconds"] = float(seconds)
        if card is not None:
            fields["card"] = card
        # wall time to allow for the reply (lockstep runs faster than real time); a span out
        # of range is the daemon's to refuse (bad_param), not a reason to wait for ever
        span = (ns or 0) / _NS + (seconds or 0.0) + (ticks or 0) * 0.01
        span = span if 0 <= span <= _MAX_SPAN_S else 0.0
        return self._rack.request("sim", _wait_s=span, action="step", **fields)["now_ns"]


class Card:
    """One card of the rack."""

    def __init__(self, rack: Rack, info: CardInfo) -> None:
        self.rack = rack
        self.info = info
        self.name = info.name
        self.type = info.type
        self.irq = Irq(self)
        self._regions = {r.name: r for r in info.regions}

    def region(self, name: str) -> Region:
        if name not in self._regions:
            raise KeyError(f"card {self.name!r} has no region {name!r} "
                           f"(regions: {', '.join(self._regions)})")
        return Region(self, self._regions[name])

    def control(self, action: str, **params: Any) -> Any:
        return self.rack.control(self.name, action, **params)

    def scope(self, axes: Sequence[str | int] | None = None, signals: Sequence[str] | None = None,
              *, seconds: float, every: int = 1, trigger: dict[str, Any] | str | None = None,
              pre: int = 0, step: bool = True) -> Any:
        """Record `signals` of `axes` for `seconds` (issue 23 §1): arm, step the lockstep clock
        that long (unless `step` is false), read; a `vdevclient.scope.Trace` of numpy arrays
        with the simulated time base. `scope_recorder()` gives the single actions."""
        from vdevclient.scope import record

        return record(self, axes, signals, seconds=seconds, every=every, trigger=trigger,
                      pre=pre, step=step)

    def scope_recorder(self) -> Any:
        """The card's recorder (`vdevclient.scope.Scope`: arm, status, read, clear)."""
        from vdevclient.scope import Scope

        return Scope(self)


class Region:
    """Register access to one region, in the card's byte order.

    An access inside one passive range, of a width the bus takes, goes through the daemon's
    shared memory when the rack maps it (`mapped`); any other access is a request. Either way
    the result is the same: the memory as the card's last tick left it (in realtime, as of the
    daemon's last pass; PROTOCOL.md "Shared memory")."""

    def __init__(self, card: Card, info: RegionInfo) -> None:
        self.card = card
        self.info = info
        self.name = info.name
        self.size = info.size
        self._endian: Literal["little", "big"] = "big" if info.endian == "big" else "little"
        self._req = card.rack.request
        self._call = card.rack.call
        self._where: dict[str, Any] = {"card": card.name, "region": info.name}
        self._card_name = card.name
        mapping = card.rack.mapping(card.name, info.name)
        self._mm: Any = None  # the mapping (an mmap) when `_starts` is not empty
        self._base = 0
        if mapping is not None:
            self._mm, self._base = mapping
        passive = info.passive if mapping is not None else ()
        self._starts = [start for start, _ in passive]
        self._ends = [end for _, end in passive]
        self._widths = frozenset(info.widths)
        self._unit = min(info.widths, default=1)
        self._aligned, self._block = info.aligned, info.block
        prefix = ">" if self._endian == "big" else "<"
        self._formats = {n: struct.Struct(prefix + f).unpack_from
                         for n, f in ((1, "B"), (2, "H"), (4, "I"), (8, "Q"))}
        self._get32 = self._formats[4]

    @property
    def mapped(self) -> bool:
        """Accesses to the passive ranges go through shared memory."""
        return bool(self._starts)

    def is_mapped(self, offset: int, size: int) -> bool:
        """This access would go through shared memory: inside one passive range, of a width the
        bus takes, and the daemon still serves the mapping (anything else is a request, which
        also reports the errors, and the closed connection)."""
        i = bisect.bisect_right(self._starts, offset) - 1
        if i < 0 or offset + size > self._ends[i] or size <= 0:
            return False
        if size in self._widths:
            if self._aligned and offset % size:
                return False
        elif not self._block or size % self._unit or (self._aligned and offset % self._unit):
            return False
        try:
            return self._mm[0] == _LIVE  # 0 once the daemon stopped or a successor replaced it
        except ValueError:  # the rack was closed
            return False

    def read(self, offset: int, size: int) -> bytes:
        if self._starts and self.is_mapped(offset, size):
            at = self._base + offset
            return self._mm[at:at + size]
        return self._call({"op": "read", "card": self._card_name, "region": self.name,
                           "offset": offset, "size": size})

    def write(self, offset: int, data: bytes) -> None:
        if self._starts and self.is_mapped(offset, len(data)):
            at = self._base + offset
            self._mm[at:at + len(data)] = data
            return
        self._req("write", offset=offset, data=bytes(data), **self._where)

    def read_rep(self, offset: int, size: int) -> bytes:
        """`size` bytes read from one register (a FIFO port), one bus access at a time."""
        return self._req("read", offset=offset, size=size, rep=True, **self._where)

    def write_rep(self, offset: int, data: bytes) -> None:
        """`data` written to one register (a FIFO port), one bus access at a time."""
        self._req("write", offset=offset, data=bytes(data), rep=True, **self._where)

    def _read_int(self, offset: int, size: int) -> int:
        if self._starts and self.is_mapped(offset, size):
            return int(self._formats[size](self._mm, self._base + offset)[0])
        return int.from_bytes(self.read(offset, size), self._endian)

    def _write_int(self, offset: int, value: int, size: int) -> None:
        self.write(offset, (value & ((1 << 8 * size) - 1)).to_bytes(size, self._endian))

    def read8(self, offset: int) -> int:
        return self._read_int(offset, 1)

    def read16(self, offset: int) -> int:
        return self._read_int(offset, 2)

    def read32(self, offset: int) -> int:
        if self._starts and self.is_mapped(offset, 4):  # the status poll: kept short
            return int(self._get32(self._mm, self._base + offset)[0])
        return self._read_int(offset, 4)

    def read64(self, offset: int) -> int:
        return self._read_int(offset, 8)

    def write8(self, offset: int, value: int) -> None:
        self._write_int(offset, value, 1)

    def write16(self, offset: int, value: int) -> None:
        self._write_int(offset, value, 2)

    def write32(self, offset: int, value: int) -> None:
        self._write_int(offset, value, 4)

    def write64(self, offset: int, value: int) -> None:
        self._write_int(offset, value, 8)

    def wait_value(self, offset: int, value: int, *, mask: int | None = None, size: int = 4,
                   timeout_s: float = 1.0, equal: bool = True) -> int | None:
        """Block (server side) until (register & mask) == value (or != with equal=False);
        the register's value, or None on timeout. In lockstep, time advances while waiting."""
        op = self.wait_op(offset, value, mask=mask, size=size, timeout_s=timeout_s, equal=equal)
        del op["op"]
        res = self._req("wait", _wait_s=timeout_s, **op)
        return res["value"] if res["fired"] else None

    # -- batch ops --------------------------------------------------------------------------------
    def read_op(self, offset: int, size: int, *, rep: bool = False) -> dict[str, Any]:
        """A `read` for `Rack.batch`; `rep`: `size` bytes from one register (a FIFO port)."""
        op = {"op": "read", "offset": offset, "size": size, **self._where}
        if rep:
            op["rep"] = True
        return op

    def write_op(self, offset: int, data: bytes, *, rep: bool = False) -> dict[str, Any]:
        """A `write` for `Rack.batch`; `rep`: every byte to one register (a FIFO port)."""
        op = {"op": "write", "offset": offset, "data": bytes(data), **self._where}
        if rep:
            op["rep"] = True
        return op

    def wait_op(self, offset: int, value: int, *, mask: int | None = None, size: int = 4,
                timeout_s: float = 1.0, equal: bool = True) -> dict[str, Any]:
        op: dict[str, Any] = {
            "op": "wait", "on": "value", "offset": offset, "size": size, "value": value,
            "cmp": "eq" if equal else "ne", "timeout_ns": int(timeout_s * _NS), **self._where,
        }
        if mask is not None:
            op["mask"] = mask
        return op


class Irq:
    """A card's interrupts: server-side `wait`, or a PUB/SUB subscription to every assertion."""

    def __init__(self, card: Card) -> None:
        self._card = card
        self._sub: zmq.Socket[bytes] | None = None
        self._liveness: Liveness | None = None
        self.last_seq: int | None = None

    def wait(self, timeout_s: float, line: str | None = None) -> dict[str, Any] | None:
        """The next assertion (of `line`, or of any line) after the last one this object saw,
        or None on timeout. The first call waits for an assertion after the call."""
        fields: dict[str, Any] = {"card": self._card.name, "on": "irq",
                                  "timeout_ns": int(timeout_s * _NS)}
        if line is not None:
            fields["line"] = line
        if self.last_seq is not None:
            fields["after_seq"] = self.last_seq
        res = self._card.rack.request("wait", _wait_s=timeout_s, **fields)
        if not res["fired"]:
            return None
        event: dict[str, Any] = res["event"]
        self.last_seq = event["seq"]
        return event

    def subscribe(self) -> Irq:
        """Start receiving every assertion of this card published on the events socket."""
        if self._sub is None:
            self._sub, self._liveness = self._card.rack.subscriber([self._card.name])
            try:
                self._sync()
            except BaseException:
                self.close()
                raise
        return self

    def _sync(self, attempts: int = 100) -> None:
        """Wait until the subscription is live: ZeroMQ joins a PUB asynchronously, so ask the
        daemon to publish `sync` events until something arrives (PROTOCOL.md, sync). What
        arrived stays queued: an interrupt published meanwhile is the first `events()` yields."""
        assert self._sub is not None
        for _ in range(attempts):
            self._card.rack.request("sync", card=self._card.name)
            if self._sub.poll(50):
                return
        raise VdevTimeout(f"no events from {self._card.rack.events_endpoint}")

    def events(self, timeout_s: float | None = None) -> Iterator[dict[str, Any]]:
        """Yield published events as they come; stop after `timeout_s` without one. A daemon
        silent for three heartbeat periods raises `DaemonGone` (PROTOCOL.md "Heartbeat")."""
        if self._sub is None:
            self.subscribe()
        assert self._liveness is not None
        name = self._card.name.encode()
        while True:
            got = self._liveness.receive(timeout_s)
            if got is None:
                return
            topic, body = got
            event = msgpack.unpackb(body, raw=False)
            if topic == name and event.get("kind") != "sync":
                yield event

    def close(self) -> None:
        if self._sub is not None:
            self._sub.close()
            self._sub = None
            self._liveness = None


def _card_info(c: dict[str, Any]) -> CardInfo:
    regions = tuple(
        RegionInfo(r["name"], r["size"], tuple(r["widths"]), r.get("endian", c["endian"]),
                   bool(r.get("aligned", True)), bool(r.get("block", True)),
                   tuple((int(start), int(end)) for start, end in r.get("passive", ())))
        for r in c["regions"]
    )
    return CardInfo(c["name"], c["type"], c["endian"], c["period_ns"], regions,
                    tuple(c["irq"]), c.get("controls", {}))


def _map_segment(info: Any) -> mmap.mmap | None:
    """The daemon's shared memory as `hello` describes it, mapped; None (logged) when this
    process may not open it (another user's: it is 0o600) or the file found is not that one."""
    if not isinstance(info, dict):
        return None
    try:
        path, size, ident = str(info["path"]), int(info["size"]), (info["dev"], info["ino"])
        fd = os.open(path, os.O_RDWR | os.O_CLOEXEC | os.O_NOFOLLOW)
    except (OSError, KeyError, TypeError, ValueError) as exc:
        log.info("shared memory not used, every access is a request: %s", exc)
        return None
    try:
        st = os.fstat(fd)
        if (st.st_dev, st.st_ino) != ident or st.st_size < size or size <= 0:
            log.info("shared memory not used: %s is not the daemon's segment", path)
            return None
        mapped = mmap.mmap(fd, size)
        if mapped[0] != _LIVE:
            mapped.close()
            return None
        return mapped
    except (OSError, ValueError) as exc:
        log.info("shared memory not used, every access is a request: %s", exc)
        return None
    finally:
        os.close(fd)
