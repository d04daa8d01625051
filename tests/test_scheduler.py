"""The scheduler and the lockstep rack without sockets (sans-I/O): ticks due, batches, waits."""

from __future__ import annotations

from typing import Any

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
