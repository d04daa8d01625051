"""The embedded default rack in realtime (issue 17): its CPU use idle, and how far simulated time
lags wall time while eight clients poll it.

Goals: `rt-cpu`: the idle default rack uses <= 15 % of one core (the daemon's CPU time over 60 s);
`rt-behind`: simulated time behind wall time p99 <= 500 us with 8 clients polling, no tick lost.

Method. The daemon runs `vdevd serve` with the embedded default rack (one card of each type, at
their defaults, realtime clock, default wake period and waker); the only change is the PMAC's
Ethernet port, on a free port so that runs never collide. It is pinned to the server cpu.
* rt-cpu: nothing talks to the daemon; its user + system time (/proc, every thread) over the
  window, as % of one core. Baseline of the same run: an empty rack (no card) on the same clock,
  what the pacing and the process cost without a tick.
* rt-behind: eight client processes (bench/poller.py, client cpu) each read a register by
  request (they map no shared memory) every `poll_ms` on absolute deadlines, alternately of the
  generic card and of the MAXk. The figure
  is how far simulated time is behind wall time when a request is answered, taken two ways:
  by the daemon itself, at every request of every client (`stats` `answered_behind_ns`, after
  the request's catch-up, the last 65536 requests); and from outside by this process, which
  every `interval_ms` sends a `sim now` at t0 and gets now_ns back at t1: t0 - epoch - now_ns is
  how much older than the question the answered state is (a lower bound: it leaves out the
  request's way in). Both must be within the goal. The midpoint estimate of bench/realtime.py,
  (t0 + t1) / 2 - epoch - now_ns, is printed too; it also counts half of any delay of the reply
  on its way out, so its tail follows the round trip's (the baseline: the round trip of the same
  `sim now` requests). The daemon's `stats` then give lost ticks per card, overruns, and its
  behind at each wake (the sawtooth between passes: what a reader of shared memory sees).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/default_rack.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.common import (  # noqa: E402
    BENCH_DIR,
    DIST_HEADERS,
    child,
    connect,
    daemon,
    dist,
    dist_row,
    free_port,
    install_signal_handlers,
    ns_dist_to_us,
    pin_self,
    placement,
    table,
    verdict,
    write_json,
)
from vdevd.config import default_config  # noqa: E402

GOAL_CPU_PERCENT = 15.0
GOAL_BEHIND_P99_US = 500.0
#: what the pollers read: the generic card's axis 0 position, the MAXk's X position (plain memory)
POLLED = (("servo0", "bar0", 0x11C), ("maxk0", "shm", 0x0))


def default_rack_toml(wake_us: int | None = None, waker: str | None = None,
                      cards: bool = True) -> str:
    """The embedded default rack (vdevd/config.py `default_config`) as a configuration file,
    the PMAC's Ethernet port on a free port; `cards=False`: the same clock and no card."""
    clock = '[clock]\nmode = "realtime"\n'
    if wake_us is not None:
        clock += f"wake_us = {wake_us}\n"
    if waker is not None:
        clock += f'waker = "{waker}"\n'
    text = clock
    for spec in default_config().cards if cards else []:
        text += f'\n[[card]]\ntype = "{spec.type}"\nname = "{spec.name}"\n'
        if spec.options.get("ethernet"):
            text += f'ethernet = "tcp://127.0.0.1:{free_port()}"\n'
    return text


def _idle_cpu(config: str, seconds: float, server_cpus: set[int] | None) -> dict[str, Any]:
    """The daemon's CPU use (% of one core) over `seconds` with nothing talking to it."""
    with daemon(config, "realtime", server_cpus) as d:
        rack = connect(d)
        try:
            time.sleep(1.0)  # past the start-up
            cpu0, t0 = d.child.cpu_seconds(), time.perf_counter()
            time.sleep(seconds)
            cpu, wall = d.child.cpu_seconds() - cpu0, time.perf_counter() - t0
            stats = rack.stats()
        finally:
            rack.close()
        d.child.check_alive("vdevd")
    sched = stats["scheduler"]
    return {"cpu_percent": 100 * cpu / wall, "wall_s": wall, "passes": sched["passes"],
            "overruns": sched["overruns"], "lost_ticks": sched["lost_ticks"],
            "waker": stats["clock"]["waker"], "wake_ns": stats["clock"]["wake_ns"]}


