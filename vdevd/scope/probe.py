"""A recorder on one card's ticks (issue 23 §1): what the hot path of an armed scope runs.

Every card ticks its axes through its `MotionCore` (`tick`) and runs ticks at rest in closed
form through it (`skip`, decision 0008). While a scope is armed, the core's `tick` and `skip` are
replaced, on the core object only, by callables that call the core's own and then sample
(`CoreTick`) or write the skipped ticks' samples from the resting state (`CoreSkip`); disarmed or
done, they are removed, so a card without a scope costs nothing more.

The tick's share is one block copy: the rows of the core's state block that hold the recorded
signals (`Axes.state[lo:hi]`, every axis) go into a staging block (`STAGE` samples); the
recorder takes its columns from it, with their times and the trigger's look, vectorised, when it
is full, before a skip, and before a status or a read (`flush`). A `register` or `irq` trigger
needs the card's state after each whole tick (a card publishes its memory at the end of a batch),
so until it fires the card runs one tick a call (`CardTicks`), as a `wait` makes it.

A sample's time is its tick's (`Card.time_of_tick`), ticks counted from the card's at arming.
Only plain objects refer to each other here: a snapshot of the rack pickles them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from vdevd.scope.recorder import ARMED, DONE, Recorder
from vdevd.scope.signals import Signals
from vdevd.scope.trigger import Trigger, TriggerMachine

#: samples staged between two vectorised writes into the recorder: at most STAGE, in at most
#: STAGE_BYTES (a write costs some 30 us: spread over a thousand ticks, 30 ns a tick)
STAGE, STAGE_BYTES = 4096, 1 << 20


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
        self.trigger = trigger
        #: the columns, axis by axis: (AXIS.signal, "f" a row of the core's state | "w" a word)
        self.columns: list[tuple[str, str]] = []
        rows: list[tuple[int, int]] = []  # (row, axis) of each float column
        self.word_names = [s for s in wanted if s not in signals.rows]
        for a, name in zip(axes, names, strict=True):
            for s in wanted:
                kind = "f" if s in signals.rows else "w"
                self.columns.append((f"{name}.{s}", kind))
                if kind == "f":
                    rows.append((signals.rows[s], a))
        watch_row = signals.rows["position"] if trigger.kind == "position" else -1
        used = [r for r, _ in rows] + ([watch_row] if watch_row >= 0 else [])
        lo, hi = (min(used), max(used) + 1) if used else (0, 1)
        n = core.n
        #: the staged rows of the state block (a view), and each float column's place in them
        self.rows_span = (lo, hi)
        self.src = core.axes.state[lo:hi]
        self.take = np.array([(r - lo) * n + a for r, a in rows], dtype=np.intp)
        # a `now` recording takes `capacity` samples at most; one waiting for its trigger, more
        size = max(16, min(STAGE, STAGE_BYTES // self.src.nbytes,
                           capacity if trigger.kind == "now" else STAGE))
        self.stage = np.zeros((size,) + self.src.shape)
        self.stage.fill(0.0)  # its pages mapped now, at arming, not in the ticks
        self.wstage = np.zeros((len(self.stage), len(axes) * len(self.word_names)),
                               dtype=np.int64)
        self._axes = np.array(axes, dtype=np.intp)
        watch = -1
        if watch_row >= 0:
            self.take = np.append(self.take, (watch_row - lo) * n + trigger.axis)
            watch = len(self.take) - 1  # an extra column, the watched position
        machine = TriggerMachine(trigger, self._register(trigger), self._irq_seq(trigger))
        self.rec = Recorder(len(self.take), len(axes) * len(self.word_names), capacity, pre,
                            machine, watch)
        self.tick = card.ticks  # the card's tick of the last sample flushed (or at arming)
        self.countdown = every  # ticks to the next sample
        self._regime = self._period_regime()
        self.hook = CoreTick(self)  # holds the count of staged samples (`n`)
        self.attached = False
        self.attach()

    # -- pickling (snapshots) ---------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        """Without the view of the core's state (a copy once unpickled): `rebuild` makes it."""
        state = dict(vars(self))
        state.pop("src", None)
        return state

    def rebuild(self) -> None:
        """The views an unpickled probe and its hook need, of the objects unpickled with them."""
        lo, hi = self.rows_span
        self.src = self.core.axes.state[lo:hi]
        self.hook.src, self.hook.rows = self.src, list(self.stage)

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

    def _words(self) -> np.ndarray:
        """The word signals now, axis by axis (the columns' order)."""
        card, sig = self.card, self.signals
        return np.stack([sig.word(card, w) for w in self.word_names], axis=1)[self._axes].ravel()

    def _period_regime(self) -> tuple[int, int, int, int]:
        c = self.card
        return c._base_ns, c._base_ticks, c._period_num, c._period_den

    def times(self, ticks: np.ndarray) -> np.ndarray:
        """The simulated times of `ticks`: the card's period now from the tick it took effect,
        the one of the last flush before it."""
        now = self._period_regime()
        out = np.empty(len(ticks), dtype=np.int64)
        for regime, sel in ((now, ticks >= now[1]), (self._regime, ticks < now[1])):
            if sel.any():
                base_ns, base_ticks, num, den = regime
                k = ticks[sel] - base_ticks
                if int(k.max()) * num < 1 << 62:  # int64 arithmetic is exact
                    out[sel] = base_ns + k * num // den
                else:
                    out[sel] = np.asarray(base_ns + k.astype(object) * num // den,
                                          dtype=np.int64)
        self._regime = now
        return out

    # -- hooks ---------------------------------------------------------------------------------------
    def attach(self) -> None:
        core = self.core
        core.tick = self.hook  # type: ignore[method-assign]
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

    def flush(self) -> None:
        """Write the staged samples into the recorder (their ticks follow `tick` every
        `every`); detach once it is done."""
        m = self.hook.n
        if not m:
            return
        self.hook.n = 0
        ticks = self.tick + self.every * np.arange(1, m + 1, dtype=np.int64)
        self.tick = int(ticks[-1])
        values = self.stage[:m].reshape(m, -1)[:, self.take]
        self.rec.write(self.times(ticks), values, self.wstage[:m] if self.word_names else None)
        if self.rec.state == DONE:
            self.detach()

    def on_skip(self, k: int) -> None:
        """After k ticks at rest: their samples, of the resting state."""
        if self.rec.state == DONE:
            return
        self.flush()
        if "src" not in vars(self):
            self.rebuild()
        c, every = self.countdown, self.every
        ticks_before = self.tick + (every - c)  # the card's tick before the skip
        if k < c:
            self.countdown = c - k
            return
        m = 1 + (k - c) // every
        first = ticks_before + c  # the tick of the first sample among them
        self.countdown = every - (k - c) % every
        self.tick = first + (m - 1) * every
        row = self.src.reshape(-1)[self.take]
        words = self._words() if self.word_names else None
        self.rec.rest(m, lambda j: self.times(first + j * every), row, words)
        if self.rec.state == DONE:
            self.detach()

    def after_card_tick(self) -> None:
        """After a whole tick of the card (`CardTicks`): a register or irq trigger."""
        rec, t, card = self.rec, self.trigger, self.card
        if rec.state != ARMED:
            return
        sampled = self.countdown == self.every  # this tick was sampled
        self.flush()
        m = rec.machine
        if t.kind == "register":
            fired = m.register(int(card.regions[t.region].get_peek(t.offset, t.width)))
        else:
            event = card.last_event if t.line is None else card.line_events.get(t.line)
            fired = m.irq(0 if event is None else int(event.seq))
        if fired:  # at this tick's sample, or the next one taken
            rec.fire(rec.written - 1 if sampled else rec.written)
            if rec.state == DONE:
                self.detach()

    def status(self) -> None:
        """Before a status or a read: what is staged, written."""
        if self.rec.state != DONE:
            self.flush()


