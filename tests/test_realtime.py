"""The realtime clock: simulated time follows wall time and no tick is lost (no wall-clock asserts:
the daemon's own counters are checked)."""

from __future__ import annotations

import vdevclient

from tests.conftest import rack_config
from vdevd.devices.generic import regions as R
from vdevd.testing import DaemonThread


def test_realtime_runs_every_tick_and_serves_waits() -> None:
    with DaemonThread(rack_config(clock="realtime")) as d, vdevclient.connect(d.endpoint) as rack:
        assert rack.sim.mode == "realtime"
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
