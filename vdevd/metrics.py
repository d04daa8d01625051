"""Sample rings for the `stats` op: percentiles of the last N samples, counters beside them."""

from __future__ import annotations

from array import array

import numpy as np


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
