"""The rack: the cards by name, their clock, and the operations of protocol v1 (DESIGN.md).

Sans-I/O except for the event loop's timers: `execute(request, reply)` serves one validated
request and calls `reply(result)` or `reply(VdevError)` exactly once, at once or later (a wait).
How time moves is `vdevd/pacing.py`'s, pending waits and timers are `vdevd/waits.py`'s; interrupt
and `sync` events go to the `EventSink` given at construction (the server's PUB socket).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Iterable
from typing import Any, Protocol

from vdevd import snapshot
from vdevd.bounds import (
    MAX_HELD_OPS,
    MAX_READ,
    MAX_SCHEDULED,
    MAX_SCHEDULED_PER_CLIENT,
    ScheduledCount,
    check_batch,
    check_read,
    check_rep_work,
)
from vdevd.devices.base import Card
from vdevd.errors import ErrorCode, StartError, VdevError
from vdevd.irq import IrqEvent
from vdevd.metrics import Samples, TaggedSamples
from vdevd.pacing import ClockMode, Pacer, Waker
from vdevd.protocol import (
    CAPABILITIES,
    MAX_MESSAGE,
    MAX_WAIT_NS,
    SCHEMA,
    VERSION,
    Access,
    Request,
)
from vdevd.region import Region
from vdevd.rt import kernel
from vdevd.rt.scheduler import Scheduler
from vdevd.scope.op import Scopes
from vdevd.shm import Segment
from vdevd.snapshot_transfer import Transfers
from vdevd.waits import MAX_PENDING, Reply, Waiter, Waits, make_waiter, value_wait

log = logging.getLogger("vdevd.rack")

__all__ = ["ClockMode", "EventSink", "NullSink", "Rack"]


class EventSink(Protocol):
    """Where the rack's events go (the server's PUB socket; PROTOCOL.md "Events")."""

    @property
    def endpoint(self) -> str:
        """The endpoint subscribers connect to ("" when there is none), for `hello`."""
        ...

    def publish(self, event: IrqEvent) -> None:
        """An interrupt assertion, on the card's topic."""

    def sync(self, card: str) -> None:
        """A `sync` event on the card's topic (the `sync` request)."""


class NullSink:
    """An event sink that drops everything (a rack served by no socket)."""

    endpoint = ""

    def publish(self, event: IrqEvent) -> None:
        pass

    def sync(self, card: str) -> None:
        pass


