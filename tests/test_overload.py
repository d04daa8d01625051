"""A realtime rack that cannot keep up (issue 17, decision 0009): no piece of ticking holds the
event loop longer than about SLICE_BUDGET_NS, beyond OVERLOAD_BEHIND_NS simulated time slips
(marked in `stats` and logged once per episode), no tick is lost, and the daemon answers and
stops on a signal while overloaded.

The rule is tested without sockets on a test-driven wall clock that each tick moves on by its
cost; the live daemon test overloads a real daemon (eight MAXk at 8192 Hz running contours,
about four times what this project's machine can tick) and measures from a client.
"""

from __future__ import annotations

import json
import logging
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import vdevclient
from vdevclient import maxk

from tests.test_scheduler import Counter, run
from vdevd.pacing import (
    CALM_BEHIND_NS,
    CALM_HOLD_NS,
    OVERLOAD_BEHIND_NS,
    SLICE_BUDGET_NS,
)
from vdevd.rack import Rack

PERIOD_NS = 100_000
WAKE_NS = 1_000_000


class WallClock:
    """A monotonic clock in ns that the test and the cards' ticks move."""

    def __init__(self) -> None:
        self.ns = 7_000_000_000

    def __call__(self) -> int:
        return self.ns


class Heavy(Counter):
    """A card whose every tick costs `cost_ns` of wall time (the clock moves on by it)."""

    def __init__(self, name: str, clock: WallClock, cost_ns: int) -> None:
        super().__init__(name, PERIOD_NS)
        self.clock = clock
        self.cost_ns = cost_ns

    def step(self) -> None:
        super().step()
        self.clock.ns += self.cost_ns


class Loop:
    """The part of an event loop the pacing uses: timers (the `timer` waker) and `call_soon`."""

    def __init__(self) -> None:
        self.later: list[tuple[float, Callable[[], None]]] = []
        self.soon: list[Callable[[], None]] = []

    def call_later(self, delay: float, callback: Callable[[], None]) -> None:
        self.later.append((delay, callback))

    def call_soon(self, callback: Callable[[], None]) -> None:
        self.soon.append(callback)


