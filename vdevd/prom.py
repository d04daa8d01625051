"""The rack's Prometheus metrics (issue 22 "Operations"), read at scrape time only.

Nothing here runs between scrapes: a scrape asks the rack's event loop for one snapshot of its
counters (`Rack.stats`, the cards' counters), so the daemon at rest and per request pays nothing
for the endpoint; a scrape costs the loop what a `stats` request does (its percentiles: a few ms
once the sample rings are full). The request latency histograms are filled at scrape time from the latency
ring the `stats` op already keeps (`metrics.TaggedSamples`, each sample tagged with its op): the
samples added since the last scrape go to their buckets. When more requests than the ring holds
(65,536) arrived between two scrapes, the buckets are scaled from the ones still held; the
request counters (`vdevd_requests_total`) are exact.

Names start with `vdevd_`; per-card series carry a `card` label.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
from collections.abc import Iterator
from typing import Any

import numpy as np
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, HistogramMetricFamily
from prometheus_client.registry import Collector, CollectorRegistry

from vdevd.metrics import OP_TAGS
from vdevd.rack import Rack

#: request latency buckets, seconds (a read on loopback takes ~20 us end to end)
LATENCY_BUCKETS_S = (5e-6, 1e-5, 2e-5, 5e-5, 1e-4, 2e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 5e-2, 0.1,
                     1.0)
_BOUNDS_NS = np.array([round(b * 1e9) for b in LATENCY_BUCKETS_S], dtype=np.int64)
_OP_OF_TAG = {tag: op for op, tag in OP_TAGS.items()}
_QUANTILES = (("0.5", "p50"), ("0.9", "p90"), ("0.99", "p99"), ("0.999", "p999"))


class LatencyHistograms:
    """Cumulative latency histograms by op, fed from the rack's tagged latency ring."""

    def __init__(self) -> None:
        self.seen = 0  # samples of the ring already in the buckets
        self.buckets: dict[str, np.ndarray] = {}  # op -> counts per bucket (last: above all)
        self.sum_ns: dict[str, int] = {}

    def update(self, rack: Rack) -> None:
        """Bucket the samples added since the last update (on the rack's loop)."""
        values, tags, added = rack.latency.since(self.seen)
        self.seen = rack.latency.added
        if not len(values):
            return
        scale = added / len(values)  # > 1 only when the ring went round between two scrapes
        slots = np.searchsorted(_BOUNDS_NS, values, side="left")
        for tag in np.unique(tags):
            op = _OP_OF_TAG.get(int(tag))
            if op is None:
                continue
            mine = tags == tag
            counts = np.bincount(slots[mine], minlength=len(_BOUNDS_NS) + 1)
            total = int(values[mine].sum())
            if scale != 1:
                counts, total = np.rint(counts * scale).astype(np.int64), round(total * scale)
            self.buckets[op] = self.buckets.get(op, 0) + counts
            self.sum_ns[op] = self.sum_ns.get(op, 0) + total

    def family(self) -> HistogramMetricFamily:
        fam = HistogramMetricFamily("vdevd_request_duration_seconds",
                                    "time to serve a request (its reply, or its deferral for a "
                                    "wait), by op", labels=["op"])
        for op, counts in sorted(self.buckets.items()):
            cumulative = np.cumsum(counts)
            buckets = [(f"{b:g}", float(c)) for b, c in zip(LATENCY_BUCKETS_S, cumulative[:-1],
                                                            strict=True)]
            buckets.append(("+Inf", float(cumulative[-1])))
            fam.add_metric([op], buckets, self.sum_ns[op] / 1e9)
        return fam