def run_cpu(seconds: float = 60.0, pin: str = "split", wake_us: int | None = None,
            waker: str | None = None) -> dict[str, Any]:
    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    rack = _idle_cpu(default_rack_toml(wake_us, waker), seconds, server_cpus)
    empty = _idle_cpu(default_rack_toml(wake_us, waker, cards=False), max(seconds / 3, 2.0),
                      server_cpus)
    return {
        "figure": "rt-cpu", "placement": where,
        "params": {"seconds": seconds, "wake_us": wake_us, "waker": waker},
        "default_rack": rack, "baseline_empty_rack": empty,
        "cards_percent": rack["cpu_percent"] - empty["cpu_percent"],
        "goal": f"idle default rack <= {GOAL_CPU_PERCENT:.0f} % of one core",
        "pass": rack["cpu_percent"] <= GOAL_CPU_PERCENT,
    }


def report_cpu(r: dict[str, Any]) -> None:
    rack, empty = r["default_rack"], r["baseline_empty_rack"]
    table(["rack", "cpu % of one core", "wall s", "passes", "overruns", "waker"],
          [["default rack, idle", rack["cpu_percent"], rack["wall_s"], rack["passes"],
            rack["overruns"], rack["waker"]],
           ["baseline: no card", empty["cpu_percent"], empty["wall_s"], empty["passes"],
            empty["overruns"], empty["waker"]]],
          title=f"realtime CPU, default rack idle, placement {r['placement']}")
    print(f"default rack idle {rack['cpu_percent']:.1f} % of one core (the cards' ticks "
          f"{r['cards_percent']:.1f} %, the pacing and the process {empty['cpu_percent']:.1f} %); "
          f"goal <= {GOAL_CPU_PERCENT:.0f} %  ->  {verdict(r['pass'])}")


