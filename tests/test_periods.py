"""Exact periods and periods changed at run time (DESIGN.md "Time that costs nothing", decision
0007): tick k at floor(k x period), re-anchored at the last tick run when `Card.set_period`
changes it; the same in batched and fine advances, in lockstep and realtime."""

from __future__ import annotations

import random
from fractions import Fraction
from typing import Any

import pytest

from tests.conftest import rack_config
from tests.test_scheduler import Counter, FakeLoop, WallClock, run, wake
from vdevd.daemon import build_rack
from vdevd.devices.generic.card import GenericServoCard
from vdevd.rack import Rack
from vdevd.rt.scheduler import Scheduler

#: the Turbo PMAC's servo period at I10 = 3,713,707: 442,708.37 ns
I10_PERIOD = Fraction(3_713_707 * 10**6, 2**23)


def floors(period: Fraction, ks: range, base_ns: int = 0, base_k: int = 0) -> list[int]:
    return [base_ns + int((k - base_k) * period) for k in ks]


def test_a_fractional_period_ticks_at_the_floor_of_its_exact_times() -> None:
    a, b = Counter("a", I10_PERIOD), Counter("b", Fraction(100_000, 3))  # type: ignore[arg-type]
    sched = Scheduler([a, b])
    assert a.period_ns == 442_708 and b.period_ns == 33_333 and sched.tick_ns == 33_333
    sched.advance(10**8)
    assert a.seen == floors(I10_PERIOD, range(1, 226))  # 0.1 s is 225.88 periods
    assert b.seen == floors(Fraction(100_000, 3), range(1, 3001))
    assert sched.lost_ticks() == {"a": 0, "b": 0}
    assert sched.next_tick_ns() == 100_033_333  # b's tick 3001


def test_fine_advance_runs_the_same_exact_ticks_as_a_batch() -> None:
    batch = Counter("c", Fraction(7_000_001, 7))  # type: ignore[arg-type]
    fine = Counter("c", Fraction(7_000_001, 7))  # type: ignore[arg-type]
    Scheduler([batch]).advance(50_000_000)
    sched = Scheduler([fine])
    assert sched.advance(50_000_000, stop=lambda: False) == 50_000_000
    assert fine.seen == batch.seen == floors(Fraction(7_000_001, 7), range(1, 50))


def test_ticks_due_inverts_time_of_tick() -> None:
    rng = random.Random(16)
    for _ in range(200):
        period = Fraction(rng.randrange(10_000, 10**9), rng.randrange(1, 10**4))
        card = Counter("c", period)  # type: ignore[arg-type]
        card.ticks = rng.randrange(0, 10**6)
        card.set_period(period)  # re-anchored at a tick far from 0
        k = card.ticks + rng.randrange(1, 10**6)
        t = card.time_of_tick(k)
        assert card.ticks_due(t) == k and card.ticks_due(t - 1) < k


class Retimed(Counter):
    """Changes its own period from within tick `at` (as a firmware command would)."""

    def __init__(self, name: str, period_ns: int, at: int, new: Fraction) -> None:
        super().__init__(name, period_ns)
        self.at, self.new = at, new

    def step(self) -> None:
        super().step()
        if self.ticks == self.at:
            self.set_period(self.new)


def test_a_period_set_during_a_batch_spaces_the_next_ticks_from_that_tick() -> None:
    new = Fraction(2_500_001, 2)
    for stop in (None, lambda: False):
        card = Retimed("c", 1_000_000, at=5, new=new)
        sched = Scheduler([card])
        sched.advance(20_000_000, stop)
        assert card.seen == floors(Fraction(10**6), range(1, 6)) + floors(
            new, range(6, 17), base_ns=5_000_000, base_k=5)
        assert sched.lost_ticks() == {"c": 0}
        assert sched.tick_ns == 1_250_000


def generic(name: str = "servo0") -> GenericServoCard:
    card = build_rack(rack_config()).cards[name]
    assert isinstance(card, GenericServoCard)
    return card


def tick_time(rack: Rack, k: int) -> int:
    """When the generic card's tick counter (TICK_LO) reaches k: the time of its tick k."""
    from vdevd.devices.generic import regions as R

    result = run(rack, "wait", card="servo0", on="value", region="bar0", offset=R.TICK_LO,
                 value=k, timeout_ns=10**9)
    assert result["fired"]
    return int(result["now_ns"])


