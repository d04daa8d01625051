"""The scope's bounded ring buffer with pre-trigger samples, sans-I/O (issue 23 §1).

A `Recorder` copies, at each sample, a fixed set of entries of a 2-D float block (the motion
core's `Axes.state`: one `np.take` into a ring row, whatever the axes and signals) and a row
of ints given to it (the card's words), with the sample's simulated time. It keeps the last
`capacity` samples while armed; when its trigger fires at sample T it goes on to sample
T + capacity - pre and stops (`DONE`), keeping samples T - pre .. T + capacity - pre - 1
(fewer before T when fewer were taken). Ticks at rest are filled (`rest`) with the state then,
which is constant (decision 0008). Only numpy arrays and ints: a snapshot pickles it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vdevd.scope.trigger import TriggerMachine

ARMED, RECORDING, DONE = "armed", "recording", "done"


class Recorder:
    """Samples of `len(flat)` floats and `n_words` ints, at most `capacity` of them kept."""

    def __init__(self, source: np.ndarray, flat: np.ndarray, n_words: int, capacity: int,
                 pre: int, machine: TriggerMachine, watch: int = -1) -> None:
        """`source`: the C-contiguous float block sampled; `flat`: the flat indices of its
        entries taken, in column order; `pre`: the samples kept before the trigger (< capacity);
        `watch`: the flat index of the position a `position` trigger watches (-1: none)."""
        if capacity < 1 or not 0 <= pre < capacity:
            raise ValueError(f"capacity {capacity}, pre {pre}: need 0 <= pre < capacity")
        if not source.flags.c_contiguous:
            raise ValueError("the sampled block must be C-contiguous")
        self.source = source
        self.flat = np.ascontiguousarray(flat, dtype=np.intp)
        self.capacity, self.pre = capacity, pre
        self.ring = np.zeros((capacity, len(self.flat)))
        self.words = np.zeros((capacity, n_words), dtype=np.int64)
        self.times = np.zeros(capacity, dtype=np.int64)
        self.machine = machine
        self.watch = watch
        self.written = 0  # samples taken since arming
        self.trigger_index = -1
        self.start = self.end = 0  # the kept window once fired: samples [start, end)
        self.state = ARMED
        if machine.fired:  # `now`: the first sample is the trigger's
            self.fire(0)

    # -- sampling (the tick's hot path) -----------------------------------------------------------
    def sample(self, t_ns: int, words: np.ndarray | None = None) -> None:
        """Take one sample of the source now, at simulated time t_ns (none once done)."""
        if self.state == DONE:
            return
        i = self.written
        slot = i % self.capacity
        np.take(self.source, self.flat, out=self.ring[slot])
        if words is not None:
            self.words[slot] = words
        self.times[slot] = t_ns
        self.written = i + 1
        if self.state == ARMED:
            if self.watch >= 0 and self.machine.position(float(self.source.flat[self.watch])):
                self.fire(i)
        elif self.written >= self.end:
            self.state = DONE

    def rest(self, count: int, times: Callable[[np.ndarray], np.ndarray],
             words: np.ndarray | None = None) -> None:
        """`count` samples at rest, the state constant (decision 0008), the words `words`:
        `times(j)` gives the times of samples j (0-based from the next one). Writes those it
        keeps: the last `capacity` while armed (a trigger cannot fire at rest), else up to the
        window's end."""
        if count <= 0 or self.state == DONE:
            return
        row = np.take(self.source, self.flat)
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
        """The trigger fired at sample `index` (the last taken or the next one)."""
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
