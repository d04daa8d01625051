"""Lockstep speed: simulated seconds per wall second of a 4-axis servo card at a 1 kHz servo rate.

Goal (issue "Done when"): >= 50x faster than real time.

Method. `vdevd serve --clock lockstep` with one generic-servo card (axes = 4, plant = "servo",
period_ns = 1000000) runs pinned to the server cpu. Through vdevclient, every axis is set jogging
(TARGET = a signed velocity, VMAX, ACC, DEC, then COMMAND = JOG), so that profile, PID and plant
work on every tick of the run, then `rack.sim.step(seconds=S)` is timed from this process
(speed = S / wall seconds). The baseline of the same run is the same step with every axis
stopped (idle). The same card is also built in this process (vdevd.daemon.build_rack) and driven
with `rack.sched.advance` (no sockets, no event loop), so the transport's share is visible. Each
repeat runs daemon moving, daemon idle, in-process moving, in-process idle in turn (an untimed
settling step after each start or stop), so that the host's slow phases (this VM has phases of
seconds ~1.6x slower) hit every series alike. Sanity
checks: each step ends exactly S later, and the axes are still moving (VELOCITY != 0) at the end
of every moving repeat (|VELOCITY| >= half the jog speed) and stopped after every idle one
(below 1% of it: the servo's hunting at standstill remains).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/lockstep.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.common import (  # noqa: E402
    VELOCITY,
    axis_reg,
    connect,
    daemon,
    install_signal_handlers,
    jog_axes,
    jog_velocity,
    pin_self,
    placement,
    servo_card,
    signed32,
    stop_axes,
    table,
    verdict,
    write_json,
)

GOAL_SPEED = 50.0
SETTLE_S = 0.5  # untimed simulated seconds after starting or stopping the axes


def velocities(read32: Callable[[int], int], axes: int) -> list[int]:
    return [signed32(read32(axis_reg(a, VELOCITY))) for a in range(axes)]


def timed(step: Callable[[float], int], seconds: float) -> float:
    """Speed factor of one step of `seconds` simulated; checks that time moved exactly."""
    t0 = time.perf_counter()
    before_after = step(seconds)
    wall = time.perf_counter() - t0
    if before_after != round(seconds * 1e9):
        raise RuntimeError(f"a step of {seconds} s advanced {before_after} ns")
    return seconds / wall


@dataclass
class Target:
    """One way to drive the card: step simulated time, read and write its registers."""

    step: Callable[[float], int]
    read32: Callable[[int], int]
    write32: Callable[[int, int], None]


def one_repeat(t: Target, seconds: float, axes: int) -> tuple[float, float]:
    """(moving speed, idle speed): jog, settle, time a step; stop, settle, time a step."""
    jog_axes(t.write32, axes)
    t.step(SETTLE_S)
    moving = timed(t.step, seconds)
    v = velocities(t.read32, axes)
    if not all(abs(x) >= abs(jog_velocity(a)) / 2 for a, x in enumerate(v)):
        raise RuntimeError(f"an axis stopped during the moving run: velocities {v}")
    stop_axes(t.write32, axes)
    t.step(SETTLE_S)
    idle = timed(t.step, seconds)
    v = velocities(t.read32, axes)
    if any(abs(x) > abs(jog_velocity(a)) / 100 for a, x in enumerate(v)):  # servo hunting is fine
        raise RuntimeError(f"an axis still moves during the idle run: velocities {v}")
    return moving, idle


def in_process_target(axes: int, period_ns: int, plant: str) -> Target:
    """The same card built in this process (vdevd.daemon.build_rack), stepped with
    rack.sched.advance: no sockets, no event loop."""
    from vdevd.config import parse
    from vdevd.daemon import build_rack

    rack = build_rack(parse({"clock": {"mode": "lockstep"}, "card": [
        {"type": "generic-servo", "name": "servo0", "axes": axes, "plant": plant,
         "period_ns": period_ns}]}))
    bar = rack.cards["servo0"].regions["bar0"]

    def step(s: float) -> int:
        start = rack.sched.now_ns
        return rack.sched.advance(start + round(s * 1e9)) - start

    def read32(offset: int) -> int:
        return int.from_bytes(bar.read(offset, 4), "little")

    def write32(offset: int, value: int) -> None:
        bar.write(offset, (value & 0xFFFF_FFFF).to_bytes(4, "little"))

    return Target(step, read32, write32)


def run(seconds: float = 10.0, repeats: int = 5, pin: str = "split", axes: int = 4,
        period_ns: int = 1_000_000, plant: str = "servo") -> dict[str, Any]:
    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    config = '[clock]\nmode = "lockstep"\n' + servo_card(axes=axes, plant=plant, period_ns=period_ns)
    with daemon(config, "lockstep", server_cpus) as d:
        rack = connect(d)
        pin_self(client_cpus)
        bar = rack.card("servo0").region("bar0")

        def step(s: float) -> int:
            start = rack.sim.now_ns()
            return rack.sim.step(seconds=s) - start

        targets = {"daemon": Target(step, bar.read32, bar.write32),
                   "in-process": in_process_target(axes, period_ns, plant)}
        for t in targets.values():
            t.step(SETTLE_S)  # warm-up: first ticks, caches
        rows: dict[str, list[float]] = {
            "daemon, axes moving": [], "baseline: daemon, axes idle": [],
            "in-process, axes moving": [], "in-process, axes idle": []}
        for _ in range(repeats):  # interleaved: the host's slow phases hit every series alike
            for name, t in targets.items():
                moving, idle = one_repeat(t, seconds, axes)
                rows[f"{name}, axes moving"].append(moving)
                rows["baseline: daemon, axes idle" if name == "daemon" else f"{name}, axes idle"
                     ].append(idle)
        stats = rack.stats()
        rack.close()
        d.child.check_alive("vdevd")
    med = statistics.median(rows["daemon, axes moving"])
    ticks_per_s = 1e9 / period_ns
    series = {name: {"median": statistics.median(xs), "min": min(xs), "max": max(xs),
                     "us_per_tick": 1e6 / (statistics.median(xs) * ticks_per_s), "runs": xs}
              for name, xs in rows.items()}
    return {
        "figure": "lockstep",
        "placement": where,
        "params": {"seconds": seconds, "repeats": repeats, "axes": axes, "period_ns": period_ns,
                   "plant": plant},
        "series": series,
        "speed_median": med,
        # medians of per-repeat ratios: each pair ran back to back, in the same phase of the host
        "moving_over_idle": statistics.median(
            m / i for m, i in zip(rows["daemon, axes moving"], rows["baseline: daemon, axes idle"],
                                  strict=True)),
        "daemon_over_in_process": statistics.median(
            m / i for m, i in zip(rows["daemon, axes moving"], rows["in-process, axes moving"],
                                  strict=True)),
        "daemon_lost_ticks": stats["scheduler"]["lost_ticks"],
        "goal": f"median speed >= {GOAL_SPEED:.0f}x real time (axes moving)",
        "pass": med >= GOAL_SPEED and stats["scheduler"]["lost_ticks"] == 0,
    }


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    rows = [[name, s["median"], s["min"], s["max"], s["us_per_tick"]]
            for name, s in r["series"].items()]
    table(["series", "median x", "min x", "max x", "us/tick (median)"], rows,
          title=f"lockstep speed (simulated s / wall s), {p['axes']}-axis {p['plant']} card at "
                f"{1e9 / p['period_ns']:g} Hz, {p['repeats']} x {p['seconds']:g} s simulated, "
                f"placement {r['placement']}")
    print(f"speed ratios (median of per-repeat pairs): daemon moving / daemon idle "
          f"{r['moving_over_idle']:.2f}, daemon / in-process (moving) {r['daemon_over_in_process']:.2f}; "
          f"lost ticks {r['daemon_lost_ticks']}")
    print(f"speed {r['speed_median']:.1f}x real time (goal >= {GOAL_SPEED:.0f}x)  ->  "
          f"{verdict(r['pass'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per step")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--axes", type=int, default=4)
    ap.add_argument("--period-ns", type=int, default=1_000_000)
    ap.add_argument("--plant", choices=("servo", "stepper", "ideal"), default="servo")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(a.seconds, a.repeats, a.pin, a.axes, a.period_ns, a.plant)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'lockstep')}")


if __name__ == "__main__":
    main()
