"""A recorder on one card's ticks (issue 23 §1): what the hot path of an armed scope runs.

Every card ticks its axes through its `MotionCore` (`tick`) and runs ticks at rest in closed
form through it (`skip`, decision 0008). While a scope is armed, the core stages a sample after
each whole tick itself (`MotionCore.stage_into`): the compiled kernel copies the recorded cells
of the state block (`Axes.state[row, axis]`, in the columns' order) into the recorder's ring,
which is the stage block's tail, and counts the ticks between samples, so an armed scope adds no
Python call to the tick (decision 0016). The core's `skip` is replaced, on the core object only,
by a callable that calls the core's own and writes the skipped ticks' samples from the resting
state (`CoreSkip`). The recorder commits the staged samples (their times and the trigger's look,
vectorised) when the kernel says it has staged as many as it may (`Recorder.room`), before a
skip, and before a status or a read (`flush`). A word signal (the card's registers) needs Python
after each sample's tick: the core's `tick` is then replaced (`CoreTick`), staging the same way.
Disarmed or done, all of it is removed, so a card without a scope costs nothing more. A
`register` or `irq` trigger needs the card's state after each whole tick (a card publishes its
memory at the end of a batch), so until it fires the card runs one tick a call (`CardTicks`), as
a `wait` makes it.

A sample's time is its tick's (`Card.time_of_tick`), ticks counted from the card's at arming.
Only plain objects refer to each other here: a snapshot of the rack pickles them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from vdevd.rt import kernel as kn
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
        self.core = signals.core(card)
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
        watch = -1
        if watch_row >= 0:
            rows.append((watch_row, trigger.axis))
            watch = len(rows) - 1  # an extra column, the watched position
        #: each float column's (state row, axis): a sample, in the columns' order
        self.cells = np.array(rows, dtype=np.intp).reshape(-1, 2)
        self.width = width = len(rows)  # floats a sample
        #: the stage block (vdevd.rt.kernel "Staging"): counters, the cells, then the ring
        self.block = np.zeros((kn.STAGE_HEAD + capacity, max(kn.STAGE_COLS, width)))
        self.block.fill(0.0)  # its pages mapped now, at arming, not in the ticks
        self.block[kn.STAGED:kn.LIMIT + 1, 0] = (0, every, every, width, 0, 1)
        self.block[kn.CELL_ROWS, :width] = self.cells[:, 0]
        self.block[kn.CELL_AXES, :width] = self.cells[:, 1]
        self._axes = np.array(axes, dtype=np.intp)
        machine = TriggerMachine(trigger, self._register(trigger), self._irq_seq(trigger))
        self.rec = Recorder(width, len(axes) * len(self.word_names), capacity, pre,
                            machine, watch, self.ring)
        self._limit()
        self.tick = card.ticks  # the card's tick of the last sample flushed (or at arming)
        self._regime = self._period_regime()
        #: the core's tick while recording a word signal (else the core stages: `stage_into`)
        self.hook = CoreTick(self) if self.word_names else None
        self.attached = False
        self.attach()

    # -- pickling (snapshots) ---------------------------------------------------------------------
    def __setstate__(self, state: dict[str, Any]) -> None:
        """The recorder's ring is a view of the stage block (pickled once, with the probe)."""
        vars(self).update(state)
        self.rec.ring = self.ring

    def rebuild(self) -> None:
        """The views an unpickled hook needs, of the stage block unpickled with it."""
        if self.hook is not None:
            self.hook.rows = self.hook.views()

    def sample(self) -> np.ndarray:
        """A sample's floats now (a fresh array)."""
        return self.core.axes.state[self.cells[:, 0], self.cells[:, 1]]

    @property
    def ring(self) -> np.ndarray:
        """The recorder's ring of samples, one a row, in the columns' order: the stage block's
        rows the tick writes (a view)."""
        return self.block[kn.STAGE_HEAD:, :self.width]

    # -- the stage's counters (in the stage block: the kernel keeps them) --------------------------
    @property
    def staged(self) -> int:
        """Samples staged, not yet committed to the recorder."""
        return int(self.block[kn.STAGED, 0])

    @property
    def countdown(self) -> int:
        """Ticks to the next sample."""
        return int(self.block[kn.COUNTDOWN, 0])

    @countdown.setter
    def countdown(self, c: int) -> None:
        self.block[kn.COUNTDOWN, 0] = c

    def _limit(self) -> None:
        """None staged; the next into the recorder's next slot, as many as it has room for."""
        h = self.block[:, 0]
        h[kn.STAGED], h[kn.SLOT], h[kn.LIMIT] = 0, self.rec.slot, max(1, self.rec.room)

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
        the one of the last flush before it (`ticks` ascending)."""
        now = self._period_regime()
        out = np.empty(len(ticks), dtype=np.int64)
        split = int(np.searchsorted(ticks, now[1]))  # the first tick of the period now
        for regime, sel in ((now, slice(split, None)), (self._regime, slice(0, split))):
            if len(ticks[sel]):
                base_ns, base_ticks, num, den = regime
                k = ticks[sel] - base_ticks
                if den == 1 and int(k.max()) * num < 1 << 62:  # a whole period in ns
                    out[sel] = base_ns + k * num
                elif int(k.max()) * num < 1 << 62:  # int64 arithmetic is exact
                    out[sel] = base_ns + k * num // den
                else:
                    out[sel] = np.asarray(base_ns + k.astype(object) * num // den,
                                          dtype=np.int64)
        self._regime = now
        return out

    # -- hooks ---------------------------------------------------------------------------------------
    def attach(self) -> None:
        core = self.core
        if self.hook is None:
            core.stage_into(self.block, self.flush)
        else:
            core.tick = self.hook  # type: ignore[method-assign]
        core.skip = CoreSkip(self)  # type: ignore[method-assign]
        if self.trigger.kind in ("register", "irq") and self.rec.state == ARMED:
            self.card.tick = CardTicks(self)
        self.attached = True

    def detach(self) -> None:
        """Remove the hooks: the card ticks as if no scope had been armed."""
        if self.core.staging is self.block:
            self.core.stop_staging()
        for obj, name in ((self.core, "tick"), (self.core, "skip"), (self.card, "tick")):
            if isinstance(vars(obj).get(name), CoreTick | CoreSkip | CardTicks):
                delattr(obj, name)
        self.attached = False

    def flush(self) -> None:
        """Commit the staged samples to the recorder (their ticks follow `tick` every
        `every`); detach once it is done."""
        m = self.staged
        if not m:
            return
        ticks = self.tick + self.every * np.arange(1, m + 1, dtype=np.int64)
        self.tick = int(ticks[-1])
        self.rec.commit(self.times(ticks))
        self._limit()
        if self.rec.state == DONE:
            self.detach()

    def on_skip(self, k: int) -> None:
        """After k ticks at rest: their samples, of the resting state."""
        if self.rec.state == DONE:
            return
        self.flush()
        c, every = self.countdown, self.every
        ticks_before = self.tick + (every - c)  # the card's tick before the skip
        if k < c:
            self.countdown = c - k
            return
        m = 1 + (k - c) // every
        first = ticks_before + c  # the tick of the first sample among them
        self.countdown = every - (k - c) % every
        self.tick = first + (m - 1) * every
        row = self.sample()
        words = self._words() if self.word_names else None
        self.rec.rest(m, lambda j: self.times(first + j * every), row, words)
        self._limit()
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
            self._limit()
            if rec.state == DONE:
                self.detach()

    def status(self) -> None:
        """Before a status or a read: what is staged, written."""
        if self.rec.state != DONE:
            self.flush()


class CoreTick:
    """The core's `tick` while a scope records a word signal: the core's own, then, every
    `every` ticks, the sample's floats and words into the recorder's next slot, counted in the
    stage block as the kernel counts (no Python loop over axes or signals)."""

    def __init__(self, probe: Probe) -> None:
        self.probe = probe
        self.core = probe.core
        self.fn: Callable[[Any], int] = type(probe.core).tick
        self.state = probe.core.axes.state
        self.rows = self.views()  # a view per ring row: copied into

    def views(self) -> list[np.ndarray]:
        return list(self.probe.ring)

    def __getstate__(self) -> dict[str, Any]:
        state = dict(vars(self))
        del state["state"], state["rows"]  # views: rebuilt at the first call (StaleCoreTick)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        vars(self).update(state)
        self.__class__ = StaleCoreTick

    def __call__(self) -> int:
        events = self.fn(self.core)
        p = self.probe
        if not p.attached:  # done during a run that holds this tick (`MotionCore.run`)
            return events
        h = p.block[:, 0]
        c = h[kn.COUNTDOWN] - 1.0
        if c > 0.0:
            h[kn.COUNTDOWN] = c
            return events
        h[kn.COUNTDOWN] = p.every
        slot = int(h[kn.SLOT])
        cells = p.cells
        self.rows[slot][...] = self.state[cells[:, 0], cells[:, 1]]
        p.rec.words[slot] = p._words()
        h[kn.SLOT] = 0 if slot + 1 == len(self.rows) else slot + 1
        h[kn.STAGED] += 1
        if h[kn.STAGED] >= h[kn.LIMIT]:
            p.flush()
        return events


class StaleCoreTick(CoreTick):
    """An unpickled `CoreTick`: its first call rebuilds the views (`Probe.rebuild`), then it is
    a `CoreTick` again (no test on the hot path)."""

    def __call__(self) -> int:
        self.state = self.core.axes.state
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
