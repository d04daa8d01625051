"""Register read round trip: a 4-byte `Region.read` through vdevclient against a live daemon,
as a ratio of a raw pyzmq REQ/REP round trip measured in the same run with the same placement.

Goal (issue 2): p50 <= 1.25x and p99 <= 1.5x. Placement `split` (default): server on cpu0,
client on cpu1 (../shared/spec/limits.md: cross-core wake-ups dominate, so state placement).
Baseline and daemon repeats are interleaved to cancel drift.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import msgpack
import zmq

from bench.common import (
    connect,
    daemon,
    fmt,
    free_port,
    pin,
    placement,
    process,
    servo_card,
    summary,
    wait_for,
)

POSITION0 = 0x11C  # generic-servo axis 0 POSITION register


def time_calls(fn: Any, n: int) -> list[float]:
    out = []
    clock = time.perf_counter_ns
    for _ in range(n):
        t0 = clock()
        fn()
        out.append((clock() - t0) / 1000)
    return out


def run(n: int = 5000, repeats: int = 3, warmup: int = 1000, pin_mode: str = "split") -> dict[str, Any]:
    server_cpus, client_cpus = placement(pin_mode)
    pin(client_cpus)
    raw_ep = f"tcp://127.0.0.1:{free_port()}"
    raw_samples: list[float] = []
    vdev_samples: list[float] = []
    argv = [sys.executable, "-m", "bench.raw_server", raw_ep]
    with process(argv, server_cpus), daemon(servo_card(), server_cpus) as (endpoint, _):
        req = zmq.Context.instance().socket(zmq.REQ)
        req.linger = 0
        req.rcvtimeo = 10_000
        req.connect(raw_ep)
        body = msgpack.packb([1, "bar0", POSITION0, 4])

        def raw_read() -> bytes:
            req.send(body)
            return req.recv()

        wait_for(raw_read)
        rack = connect(endpoint, timeout=5)
        region = rack.card("servo0").region("bar0")

        def vdev_read() -> bytes:
            return region.read(POSITION0, 4)

        time_calls(raw_read, warmup)
        time_calls(vdev_read, warmup)
        block = 250  # alternate short blocks so that drift on a shared host hits both alike
        for _ in range(repeats * n // block):
            raw_samples += time_calls(raw_read, block)
            vdev_samples += time_calls(vdev_read, block)
        rack.close()
        req.close()
    raw, vdev = summary(raw_samples), summary(vdev_samples)
    return {
        "placement": pin_mode,
        "raw": raw,
        "vdevd": vdev,
        "ratio_p50": vdev["p50"] / raw["p50"],
        "ratio_p99": vdev["p99"] / raw["p99"],
        "pass": vdev["p50"] <= 1.25 * raw["p50"] and vdev["p99"] <= 1.5 * raw["p99"],
    }


def report(r: dict[str, Any]) -> None:
    print(f"register read round trip, placement {r['placement']} (server cpu0, client cpu1 when split)")
    print(f"  raw pyzmq REQ/REP      {fmt(r['raw'])}")
    print(f"  vdevclient read(4)     {fmt(r['vdevd'])}")
    print(f"  ratio p50 {r['ratio_p50']:.2f}x (goal <= 1.25)   p99 {r['ratio_p99']:.2f}x (goal <= 1.5)"
          f"   {'PASS' if r['pass'] else 'FAIL'}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--n", type=int, default=5000)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--pin", choices=["split", "same", "none"], default="split")
    a = p.parse_args()
    report(run(a.n, a.repeats, pin_mode=a.pin))


if __name__ == "__main__":
    main()
