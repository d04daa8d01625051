"""A realtime rack beyond this machine (issue 17, decision 0009): it answers, says it is
overloaded, and stops on a signal.

Goals: requests and `stats` answered within 50 ms at the 99th percentile while overloaded; the
overload in `stats` (`overload.active`, `episodes`, `behind_ns`) and logged once per episode; no
tick lost (simulated time slips instead); SIGTERM and SIGINT stop the daemon within 2 s.

Method. `vdevd serve` (realtime, pinned to the server cpu) with eight oms-maxk cards at
update_hz = 8192, each running a contour (`VP`, an arc `VC`, `VP` back; tens of seconds of
simulated time): about four times what one core here ticks in real time. This process (client
cpu) sends a 4-byte register read (a request: the client maps no shared memory) and a `stats`
every `interval_ms` for `seconds` and times each round trip. Baseline of the same run and
placement: the same requests against one oms-maxk at its default 1024 Hz running the same
contour (a rack that keeps up). The overloaded daemon's `stats` give the overload fields and how
fast simulated time ran (simulated s per wall s over the window); its log is counted for
overload lines. Then SIGTERM is sent and the time to its exit taken; a second overloaded daemon
gets SIGINT after `signal_after_s`.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/overload.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vdevclient import maxk  # noqa: E402

from bench.common import (  # noqa: E402
    DIST_HEADERS,
    Daemon,
    connect,
    daemon,
    dist,
    dist_row,
    install_signal_handlers,
    pin_self,
    placement,
    table,
    verdict,
    write_json,
)

GOAL_ANSWER_P99_MS = 50.0
GOAL_STOP_S = 2.0
CONTOUR = "AA; VV4000; VA20000; VP40000,20000; VCR1000,0,180; VP0,0; VE;"


def maxk_rack(cards: int, update_hz: int) -> str:
    return '[clock]\nmode = "realtime"\n' + "".join(
        f'\n[[card]]\ntype = "oms-maxk"\nname = "maxk{i}"\nboard = {i + 1}\naxes = 4\n'
        f"update_hz = {update_hz}\n" for i in range(cards))


def _contours(rack: Any, cards: int) -> None:
    for i in range(cards):
        maxk.Maxk(rack, f"maxk{i}", timeout_ms=10_000).send_string(CONTOUR)


def _answers(rack: Any, seconds: float, interval_ms: float) -> dict[str, Any]:
    """Round trips (ms) of a register read and of `stats`, one pair every `interval_ms`."""
    read32 = rack.card("maxk0").region("shm").read32
    reads: list[float] = []
    stats: list[float] = []
    clock = time.perf_counter_ns
    first = rack.stats()
    t_first = clock()
    end = t_first + int(seconds * 1e9)
    step = int(interval_ms * 1e6)
    deadline = t_first
    while deadline < end:
        t0 = clock()
        read32(0)
        t1 = clock()
        last = rack.stats()
        t2 = clock()
        reads.append((t1 - t0) / 1e6)
        stats.append((t2 - t1) / 1e6)
        deadline += step
        delay = deadline - clock()
        if delay > 0:
            time.sleep(delay / 1e9)
    wall_ns = clock() - t_first
    return {"read_ms": dist(reads), "stats_ms": dist(stats), "stats": last,
            "sim_speed": (last["clock"]["now_ns"] - first["clock"]["now_ns"]) / wall_ns}


def _stop_time(d: Daemon, signum: int) -> float:
    """Seconds from `signum` to the daemon's exit (60 s at most: then it is killed)."""
    t0 = time.perf_counter()
    d.child.proc.send_signal(signum)
    try:
        d.child.proc.wait(timeout=60)
    except Exception:
        d.child.proc.kill()
        d.child.proc.wait()
        return float("inf")
    return time.perf_counter() - t0


