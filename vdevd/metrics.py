"""Sample rings for the `stats` op: percentiles of the last N samples, counters beside them."""

from __future__ import annotations

from array import array

import numpy as np

from vdevd.protocol import SCHEMA

#: each op's tag in the request latencies (`TaggedSamples`); 0: no op
OP_TAGS: dict[str, int] = {op: i for i, op in enumerate(SCHEMA, 1)}


class Samples:
    """The last `capacity` samples of one quantity (ints, e.g. ns), with percentiles."""

    def __init__(self, capacity: int = 65536) -> None:
        self._buf = array("q", bytes(8 * capacity))  # a plain array: a store costs less than numpy's
        self._capacity = capacity
        self._n = 0
        self.count = 0
        self.max = 0

    def add(self, value: int) -> None:
        self._buf[self._n % self._capacity] = value
        self._n += 1
        self.count += 1
        if value > self.max:
            self.max = value

    def summary(self) -> dict[str, int]:
        """{count, p50, p90, p99, p999, max}: count and max over every sample, the percentiles
        over the last `capacity`; all 0 before the first sample."""
        n = min(self._n, self._capacity)
        if n == 0:
            return dict.fromkeys(("count", "p50", "p90", "p99", "p999", "max"), 0)
        p50, p90, p99, p999 = np.percentile(
            np.frombuffer(self._buf, dtype=np.int64, count=n), [50, 90, 99, 99.9])
        return {
            "count": self.count,
            "p50": int(p50),
            "p90": int(p90),
            "p99": int(p99),
            "p999": int(p999),
            "max": int(self.max),
        }


class TaggedSamples(Samples):
    """Samples each tagged with a small integer (the request latencies, tagged with their op:
    `OP_TAGS`), so the metrics endpoint can sort the last `capacity` samples by tag without a
    ring per tag on the request path."""

    def __init__(self, capacity: int = 65536) -> None:
        super().__init__(capacity)
        self._tags = array("B", bytes(capacity))

    def add(self, value: int, tag: int = 0) -> None:
        i = self._n % self._capacity
        self._buf[i] = value
        self._tags[i] = tag
        self._n += 1
        self.count += 1
        if value > self.max:
            self.max = value

    def since(self, n: int) -> tuple[np.ndarray, np.ndarray, int]:
        """(values, tags, added) of the samples added after the first `n` (`added` of them, of
        which at most the last `capacity` are still held and returned), oldest first."""
        added = self._n - n
        held = min(added, self._capacity)
        if held <= 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty.astype(np.uint8), max(added, 0)
        values = np.frombuffer(self._buf, dtype=np.int64)
        tags = np.frombuffer(self._tags, dtype=np.uint8)
        start, end = (self._n - held) % self._capacity, self._n % self._capacity
        if start < end:
            return values[start:end].copy(), tags[start:end].copy(), added
        return (np.concatenate((values[start:], values[:end])),
                np.concatenate((tags[start:], tags[:end])), added)

    @property
    def added(self) -> int:
        """Samples added so far (the `n` of `since`)."""
        return self._n
