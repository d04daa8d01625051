"""What the web page shows of a rack, as JSON-able data (issue 23 §3); sans-I/O.

`describe(rack)` is what changes only with the rack's layout (the cards, their axes, backdoor
actions, interrupt lines, the core's status bit names); `rack_state(rack, watch)` is the live
part the page is pushed at a bounded rate: the clock and, per card, each axis's position,
command, velocity, following error and output (the motion core's rows) and its `status`,
`inputs` and `outputs` words, read through the card's scope signal map
(vdevd/scope/signals.py: the names and words the scope records, so page and scope agree), and
the interrupts asserted since the last push (`IrqWatch`).

Reading never changes the rack: the signal maps read the core's arrays and the cards'
side-effect-free views, never a register's read hook.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vdevd.rack import Rack
from vdevd.rt.axes import AxisFlag
from vdevd.scope.signals import CORE_SIGNALS, WORD_SIGNALS, Signals

#: the motion core's rows the page shows per axis (`command_velocity` is left to the scope)
ROWS = ("position", "command", "velocity", "error", "output")
#: interrupts one push carries at most (the rest are counted as missed, as a slow PUB
#: subscriber's gap in `seq` would show them)
MAX_IRQS_PER_PUSH = 64
#: the names of the motion core's status bits (`AxisFlag`), by bit
FLAG_NAMES = {int(f.value).bit_length() - 1: str(f.name) for f in AxisFlag}


def signals_of(card: Any) -> type[Signals] | None:
    """The card's scope signal map, or None for a card with no axes to show."""
    try:
        return card.scope_signals()
    except (LookupError, AttributeError):
        return None


def describe(rack: Rack) -> dict[str, Any]:
    """The rack's layout: `hello` (cards with their actions and interrupt lines, the clock),
    and per card the axis names and whether it has a scope."""
    hello = rack.hello()
    axes: dict[str, list[str]] = {}
    for card in rack.cards.values():
        sig = signals_of(card)
        axes[card.name] = sig.axis_names(card) if sig is not None else []
    return {"hello": hello, "axes": axes, "flags": FLAG_NAMES,
            "signals": list(CORE_SIGNALS + WORD_SIGNALS)}


def _floats(values: np.ndarray) -> list[float | None]:
    """A row as JSON numbers (a non-finite value as null: JSON has no NaN)."""
    row = np.round(np.asarray(values, dtype=np.float64), 6)
    if np.isfinite(row).all():
        return row.tolist()
    return [v if math.isfinite(v) else None for v in row.tolist()]


def card_state(card: Any) -> dict[str, Any]:
    """One card's axes now: a list per signal, one value per axis (empty for a card without a
    signal map)."""
    sig = signals_of(card)
    if sig is None:
        return {"ticks": card.ticks}
    core = sig.core(card)
    state = core.axes.state
    out: dict[str, Any] = {"ticks": card.ticks,
                           "flags": np.asarray(core.axes.flags, dtype=np.int64).tolist()}
    for name in ROWS:
        out[name] = _floats(state[sig.rows[name]])
    for name in WORD_SIGNALS:
        out[name] = sig.word(card, name).tolist()
    return out


class IrqWatch:
    """The interrupts asserted since the last look, from each card's latest event of each line
    (`Card.line_events`): nothing is added to the tick path. Between two looks a line that
    asserted several times shows its latest assertion; the others are counted as `missed`."""

    def __init__(self) -> None:
        self._seen: dict[str, tuple[Any, int]] = {}  # card name -> (the card, its last seq seen)

    def poll(self, rack: Rack) -> tuple[list[dict[str, Any]], int]:
        """(the new events in `seq` order per card, the count of assertions not shown)."""
        events: list[dict[str, Any]] = []
        missed = 0
        for name, card in rack.cards.items():
            seen_card, last = self._seen.get(name, (None, 0))
            if seen_card is not card or card.irq_seq < last:  # a new rack (reset, restore)
                last = 0
            seq = card.irq_seq
            if seq > last:
                new = sorted((e for e in card.line_events.values() if e.seq > last),
                             key=lambda e: e.seq)
                missed += seq - last - len(new)
                events.extend(e.as_dict() for e in new)
            self._seen[name] = (card, seq)
        if len(events) > MAX_IRQS_PER_PUSH:
            missed += len(events) - MAX_IRQS_PER_PUSH
            events = events[-MAX_IRQS_PER_PUSH:]
        return events, missed


def rack_state(rack: Rack, watch: IrqWatch) -> dict[str, Any]:
    """The live state the page is pushed: the clock, every card's axes, the new interrupts."""
    events, missed = watch.poll(rack)
    return {
        "clock": {"now_ns": rack.now_ns, "mode": rack.mode, "tick_ns": rack.sched.tick_ns},
        "cards": {name: card_state(card) for name, card in rack.cards.items()},
        "irqs": events,
        "missed_irqs": missed,
    }
