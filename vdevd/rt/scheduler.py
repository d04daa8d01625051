"""The fixed-period scheduler: runs every card's servo ticks in simulated time (DESIGN.md "Clock").

Simulated time is an int of ns. Tick k of a card is at `time_of_tick(k)`, the floor of its exact
time (a period may be a Fraction of ns, and change at run time: DESIGN.md "Time that costs
nothing", decision 0007). `advance(target)` runs
every tick due up to `target`: per card in one batch (`Card.tick(n)`) when nothing needs tick
granularity, or tick by tick in time order when `fine` is set (a pending wait must stop at the
exact tick its condition becomes true). The realtime pacing and lockstep driving live in the
rack; this module has no I/O and no wall clock.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Collection, Sequence
from fractions import Fraction
from typing import Protocol


class Tickable(Protocol):
    name: str
    now_ns: int
    ticks: int

    @property
    def period_ns(self) -> int: ...

    @property
    def period(self) -> Fraction: ...

    on_period: Callable[[], None] | None

    def tick(self, n: int) -> int: ...

    def time_of_tick(self, k: int) -> int: ...

    def ticks_due(self, t: int) -> int: ...


class Scheduler:
    """Ticks a fixed set of cards in simulated time."""

    def __init__(self, cards: Sequence[Tickable]) -> None:
        self.cards: list[Tickable] = []
        self.now_ns = 0
        #: the rack's base tick: the shortest card period now, in whole ns (`sim step ticks=`);
        #: kept current by the cards (`periods_changed`), as a realtime request reads it
        self.tick_ns = 1_000_000
        #: the longest card period now, in whole ns (a lockstep slice holds QUIET_MIN of them)
        self.longest_ns = 1_000_000
        for card in cards:
            self.add(card)

    def add(self, card: Tickable) -> None:
        self.cards.append(card)
        card.on_period = self.periods_changed
        self.periods_changed()

    def periods_changed(self) -> None:
        """A card's period changed (Card.set_period): the base tick again."""
        self.tick_ns = min((c.period_ns for c in self.cards), default=1_000_000)
        self.longest_ns = max((c.period_ns for c in self.cards), default=1_000_000)

    @property
    def base_period(self) -> Fraction:
        """The shortest card period now, exact (`sim step ticks=` counts these)."""
        return min((c.period for c in self.cards), default=Fraction(1_000_000))

    def next_tick_ns(self) -> int:
        """When the next tick of any card is due."""
        return min((c.time_of_tick(c.ticks + 1) for c in self.cards),
                   default=self.now_ns + self.tick_ns)

    def advance(self, target_ns: int, stop: Callable[[], bool] | None = None,
                watched: Collection[Tickable] | None = None) -> int:
        """Run every tick with time <= target_ns and return the time reached.

        With `stop`, the ticks of the `watched` cards (every card when None: the cards whose
        state `stop` reads) run one at a time in time order (ties in rack order) and the
        advance ends right after the first tick after which `stop()` is true; the time reached
        is then that tick's time, and the other cards run in batches to where the tick-by-tick
        order would have left them (their ticks before it, and those at its time that come
        before it in rack order). Without `stop` each card runs its due ticks as one batch.
        """
        if target_ns < self.now_ns:
            return self.now_ns
        if stop is None:
            for card in self.cards:
                self._run_to(card, target_ns)
            self.settle(target_ns)
            return target_ns
        fine = [(i, c) for i, c in enumerate(self.cards) if watched is None or c in watched]
        if len(fine) == 1:  # one card watched (an RTC post, a register poll): no heap
            return self._advance_one(fine, target_ns, stop)
        heap = [(c.time_of_tick(c.ticks + 1), i) for i, c in fine]
        heapq.heapify(heap)
        while heap and heap[0][0] <= target_ns:
            t, i = heapq.heappop(heap)
            card = self.cards[i]
            try:
                card.tick(1)
            except Exception:  # the others to where ticking in time order leaves them
                self._run_others(fine, t, i)
                raise
            heapq.heappush(heap, (card.time_of_tick(card.ticks + 1), i))
            if stop():
                self._run_others(fine, t, i)
                self.settle(t)
                return t
        self._run_others(fine, target_ns, len(self.cards))
        self.settle(target_ns)
        return target_ns

    def _advance_one(self, fine: list[tuple[int, Tickable]], target_ns: int,
                     stop: Callable[[], bool]) -> int:
        """`advance` with `stop` when one card is watched: what the heap of one card does."""
        i, card = fine[0]
        t = card.time_of_tick(card.ticks + 1)
        while t <= target_ns:
            try:
                card.tick(1)
            except Exception:  # the others to where ticking in time order leaves them
                self._run_others(fine, t, i)
                raise
            if stop():
                self._run_others(fine, t, i)
                self.settle(t)
                return t
            t = card.time_of_tick(card.ticks + 1)
        self._run_others(fine, target_ns, len(self.cards))
        self.settle(target_ns)
        return target_ns

    def _run_others(self, fine: list[tuple[int, Tickable]], t: int, before: int) -> None:
        """The cards not run tick by tick: every tick before `t`, and the one at `t` of the
        cards before rack position `before` (the order of ticking every card in time order)."""
        if len(fine) == len(self.cards):
            return
        done = {i for i, _ in fine}
        for i, card in enumerate(self.cards):
            if i not in done:
                self._run_to(card, t if i < before else t - 1)

    @staticmethod
    def _run_to(card: Tickable, t: int) -> None:
        """Run the card's ticks due by `t` in batches (recounted after a batch that stopped
        early: a tick may change the period)."""
        due = card.ticks_due(t) - card.ticks
        while due > 0:
            card.tick(due)
            due = card.ticks_due(t) - card.ticks

    def settle(self, t: int) -> None:
        """Make every card's clock read `t`, the time stamped on what happens until the next tick."""
        for card in self.cards:
            card.now_ns = t
        self.now_ns = t

    def lost_ticks(self) -> dict[str, int]:
        """Ticks due by now that were not run, per card (always 0 unless something is broken)."""
        return {c.name: c.ticks_due(self.now_ns) - c.ticks for c in self.cards}
