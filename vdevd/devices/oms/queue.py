"""The per-axis command queues of the MAXk [S §6.2; CRM-1-11 §1.3.4; spec oms.md §4.1, §8.12].

Motion and parameter commands wait in the queue of each axis they address and run in order: a
command that takes time (a move, a home, a wait) holds the queue until it has finished, while
commands that complete at once are chained in the same update cycle. `LS n`/`LE` repeat what lies
between them (nestable); the queue space is reused, so repeats cost no units. A `Group` makes a
command of several axes (an `AA` move, `MT`, an `AA` `ID`) start only when every member axis has
reached it. 2559 units per axis; one per command plus one per operand, `GO` four (spec §8.12).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

QUEUE_UNITS = 2559  # [S App C]
CHAIN_LIMIT = 64  # commands one axis may complete in one update cycle

#: run(axis) -> True when the command is finished (it is then removed from the queue)
Run = Callable[[int], bool]


def at_once(fn: Callable[[int], None]) -> Callable[[], Run]:
    """A queued command that completes when it runs: `fn(axis)`, then the next command."""

    def make() -> Run:
        def run(axis: int) -> bool:
            fn(axis)
            return True

        return run

    return make


@dataclass(eq=False)
class Group:
    """A command shared by several axes: it runs when every member has reached it, on every
    member in the same update cycle. Inside a loop the same group serves every pass: `passes`
    counts each member's arrivals, and pass k is ready when every member has arrived k times."""

    members: frozenset[int]
    passes: dict[int, int] = field(default_factory=dict)
    acted: int = 0  # the last pass whose shared action ran (act_once)
    waiting: list[tuple[AxisQueue, int]] = field(default_factory=list)
    cancelled: bool = False  # a member's queue holding it (or a loop of it) was flushed

    def arrive(self, axis: int) -> int:
        """Count one arrival of `axis`; its pass number."""
        n = self.passes.get(axis, 0) + 1
        self.passes[axis] = n
        return n

    def ready(self, n: int) -> bool:
        return all(self.passes.get(m, 0) >= n for m in self.members)

    def act_once(self) -> bool:
        """True the first time a member runs the present pass (for an action shared by all
        members, such as planning an MT move)."""
        n = min(self.passes.get(m, 0) for m in self.members)
        if self.acted >= n:
            return False
        self.acted = n
        return True


@dataclass(eq=False)
class Item:
    """One queued command. `make` builds the runner again for a loop's repeat."""

    label: str
    make: Callable[[], Run]
    units: int = 1
    group: Group | None = None
    kind: str = ""  # "LS" / "LE" for loops
    count: int = 0
    run: Run | None = None
    pass_: int = 0  # the pass of its group this item belongs to (0: not arrived yet)

    def fresh(self) -> Item:
        return Item(self.label, self.make, 0, self.group, self.kind, self.count)


@dataclass
class _Loop:
    count: int
    start: Item
    body: list[Item] = field(default_factory=list)


class AxisQueue:
    """The queue of one axis."""

    def __init__(self) -> None:
        self.items: deque[Item] = deque()
        self.units = 0
        self.loops: list[_Loop] = []

    @property
    def free(self) -> int:
        return QUEUE_UNITS - self.units

    def push(self, item: Item) -> bool:
        """Append; False when the queue has no room (a command error)."""
        if self.units + item.units > QUEUE_UNITS:
            return False
        self.items.append(item)
        self.units += item.units
        return True

    def flush(self) -> None:
        """Drop every command. A command of several axes in it (or in a loop it is running) is
        cancelled on the other members too: where it has not started there yet they drop it
        when they reach it, instead of waiting forever for this axis (README)."""
        looped = [i for loop in self.loops for i in (loop.start, *loop.body)]
        for item in (*self.items, *looped):
            if item.group is not None:
                item.group.cancelled = True
        self.items.clear()
        self.units = 0
        self.loops.clear()

    @property
    def idle(self) -> bool:
        return not self.items

    def advance(self, axis: int) -> None:
        """Run the commands at the head until one must wait (or CHAIN_LIMIT ran)."""
        items = self.items
        for _ in range(CHAIN_LIMIT):
            if not items:
                return
            item = items[0]
            group = item.group
            if group is not None:
                if group.cancelled and item.run is None:
                    items.popleft()
                    self.units -= item.units
                    continue
                if not item.pass_:
                    item.pass_ = group.arrive(axis)
                if not group.ready(item.pass_):
                    if (self, axis) not in group.waiting:
                        group.waiting.append((self, axis))
                    return
                waiting, group.waiting = group.waiting, []
                for q, a in waiting:  # the members that arrived earlier run it now too
                    q.advance(a)
            if item.run is None:
                item.run = item.make()
            if not item.run(axis):
                return
            items.popleft()
            self.units -= item.units
            self._record(item)

    def _record(self, item: Item) -> None:
        loops = self.loops
        if item.kind == "LS":
            loops.append(_Loop(item.count, item))
            return
        if item.kind == "LE":
            if not loops:
                return  # an LE without LS: nothing to repeat
            loop = loops[-1]
            loop.count -= 1
            if loop.count > 0:
                repeat = [i.fresh() for i in loop.body] + [item.fresh()]
                self.items.extendleft(reversed(repeat))
                loop.body = []
                return
            loops.pop()
            if loops:
                loops[-1].body += [loop.start, *loop.body, item]
            return
        if loops:
            loops[-1].body.append(item)
