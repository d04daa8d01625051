"""The rack: the cards by name, the clock, the scheduler, and the operations of protocol v1.

Sans-I/O except for the event loop's timers: `execute(request, reply)` serves one validated
request and calls `reply(result)` or `reply(VdevError)` exactly once, at once or later (a wait).
Interrupt events go to the `publish` callable given at construction.
"""

from __future__ import annotations

import asyncio
import heapq
import itertools
import logging
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Literal

from vdevd.devices.base import Card
from vdevd.errors import ErrorCode, VdevError
from vdevd.irq import IrqEvent
from vdevd.metrics import Samples
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
from vdevd.rt.scheduler import Scheduler

log = logging.getLogger("vdevd.rack")

ClockMode = Literal["realtime", "lockstep"]
Reply = Callable[[Any], None]

#: waits that may be pending at once, over all clients
MAX_PENDING = 1024
#: lockstep: simulated ticks run between two looks at the socket while time is driven
LOCKSTEP_CHUNK_TICKS = 1000


@dataclass(eq=False)
class Waiter:
    """A pending `wait` (or a lockstep `sim step`): resolved by its condition or its deadline."""

    deadline_ns: int
    reply: Reply
    card: Card | None = None
    on: str = "step"  # "step" | "irq" | "value"
    line: str | None = None
    after_seq: int = 0
    region: Region | None = None
    offset: int = 0
    size: int = 4
    mask: int = 0xFFFFFFFF
    value: int = 0
    equal: bool = True
    extra: dict[str, Any] = field(default_factory=dict)

    def fired(self) -> dict[str, Any] | None:
        """The result if the condition holds now, else None."""
        if self.on == "irq":
            assert self.card is not None
            event = (
                self.card.last_event if self.line is None else self.card.line_events.get(self.line)
            )
            if event is not None and event.seq > self.after_seq:
                return {"fired": True, "event": event.as_dict()}
            return None
        if self.on == "value":
            assert self.region is not None
            raw = self.region.get_peek(self.offset, self.size)
            if ((raw & self.mask) == self.value) == self.equal:
                return {"fired": True, "value": raw}
        return None