def run(seconds: float = 10.0, interval_ms: float = 5.0, cards: int = 8, update_hz: int = 8192,
        signal_after_s: float = 2.0, pin: str = "split") -> dict[str, Any]:
    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    with daemon(maxk_rack(1, 1024), "realtime", server_cpus) as d:
        rack = connect(d, shm=False)
        try:
            pin_self(client_cpus)
            _contours(rack, 1)
            base = _answers(rack, min(seconds, 3.0), interval_ms)
        finally:
            rack.close()
    with daemon(maxk_rack(cards, update_hz), "realtime", server_cpus) as d:
        rack = connect(d, shm=False)
        try:
            pin_self(client_cpus)
            _contours(rack, cards)
            over = _answers(rack, seconds, interval_ms)
        finally:
            rack.close()
        stop_term = _stop_time(d, signal.SIGTERM)
        log_lines = d.child.log.read_text(errors="replace").count("overload:")
    with daemon(maxk_rack(cards, update_hz), "realtime", server_cpus) as d:
        rack = connect(d, shm=False)
        try:
            pin_self(client_cpus)
            _contours(rack, cards)
        finally:
            rack.close()
        time.sleep(signal_after_s)
        stop_int = _stop_time(d, signal.SIGINT)
    ov, sched = over["stats"]["overload"], over["stats"]["scheduler"]
    answers_ok = (over["read_ms"]["p99"] <= GOAL_ANSWER_P99_MS
                  and over["stats_ms"]["p99"] <= GOAL_ANSWER_P99_MS)
    reported = bool(ov["active"]) and ov["episodes"] >= 1 and ov["behind_ns"] > 0
    stops_ok = max(stop_term, stop_int) <= GOAL_STOP_S
    return {
        "figure": "overload", "placement": where,
        "params": {"seconds": seconds, "interval_ms": interval_ms, "cards": cards,
                   "update_hz": update_hz, "signal_after_s": signal_after_s},
        "overloaded": {"read_ms": over["read_ms"], "stats_ms": over["stats_ms"],
                       "sim_speed": over["sim_speed"]},
        "baseline": {"read_ms": base["read_ms"], "stats_ms": base["stats_ms"],
                     "sim_speed": base["sim_speed"]},
        "overload": ov, "lost_ticks": sched["lost_ticks"], "continuations": sched["continuations"],
        "log_lines": log_lines, "stop_s": {"SIGTERM": stop_term, "SIGINT": stop_int},
        "answers_ok": answers_ok, "reported_ok": reported and log_lines == ov["episodes"],
        "stops_ok": stops_ok,
        "goal": f"answers p99 <= {GOAL_ANSWER_P99_MS:.0f} ms, overload reported, no tick lost, "
                f"stop <= {GOAL_STOP_S:.0f} s",
        "pass": (answers_ok and reported and log_lines == ov["episodes"]
                 and sched["lost_ticks"] == 0 and stops_ok),
    }


def report(r: dict[str, Any]) -> None:
    p, o, b, ov = r["params"], r["overloaded"], r["baseline"], r["overload"]
    table(DIST_HEADERS, [dist_row("read, overloaded", o["read_ms"]),
                         dist_row("stats, overloaded", o["stats_ms"]),
                         dist_row("baseline: read, 1 MAXk at 1024 Hz", b["read_ms"]),
                         dist_row("baseline: stats, 1 MAXk at 1024 Hz", b["stats_ms"])],
          title=(f"overload: {p['cards']} MAXk at {p['update_hz']} Hz running contours, "
                 f"{p['seconds']:g} s, a read and a stats every {p['interval_ms']:g} ms, "
                 f"placement {r['placement']}; round trips in ms"))
    print(f"simulated time ran at {o['sim_speed']:.2f}x real time (baseline rack "
          f"{b['sim_speed']:.2f}x); overload: active {ov['active']}, episodes {ov['episodes']}, "
          f"behind {ov['behind_ns'] / 1e6:.0f} ms, slipped {ov['slipped_ns'] / 1e9:.1f} s; "
          f"overload log lines {r['log_lines']}; lost ticks {r['lost_ticks']}; "
          f"continuations {r['continuations']}")
    print(f"stop: SIGTERM {r['stop_s']['SIGTERM']:.2f} s, SIGINT {r['stop_s']['SIGINT']:.2f} s "
          f"(goal <= {GOAL_STOP_S:.0f} s)")
    print(f"answers p99: read {o['read_ms']['p99']:.1f} ms, stats {o['stats_ms']['p99']:.1f} ms "
          f"(goal <= {GOAL_ANSWER_P99_MS:.0f} ms; baseline read p99 {b['read_ms']['p99']:.1f} ms)"
          f"  ->  {verdict(r['pass'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--interval-ms", type=float, default=5.0)
    ap.add_argument("--cards", type=int, default=8)
    ap.add_argument("--update-hz", type=int, default=8192)
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(a.seconds, a.interval_ms, a.cards, a.update_hz, pin=a.pin)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'overload')}")


if __name__ == "__main__":
    main()
