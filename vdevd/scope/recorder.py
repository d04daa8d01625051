"""The scope's bounded ring buffer with pre-trigger samples, sans-I/O (issue 23 §1).

A `Recorder` keeps samples of `columns` floats and `n_words` ints with their simulated times,
written in blocks (`write`: one vectorised ring write for any number of samples, axes and
signals). While armed it keeps the last `capacity` samples; when its trigger fires at sample T
it goes on to sample T + capacity - pre and stops (`DONE`), keeping samples T - pre ..
T + capacity - pre - 1 (fewer before T when fewer were taken). Ticks at rest are written as one
block of the resting state (`rest`, decision 0008). Only numpy arrays and ints: a snapshot
pickles it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vdevd.scope.trigger import TriggerMachine

ARMED, RECORDING, DONE = "armed", "recording", "done"


class Recorder:
    """Samples of `columns` floats and `n_words` ints, at most `capacity` of them kept."""

    def __init__(self, columns: int, n_words: int, capacity: int, pre: int,
                 machine: TriggerMachine, watch: int = -1) -> None:
        """`pre`: the samples kept before the trigger (< capacity); `watch`: the float column
        a `position` trigger watches (-1: none)."""
        if capacity < 1 or not 0 <= pre < capacity:
            raise ValueError(f"capacity {capacity}, pre {pre}: need 0 <= pre < capacity")
        self.capacity, self.pre = capacity, pre
        self.ring = np.zeros((capacity, columns))
        self.words = np.zeros((capacity, n_words), dtype=np.int64)
        self.times = np.zeros(capacity, dtype=np.int64)
        for block in (self.ring, self.words, self.times):  # pages mapped now, not in the ticks
            block.fill(0)
        self.machine = machine
        self.watch = watch
        self.written = 0  # samples taken since arming
        self.trigger_index = -1
        self.start = self.end = 0  # the kept window once fired: samples [start, end)
        self.state = ARMED
        if machine.fired:  # `now`: the first sample is the trigger's
            self.fire(0)

    def write(self, times: np.ndarray, values: np.ndarray,
              words: np.ndarray | None = None) -> None:
        """The next len(times) samples: `values` (m, columns), `words` (m, n_words). A
        `position` trigger looks at its column; samples past the window's end are dropped."""
        m = len(times)
        if m == 0 or self.state == DONE:
            return
        if self.state == ARMED and self.watch >= 0:
            hit = self.machine.position(values[:, self.watch])
            if hit >= 0:
                self.fire(self.written + hit)
        keep = m if self.state == ARMED else min(m, self.end - self.written)
        if keep <= 0:
            self.state = DONE
            return
        first = max(0, keep - self.capacity)  # armed: only the last `capacity` matter
        slots = (self.written + np.arange(first, keep)) % self.capacity
        self.ring[slots] = values[first:keep]
        if words is not None:
            self.words[slots] = words[first:keep]
        self.times[slots] = times[first:keep]
        self.written += keep
        if self.state == RECORDING and self.written >= self.end:
            self.state = DONE

    def rest(self, count: int, times: Callable[[np.ndarray], np.ndarray], row: np.ndarray,
             words: np.ndarray | None = None) -> None:
        """`count` samples at rest, each `row` (the constant state, decision 0008) and `words`:
        `times(j)` gives the times of samples j (0-based from the next one). Writes those it
        keeps: the last `capacity` while armed (a trigger cannot fire at rest), else up to the
        window's end."""
        if count <= 0 or self.state == DONE:
            return
        if self.state == RECORDING:
            first, count = 0, min(count, self.end - self.written)
        else:
            first = max(0, count - self.capacity)
        j = np.arange(first, count, dtype=np.int64)
        slots = (self.written + j) % self.capacity
        self.ring[slots] = row
        if words is not None:
            self.words[slots] = words
        self.times[slots] = times(j)
        self.written += count
        if self.state == RECORDING and self.written >= self.end:
            self.state = DONE

    def fire(self, index: int) -> None:
        """The trigger fired at sample `index` (one taken or the next one)."""
        if self.state != ARMED:
            return
        self.trigger_index = index
        oldest = max(0, self.written - self.capacity)
        self.start = max(index - self.pre, oldest)
        self.end = index + self.capacity - self.pre
        self.state = RECORDING if self.written < self.end else DONE

    # -- reading -----------------------------------------------------------------------------------
    @property
    def available(self) -> int:
        """Samples of the kept window taken so far (0 while armed)."""
        if self.state == ARMED:
            return 0
        return min(self.written, self.end) - self.start

    def window(self, first: int, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Samples first .. first + count - 1 of the kept window (clipped to what is there):
        (times, floats, ints), copies."""
        first = max(0, min(first, self.available))
        count = max(0, min(count, self.available - first))
        slots = (self.start + first + np.arange(count)) % self.capacity
        return self.times[slots], self.ring[slots], self.words[slots]