class Bench:
    """A realtime rack of one Heavy card on the test's clock and loop; `turn()` runs what the
    loop would run next (a continuation first, else the next wake) and returns the wall time
    it held the loop."""

    def __init__(self, cost_ns: int) -> None:
        self.clock, self.loop = WallClock(), Loop()
        self.card = Heavy("c", self.clock, cost_ns)
        self.rack = Rack([self.card], "realtime", wake_ns=WAKE_NS, waker="timer",
                         clock=self.clock)
        self.rack.start(self.loop)  # type: ignore[arg-type]

    def turn(self) -> int:
        before = self.clock.ns
        if self.loop.soon:
            self.loop.soon.pop(0)()
        else:
            delay, callback = self.loop.later.pop()
            self.clock.ns = max(self.clock.ns, before + int(delay * 1e9))
            before = self.clock.ns
            callback()
        return self.clock.ns - before

    def behind(self) -> int:
        return int(self.rack.stats()["overload"]["behind_ns"])

    def ticks_all_run(self) -> bool:
        return (self.rack.sched.lost_ticks() == {"c": 0}
                and self.card.ticks == self.rack.now_ns // PERIOD_NS)


def test_a_pass_holds_the_loop_one_slice_budget_and_continues_at_the_next_turn() -> None:
    b = Bench(cost_ns=250_000)  # a tick of 100 us costs 250 us: 2.5 times real time
    held = [b.turn() for _ in range(200)]
    tick = b.card.cost_ns
    # the first slice has no cost estimate yet: at most one wake period of ticks
    assert held[0] <= max(SLICE_BUDGET_NS, WAKE_NS // PERIOD_NS * tick)
    assert max(held[1:]) <= SLICE_BUDGET_NS + tick
    assert b.rack.pacer.continuations > 100  # the work went on at the loop's next turns
    assert b.ticks_all_run()


def test_beyond_the_threshold_simulated_time_slips_and_the_episode_is_logged_once(
        caplog: pytest.LogCaptureFixture) -> None:
    b = Bench(cost_ns=250_000)
    with caplog.at_level(logging.WARNING, "vdevd.rack"):
        while b.clock.ns - 7_000_000_000 < 2_000_000_000:  # 2 s of wall time
            b.turn()
    overload = b.rack.stats()["overload"]
    assert overload["active"] is True and overload["episodes"] == 1
    # simulated time runs at 1/2.5 of wall time: ~1.2 s of the 2 s slipped, 100 ms is behind
    assert 1_100_000_000 < overload["slipped_ns"] < 1_300_000_000
    assert OVERLOAD_BEHIND_NS - SLICE_BUDGET_NS <= overload["behind_ns"] \
        <= OVERLOAD_BEHIND_NS + 2 * SLICE_BUDGET_NS
    assert b.rack.stats()["clock"]["epoch_monotonic_ns"] == 7_000_000_000 + overload["slipped_ns"]
    assert b.ticks_all_run()  # time slipped: not one tick was skipped
    starts = [r for r in caplog.records if "overload" in r.getMessage()]
    assert len(starts) == 1 and "behind" in starts[0].getMessage()


def test_the_episode_ends_once_calm_for_the_hold_time_and_the_next_one_counts_again(
        caplog: pytest.LogCaptureFixture) -> None:
    b = Bench(cost_ns=250_000)
    while not b.rack.pacer.overloaded:
        b.turn()
    caplog.clear()
    with caplog.at_level(logging.WARNING, "vdevd.rack"):
        b.card.cost_ns = 10_000  # the load goes: 10 % of real time
        calm_from = None
        while b.rack.pacer.overloaded:
            b.turn()
            if calm_from is None and b.behind() <= CALM_BEHIND_NS:
                calm_from = b.clock.ns
        assert calm_from is not None
        assert CALM_HOLD_NS <= b.clock.ns - calm_from <= CALM_HOLD_NS + 2 * WAKE_NS
        slipped = b.rack.pacer.slipped_ns
        for _ in range(1000):  # calm: real time again, nothing slips
            b.turn()
        assert b.rack.pacer.slipped_ns == slipped and b.behind() < WAKE_NS
        b.card.cost_ns = 250_000
        while not b.rack.pacer.overloaded:
            b.turn()
    # (the test's loop runs every queued continuation before a timer: a wake it holds back
    # 100 ms is a stall, logged apart)
    messages = [r.getMessage() for r in caplog.records if not r.getMessage().startswith("stall")]
    assert len(messages) == 2 and "over after" in messages[0] and "episode 2" in messages[1]
    assert b.rack.stats()["overload"]["episodes"] == 2
    assert b.ticks_all_run()


def test_a_request_does_not_catch_up_while_the_pacing_is_catching_up() -> None:
    b = Bench(cost_ns=250_000)
    while not b.loop.soon:
        b.turn()
    catch_ups, before = b.rack.catch_ups, b.clock.ns
    assert run(b.rack, "read", card="c", region="mem", offset=0, size=4) is not None
    assert b.clock.ns == before and b.rack.catch_ups == catch_ups  # answered at once


def test_a_request_catch_up_is_budgeted_too() -> None:
    b = Bench(cost_ns=250_000)
    b.turn()
    b.clock.ns += 50_000_000  # a request 50 ms after the pass: 500 ticks due, 125 ms of work
    before = b.clock.ns
    run(b.rack, "stats")
    assert b.clock.ns - before <= SLICE_BUDGET_NS + b.card.cost_ns
    assert b.rack.catch_ups == 1 and len(b.loop.soon) == 1  # the rest goes on at the next turn


# -- a live daemon beyond this machine --------------------------------------------------------------
CONTOUR = "AA; VV4000; VA20000; VP40000,20000; VCR1000,0,180; VP0,0; VE;"
#: the issue's figures: answers within 50 ms at the 99th percentile, a stop within 2 s
ANSWER_P99_S = 0.050
STOP_S = 2.0


def overloaded_rack(tmp_path: Path) -> str:
    cards = "".join(f'[[card]]\ntype = "oms-maxk"\nname = "maxk{i}"\nboard = {i + 1}\n'
                    f"axes = 4\nupdate_hz = 8192\n" for i in range(8))
    (tmp_path / "rack.toml").write_text('[clock]\nmode = "realtime"\n\n' + cards)
    return str(tmp_path / "rack.toml")


def start_daemon(tmp_path: Path, config: str) -> tuple[subprocess.Popen[bytes], dict[str, Any]]:
    ready = tmp_path / "ready.json"
    with open(tmp_path / "vdevd.log", "wb") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "vdevd", "serve", "--config", config, "--endpoint",
             "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*", "--ready-file", str(ready)],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log)
    deadline = time.monotonic() + 60  # a guard against a daemon that never starts
    while not ready.exists():
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            raise AssertionError(f"vdevd did not start:\n{(tmp_path / 'vdevd.log').read_text()}")
        time.sleep(0.01)
    return proc, json.loads(ready.read_text())


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_an_overloaded_daemon_answers_within_50_ms_and_stops_on_a_signal_within_2_s(
        tmp_path: Path, signum: signal.Signals) -> None:
    proc, info = start_daemon(tmp_path, overloaded_rack(tmp_path))
    try:
        # requests only: a read through shared memory would not wait for the event loop
        with vdevclient.connect(info["endpoint"], info["events"], timeout=5.0, shm=False) as rack:
            for i in range(8):
                maxk.Maxk(rack, f"maxk{i}", timeout_ms=5000).send_string(CONTOUR)
            shm = rack.card("maxk0").region("shm")
            reads: list[float] = []
            stats: list[float] = []
            end = time.monotonic() + 3.0
            while time.monotonic() < end:
                t0 = time.perf_counter()
                shm.read32(0)
                t1 = time.perf_counter()
                overload = rack.stats()["overload"]
                t2 = time.perf_counter()
                reads.append(t1 - t0)
                stats.append(t2 - t1)
                time.sleep(0.002)
            final = rack.stats()
        assert overload["active"] and final["overload"]["active"]
        assert final["overload"]["episodes"] == 1
        assert final["overload"]["behind_ns"] >= OVERLOAD_BEHIND_NS // 2
        assert final["overload"]["slipped_ns"] > 1_000_000_000  # ~3/4 of the 3 s and more
        assert final["scheduler"]["lost_ticks"] == 0
        assert float(np.percentile(reads, 99)) <= ANSWER_P99_S, sorted(reads)[-5:]
        assert float(np.percentile(stats, 99)) <= ANSWER_P99_S, sorted(stats)[-5:]
        t0 = time.monotonic()
        proc.send_signal(signum)
        try:
            code = proc.wait(timeout=30)  # a guard; the figure is the time taken
        except subprocess.TimeoutExpired:
            code = None
        took = time.monotonic() - t0
        assert code == 0 and took <= STOP_S, f"exit {code} after {took:.1f} s"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    log = (tmp_path / "vdevd.log").read_text()
    assert log.count("overload:") == 1, log