class Rack:
    """Every card of one daemon, on one clock."""

    def __init__(
        self,
        cards: Iterable[Card],
        mode: ClockMode = "lockstep",
        *,
        publish: Callable[[IrqEvent], None] | None = None,
        events_endpoint: str = "",
        wake_ns: int = 1_000_000,
        waker: Literal["timer", "thread"] = "thread",
        clock: Callable[[], int] = time.perf_counter_ns,
    ) -> None:
        """`clock`: the monotonic wall clock in ns that realtime follows (a test may pass its own)."""
        self.cards: dict[str, Card] = {}
        self._regions: dict[tuple[str, str], Region] = {}
        self.reads = 0  # counted apart from `requests`: the hot path keeps no dict
        self.sched = Scheduler([])
        for card in cards:
            self.add_card(card)
        self.mode: ClockMode = mode
        self.publish = publish
        self.publish_sync: Callable[[str], None] | None = None
        self.events_endpoint = events_endpoint
        self.wake_ns = wake_ns
        self.waker = waker
        self._clock = clock
        self._waiters: list[Waiter] = []
        self._timers: list[tuple[int, int, Callable[[], None]]] = []
        self._seq = itertools.count()
        self._driving = False
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0  # realtime: the wall clock reading at simulated time 0
        self._paced = False  # realtime and started: requests first run the ticks fallen due
        self._next_wake = 0
        # stats
        self.started_monotonic_ns = time.monotonic_ns()
        self.late = Samples()
        self.behind = Samples()
        self.passes = 0
        self.catch_ups = 0
        self.overruns = 0
        self.card_faults = 0
        self.requests: dict[str, int] = {}
        self.errors = 0
        self.latency = Samples()
        self.events_published = 0
        #: the ops a batch runs as requests (its plain accesses run inline)
        self._batchable: dict[str, Callable[[dict[str, Any], Reply], Any]] = {
            "read": self.op_read, "write": self.op_write, "control": self.op_control}
        #: op -> its handler (every op of protocol.SCHEMA has an `op_<name>`)
        self._handlers: dict[str, Callable[[dict[str, Any], Reply], Any]] = {
            name: getattr(self, "op_" + name) for name in SCHEMA}

    def add_card(self, card: Card) -> None:
        if card.name in self.cards:
            raise ValueError(f"duplicate card name {card.name!r}")
        self.cards[card.name] = card
        self.sched.add(card)
        self._regions.update({(card.name, r.name): r for r in card.regions.values()})

    # -- events ------------------------------------------------------------------------------------
    def emit(self, event: IrqEvent) -> None:
        """The sink every card's interrupt lines report to."""
        self.events_published += 1
        if self.publish is not None:
            self.publish(event)

    @property
    def now_ns(self) -> int:
        return self.sched.now_ns

    # -- running -----------------------------------------------------------------------------------
    def start(self, loop: asyncio.AbstractEventLoop) -> None:
        """Attach to the event loop; in realtime start pacing simulated time to wall time."""
        self._loop = loop
        if self.mode != "realtime":
            return
        self._t0 = self._clock() - self.sched.now_ns
        self._paced = True
        self._next_wake = self.sched.now_ns + self.wake_ns
        if self.waker == "thread":
            self._thread = threading.Thread(target=self._wake_thread, name="vdevd-waker",
                                            daemon=True)
            self._thread.start()
        else:
            loop.call_later(self.wake_ns / 1e9, self._pass)

    async def open_services(self) -> None:
        """Each card's own listeners (e.g. the PMAC Ethernet port), after `start`."""
        for card in self.cards.values():
            await card.open_services()

    async def close_services(self) -> None:
        for card in self.cards.values():
            try:
                await card.close_services()
            except Exception:  # one card's listener must not keep the others open
                log.exception("closing the services of %s", card.name)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)

    def _wake_thread(self) -> None:
        """Sleep to each wake deadline, then hand the pass to the event loop (no shared state)."""
        assert self._loop is not None
        loop, period, t0, clock = self._loop, self.wake_ns, self._t0, self._clock
        deadline = t0 + ((clock() - t0) // period + 1) * period
        while not self._stop.is_set():
            delay = deadline - clock()
            if delay > 0:
                time.sleep(delay / 1e9)
            try:
                loop.call_soon_threadsafe(self._pass)
            except RuntimeError:  # loop closed
                return
            deadline = t0 + ((clock() - t0) // period + 1) * period

    def _pass(self) -> None:
        """Realtime: run every tick due by wall time (a batch after a late wake), then waiters."""
        if self._stop.is_set():
            return
        wall = self._clock() - self._t0
        self.passes += 1
        self.late.add(wall - self._next_wake)
        self.behind.add(wall - self.sched.now_ns)
        if wall - self._next_wake >= self.wake_ns:
            self.overruns += 1
        self._advance(wall)
        self._service()
        self._next_wake = wall - wall % self.wake_ns + self.wake_ns
        if self.waker == "timer" and self._loop is not None:
            delay = self._next_wake - (self._clock() - self._t0)
            self._loop.call_later(max(delay, 0) / 1e9, self._pass)

    def _advance(self, target_ns: int, stop: Callable[[], bool] | None = None) -> int:
        try:
            return self.sched.advance(target_ns, stop)
        except Exception:
            # A card bug must not stop the rack: log it, count it, keep time moving.
            self.card_faults += 1
            log.exception("card raised during a tick; time continues")
            self.sched.settle(max(self.sched.now_ns, min(target_ns, self.sched.next_tick_ns())))
            return self.sched.now_ns

    def _service(self) -> None:
        """Run due timers, then resolve every waiter whose condition or deadline has come."""
        now = self.sched.now_ns
        while self._timers and self._timers[0][0] <= now:
            _, _, action = heapq.heappop(self._timers)
            action()
        if not self._waiters:
            return
        keep: list[Waiter] = []
        waiters, self._waiters = self._waiters, []
        for w in waiters:
            try:
                result = w.fired()
            except Exception as exc:  # a card's peek hook with a bug: this waiter only
                w.reply(self._internal(exc, f"wait on {w.on}"))
                continue
            if result is None and now >= w.deadline_ns:
                result = {"fired": False} if w.on != "step" else {}
            if result is None:
                keep.append(w)
                continue
            result["now_ns"] = now
            result.update(w.extra)
            w.reply(result)
        self._waiters = keep + self._waiters  # a reply may have added waits (a batch resuming)

    def _add_waiter(self, w: Waiter) -> None:
        if len(self._waiters) >= MAX_PENDING:
            raise VdevError(ErrorCode.BUSY, f"more than {MAX_PENDING} waits pending")
        result = w.fired()
        if result is not None or (w.on == "step" and w.deadline_ns <= self.now_ns):
            result = result or {}
            result["now_ns"] = self.now_ns
            result.update(w.extra)
            w.reply(result)
            return
        self._waiters.append(w)
        if self.mode == "lockstep" and not self._driving:
            self._driving = True
            if self._loop is None:
                self._drive_sync()
                return
            # The first chunk at once: a wait that resolves in it (a reply at the next tick)
            # costs no trip through the event loop; the rest runs as a task, between requests.
            try:
                self._drive_step()
            finally:
                if self._waiters:
                    self._loop.create_task(self._drive())
                else:
                    self._driving = False

    def _lockstep_target(self) -> tuple[int, bool]:
        """Where lockstep time goes next, and whether it must go tick by tick."""
        target = min(w.deadline_ns for w in self._waiters)
        if self._timers:
            target = min(target, self._timers[0][0])
        chunk_end = self.sched.now_ns + LOCKSTEP_CHUNK_TICKS * self.sched.tick_ns
        fine = any(w.on != "step" for w in self._waiters)
        return min(target, chunk_end), fine

    def _drive_step(self) -> None:
        target, fine = self._lockstep_target()
        stop = self._any_fired if fine else None
        self._advance(max(target, self.sched.now_ns), stop)
        self._service()

    def _any_fired(self) -> bool:
        """Whether a waiter resolves now; one whose condition raises does (_service answers it)."""
        try:
            return any(w.fired() is not None for w in self._waiters)
        except Exception:
            return True

    async def _drive(self) -> None:
        """Lockstep: advance time while anyone waits, looking at the sockets between chunks."""
        try:
            while self._waiters:
                self._drive_step()
                await asyncio.sleep(0)
        finally:
            self._driving = False

    def _drive_sync(self) -> None:
        """Lockstep without an event loop (in-process use and tests)."""
        try:
            while self._waiters:
                self._drive_step()
        finally:
            self._driving = False

    # -- requests ----------------------------------------------------------------------------------
    def catch_up(self) -> None:
        """Realtime: run the ticks that fell due since the last pass, so that a request sees the
        hardware as it is at this wall time (within one servo period), not as at the last wake."""
        if self._paced:
            wall = self._clock() - self._t0
            if wall - self.sched.now_ns >= self.sched.tick_ns:
                self.catch_ups += 1
                self._advance(wall)
                self._service()

    def execute(self, req: Request, reply: Reply) -> None:
        """Serve one request; `reply` gets the result or a VdevError, exactly once."""
        if self._paced:
            self.catch_up()
        op = req.op
        self.requests[op] = self.requests.get(op, 0) + 1
        try:
            result = self._handlers[op](req.args, reply)
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

    def hello(self) -> dict[str, Any]:
        return {
            "protocol": VERSION,
            "server": "vdevd",
            "capabilities": list(CAPABILITIES),
            "max_message": MAX_MESSAGE,
            "events": self.events_endpoint,
            "clock": {"mode": self.mode, "now_ns": self.now_ns, "tick_ns": self.sched.tick_ns},
            "cards": [c.describe() for c in self.cards.values()],
        }

    def op_hello(self, args: dict[str, Any], reply: Reply) -> Any:
        return self.hello()

    def _region_of(self, args: dict[str, Any]) -> Region:
        """The region an access names (the dict lookup first, the checks only when it misses)."""
        r = self._regions.get((args["card"], args["region"]))
        return r if r is not None else self.region(args["card"], args["region"])

    def op_read(self, args: dict[str, Any], reply: Reply) -> Any:
        region = self._region_of(args)
        if args.get("rep"):
            return region.read_rep(args["offset"], args["size"])
        return region.read(args["offset"], args["size"])

    def read(self, card: str, region: str, offset: int, size: int) -> bytes:
        """A `read` request on the hot path (protocol.read_fields): the same effects and
        counters as `execute` of a read, without building a Request."""
        if self._paced:
            self.catch_up()
        self.reads += 1
        r = self._regions.get((card, region))
        try:
            if r is None:
                r = self.region(card, region)  # raises the error naming what is missing
            return r.read(offset, size)
        except VdevError:
            self.errors += 1
            raise

    def op_write(self, args: dict[str, Any], reply: Reply) -> Any:
        region = self._region_of(args)
        if args.get("rep"):
            region.write_rep(args["offset"], args["data"])
        else:
            region.write(args["offset"], args["data"])
        return None

    def op_batch(self, args: dict[str, Any], reply: Reply) -> Any:
        ops: list[Request | Access] = args["ops"]
        results: list[Any] = []
        self._run_batch(ops, 0, results, reply)
        return _DEFERRED

    def _run_batch(self, ops: list[Request | Access], start: int, results: list[Any],
                   reply: Reply) -> None:
        """Run ops from `start`; a wait suspends the rest until it resolves (atomic after it)."""
        regions = self._regions
        append = results.append
        for i in range(start, len(ops)):
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
                continue
            if op.op == "wait":
                def resume(res: Any, i: int = i) -> None:
                    if isinstance(res, VdevError):
                        reply(res)
                        return
                    results.append(res)
                    if not res.get("fired", True):
                        results.extend([None] * (len(ops) - i - 1))
                        reply(results)
                        return
                    try:
                        self._run_batch(ops, i + 1, results, reply)
                    except VdevError as exc:
                        reply(exc)
                    except Exception as exc:  # resumed from _service: no execute() around it
                        reply(self._internal(exc, f"batch op {i + 1}.."))

                try:
                    waiter = self._make_waiter(op.args, resume)
                except VdevError as exc:
                    raise VdevError(exc.code, f"batch op {i}: {exc.message}") from None
                self._add_waiter(waiter)
                return
            try:
                append(self._batchable[op.op](op.args, reply))
            except VdevError as exc:
                raise VdevError(exc.code, f"batch op {i}: {exc.message}") from None
        reply(results)

    def _make_waiter(self, args: dict[str, Any], reply: Reply) -> Waiter:
        card = self.card(args["card"])
        timeout = args["timeout_ns"]
        if not 0 <= timeout <= MAX_WAIT_NS:
            raise VdevError(ErrorCode.BAD_PARAM, f"timeout_ns {timeout} outside 0..{MAX_WAIT_NS}")
        w = Waiter(self.now_ns + timeout, reply, card=card, on=args["on"])
        if w.on == "irq":
            line = args.get("line")
            if line is not None and line not in card.irq_lines:
                raise VdevError(
                    ErrorCode.NO_IRQ,
                    f"card {card.name!r} has no irq line {line!r} "
                    f"(lines: {', '.join(card.irq_lines)})",
                )
            w.line = line
            w.after_seq = args.get("after_seq", card.irq_seq)
        elif w.on == "value":
            for key in ("region", "offset", "value"):
                if key not in args:
                    raise VdevError(ErrorCode.MALFORMED, f"wait on value: missing field {key!r}")
            w.region = self.region(card.name, args["region"])
            w.offset, w.size = args["offset"], args.get("size", 4)
            if w.size not in (1, 2, 4, 8):
                raise VdevError(ErrorCode.BAD_WIDTH, f"wait on value: size {w.size} not 1/2/4/8")
            w.region.peek(w.offset, w.size)  # bounds check now, not at every tick
            full = (1 << (8 * w.size)) - 1
            w.mask = args.get("mask", full)
            w.value = args["value"]
            if not 0 <= w.mask <= full:
                raise VdevError(ErrorCode.BAD_PARAM,
                                f"wait on value: mask {w.mask:#x} outside {w.size} bytes")
            if w.value & ~w.mask:  # also a negative value
                raise VdevError(ErrorCode.BAD_PARAM, f"wait on value: value {w.value:#x} has "
                                f"bits outside the mask {w.mask:#x}")
            cmp = args.get("cmp", "eq")
            if cmp not in ("eq", "ne"):
                raise VdevError(ErrorCode.BAD_PARAM, f"wait on value: cmp {cmp!r} not eq or ne")
            w.equal = cmp == "eq"
        else:
            raise VdevError(ErrorCode.BAD_PARAM, f"wait: 'on' must be irq or value, not {w.on!r}")
        return w

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
        if "ns" in args:
            ns = args["ns"]
        elif "ticks" in args:
            period = self.card(args["card"]).period_ns if "card" in args else self.sched.tick_ns
            ns = args["ticks"] * period
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

        def later() -> None:
            try:
                card.control(action, params)
            except VdevError as exc:
                log.warning("scheduled control %s.%s failed: %s", card.name, action, exc.message)
            except Exception:  # a bug in the card's backdoor must not stop the clock
                self.card_faults += 1
                log.exception("scheduled control %s.%s raised", card.name, action)

        heapq.heappush(self._timers, (when, next(self._seq), later))
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
        card = self.card(args["card"])
        if self.publish_sync is not None:
            self.publish_sync(card.name)
        return None

    def op_stats(self, args: dict[str, Any], reply: Reply) -> Any:
        return self.stats()

    def stats(self) -> dict[str, Any]:
        lost = self.sched.lost_ticks()
        return {
            "clock": {
                **self._clock_info(),
                "epoch_monotonic_ns": self._t0,
                "wake_ns": self.wake_ns,
                "waker": self.waker,
            },
            "scheduler": {
                "passes": self.passes,
                "catch_ups": self.catch_ups,
                "overruns": self.overruns,
                "late_ns": self.late.summary(),
                "behind_ns": self.behind.summary(),
                "card_faults": self.card_faults,
                "lost_ticks": sum(lost.values()),
            },
            "cards": {
                c.name: {"ticks": c.ticks, "lost_ticks": lost[c.name], "irq_seq": c.irq_seq}
                for c in self.cards.values()
            },
            "requests": {
                "by_op": {**self.requests,
                          "read": self.requests.get("read", 0) + self.reads},
                "errors": self.errors,
                "latency_ns": self.latency.summary(),
                "pending_waits": len(self._waiters),
            },
            "events_published": self.events_published,
            "uptime_s": (time.monotonic_ns() - self.started_monotonic_ns) / 1e9,
        }


class _Deferred:
    """Marker: the handler will call `reply` later."""


_DEFERRED = _Deferred()