def test_set_period_on_the_generic_card_in_lockstep() -> None:
    """Set between two ticks, a new period lets the cycle under way end when it was due and
    counts from that tick on (the motion of each tick integrates one whole period)."""
    card = generic()
    rack = Rack([card], "lockstep")
    assert run(rack, "sim", action="step", ticks=3, card="servo0")["now_ns"] == 3_000_000
    run(rack, "sim", action="step", ns=400_000)  # between two ticks: 3.4 ms
    card.set_period(Fraction(4_000_000, 3))  # longer: tick 4 at 4 ms still, then 4/3 ms apart
    assert rack.sched.tick_ns == 1_333_333 and rack.hello()["clock"]["tick_ns"] == 1_333_333
    assert rack.hello()["cards"][0]["period_ns"] == 1_333_333
    assert rack.stats()["scheduler"]["lost_ticks"] == 0
    assert [tick_time(rack, k) for k in (4, 5, 6)] == [4_000_000, 5_333_333, 6_666_666]
    run(rack, "sim", action="step", ns=100_000)
    card.set_period(Fraction(1_000_000, 3))  # shorter: tick 7 at 8 ms as due, then 1/3 ms
    assert tick_time(rack, 7) == 8_000_000
    assert tick_time(rack, 8) == 8_333_333
    run(rack, "sim", action="step", ns=100_000)  # 8.433 ms
    card.set_period(Fraction(1_000_000, 7))  # tick 9 at 8.667 ms as due, then 1/7 ms
    assert rack.stats()["scheduler"]["lost_ticks"] == 0
    assert tick_time(rack, 9) == 8_666_666
    assert run(rack, "sim", action="step", ticks=1, card="servo0")["now_ns"] == 8_809_523
    run(rack, "sim", action="step", ns=857_143)  # to 9,666,666: 8.667 ms + 7 x 142,857.14
    stats = rack.stats()
    assert stats["scheduler"]["lost_ticks"] == 0 and stats["cards"]["servo0"]["ticks"] == 16
    assert read_ticks(rack) == 16 and card.now_ns == 9_666_666


def test_a_new_period_reaches_the_cards_motion_and_registers() -> None:
    """The generic card's PERIOD_NS and its motion core follow set_period: a jog at 10000
    counts/s covers 10000 counts a second at either period."""
    from vdevd.devices.generic import regions as R

    card = generic()
    rack = Rack([card], "lockstep")
    card.core.servo_on(0)
    card.core.jog(0, 10_000.0, 1e9, 1e9)
    run(rack, "sim", action="step", seconds=1.0)
    card.set_period(500_000)
    run(rack, "sim", action="step", seconds=1.0)
    assert card.core.axes.cmd_pos[0] == pytest.approx(20_000, abs=1)
    data: Any = run(rack, "read", card="servo0", region="bar0", offset=R.PERIOD_NS, size=4)
    assert int.from_bytes(data, "little") == 500_000


def read_ticks(rack: Rack) -> int:
    from vdevd.devices.generic import regions as R

    data: Any = run(rack, "read", card="servo0", region="bar0", offset=R.TICK_LO, size=4)
    return int.from_bytes(data, "little")


def test_set_period_on_the_generic_card_in_realtime() -> None:
    card, loop, clock = generic(), FakeLoop(), WallClock()
    rack = Rack([card], "realtime", wake_ns=1_000_000, waker="timer", clock=clock)
    rack.start(loop)  # type: ignore[arg-type]
    wake(loop, clock, 2_000_000)
    assert card.ticks == 2 and card.now_ns == 2_000_000
    card.set_period(Fraction(2_000_000, 3))  # 666,666.67 ns from tick 2 (at 2 ms) on
    wake(loop, clock, 1_000_000)  # wall 3 ms: the tick at 2.666 ms, not the one at 3.333 ms
    assert card.ticks == 3 and card.time_of_tick(3) == 2_666_666 and rack.now_ns == 3_000_000
    clock.ns += 7_000_000  # a request at wall 10 ms catches up: ticks 4..14 (2 + 12 x 2/3 ms)
    assert read_ticks(rack) == 14 and card.now_ns == 10_000_000
    wake(loop, clock, 0)
    assert rack.sched.lost_ticks() == {"servo0": 0}
    assert rack.stats()["scheduler"]["lost_ticks"] == 0
    assert rack.sched.tick_ns == 666_667


def test_two_changes_before_one_tick_each_reach_the_tick_whose_length_they_set() -> None:
    """A change at a tick (tick 4 lasts 2 ms), then one between ticks (after tick 4, 0.5 ms):
    the motion of tick 4 integrates 2 ms and that of tick 5 0.5 ms."""
    card = generic()
    rack = Rack([card], "lockstep")
    card.core.servo_on(0)
    card.core.jog(0, 1_000_000.0, 1e12, 1e12)  # a count per microsecond, at once
    run(rack, "sim", action="step", ticks=3, card="servo0")
    card.set_period(2_000_000)  # at tick 3
    run(rack, "sim", action="step", ns=100_000)
    card.set_period(500_000)  # between ticks 3 and 4
    before = float(card.core.axes.cmd_pos[0])
    assert tick_time(rack, 4) == 5_000_000
    assert float(card.core.axes.cmd_pos[0]) - before == pytest.approx(2000)
    before = float(card.core.axes.cmd_pos[0])
    assert tick_time(rack, 5) == 5_500_000
    assert float(card.core.axes.cmd_pos[0]) - before == pytest.approx(500)
    assert rack.stats()["scheduler"]["lost_ticks"] == 0


def test_two_changes_between_the_same_two_ticks_leave_the_tick_under_way_as_due() -> None:
    card = generic()
    rack = Rack([card], "lockstep")
    run(rack, "sim", action="step", ticks=1, card="servo0")
    run(rack, "sim", action="step", ns=300_000)  # 1.3 ms, between ticks 1 and 2
    card.set_period(700_000)
    card.set_period(500_000)
    assert tick_time(rack, 2) == 2_000_000  # as due on the 1 ms schedule
    assert tick_time(rack, 3) == 2_500_000  # then the last period set
