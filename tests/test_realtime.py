"""The realtime clock on a live daemon, with each waker: simulated time follows wall time and no
tick is lost (no wall-clock asserts: the daemon's own counters are checked). The pacing itself
(catch-up after a late wake, overruns, lateness) is tested with a test-driven wall clock in
tests/test_scheduler.py."""

from __future__ import annotations

import pytest
import vdevclient

from tests.conftest import rack_config
from vdevd.devices.generic import regions as R
from vdevd.testing import DaemonThread


@pytest.mark.parametrize("waker", ["thread", "timer"])
def test_realtime_runs_every_tick_and_serves_waits(waker: str) -> None:
    cfg = rack_config(clock="realtime")
    cfg.waker = waker  # type: ignore[assignment]
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint) as rack:
        assert rack.sim.mode == "realtime"
        assert rack.stats()["clock"]["waker"] == waker
        bar = rack.card("servo0").region("bar0")
        # the tick counter reaches 64..127 by itself (checked after each pass, which may run
        # several ticks, hence a range); the timeout is generous, not measured
        value = bar.wait_value(R.TICK_LO, 0x40, mask=0x40, timeout_s=30.0)
        assert value is not None and value >= 64
        stats = rack.stats()
        assert stats["scheduler"]["lost_ticks"] == 0
        assert stats["cards"]["servo0"]["ticks"] >= 64
        assert stats["scheduler"]["passes"] > 0
        assert stats["clock"]["now_ns"] >= 64 * 1_000_000
        assert stats["cards"]["servo0"]["ticks"] == stats["clock"]["now_ns"] // 1_000_000