class CoreTick:
    """The core's `tick` while a scope records: the core's own, then a block copy of the
    recorded rows into the next row of the stage (the hot path: no Python loop over axes or
    signals; every tick with no word signal, the common case, takes the shortest path)."""

    def __init__(self, probe: Probe) -> None:
        self.probe = probe
        self.core = probe.core
        self.fn: Callable[[Any], int] = type(probe.core).tick
        self.src = probe.src
        self.rows = list(probe.stage)  # a view per row: the cheapest copy into it
        self.size = len(self.rows)
        self.plain = probe.every == 1 and not probe.word_names
        self.n = 0  # samples staged

    def __getstate__(self) -> dict[str, Any]:
        state = dict(vars(self))
        del state["src"], state["rows"]  # views: rebuilt at the first call (StaleCoreTick)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        vars(self).update(state)
        self.__class__ = StaleCoreTick

    def __call__(self) -> int:
        events = self.fn(self.core)
        if self.plain:
            i = self.n
            self.rows[i][...] = self.src
            self.n = i = i + 1
            if i == self.size:
                self.probe.flush()
            return events
        p = self.probe
        c = p.countdown - 1
        if c:
            p.countdown = c
            return events
        p.countdown = p.every
        i = self.n
        self.rows[i][...] = self.src
        if p.word_names:
            p.wstage[i] = p._words()
        self.n = i = i + 1
        if i == self.size:
            p.flush()
        return events


class StaleCoreTick(CoreTick):
    """An unpickled `CoreTick`: its first call rebuilds the views (`Probe.rebuild`), then it is
    a `CoreTick` again (no test on the hot path)."""

    def __call__(self) -> int:
        self.probe.rebuild()
        self.__class__ = CoreTick  # type: ignore[assignment]
        return CoreTick.__call__(self)


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
            if card.irq_seq != seq or probe.rec.state != ARMED:
                if probe.rec.state != ARMED and "tick" in vars(card):
                    delattr(card, "tick")
                return i + 1
        return n