class RackCollector(Collector):
    """A `prometheus_client` collector of one served rack. `collect` runs on the scraping
    thread; it takes the rack's numbers on the rack's loop (`timeout_s` at most, else
    `TimeoutError`: the loop does not answer)."""

    def __init__(self, rack: Rack, loop: asyncio.AbstractEventLoop, timeout_s: float = 2.0) -> None:
        self.rack = rack
        self.loop = loop
        self.timeout_s = timeout_s
        self.latency = LatencyHistograms()

    def describe(self) -> list[Any]:
        return []  # registering must not scrape

    def snapshot(self) -> dict[str, Any]:
        """The rack's numbers (on the rack's loop)."""
        self.latency.update(self.rack)
        cards = {}
        for card in self.rack.cards.values():
            nvram = card.ctx.nvram
            cards[card.name] = {"connections": card.connections(),
                                "nv_saves": nvram.saves.get(card.name, 0) if nvram else 0}
        # the histogram family is built here too: a concurrent scrape's update runs on the loop
        return {"stats": self.rack.stats(), "cards": cards, "latency": self.latency.family()}

    def _taken(self) -> dict[str, Any]:
        done: concurrent.futures.Future[dict[str, Any]] = concurrent.futures.Future()

        def take() -> None:
            try:
                done.set_result(self.snapshot())
            except BaseException as exc:
                done.set_exception(exc)

        self.loop.call_soon_threadsafe(take)
        return done.result(self.timeout_s)

    def collect(self) -> Iterator[Any]:
        snap = self._taken()
        stats, extra = snap["stats"], snap["cards"]
        sched, requests = stats["scheduler"], stats["requests"]

        info = GaugeMetricFamily("vdevd_info", "the daemon's clock mode and motion core",
                                 labels=["clock", "motion_core"])
        info.add_metric([stats["clock"]["mode"], stats["motion_core"]], 1)
        yield info
        yield GaugeMetricFamily("vdevd_uptime_seconds", "wall time since the rack was built",
                                value=stats["uptime_s"])
        yield GaugeMetricFamily("vdevd_simulated_time_seconds", "the rack's simulated clock",
                                value=stats["clock"]["now_ns"] / 1e9)

        per_card: list[tuple[str, str, str, type]] = [
            ("vdevd_card_ticks", "servo ticks run", "ticks", CounterMetricFamily),
            ("vdevd_card_quiet_ticks", "ticks run in closed form at rest", "quiet_ticks",
             CounterMetricFamily),
            ("vdevd_card_lost_ticks", "ticks that fell due and were not run (lateness)",
             "lost_ticks", CounterMetricFamily),
            ("vdevd_card_interrupts", "interrupts asserted", "irq_seq", CounterMetricFamily),
        ]
        for name, doc, key, kind in per_card:
            fam = kind(name, doc, labels=["card"])
            for card, numbers in stats["cards"].items():
                fam.add_metric([card], numbers.get(key, 0))
            yield fam
        conns = GaugeMetricFamily("vdevd_card_connections",
                                  "open connections to the card's own TCP ports", labels=["card"])
        saves = CounterMetricFamily("vdevd_card_nv_saves", "non-volatile images written",
                                    labels=["card"])
        for card, numbers in extra.items():
            conns.add_metric([card], numbers["connections"])
            saves.add_metric([card], numbers["nv_saves"])
        yield conns
        yield saves
        yield from _stalls(sched, stats["cards"])

        yield CounterMetricFamily("vdevd_scheduler_passes", "scheduler passes",
                                  value=sched["passes"])
        yield CounterMetricFamily("vdevd_scheduler_overruns",
                                  "passes that could not finish the ticks due",
                                  value=sched["overruns"])
        yield CounterMetricFamily("vdevd_card_faults", "ticks and scheduled actions that raised",
                                  value=sched["card_faults"])
        for key, name, doc in (("late_ns", "vdevd_scheduler_late_seconds",
                                "how late a scheduler pass started (last 65536 passes)"),
                               ("behind_ns", "vdevd_scheduler_behind_seconds",
                                "simulated time behind wall time at a pass (last 65536)")):
            fam = GaugeMetricFamily(name, doc, labels=["quantile"])
            for q, field in _QUANTILES:
                fam.add_metric([q], sched[key][field] / 1e9)
            yield fam
        overload = stats.get("overload", {})
        yield GaugeMetricFamily("vdevd_overloaded", "1 while the rack cannot keep up with wall "
                                "time", value=int(bool(overload.get("overloaded", False))))

        by_op = CounterMetricFamily("vdevd_requests", "requests served, by op", labels=["op"])
        for op, n in sorted(requests["by_op"].items()):
            by_op.add_metric([op], n)
        yield by_op
        yield snap["latency"]
        yield CounterMetricFamily("vdevd_errors", "requests answered with an error, and "
                                  "internal errors", value=requests["errors"])
        yield GaugeMetricFamily("vdevd_pending_waits", "waits not yet answered",
                                value=requests["pending_waits"])
        if "scheduled" in requests or "scheduled" in stats:
            scheduled = requests.get("scheduled", stats.get("scheduled"))
            if isinstance(scheduled, int):
                yield GaugeMetricFamily("vdevd_scheduled_actions",
                                        "backdoor actions scheduled for later", value=scheduled)
        yield CounterMetricFamily("vdevd_events_published", "interrupt events published",
                                  value=stats["events_published"])


def _stalls(sched: dict[str, Any], cards: dict[str, Any]) -> Iterator[Any]:
    """The scheduler's stalls (a pass more than 100 ms late: `stats` "scheduler" "stalls",
    {count, longest_ns, total_ns}) under every card's label: the rack's one scheduler stalls
    every card."""
    stalls = sched["stalls"]
    count = CounterMetricFamily("vdevd_stalls", "scheduler passes more than 100 ms late",
                                labels=["card"])
    total = CounterMetricFamily("vdevd_stall_seconds", "time lost in stalls", labels=["card"])
    longest = GaugeMetricFamily("vdevd_stall_longest_seconds", "the longest stall",
                                labels=["card"])
    for name in cards:
        count.add_metric([name], stalls["count"])
        total.add_metric([name], stalls["total_ns"] / 1e9)
        longest.add_metric([name], stalls["longest_ns"] / 1e9)
    yield from (count, total, longest)


def registry_of(rack: Rack, loop: asyncio.AbstractEventLoop,
                collector: RackCollector | None = None) -> CollectorRegistry:
    """A registry of the rack's metrics (through `collector`, made here when not given) and the
    process's (memory, CPU, open files)."""
    from prometheus_client import ProcessCollector

    registry = CollectorRegistry()
    registry.register(collector or RackCollector(rack, loop))
    ProcessCollector(namespace="vdevd", registry=registry)
    return registry
