"""`stats`: clock, scheduler, per-card ticks and request counters."""

from __future__ import annotations

from tests.conftest import RawClient, error_code


def test_stats_counts_requests_errors_and_ticks(raw: RawClient) -> None:
    raw.call(op="sim", action="step", ns=5_000_000)
    raw.call(op="read", card="servo0", region="bar0", offset=0, size=4)
    error_code(raw.call(op="read", card="servo0", region="bar0", offset=1, size=4))
    stats = raw.call(op="stats")["ok"]
    assert stats["clock"]["now_ns"] == 5_000_000
    assert stats["cards"]["servo0"]["ticks"] == 5
    assert stats["scheduler"]["lost_ticks"] == 0
    assert stats["requests"]["by_op"]["read"] == 2
    assert stats["requests"]["errors"] == 1
    assert stats["requests"]["latency_ns"]["count"] >= 3


def test_distributions_have_every_field_before_the_first_sample(raw: RawClient) -> None:
    stats = raw.call(op="stats")["ok"]
    for dist in (stats["scheduler"]["late_ns"], stats["scheduler"]["behind_ns"]):  # lockstep
        assert dist == {"count": 0, "p50": 0, "p90": 0, "p99": 0, "p999": 0, "max": 0}


def test_stats_says_which_motion_core_ticks(raw: RawClient) -> None:
    """Decision 0011: the compiled kernel (numba is a dependency), the numpy path when
    VDEVD_JIT=0 runs the suite."""
    from vdevd.rt import kernel

    want = "numpy" if kernel.jit_disabled() else "compiled"
    assert raw.call(op="stats")["ok"]["motion_core"] == want
