"""The scheduler and the lockstep rack without sockets (sans-I/O): ticks due, batches, waits."""

from __future__ import annotations

import logging
from typing import Any

import pytest

from vdevd.devices.base import Card, CardContext, control
from vdevd.errors import VdevError
from vdevd.protocol import Request
from vdevd.rack import Rack
from vdevd.region import Region
from vdevd.rt.scheduler import Scheduler


class Counter(Card):
    """Counts its ticks into a register; interrupts at the ticks listed in `irq_at`."""

    type_name = "counter"

    def __init__(self, name: str, period_ns: int, irq_at: tuple[int, ...] = ()) -> None:
        super().__init__(name, {"period_ns": period_ns}, CardContext(emit=lambda e: None))
        self.mem = self.add_region(Region("mem", 16))
        self.line = self.add_irq("irq")
        self.irq_at = set(irq_at)
        self.seen: list[int] = []

    def step(self) -> None:
        self.seen.append(self.now_ns)
        self.mem.set(0, self.ticks)
        if self.ticks in self.irq_at:
            self.line.trigger(self.ticks)


def test_advance_runs_every_due_tick_of_every_card_at_its_period() -> None:
    a, b = Counter("a", 1000), Counter("b", 400)
    sched = Scheduler([a, b])
    assert sched.tick_ns == 400
    assert sched.advance(2500) == 2500
    assert a.seen == [1000, 2000]
    assert b.seen == [400, 800, 1200, 1600, 2000, 2400]
    sched.advance(3000)
    assert a.seen[-1] == 3000 and b.seen[-1] == 2800
    assert sched.lost_ticks() == {"a": 0, "b": 0}


def test_fine_advance_stops_after_the_tick_that_satisfies_stop() -> None:
    a, b = Counter("a", 1000), Counter("b", 300)
    sched = Scheduler([a, b])
    reached = sched.advance(10_000, stop=lambda: a.ticks == 2)
    assert reached == 2000
    assert b.seen == [300, 600, 900, 1200, 1500, 1800]  # nothing beyond 2000 ran
    assert a.now_ns == b.now_ns == 2000


def test_fine_advance_batches_the_cards_it_does_not_watch_to_where_ticking_leaves_them() -> None:
    """Watching one card (the one a wait reads) gives every card the ticks of watching all:
    those before the stopping tick, and those at its time that come before it in rack order."""
    def run(watched: bool) -> list[list[int]]:
        a, b, c = Counter("a", 400), Counter("b", 1000), Counter("c", 250)
        sched = Scheduler([a, b, c])
        reached = sched.advance(50_000, stop=lambda: b.ticks == 3,
                                watched={b} if watched else None)
        at_stop = [reached, a.seen[-1], c.seen[-1]]
        sched.advance(7777, stop=lambda: b.ticks == 99, watched={b} if watched else None)
        return [at_stop, a.seen, b.seen, c.seen, [sched.now_ns]]

    batched, ticked = run(True), run(False)
    assert batched == ticked
    # b's tick at 3000 stopped it: a's tick at 2800 ran, c's at 3000 (after b in rack order) not
    assert batched[0] == [3000, 2800, 2750]
    assert batched[1][-1] == 7600 and batched[3][-1] == 7750


def test_batched_tick_stops_at_an_interrupt_and_resumes() -> None:
    card = Counter("c", 1000, irq_at=(3,))
    assert card.tick(10) == 3
    assert card.tick(7) == 7
    assert card.ticks == 10


def run(rack: Rack, op: str, **args: Any) -> Any:
    out: list[Any] = []
    rack.execute(Request(1, op, args), out.append)
    assert len(out) == 1, "exactly one reply"
    if isinstance(out[0], VdevError):
        raise out[0]
    return out[0]


def test_lockstep_wait_without_a_loop_drives_time_to_the_event() -> None:
    card = Counter("c", 1000, irq_at=(7,))
    rack = Rack([card], "lockstep")
    result = run(rack, "wait", card="c", on="irq", timeout_ns=10**9)
    assert result["fired"] and result["now_ns"] == 7000
    assert result["event"]["status"] == 7
    assert run(rack, "sim", action="step", ns=500)["now_ns"] == 7500


