"""Lockstep speed: simulated seconds per wall second for a 4-axis servo card at 1 kHz.

Through the daemon (`sim step seconds=S` from a client, the card's four axes jogging all the
time, so the PID and plant work every tick), with the same card idle as the baseline of the same
run, and in-process (no sockets) to show the transport's share. Goal (issue 2): >= 50x.
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

from bench.common import connect, daemon, pin, placement, servo_card
from vdevd.config import parse
from vdevd.daemon import build_rack

CONFIG = '[clock]\nmode = "lockstep"\n' + servo_card(axes=4, plant="servo", period_ns=1_000_000)


def jog_all(write32: Any) -> None:
    for axis in range(4):
        base = 0x100 + 0x40 * axis
        write32(base + 0x04, 20_000 * (axis + 1))  # TARGET = velocity for JOG
        write32(base + 0x0C, 500_000)
        write32(base + 0x10, 500_000)
        write32(base + 0x00, 3)  # COMMAND = JOG


def stop_all(write32: Any) -> None:
    for axis in range(4):
        write32(0x100 + 0x40 * axis, 4)  # COMMAND = STOP


def speeds(step: Any, seconds: float, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        step(seconds)
        out.append(seconds / (time.perf_counter() - t0))
    return out


def run(seconds: float = 10.0, repeats: int = 3, pin_mode: str = "split") -> dict[str, Any]:
    server_cpus, client_cpus = placement(pin_mode)
    pin(client_cpus)
    with daemon(CONFIG, server_cpus) as (endpoint, _):
        rack = connect(endpoint, timeout=120)
        bar = rack.card("servo0").region("bar0")

        def step(s: float) -> None:
            rack.sim.step(seconds=s)  # type: ignore[union-attr]

        jog_all(bar.write32)
        moving = speeds(step, seconds, repeats)
        stop_all(bar.write32)
        step(1.0)
        idle = speeds(step, seconds, repeats)
        rack.close()
    local = build_rack(parse({"clock": {"mode": "lockstep"}, "card": [
        {"type": "generic-servo", "name": "servo0", "axes": 4, "plant": "servo",
         "period_ns": 1_000_000}]}))
    card = local.cards["servo0"]
    jog_all(lambda off, v: card.bar.write(off, (v & 0xFFFFFFFF).to_bytes(4, "little")))

    def advance(s: float) -> None:
        local.sched.advance(local.now_ns + int(s * 1e9))

    inproc = speeds(advance, seconds, repeats)
    med = statistics.median(moving)
    return {"seconds": seconds, "moving": moving, "idle": idle, "in_process": inproc,
            "median": med, "pass": med >= 50}


def report(r: dict[str, Any]) -> None:
    def line(xs: list[float]) -> str:
        return f"median {statistics.median(xs):6.1f}x  min {min(xs):6.1f}x  max {max(xs):6.1f}x"

    print(f"lockstep speed, 4-axis servo card at 1 kHz, steps of {r['seconds']:.0f} s simulated")
    print(f"  through the daemon, axes jogging  {line(r['moving'])}")
    print(f"  baseline: same card idle          {line(r['idle'])}")
    print(f"  in-process, axes jogging          {line(r['in_process'])}")
    print(f"  goal >= 50x real time   {'PASS' if r['pass'] else 'FAIL'}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--pin", choices=["split", "same", "none"], default="split")
    a = p.parse_args()
    report(run(a.seconds, a.repeats, a.pin))


if __name__ == "__main__":
    main()
