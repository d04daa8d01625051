"""Pending waits and timers of the rack (DESIGN.md "Clock and scheduler", decision 0002).

A `Waiter` is a `wait` request (or a lockstep `sim step`) resolved by its condition or its
deadline; `Waits` holds the pending ones (at most MAX_PENDING) and the timer heap of scheduled
`control` actions, and `service(now)` answers what has come due. No clock of its own: the rack's
pacing calls `service` after every advance.
"""

from __future__ import annotations

import heapq
import itertools
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from vdevd.devices.base import Card
from vdevd.errors import ErrorCode, VdevError
from vdevd.protocol import MAX_WAIT_NS
from vdevd.region import Region

log = logging.getLogger("vdevd.rack")

Reply = Callable[[Any], None]
#: a bug met while serving `what` -> the `internal` error to answer (logged and counted)
Internal = Callable[[Exception, str], VdevError]

#: waits that may be pending at once, over all clients
MAX_PENDING = 1024
#: due timers (scheduled `control` actions) one `service` runs: a backdoor action costs up to
#: about 0.5 ms, so 128 of them hold the event loop some 60 ms
TIMERS_A_SERVICE = 128


@dataclass(eq=False, slots=True)
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


def make_waiter(args: Mapping[str, Any], card: Card, region: Callable[[str], Region],
                now_ns: int, reply: Reply) -> Waiter:
    """The waiter of a validated `wait` request on `card` (PROTOCOL.md, wait); `region(name)`
    is the card's region or the `no_region` error."""
    timeout = args["timeout_ns"]
    if not 0 <= timeout <= MAX_WAIT_NS:
        raise VdevError(ErrorCode.BAD_PARAM, f"timeout_ns {timeout} outside 0..{MAX_WAIT_NS}")
    w = Waiter(now_ns + timeout, reply, card=card, on=args["on"])
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
        w.region = region(args["region"])
        w.offset, w.size = args["offset"], args.get("size", 4)
        if w.size not in (1, 2, 4, 8):
            raise VdevError(ErrorCode.BAD_WIDTH, f"wait on value: size {w.size} not 1/2/4/8")
        w.region.get_peek(w.offset, w.size)  # bounds check now (and plan the peek), not at every tick
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


def value_wait(args: Mapping[str, Any], cards: Mapping[str, Card],
               regions: Mapping[tuple[str, str], Region], now_ns: int
               ) -> dict[str, Any] | Waiter | None:
    """A batch's wait on a value (`args` of a validated `wait`) in a few operations, when every
    field is one `make_waiter` accepts: what `Waits.add` answers at once if its condition holds
    now ({fired, value, now_ns}: an RTC post's first wait, for the idle 3C2h), else its waiter as
    `make_waiter` makes it, with no `reply` yet (the caller sets it, then adds it). None for
    anything else (another kind of wait, a field `make_waiter` refuses, a card or region not
    there): `make_waiter` and `Waits.add` then take it as always, and raise what they raise."""
    if args.get("on") != "value":
        return None
    name = args.get("card")
    card, region = cards.get(name), regions.get((name, args.get("region")))  # type: ignore[arg-type]
    size = args.get("size", 4)
    if card is None or region is None or "offset" not in args or "value" not in args \
            or size not in (1, 2, 4, 8):
        return None
    full = (1 << (8 * size)) - 1
    mask, value, cmp, timeout = (args.get("mask", full), args["value"], args.get("cmp", "eq"),
                                 args["timeout_ns"])
    if not 0 <= timeout <= MAX_WAIT_NS or cmp not in ("eq", "ne") or not 0 <= mask <= full \
            or value & ~mask:
        return None
    offset = args["offset"]
    try:
        raw = region.get_peek(offset, size)  # (make_waiter's bounds check)
    except VdevError:  # out of bounds: make_waiter says so
        return None
    equal = cmp == "eq"
    if ((raw & mask) == value) == equal:
        return {"fired": True, "value": raw, "now_ns": now_ns}
    return Waiter(now_ns + timeout, _UNSET, card=card, on="value", region=region, offset=offset,
                  size=size, mask=mask, value=value, equal=equal)


def _UNSET(result: Any) -> None:
    raise AssertionError("value_wait's waiter was added without its reply")