def test_lockstep_value_wait_and_timeout() -> None:
    rack = Rack([Counter("c", 1000)], "lockstep")
    fired = run(rack, "wait", card="c", on="value", region="mem", offset=0, value=5,
                timeout_ns=10**6)
    assert fired == {"fired": True, "value": 5, "now_ns": 5000}
    late = run(rack, "wait", card="c", on="value", region="mem", offset=0, value=2,
               timeout_ns=3500)
    assert late == {"fired": False, "now_ns": 8500}


class Faulty(Counter):
    """A card with a bug: its firmware raises at tick 3, its backdoor always."""

    def step(self) -> None:
        super().step()
        if self.ticks == 3:
            raise RuntimeError("firmware bug")

    @control()
    def explode(self) -> None:
        """A backdoor action with a bug."""
        raise RuntimeError("backdoor bug")


def test_a_card_that_raises_does_not_stop_the_rack() -> None:
    bad, good = Faulty("bad", 1000), Counter("good", 1000)
    rack = Rack([bad, good], "lockstep")
    assert run(rack, "sim", action="step", ns=10_000)["now_ns"] == 10_000
    assert rack.card_faults == 1
    out: list[Any] = []
    rack.execute(Request(7, "control", {"card": "bad", "action": "explode"}), out.append)
    assert isinstance(out[0], VdevError) and out[0].code == "internal"
    assert run(rack, "read", card="good", region="mem", offset=0, size=4) == good.mem.read(0, 4)


class AlwaysFaulty(Counter):
    """A card whose firmware raises at every tick from the third on."""

    def step(self) -> None:
        super().step()
        if self.ticks >= 3:
            raise RuntimeError("firmware bug")


def test_a_card_that_raises_at_every_tick_is_counted_every_time_and_logged_once_a_while(
        caplog: pytest.LogCaptureFixture) -> None:
    """No log flood from a card that raises at every tick: every fault counts in `card_faults`,
    the log has one report with its traceback every FAULT_LOG_NS of wall time."""
    rack = Rack([AlwaysFaulty("bad", 1000), Counter("good", 1000)], "lockstep")
    with caplog.at_level(logging.ERROR, logger="vdevd.rack"):
        assert run(rack, "sim", action="step", ns=1_000_000)["now_ns"] == 1_000_000
    assert rack.card_faults == 998
    reports = [r for r in caplog.records if "card raised during a tick" in r.getMessage()]
    assert len(reports) == 1 and reports[0].exc_info is not None


def test_a_watched_card_that_raises_leaves_the_other_cards_where_ticking_would() -> None:
    """A fault in a fine advance: the cards not watched run to the faulting tick's time, as if
    every card had ticked in time order, so time goes on from there and no card is behind."""
    bad, other = Faulty("bad", 1000), Counter("other", 300)
    sched = Scheduler([other, bad])
    try:
        sched.advance(10_000, stop=lambda: False, watched={bad})
    except RuntimeError:
        pass
    else:
        raise AssertionError("the fault did not reach the caller")
    assert bad.ticks == 3 and other.seen[-1] == 3000  # other comes first in rack order


class BrokenPeek(Counter):
    """A card whose status register's side-effect-free read breaks from tick 3 on."""

    def __init__(self, name: str, period_ns: int) -> None:
        super().__init__(name, period_ns)
        self.mem.hook(8, 4, on_read=self._status, peek=self._status)

    def _status(self, offset: int, size: int) -> bytes:
        if self.ticks >= 3:
            raise RuntimeError("peek bug")
        return bytes(size)


def test_a_resumed_batch_whose_op_raises_gets_one_internal_error_reply() -> None:
    bad = Faulty("bad", 1000)
    rack = Rack([bad], "lockstep")
    ops = [Request(None, "wait", {"card": "bad", "on": "value", "region": "mem", "offset": 0,
                                  "value": 2, "timeout_ns": 10**6}),
           Request(None, "control", {"card": "bad", "action": "explode"})]
    out: list[Any] = []
    rack.execute(Request(3, "batch", {"ops": ops}), out.append)
    assert len(out) == 1
    assert isinstance(out[0], VdevError) and out[0].code == "internal"
    assert "backdoor bug" in out[0].message
    assert rack.errors == 1
    assert run(rack, "sim", action="step", ns=1000)["now_ns"] == bad.now_ns == 3000


def test_a_wait_whose_condition_raises_gets_an_internal_error_and_time_goes_on() -> None:
    rack = Rack([BrokenPeek("c", 1000)], "lockstep")
    out: list[Any] = []
    rack.execute(Request(1, "wait", {"card": "c", "on": "value", "region": "mem", "offset": 8,
                                     "value": 1, "timeout_ns": 10**6}), out.append)
    assert len(out) == 1 and isinstance(out[0], VdevError) and out[0].code == "internal"
    assert run(rack, "sim", action="step", ns=2000)["now_ns"] == 5000