class Rack:
    """Every card of one daemon, on one clock."""

    def __init__(
        self,
        cards: Iterable[Card],
        mode: ClockMode = "lockstep",
        *,
        sink: EventSink | None = None,
        wake_ns: int = 1_000_000,
        waker: Waker = "thread",
        clock: Callable[[], int] = time.perf_counter_ns,
        skip_quiet: bool = True,
        memory: Segment | None = None,
        max_scheduled_per_client: int = MAX_SCHEDULED_PER_CLIENT,
        max_scheduled: int = MAX_SCHEDULED,
    ) -> None:
        """`sink`: where events go (default: nowhere); `wake_ns`, `waker`, `clock`: the
        realtime pacing (`Pacer`); `skip_quiet`: whether cards at rest run their quiet ticks in
        closed form (`Card.tick`; false ticks every period in full); `memory`: the shared
        segment the cards' passive regions were built on (`CardContext.memory`), announced to
        local clients and removed at `stop`; `max_scheduled_per_client`, `max_scheduled`: the
        scheduled `control` actions one client, and all, may have pending."""
        self.skip_quiet = skip_quiet
        self.cards: dict[str, Card] = {}
        self._regions: dict[tuple[str, str], Region] = {}
        self.reads = 0  # counted apart from `requests`: the hot path keeps no dict
        self.sched = Scheduler([])
        for card in cards:
            self.add_card(card)
        self.mode: ClockMode = mode
        self.sink: EventSink = sink if sink is not None else NullSink()
        self.memory = memory
        self.waits = Waits(self._internal)
        #: scheduled `control` actions pending, per client and in all (`busy` past the limits)
        self.scheduled = ScheduledCount(max_scheduled_per_client, max_scheduled)
        #: the ops of batches with a wait not yet answered (bounds.MAX_HELD_OPS)
        self.held_ops = 0
        #: who sent the request being served (`Request.client`)
        self._client = b""
        self.pacer = Pacer(self.sched, self.waits, mode, wake_ns=wake_ns, waker=waker,
                           clock=clock)
        # stats
        self.started_monotonic_ns = time.monotonic_ns()
        self.requests: dict[str, int] = {}
        self.errors = 0
        self.latency = TaggedSamples()  # tagged with the op (metrics.OP_TAGS)
        self.events_published = 0
        #: the scope's recorder of each card (`scope` op)
        self.scopes = Scopes()
        #: the ops a batch runs as requests (its plain accesses run inline)
        self._batchable: dict[str, Callable[[dict[str, Any], Reply], Any]] = {
            "read": self.op_read, "write": self.op_write, "control": self.op_control}
        #: op -> its handler (every op of protocol.SCHEMA has an `op_<name>`)
        self._handlers: dict[str, Callable[[dict[str, Any], Reply], Any]] = {
            name: getattr(self, "op_" + name) for name in SCHEMA}
        #: the snapshot transfers under way (`op_snapshot`)
        self.transfers = Transfers()
        #: how a loaded snapshot replaces this rack in the server serving it (`Server` sets it:
        #: called with the file and the reply); None: `snapshot load` is refused
        self.on_restore: Callable[[bytes, Reply], None] | None = None

    def add_card(self, card: Card) -> None:
        if card.name in self.cards:
            raise ValueError(f"duplicate card name {card.name!r}")
        self.cards[card.name] = card
        card.skip_quiet = self.skip_quiet
        self.sched.add(card)
        self._regions.update({(card.name, r.name): r for r in card.regions.values()})

    # -- snapshots (vdevd/snapshot.py) --------------------------------------------------------------
    def snapshot(self) -> bytes:
        """Every card's state and the simulated clock, as one versioned file."""
        return snapshot.save(self)

    def restore(self, data: bytes, memory: Segment | None = None) -> Rack:
        """A NEW rack with this one's settings, the cards and clock of the snapshot `data`, its
        shared regions in `memory`; this rack is untouched. `bad_snapshot` naming why a snapshot
        does not load (another version or layout, truncated, changed). Its NV images go to the
        store once it serves (`snapshot.write_nv_images`, `Server.restore`)."""
        return snapshot.load(data, self, memory)

    def empty_like(self, memory: Segment | None = None) -> Rack:
        """A rack with no card and this one's settings and event sink."""
        p = self.pacer
        return Rack([], self.mode, sink=self.sink, wake_ns=p.wake_ns, waker=p.waker,
                    clock=p.clock, skip_quiet=self.skip_quiet, memory=memory,
                    max_scheduled_per_client=self.scheduled.per_client,
                    max_scheduled=self.scheduled.limit)

    def adopt(self, sched: Scheduler) -> None:
        """Serve the cards of `sched` on its clock (a restored snapshot's, to an empty rack)."""
        self.sched = self.pacer.sched = sched
        self.cards, self._regions = {}, {}
        for card in sched.cards:
            assert isinstance(card, Card)
            self.cards[card.name] = card
            self._regions.update({(card.name, r.name): r for r in card.regions.values()})

    # -- events ------------------------------------------------------------------------------------
    def emit(self, event: IrqEvent) -> None:
        """The sink every card's interrupt lines report to."""
        self.events_published += 1
        self.sink.publish(event)

    @property
    def events_endpoint(self) -> str:
        return self.sink.endpoint

    @property
    def now_ns(self) -> int:
        return self.sched.now_ns

    # -- running (vdevd/pacing.py) -----------------------------------------------------------------
    def start(self, loop: asyncio.AbstractEventLoop) -> None:
        """Attach to the event loop; in realtime start pacing simulated time to wall time."""
        self.pacer.start(loop)

    async def open_services(self) -> None:
        """Each card's own listeners (e.g. the PMAC Ethernet port), after `start`; a listener
        that cannot start is a `StartError` naming the card as the configuration counts it
        (`card[2] (pmac0) ethernet: 127.0.0.1:1025 already in use`)."""
        for i, card in enumerate(self.cards.values()):
            try:
                await card.open_services()
            except StartError as exc:
                raise StartError(f"card[{i}] ({card.name}) {exc}") from None

    async def close_services(self) -> None:
        for card in self.cards.values():
            try:
                await card.close_services()
            except Exception:  # one card's listener must not keep the others open
                log.exception("closing the services of %s", card.name)

    def stop(self) -> None:
        """Stop pacing and remove the shared segment (the cards keep their memory)."""
        self.pacer.stop()
        if self.memory is not None:
            self.memory.close()

    def catch_up(self) -> None:
        """Realtime: run the ticks fallen due since the last pass (`Pacer.catch_up`)."""
        self.pacer.catch_up()

    # the pacing's counters, as the rack's (stats, tests)
    @property
    def passes(self) -> int:
        return self.pacer.passes

    @property
    def catch_ups(self) -> int:
        return self.pacer.catch_ups

    @property
    def overruns(self) -> int:
        return self.pacer.overruns

    @property
    def late(self) -> Samples:
        return self.pacer.late

    @property
    def behind(self) -> Samples:
        return self.pacer.behind

    @property
    def card_faults(self) -> int:
        """Ticks and scheduled backdoor actions that raised."""
        return self.pacer.card_faults + self.waits.control_faults

    def _add_waiter(self, w: Waiter) -> None:
        if self.waits.add(w, self.now_ns):
            self.pacer.waiting()

    # -- requests ----------------------------------------------------------------------------------
    def execute(self, req: Request, reply: Reply) -> None:
        """Serve one request; `reply` gets the result or a VdevError, exactly once."""
        if self.pacer.paced:
            self.pacer.catch_up()
        op = req.op
        self.requests[op] = self.requests.get(op, 0) + 1
        self._client = req.client
        try:
            # `local` is set on a hello only (the server's knowledge of the peer)
            result = self.hello(local=True) if req.local else self._handlers[op](req.args, reply)
        except VdevError as exc:
            self.errors += 1
            reply(exc)
            return
        except Exception as exc:
            reply(self._internal(exc, req.op))
            return
        if result is not _DEFERRED:
            reply(result)

    def _internal(self, exc: Exception, what: str) -> VdevError:
        """A bug met while serving `what` (a card's hook or action, most likely): logged,
        counted, and answered as an `internal` error; the daemon goes on."""
        self.errors += 1
        log.error("internal error serving %s", what, exc_info=exc)
        return VdevError(ErrorCode.INTERNAL, f"{type(exc).__name__}: {exc}")

    def card(self, name: str) -> Card:
        card = self.cards.get(name)
        if card is None:
            raise VdevError(ErrorCode.NO_CARD, f"no card {name!r} (cards: {', '.join(self.cards)})")
        return card

    def region(self, card: str, region: str) -> Region:
        c = self.card(card)
        r = c.regions.get(region)
        if r is None:
            raise VdevError(
                ErrorCode.NO_REGION,
                f"card {card!r} has no region {region!r} (regions: {', '.join(c.regions)})",
            )
        return r

    def hello(self, local: bool = False) -> dict[str, Any]:
        """The `hello` result; to a `local` client (on this machine), with the shared memory
        that backs the regions' passive ranges (PROTOCOL.md "hello", decision 0010)."""
        info = {
            "protocol": VERSION,
            "server": "vdevd",
            "capabilities": list(CAPABILITIES),
            "max_message": MAX_MESSAGE,
            "events": self.events_endpoint,
            # a sink with no heartbeat (no events socket): 0
            "heartbeat_ns": getattr(self.sink, "heartbeat_ns", 0),
            "clock": {"mode": self.mode, "now_ns": self.now_ns, "tick_ns": self.sched.tick_ns},
            "cards": [c.describe() for c in self.cards.values()],
        }
        shm = self.shared_memory() if local else None
        if shm is not None:
            info["shm"] = shm
        return info

    def shared_memory(self) -> dict[str, Any] | None:
        """The segment (path, size, identity) and where each shared region starts in it
        ({card: {region: offset}}); None when no region is shared."""
        regions: dict[str, dict[str, int]] = {}
        for card in self.cards.values():
            for r in card.regions.values():
                if r.shared_offset is not None:
                    regions.setdefault(card.name, {})[r.name] = r.shared_offset
        if self.memory is None or not regions:
            return None
        return {**self.memory.describe(), "regions": regions}

    def op_hello(self, args: dict[str, Any], reply: Reply) -> Any:
        return self.hello()

    def _region_of(self, args: dict[str, Any]) -> Region:
        """The region an access names (the dict lookup first, the checks only when it misses)."""
        r = self._regions.get((args["card"], args["region"]))
        return r if r is not None else self.region(args["card"], args["region"])

    def op_read(self, args: dict[str, Any], reply: Reply) -> Any:
        check_read(args["size"])
        region = self._region_of(args)
        if args.get("rep"):
            check_rep_work(region.rep_hook_calls(args["offset"], args["size"], False))
            return region.read_rep(args["offset"], args["size"])
        return region.read(args["offset"], args["size"])

    def read(self, card: str, region: str, offset: int, size: int) -> bytes:
        """A `read` request on the hot path (protocol.read_fields): the same effects and
        counters as `execute` of a read, without building a Request."""
        if self.pacer.paced:
            self.pacer.catch_up()
        self.reads += 1
        r = self._regions.get((card, region))
        try:
            if size > MAX_READ:
                check_read(size)  # too_large before any work (bounds.py)
            if r is None:
                r = self.region(card, region)  # raises the error naming what is missing
            return r.read(offset, size)
        except VdevError:
            self.errors += 1
            raise

    def op_write(self, args: dict[str, Any], reply: Reply) -> Any:
        region = self._region_of(args)
        if args.get("rep"):
            check_rep_work(region.rep_hook_calls(args["offset"], len(args["data"]), True))
            region.write_rep(args["offset"], args["data"])
        else:
            region.write(args["offset"], args["data"])
        return None

    def op_batch(self, args: dict[str, Any], reply: Reply) -> Any:
        ops: list[Request | Access] = args["ops"]
        if not check_batch(ops, self._hook_calls):
            self._run_batch(ops, 0, [], reply)
            return _DEFERRED
        # a batch with a wait may be held until the wait resolves: its ops count against
        # MAX_HELD_OPS until it is answered
        n = len(ops)
        if self.held_ops + n > MAX_HELD_OPS:
            raise VdevError(ErrorCode.BUSY, f"batch of {n} ops with a wait: batches with waits "
                            f"hold {self.held_ops} ops, the most the daemon holds is "
                            f"{MAX_HELD_OPS}")
        self.held_ops += n
        held = [n]

        def answer(result: Any) -> None:
            self.held_ops -= held.pop() if held else 0
            reply(result)

        try:
            self._run_batch(ops, 0, [], answer)
        except BaseException:
            self.held_ops -= held.pop() if held else 0
            raise
        return _DEFERRED

    def _hook_calls(self, card: str, region: str, offset: int, size: int, write: bool,
                    rep: bool) -> int:
        """`Region.hook_calls` (`rep_hook_calls` for a repeated access) by name (0 for no such
        region: the op fails when it runs)."""
        r = self._regions.get((card, region))
        if r is None:
            return 0
        return r.rep_hook_calls(offset, size, write) if rep else r.hook_calls(offset, size, write)

    def _run_batch(self, ops: list[Request | Access], start: int, results: list[Any],
                   reply: Reply) -> None:
        """Run ops from `start`; a wait suspends the rest until it resolves (atomic after it).
        A wait that resolves at once goes on in this loop, not in a nested call, so a batch of
        many such waits takes no stack."""
        regions = self._regions
        append = results.append
        client = self._client  # the batch's, for a control op after a wait resumes it
        i = start
        while i < len(ops):
            op = ops[i]
            if type(op) is not Request:  # a plain access (protocol.Access), the usual op
                kind, card, name, offset, last = op  # type: ignore[misc]
                try:
                    region = regions.get((card, name))
                    if region is None:
                        region = self.region(card, name)
                    if kind == "r":
                        append(region.read(offset, last))
                    elif kind == "w":
                        region.write(offset, last)
                        append(None)
                    elif kind == "R":
                        append(region.read_rep(offset, last))
                    else:
                        region.write_rep(offset, last)
                        append(None)
                except VdevError as exc:
                    raise VdevError(exc.code, f"batch op {i}: {exc.message}") from None
                i += 1
                continue
            if op.op == "wait":
                quick = None if len(self.waits.pending) >= MAX_PENDING else value_wait(
                    op.args, self.cards, regions, self.now_ns)
                if type(quick) is dict:  # a wait on a value that holds: Waits.add's answer
                    append(quick)
                    i += 1
                    continue
                # until _add_waiter returns, a result is kept here and this loop goes on
                now: list[Any] = []

                def resume(res: Any, i: int = i, now: list[Any] = now) -> None:
                    if now == [None]:
                        now[0] = res  # resolved at once: the loop below takes it
                        return
                    if self._resumed(ops, i, results, reply, res):
                        self._client = client
                        try:
                            self._run_batch(ops, i + 1, results, reply)
                        except VdevError as exc:
                            reply(exc)
                        except Exception as exc:  # from Waits.service: no execute() around it
                            reply(self._internal(exc, f"batch op {i + 1}.."))

                now.append(None)
                if isinstance(quick, Waiter):  # made in a few operations, known not to hold
                    quick.reply = resume
                    self.waits.keep(quick)
                    self.pacer.waiting()
                else:
                    try:
                        waiter = self._make_waiter(op.args, resume)
                    except VdevError as exc:
                        raise VdevError(exc.code, f"batch op {i}: {exc.message}") from None
                    self._add_waiter(waiter)
                res = now.pop()
                if res is None:
                    return  # the wait goes on: resume runs the rest
                if not self._resumed(ops, i, results, reply, res):
                    return
                i += 1
                continue
            try:
                append(self._batchable[op.op](op.args, reply))
            except VdevError as exc:
                raise VdevError(exc.code, f"batch op {i}: {exc.message}") from None
            i += 1
        reply(results)

    @staticmethod
    def _resumed(ops: list[Request | Access], i: int, results: list[Any], reply: Reply,
                 res: Any) -> bool:
        """A batch's wait `i` resolved with `res`: True when the ops after it run; else the
        batch is answered (an error, or a wait that timed out: the rest are None)."""
        if isinstance(res, VdevError):
            reply(res)
            return False
        results.append(res)
        if not res.get("fired", True):
            results.extend([None] * (len(ops) - i - 1))
            reply(results)
            return False
        return True

    def _make_waiter(self, args: dict[str, Any], reply: Reply) -> Waiter:
        card = self.card(args["card"])
        return make_waiter(args, card, lambda name: self.region(card.name, name), self.now_ns,
                           reply)

    def op_wait(self, args: dict[str, Any], reply: Reply) -> Any:
        self._add_waiter(self._make_waiter(args, reply))
        return _DEFERRED

    def op_sim(self, args: dict[str, Any], reply: Reply) -> Any:
        action = args["action"]
        if action == "now":
            return self._clock_info()
        if action != "step":
            raise VdevError(ErrorCode.BAD_PARAM, f"sim: unknown action {action!r} (now, step)")
        if self.mode != "lockstep":
            raise VdevError(ErrorCode.WRONG_MODE, "sim step needs the lockstep clock")
        ns = self._step_ns(args)
        extra = {"mode": self.mode, "tick_ns": self.sched.tick_ns}
        self._add_waiter(Waiter(self.now_ns + ns, reply, extra=extra))
        return _DEFERRED

    def _step_ns(self, args: dict[str, Any]) -> int:
        given = [k for k in ("ns", "ticks", "seconds") if k in args]
        if len(given) != 1:
            raise VdevError(ErrorCode.BAD_PARAM, "sim step takes exactly one of ns, ticks, seconds")
        if "card" in args and "ticks" not in args:
            raise VdevError(ErrorCode.BAD_PARAM, "sim step: card goes with ticks (the card's "
                            "next ticks), not with ns or seconds")
        if "ns" in args:
            ns = args["ns"]
        elif "card" in args:  # to the card's `ticks`-th next tick, exact
            card, n = self.card(args["card"]), args["ticks"]
            if n < 0:
                raise VdevError(ErrorCode.BAD_PARAM, f"sim step of {n} ticks")
            ns = max(0, card.time_of_tick(card.ticks + n) - self.now_ns) if n > 0 else 0
        elif "ticks" in args:  # base ticks of the exact shortest period
            base = self.sched.base_period
            ns = args["ticks"] * base.numerator // base.denominator
        else:
            seconds = float(args["seconds"])
            if not 0 <= seconds <= MAX_WAIT_NS / 1e9:  # also NaN and infinities
                raise VdevError(ErrorCode.BAD_PARAM, f"sim step of {seconds} s outside "
                                f"0..{MAX_WAIT_NS // 10**9} s")
            ns = round(seconds * 1e9)
        if not 0 <= ns <= MAX_WAIT_NS:
            raise VdevError(ErrorCode.BAD_PARAM, f"sim step of {ns} ns outside 0..{MAX_WAIT_NS}")
        return int(ns)

    def _clock_info(self) -> dict[str, Any]:
        return {"now_ns": self.now_ns, "mode": self.mode, "tick_ns": self.sched.tick_ns}

    def op_control(self, args: dict[str, Any], reply: Reply) -> Any:
        card = self.card(args["card"])
        action, params = args["action"], args.get("params") or {}
        if any(not isinstance(k, str) for k in params):
            raise VdevError(ErrorCode.MALFORMED, "control: params keys must be strings")
        when = self._control_time(args)
        if when is None or when <= self.now_ns:
            return card.control(action, params)
        card.check_control(action, params)
        client, scheduled = self._client, self.scheduled
        scheduled.reserve(client)
        self.waits.schedule_control(when, card, action, params,
                                    done=lambda: scheduled.release(client))
        return {"scheduled_ns": when}

    def _control_time(self, args: dict[str, Any]) -> int | None:
        """When a `control` runs: None (now), or `at_ns`, or now + `after_ns`; one day ahead at
        most. A time not after now runs the action at once."""
        if "at_ns" in args and "after_ns" in args:
            raise VdevError(ErrorCode.BAD_PARAM, "control: at_ns and after_ns exclude each other")
        if "after_ns" in args:
            after = args["after_ns"]
            if not 0 <= after <= MAX_WAIT_NS:
                raise VdevError(ErrorCode.BAD_PARAM, f"control: after_ns {after} outside "
                                f"0..{MAX_WAIT_NS}")
            return int(self.now_ns + after)
        if "at_ns" in args:
            at = args["at_ns"]
            if at > self.now_ns + MAX_WAIT_NS:
                raise VdevError(ErrorCode.BAD_PARAM, f"control: at_ns {at} is more than a day "
                                f"after now ({self.now_ns})")
            return int(at)
        return None

    def op_sync(self, args: dict[str, Any], reply: Reply) -> Any:
        """Publish a `sync` event on the card's topic (a subscriber's proof it is connected)."""
        self.sink.sync(self.card(args["card"]).name)
        return None

    def op_scope(self, args: dict[str, Any], reply: Reply) -> Any:
        """Arm, report, read or clear a card's scope (PROTOCOL.md "Scope")."""
        return self.scopes.op(self.card(args["card"]), args)

    def op_snapshot(self, args: dict[str, Any], reply: Reply) -> Any:
        """`save`: the chunk at `offset` of a snapshot (taken at offset 0); `load`: a chunk of
        a snapshot to restore, restored once its last chunk is here (PROTOCOL.md "snapshot")."""
        action, offset = args["action"], args.get("offset", 0)
        if action == "save":
            if self.scheduled.total:
                raise VdevError(ErrorCode.BUSY, f"snapshot save: {self.scheduled.total} "
                                "scheduled control actions pending (a snapshot holds none)")
            return self.transfers.read(self._client, offset, self.snapshot)
        if action != "load":
            raise VdevError(ErrorCode.BAD_PARAM, f"snapshot: unknown action {action!r} "
                            "(save, load)")
        if "size" not in args or "data" not in args:
            raise VdevError(ErrorCode.MALFORMED, "snapshot load: give size and data")
        data = self.transfers.write(self._client, offset, args["size"], bytes(args["data"]))
        if data is None:
            return {"received": offset + len(args["data"])}
        if self.on_restore is None:
            raise VdevError(ErrorCode.WRONG_MODE, "snapshot load: this rack is served by no "
                            "server that can swap it")
        self.on_restore(data, reply)
        return _DEFERRED

    def op_stats(self, args: dict[str, Any], reply: Reply) -> Any:
        return self.stats()

    def stats(self) -> dict[str, Any]:
        lost = self.sched.lost_ticks()
        return {
            "clock": {
                **self._clock_info(),
                "epoch_monotonic_ns": self.pacer.t0,
                "wake_ns": self.pacer.wake_ns,
                "waker": self.pacer.waker,
            },
            "scheduler": {
                "passes": self.passes,
                "catch_ups": self.catch_ups,
                "continuations": self.pacer.continuations,
                "overruns": self.overruns,
                "late_ns": self.late.summary(),
                "behind_ns": self.behind.summary(),
                "answered_behind_ns": self.pacer.answered_behind.summary(),
                "card_faults": self.card_faults,
                "lost_ticks": sum(lost.values()),
                "stalls": dict(self.pacer.stalls),
            },
            "overload": self.pacer.overload_stats(),
            "motion_core": "compiled" if kernel.compiled() is not None else "numpy",
            "cards": {
                c.name: {"ticks": c.ticks, "lost_ticks": lost[c.name], "irq_seq": c.irq_seq,
                         "quiet_ticks": c.quiet_skipped}
                for c in self.cards.values()
            },
            "requests": {
                "by_op": {**self.requests,
                          "read": self.requests.get("read", 0) + self.reads},
                "errors": self.errors + self.waits.control_errors,
                "latency_ns": self.latency.summary(),
                "pending_waits": len(self.waits.pending),
                "scheduled": self.scheduled.total,
            },
            "events_published": self.events_published,
            "uptime_s": (time.monotonic_ns() - self.started_monotonic_ns) / 1e9,
        }


class _Deferred:
    """Marker: the handler will call `reply` later."""


_DEFERRED = _Deferred()