def run_behind(seconds: float = 60.0, clients: int = 8, poll_ms: float = 4.0,
               interval_ms: float = 10.0, pin: str = "split", wake_us: int | None = None,
               waker: str | None = None) -> dict[str, Any]:
    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    behind: list[float] = []
    at_send: list[float] = []
    rtt: list[float] = []
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        d = stack.enter_context(daemon(default_rack_toml(wake_us, waker), "realtime",
                                       server_cpus))
        rack = connect(d)
        stack.callback(rack.close)
        pin_self(client_cpus)
        periods = {c.name: c.period_ns for c in rack.cards()}
        outs = [tmp / f"poller{i}.json" for i in range(clients)]
        pollers = [stack.enter_context(child(
            [sys.executable, str(BENCH_DIR / "poller.py"), d.endpoint, *map(str, POLLED[i % 2]),
             str(seconds + 1.0), str(poll_ms), str(out)], client_cpus, tmp / f"poller{i}.log"))
            for i, out in enumerate(outs)]
        time.sleep(0.5)  # the pollers connect
        before = rack.stats()
        epoch = before["clock"]["epoch_monotonic_ns"]
        clock, request = time.perf_counter_ns, rack.request
        step = int(interval_ms * 1e6)
        start = deadline = clock()
        end = start + int(seconds * 1e9)
        while deadline < end:
            t0 = clock()
            now = request("sim", action="now")["now_ns"]
            t1 = clock()
            behind.append(((t0 + t1) / 2 - epoch - now) / 1000)
            at_send.append((t0 - epoch - now) / 1000)
            rtt.append((t1 - t0) / 1000)
            deadline += step
            delay = deadline - clock()
            if delay > 0:
                time.sleep(delay / 1e9)
        wall = (clock() - start) / 1e9
        stats = rack.stats()
        for p in pollers:
            p.proc.wait(timeout=60)
        polled = [json.loads(out.read_text()) for out in outs]
        d.child.check_alive("vdevd")
    sched, now_ns = stats["scheduler"], stats["clock"]["now_ns"]
    cards = {name: {"ticks": c["ticks"], "lost_ticks": c["lost_ticks"],
                    "expected": now_ns // periods[name]} for name, c in stats["cards"].items()}
    ticks_ok = sched["lost_ticks"] == 0 and all(
        c["lost_ticks"] == 0 and abs(c["ticks"] - c["expected"]) <= 1 for c in cards.values())
    minutes = wall / 60
    b, r, a = dist(behind), dist(rtt), dist(at_send)
    answered = ns_dist_to_us(sched["answered_behind_ns"])
    slipped = stats["overload"]["slipped_ns"] - before["overload"]["slipped_ns"]
    return {
        "figure": "rt-behind", "placement": where,
        "params": {"seconds": seconds, "clients": clients, "poll_ms": poll_ms,
                   "interval_ms": interval_ms, "wake_us": wake_us, "waker": waker},
        "wall_s": wall, "answered_behind_us": answered, "behind_at_send_us": a,
        "midpoint_behind_us": b, "sim_now_rtt_us": r,
        "poller_rtt_us": {"p50_median": sorted(p["rtt_us"]["p50"] for p in polled)[len(polled) // 2],
                          "p99_max": max(p["rtt_us"]["p99"] for p in polled),
                          "max": max(p["max_us"] for p in polled),
                          "n": sum(p["rtt_us"]["n"] for p in polled)},
        "lost_ticks": sched["lost_ticks"], "cards": cards, "ticks_ok": ticks_ok,
        "slipped_ns": slipped,
        "daemon": {"passes": sched["passes"] - before["scheduler"]["passes"],
                   "catch_ups": sched["catch_ups"] - before["scheduler"]["catch_ups"],
                   "overruns": sched["overruns"] - before["scheduler"]["overruns"],
                   "overruns_per_minute": (sched["overruns"] - before["scheduler"]["overruns"])
                   / minutes,
                   "late_us": ns_dist_to_us(sched["late_ns"]),
                   "behind_at_wake_us": ns_dist_to_us(sched["behind_ns"])},
        "goal": f"behind p99 <= {GOAL_BEHIND_P99_US:.0f} us, no tick lost",
        "pass": (answered["p99"] <= GOAL_BEHIND_P99_US and a["p99"] <= GOAL_BEHIND_P99_US
                 and ticks_ok and slipped == 0),
    }


def report_behind(r: dict[str, Any]) -> None:
    p, dm, pr = r["params"], r["daemon"], r["poller_rtt_us"]
    rows = [_daemon_row("answered (daemon, every request)", r["answered_behind_us"]),
            dist_row("answered, at send (client)", r["behind_at_send_us"]),
            dist_row("midpoint estimate (client)", r["midpoint_behind_us"]),
            dist_row("baseline: sim-now RTT", r["sim_now_rtt_us"]),
            _daemon_row("daemon: wake lateness", dm["late_us"]),
            _daemon_row("daemon: behind at wake", dm["behind_at_wake_us"])]
    table(DIST_HEADERS, rows, title=(
        f"default rack, realtime, {r['wall_s']:.0f} s, {p['clients']} clients polling every "
        f"{p['poll_ms']:g} ms, sample every {p['interval_ms']:g} ms, placement {r['placement']}; "
        "simulated time behind wall time, us"))
    cards = ", ".join(f"{n}: {c['ticks']} (lost {c['lost_ticks']})" for n, c in r["cards"].items())
    print(f"pollers: {pr['n']} reads, p50 {pr['p50_median']:.0f} us (median over clients), p99 "
          f"{pr['p99_max']:.0f} us (worst client), max {pr['max']:.0f} us")
    print(f"daemon: passes {dm['passes']}, catch-ups {dm['catch_ups']}, overruns {dm['overruns']} "
          f"({dm['overruns_per_minute']:.0f}/min), slipped {r['slipped_ns']} ns; ticks: {cards}")
    print(f"behind when answered p99: {r['answered_behind_us']['p99']:.0f} us (daemon), "
          f"{r['behind_at_send_us']['p99']:.0f} us (client, at send); goal p99 <= "
          f"{GOAL_BEHIND_P99_US:.0f} us; lost ticks {r['lost_ticks']} (goal 0)  ->  "
          f"{verdict(r['pass'])}")


def _daemon_row(name: str, x: dict[str, float]) -> list[Any]:
    """A `stats` distribution (in us) as a table row."""
    return [name, x.get("p50"), x.get("p90"), x.get("p99"), x.get("p999"), x.get("max"),
            x.get("count")]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("figure", choices=("cpu", "behind"))
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--clients", type=int, default=8)
    ap.add_argument("--poll-ms", type=float, default=4.0)
    ap.add_argument("--wake-us", type=int)
    ap.add_argument("--waker", choices=("thread", "timer"))
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    if a.figure == "cpu":
        r = run_cpu(a.seconds, a.pin, a.wake_us, a.waker)
        report_cpu(r)
    else:
        r = run_behind(a.seconds, a.clients, a.poll_ms, pin=a.pin, wake_us=a.wake_us,
                       waker=a.waker)
        report_behind(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, r['figure'])}")


if __name__ == "__main__":
    main()