class FakeLoop:
    """The part of an event loop the realtime rack uses with the `timer` waker."""

    def __init__(self) -> None:
        self.later: list[tuple[float, Any]] = []

    def call_later(self, delay: float, callback: Any) -> None:
        self.later.append((delay, callback))


class WallClock:
    """A monotonic clock in ns that the test moves."""

    def __init__(self) -> None:
        self.ns = 7_000_000_000  # any start: realtime counts from the reading at start

    def __call__(self) -> int:
        return self.ns


def realtime_rack(period_ns: int = 1_000_000) -> tuple[Rack, Counter, FakeLoop, WallClock]:
    card, loop, clock = Counter("c", period_ns), FakeLoop(), WallClock()
    rack = Rack([card], "realtime", wake_ns=1_000_000, waker="timer", clock=clock)
    rack.start(loop)  # type: ignore[arg-type]
    return rack, card, loop, clock


def wake(loop: FakeLoop, clock: WallClock, after_ns: int) -> float:
    """The timer fires `after_ns` of wall time after start or the last wake; the delay it asked."""
    delay, callback = loop.later.pop()
    clock.ns += after_ns
    callback()
    return delay


def test_realtime_pass_runs_the_ticks_due_by_wall_time() -> None:
    rack, card, loop, clock = realtime_rack()
    assert wake(loop, clock, 1_000_000) == 0.001
    assert card.ticks == 1 and rack.now_ns == 1_000_000
    assert wake(loop, clock, 1_250_000) == 0.001  # the next wake is asked for 1 ms on
    assert card.ticks == 2 and rack.now_ns == 2_250_000
    assert rack.overruns == 0 and rack.passes == 2


def test_realtime_late_wake_catches_up_in_one_batch_and_counts_an_overrun() -> None:
    rack, card, loop, clock = realtime_rack()
    wake(loop, clock, 1_000_000)
    wake(loop, clock, 50_000_000)  # the host stalled the daemon for 49 ms
    assert card.ticks == 51 and rack.now_ns == 51_000_000
    assert card.seen[-3:] == [49_000_000, 50_000_000, 51_000_000]  # every tick ran, in order
    assert rack.overruns == 1 and rack.passes == 2
    assert rack.late.max == 49_000_000  # woke 49 ms after the wake it asked for
    assert rack.behind.max == 50_000_000  # simulated time was 50 ms behind when it woke
    assert loop.later[-1][0] == 0.001  # and it goes on at the period, not in a burst
    assert rack.sched.lost_ticks() == {"c": 0}


def test_realtime_request_first_runs_the_ticks_fallen_due_since_the_last_pass() -> None:
    rack, card, loop, clock = realtime_rack()
    wake(loop, clock, 1_000_000)
    clock.ns += 3_500_000  # a request arrives 3.5 ms after the last pass, before the next
    data = run(rack, "read", card="c", region="mem", offset=0, size=4)
    assert int.from_bytes(data, "little") == 4 and card.ticks == 4
    assert rack.catch_ups == 1 and rack.now_ns == 4_500_000
    assert rack.read("c", "mem", 0, 4) == data  # no tick due yet: nothing more runs
    assert rack.catch_ups == 1


class RecordingSink:
    """An `EventSink` that keeps what the rack sends it."""

    endpoint = "tcp://127.0.0.1:1"

    def __init__(self) -> None:
        self.events: list[Any] = []

    def publish(self, event: Any) -> None:
        self.events.append(("irq", event.line, event.seq))

    def sync(self, card: str) -> None:
        self.events.append(("sync", card))


def test_events_go_to_the_sink_given_at_construction() -> None:
    sink = RecordingSink()
    rack = Rack([], "lockstep", sink=sink)
    card = Counter("c", 1000, irq_at=(2,))
    card.ctx.emit = rack.emit
    rack.add_card(card)
    assert rack.hello()["events"] == "tcp://127.0.0.1:1"
    run(rack, "wait", card="c", on="irq", timeout_ns=10**6)
    assert run(rack, "sync", card="c") is None
    assert sink.events == [("irq", "irq", 1), ("sync", "c")]
    assert rack.stats()["events_published"] == 1
