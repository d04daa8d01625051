"""Realtime clock: simulated time against wall time over a long run, and lost ticks.

A client (cpu1) samples `sim now` every ~10 ms; behind = (wall midpoint of the request -
the daemon's epoch) - simulated now, both on CLOCK_MONOTONIC. The daemon (cpu0) reports its
own lateness, overruns and lost ticks in `stats`. Goal (issue 2): no tick ever lost; behind
p99 <= 2 ms over 60 s. The baseline of the same run is the `sim now` round trip itself.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from bench.common import connect, daemon, fmt, pin, placement, servo_card, summary


def run(seconds: float = 60.0, wake_us: int = 1000, waker: str = "thread",
        pin_mode: str = "split") -> dict[str, Any]:
    server_cpus, client_cpus = placement(pin_mode)
    pin(client_cpus)
    config = (f'[clock]\nmode = "realtime"\nwake_us = {wake_us}\nwaker = "{waker}"\n'
              + servo_card())
    behind: list[float] = []
    rtts: list[float] = []
    with daemon(config, server_cpus) as (endpoint, _):
        rack = connect(endpoint, timeout=5)
        # the servo card moves all the time: jog every axis
        bar = rack.card("servo0").region("bar0")
        for axis in range(4):
            base = 0x100 + 0x40 * axis
            bar.write32(base + 0x04, 20_000)
            bar.write32(base + 0x00, 3)
        epoch = rack.stats()["clock"]["epoch_monotonic_ns"]
        end = time.monotonic() + seconds
        clock = time.perf_counter_ns
        while time.monotonic() < end:
            t0 = clock()
            now = rack.request("sim", action="now")["now_ns"]
            t1 = clock()
            behind.append(((t0 + t1) / 2 - epoch - now) / 1000)
            rtts.append((t1 - t0) / 1000)
            time.sleep(0.01)
        stats = rack.stats()
        rack.close()
    b, r = summary(behind), summary(rtts)
    card = stats["cards"]["servo0"]
    return {
        "seconds": seconds, "wake_us": wake_us, "waker": waker, "placement": pin_mode,
        "behind_us": b, "rtt_us": r, "daemon": stats["scheduler"], "ticks": card["ticks"],
        "lost_ticks": stats["scheduler"]["lost_ticks"],
        "pass": stats["scheduler"]["lost_ticks"] == 0 and b["p99"] <= 2000,
    }


def report(res: dict[str, Any]) -> None:
    d = res["daemon"]
    print(f"realtime clock, {res['seconds']:.0f} s, wake {res['wake_us']} us ({res['waker']}), "
          f"placement {res['placement']}")
    print(f"  sim behind wall (client) {fmt(res['behind_us'])}")
    print(f"  baseline: sim-now RTT    {fmt(res['rtt_us'])}")
    print(f"  behind p99 = {res['behind_us']['p99'] / res['rtt_us']['p50']:.1f}x the RTT p50; "
          f"goal p99 <= 2000 us")
    late = {k: round(v / 1000, 1) for k, v in d["late_ns"].items() if k != "count"}
    print(f"  daemon: passes {d['passes']}, overruns {d['overruns']}, wake lateness us {late}")
    print(f"  ticks {res['ticks']}, lost ticks {res['lost_ticks']}   "
          f"{'PASS' if res['pass'] else 'FAIL'}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--wake-us", type=int, default=1000)
    p.add_argument("--waker", choices=["thread", "timer"], default="thread")
    p.add_argument("--pin", choices=["split", "same", "none"], default="split")
    a = p.parse_args()
    report(run(a.seconds, a.wake_us, a.waker, a.pin))


if __name__ == "__main__":
    main()
