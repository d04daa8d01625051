"""A recorder on one card's ticks (issue 23 §1): what the hot path of an armed scope runs.

Every card ticks its axes through its `MotionCore` (`tick`) and runs ticks at rest in closed
form through it (`skip`, decision 0008). While a scope is armed, the core's `tick` and `skip` are
replaced, on the core object only, by callables that call the core's own and then sample
(`on_tick`) or fill the skipped ticks' samples with the resting state (`on_skip`); disarmed or
done, they are removed, so a card without a scope costs nothing more. A `register` or `irq`
trigger needs the card's state after each whole tick (a card publishes its memory at the end of
a batch), so until it fires the card runs one tick a call (`CardTicks`): what a `wait` does.

Times: a sample's time is its tick's (`Card.time_of_tick`), the tick counted from the card's at
arming. Only plain objects refer to each other here: a snapshot of the rack pickles them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from vdevd.scope.recorder import ARMED, DONE, Recorder
from vdevd.scope.signals import Signals
from vdevd.scope.trigger import Trigger, TriggerMachine


class Probe:
    """A `Recorder` attached to `card`: `axes` (indices) x `signals` sampled every `every`
    ticks, `capacity` samples kept, `pre` of them before the trigger."""

    def __init__(self, card: Any, signals: type[Signals], axes: list[int], names: list[str],
                 wanted: list[str], every: int, capacity: int, pre: int,
                 trigger: Trigger) -> None:
        self.card, self.signals = card, signals
        self.core = core = signals.core(card)
        self.axes, self.axis_names = list(axes), list(names)
        self.every = every
        #: the columns, axis by axis: (name, kind, row) with kind "f" (a row of the core's
        #: state) or "w" (a word)
        self.columns: list[tuple[str, str]] = []
        flat: list[int] = []
        self.word_names = [s for s in wanted if s not in signals.rows]
        self._axes = np.array(axes, dtype=np.intp)
        n = core.n
        for a, name in zip(axes, names, strict=True):
            for s in wanted:
                if s in signals.rows:
                    flat.append(signals.rows[s] * n + a)
                    self.columns.append((f"{name}.{s}", "f"))
                else:
                    self.columns.append((f"{name}.{s}", "w"))
        watch = -1
        if trigger.kind == "position":
            watch = signals.rows["position"] * n + trigger.axis
        machine = TriggerMachine(trigger, self._register(trigger), self._irq_seq(trigger),
                                 float(core.axes.state.flat[watch]) if watch >= 0 else None)
        self.trigger = trigger
        self.rec = Recorder(core.axes.state, np.array(flat, dtype=np.intp),
                            len(axes) * len(self.word_names),
                            capacity, pre, machine, watch)
        self.tick = card.ticks  # the card's last tick counted
        self.countdown = every  # ticks to the next sample
        self.last_sampled = -1  # the tick of the last sample
        self.attached = False
        self.attach()

    # -- the card's state -------------------------------------------------------------------------
    def _register(self, t: Trigger) -> int:
        if t.kind != "register":
            return 0
        return int(self.card.regions[t.region].get_peek(t.offset, t.width))

    def _irq_seq(self, t: Trigger) -> int:
        if t.kind != "irq":
            return 0
        card = self.card
        event = card.last_event if t.line is None else card.line_events.get(t.line)
        return 0 if event is None else int(event.seq)

    def _words(self) -> np.ndarray | None:
        if not self.word_names:
            return None
        card, sig = self.card, self.signals
        # axis by axis, the words of each: the columns' order
        return np.stack([sig.word(card, w) for w in self.word_names], axis=1)[self._axes].ravel()

    def times(self, ticks: np.ndarray) -> np.ndarray:
        """The simulated times of `ticks` (the card's current period: none changes at rest)."""
        card = self.card
        k = ticks.astype(object) - card._base_ticks
        return np.asarray(card._base_ns + k * card._period_num // card._period_den,
                          dtype=np.int64)

    # -- hooks ---------------------------------------------------------------------------------------
    def attach(self) -> None:
        core = self.core
        core.tick = CoreTick(self)  # type: ignore[method-assign]
        core.skip = CoreSkip(self)  # type: ignore[method-assign]
        if self.trigger.kind in ("register", "irq") and self.rec.state == ARMED:
            self.card.tick = CardTicks(self)
        self.attached = True

    def detach(self) -> None:
        """Remove the hooks: the card ticks as if no scope had been armed."""
        for obj, name in ((self.core, "tick"), (self.core, "skip"), (self.card, "tick")):
            if isinstance(vars(obj).get(name), CoreTick | CoreSkip | CardTicks):
                delattr(obj, name)
        self.attached = False

    def on_tick(self) -> None:
        """After a tick of the core: a sample when one is due (none once done: a run of
        ticks under way may still call the hook it took before `detach`)."""
        if self.rec.state == DONE:
            return
        self.tick += 1
        c = self.countdown - 1
        if c:
            self.countdown = c
            return
        self.countdown = self.every
        rec = self.rec
        rec.sample(self.card.time_of_tick(self.tick), self._words())
        self.last_sampled = self.tick
        if rec.state == DONE:
            self.detach()

    def on_skip(self, k: int) -> None:
        """After k ticks at rest: their samples, of the resting state."""
        if self.rec.state == DONE:
            return
        c, every = self.countdown, self.every
        first = self.tick + c  # the tick of the first sample among them
        self.tick += k
        if k < c:
            self.countdown = c - k
            return
        m = 1 + (k - c) // every
        self.countdown = every - (k - c) % every
        self.last_sampled = first + (m - 1) * every
        self.rec.rest(m, lambda j: self.times(first + j * every), self._words())
        if self.rec.state == DONE:
            self.detach()

    def after_card_tick(self) -> None:
        """After a whole tick of the card (`CardTicks`): a register or irq trigger."""
        rec, t, card = self.rec, self.trigger, self.card
        if rec.state != ARMED:
            return
        m = rec.machine
        if t.kind == "register":
            fired = m.register(int(card.regions[t.region].get_peek(t.offset, t.width)))
        else:
            event = card.last_event if t.line is None else card.line_events.get(t.line)
            fired = m.irq(0 if event is None else int(event.seq))
        if fired:  # at this tick's sample, or the next one taken
            rec.fire(rec.written - 1 if self.last_sampled == self.tick else rec.written)
            if rec.state == DONE:
                self.detach()


class CoreTick:
    """The core's `tick` while a scope records: the core's own, then the probe's."""

    def __init__(self, probe: Probe) -> None:
        self.probe = probe
        self.fn: Callable[[Any], int] = type(probe.core).tick

    def __call__(self) -> int:
        probe = self.probe
        events = self.fn(probe.core)
        probe.on_tick()
        return events


class CoreSkip:
    """The core's `skip` while a scope records: the core's own, then the probe's fill."""

    def __init__(self, probe: Probe) -> None:
        self.probe = probe
        self.fn: Callable[[Any, int], None] = type(probe.core).skip

    def __call__(self, k: int) -> None:
        self.fn(self.probe.core, k)
        self.probe.on_skip(k)


class CardTicks:
    """The card's `tick(n)` until a register or irq trigger fires: one whole tick at a time
    (the card's memory published after each), the trigger looked at after each; stops after
    a tick that interrupted, as `Card.tick` does, and once the trigger fired."""

    def __init__(self, probe: Probe) -> None:
        self.probe = probe
        self.fn: Callable[[Any, int], int] = type(probe.card).tick

    def __call__(self, n: int) -> int:
        probe = self.probe
        card, fn = probe.card, self.fn
        for i in range(n):
            seq = card.irq_seq
            fn(card, 1)
            probe.after_card_tick()
            if card.irq_seq != seq or not probe.attached or probe.rec.state != ARMED:
                if probe.rec.state != ARMED and "tick" in vars(card):
                    delattr(card, "tick")
                return i + 1
        return n