class Waits:
    """The pending waiters and the timer heap, answered in simulated time."""

    def __init__(self, internal: Internal) -> None:
        """`internal`: how a waiter whose condition raises is answered."""
        self._internal = internal
        self.pending: list[Waiter] = []
        self._timers: list[tuple[int, int, Callable[[], None]]] = []
        self._seq = itertools.count()
        #: scheduled `control` actions that raised (a bug in a card's backdoor)
        self.control_faults = 0
        #: scheduled `control` actions whose values the card refused when they ran (counted in
        #: `stats` `requests.errors`: no one is left to reply to)
        self.control_errors = 0

    def add(self, w: Waiter, now_ns: int) -> bool:
        """Answer `w` at once if it holds already (or is a step whose time has come), else keep
        it; True when it is kept. BUSY beyond MAX_PENDING."""
        if len(self.pending) >= MAX_PENDING:
            raise VdevError(ErrorCode.BUSY, f"more than {MAX_PENDING} waits pending")
        result = w.fired()
        if result is not None or (w.on == "step" and w.deadline_ns <= now_ns):
            result = result or {}
            result["now_ns"] = now_ns
            result.update(w.extra)
            w.reply(result)
            return False
        self.pending.append(w)
        return True

    def keep(self, w: Waiter) -> None:
        """`add` of a waiter known not to hold now (`value_wait` made it after looking): kept,
        BUSY beyond MAX_PENDING."""
        if len(self.pending) >= MAX_PENDING:
            raise VdevError(ErrorCode.BUSY, f"more than {MAX_PENDING} waits pending")
        self.pending.append(w)

    def schedule_control(self, when_ns: int, card: Card, action: str,
                         params: Mapping[str, Any], done: Callable[[], None] | None = None) -> None:
        """Run the backdoor action at `when_ns`, then `done()`; its failure is logged and
        counted, never a stop of the clock."""

        def later() -> None:
            if done is not None:
                done()
            try:
                card.control(action, params)
            except VdevError as exc:
                self.control_errors += 1
                log.warning("scheduled control %s.%s failed: %s", card.name, action, exc.message)
            except Exception:  # a bug in the card's backdoor must not stop the clock
                self.control_faults += 1
                log.exception("scheduled control %s.%s raised", card.name, action)

        heapq.heappush(self._timers, (when_ns, next(self._seq), later))

    def next_due_ns(self) -> int | None:
        """The earliest deadline of a waiter or a timer, None when there is neither."""
        due = min((w.deadline_ns for w in self.pending), default=None)
        if self._timers and (due is None or self._timers[0][0] < due):
            due = self._timers[0][0]
        return due

    def outlook(self) -> tuple[int | None, set[Card] | None]:
        """`next_due_ns()`, and `watched()` when `needs_fine()` (else None), in one pass over
        the pending waiters (the lockstep drive asks before every chunk)."""
        due: int | None = None
        watched: set[Card] | None = None
        for w in self.pending:
            if due is None or w.deadline_ns < due:
                due = w.deadline_ns
            if w.on != "step":
                if watched is None:
                    watched = set()
                if w.card is not None:
                    watched.add(w.card)
        if self._timers and (due is None or self._timers[0][0] < due):
            due = self._timers[0][0]
        return due, watched

    def needs_fine(self) -> bool:
        """Whether a pending waiter must stop time at the exact tick its condition holds."""
        return any(w.on != "step" for w in self.pending)

    def watched(self) -> set[Card]:
        """The cards whose ticks may resolve a pending waiter (the others may run in batches)."""
        return {w.card for w in self.pending if w.on != "step" and w.card is not None}

    def any_fired(self) -> bool:
        """Whether a waiter resolves now; one whose condition raises does (`service` answers it)."""
        try:  # a loop, not any() of a generator: the lockstep drive asks after every tick
            for w in self.pending:  # noqa: SIM110
                if w.fired() is not None:
                    return True
            return False
        except Exception:
            return True

    def service(self, now: int) -> None:
        """Run due timers, then resolve every waiter whose condition or deadline has come. At
        most TIMERS_A_SERVICE timers a call: with more due (thousands of scheduled `control`
        actions at one time) the rest run at the next call, and no waiter is answered before
        they have (a `sim step` to that time replies once they all ran)."""
        timers = self._timers
        if timers and timers[0][0] <= now:
            for _ in range(TIMERS_A_SERVICE):
                heapq.heappop(timers)[2]()
                if not timers or timers[0][0] > now:
                    break
            else:  # more are due: the next call runs them, then answers the waits
                return
        if not self.pending:
            return
        keep: list[Waiter] = []
        waiters, self.pending = self.pending, []
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
        self.pending = keep + self.pending  # a reply may have added waits (a batch resuming)
