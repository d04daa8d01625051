"""`make bench`: the figures of the issues' "Done when", each against a baseline of the same run.

    python bench/run.py [--quick] [--only rtt,lockstep,...,pmac-program,shm,overload,rt-cpu,
                        rt-behind,rack,mx4,aps,pmac-pvt,scope]
                        [--pin split|same|none] [--json [FILE]]

1. rtt       4-byte register read through vdevclient vs a raw pyzmq REQ/REP round trip
             (p50 <= 1.25x, p99 <= 1.5x), bench/rtt.py
2. lockstep  4-axis servo card at 1 kHz, simulated s per wall s (>= 50x), bench/lockstep.py
3. realtime  no lost tick, simulated time behind wall time p99 <= 2 ms over 60 s, bench/realtime.py
4. galil     DMCCommand(h, "TPX") and gclib GCommand("TPX") on a lockstep DMC-13X8 vs a raw
             pyzmq REQ/REP round trip (p50 <= 2.5x), and the lockstep speed of the 4-axis card
             with every axis in a vector move (>= 50x real time), bench/galil.py
5. maxk      Maxk.send_and_get_string("AX RP") on a lockstep OMS MAXk vs a raw pyzmq REQ/REP
             round trip (p50 <= 2.5x), bench/maxk.py
6. pmac      pmac-dpram: PComm PmacGetResponseA("#1P") on a lockstep Turbo PMAC vs a raw pyzmq
             REQ/REP round trip; pmac-ethernet: dls-pmaclib sendCommand("#1P") on its Ethernet
             port vs a raw TCP round trip (both p50 <= 2.5x), bench/pmac.py
6b. pmac-program  dls-pmaclib sendCommand("#1P") on a REALTIME Turbo PMAC, idle and while C.S. 1
             runs a LINEAR raster and PLC 1 and 2 scan, vs a raw TCP (and pyzmq) round trip
             (busy p50 <= 2.5x), bench/pmac_program.py
7. shm       Region.read32 of a passive MAXk word through the daemon's shared memory (p50 <= 2 us,
             >= 50x faster than the read by request), bench/shm.py
8. overload  eight MAXk at 8192 Hz running contours (beyond this machine): read and `stats`
             answered within 50 ms p99 (against one MAXk at 1024 Hz), the overload in `stats`
             and logged once per episode, no tick lost, SIGTERM and SIGINT stop it within 2 s,
             bench/overload.py
9. rt-cpu    the embedded default rack idle in realtime uses <= 15 % of one core over 60 s
             (against an empty rack), bench/default_rack.py
10. rt-behind  the default rack with 8 clients polling: simulated time behind wall time when a
             request is answered p99 <= 500 us, no tick lost, over 60 s, bench/default_rack.py
11. rack     lockstep speed of sets of the default rack's four cards: one set idle >= 200x and
             all axes moving >= 30x, four sets (20 cards) moving >= 8x; the growth with cards and
             axes as a table and a PNG plot in bench/results/, bench/rack.py
12. mx4      mx4.AXMOVE(h, ...) on a lockstep Mx4 Octavia vs a raw pyzmq REQ/REP round trip
             (p50 <= 2.5x), and the lockstep speed of the 8-axis Octavia with every axis moving
             at its 200 us sample (>= 20x real time), bench/mx4.py
13. aps      vdevclient.aps APS_get_position_f(0, &pos) (p50 <= 1.5x) and APS_ptp(0, OPT_RELATIVE,
             ...) (p50 <= 2.5x) on a lockstep ADLINK AMP-208C vs a raw pyzmq REQ/REP round trip,
             and the lockstep speed of the 8-axis card with every axis in a velocity move at its
             1 ms cycle (>= 50x real time), bench/aps.py
14. pmac-pvt a 1000-point PVT scan (two servo motors, 10 ms points from P-variables) on a lockstep
             Turbo PMAC, simulated s per wall s (>= 20x), against the motors jogging,
             bench/pmac_pvt.py
15. scope    a 4-signal, 8-axis scope trace at every tick on each 8-axis card type, every axis
             moving: tick cost with the recorder against the same run without (<= 1.10x),
             bench/scope.py

The defaults are the issue's (realtime, rt-cpu and rt-behind run 60 s each; the whole takes
~6 min); `--quick` shortens everything for a smoke run (~1 min). Placement (default split:
servers on cpu0, client on cpu1) is stated with every figure. A figure that misses its goal
prints FAIL and the exit status stays 0; the status is 1 only when a benchmark could not run at
all. `--json` writes every result to bench/results/bench-<time>.json (or to FILE).
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/run.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench import (  # noqa: E402
    aps,
    default_rack,
    galil,
    lockstep,
    maxk,
    mx4,
    overload,
    pmac,
    pmac_program,
    pmac_pvt,
    rack,
    realtime,
    rtt,
    scope,
    shm,
)
from bench.common import install_signal_handlers, machine_facts, table, verdict, write_json  # noqa: E402

FIGURES = ("rtt", "lockstep", "realtime", "galil", "maxk", "pmac", "pmac-program", "shm", "overload",
           "rt-cpu", "rt-behind", "rack", "mx4", "aps", "pmac-pvt", "scope")


def plan(a: argparse.Namespace) -> dict[str, tuple[Callable[..., dict[str, Any]], dict[str, Any],
                                                   Callable[[dict[str, Any]], None]]]:
    q = a.quick
    return {
        "rtt": (rtt.run, {"n": 1000 if q else 5000, "repeats": 2 if q else 3,
                          "warmup": 500 if q else 2000, "pin": a.pin}, rtt.report),
        "lockstep": (lockstep.run, {"seconds": 2.0 if q else 10.0, "repeats": 2 if q else 5,
                                    "pin": a.pin}, lockstep.report),
        "realtime": (realtime.run, {"seconds": a.realtime_seconds or (5.0 if q else 60.0),
                                    "wake_us": a.wake_us, "waker": a.waker, "pin": a.pin},
                     realtime.report),
        "galil": (galil.run, {"n": 1000 if q else 3000, "repeats": 2 if q else 3,
                              "warmup": 300 if q else 1000, "seconds": 2.0 if q else 5.0,
                              "speed_repeats": 2 if q else 3, "pin": a.pin}, galil.report),
        "maxk": (maxk.run, {"n": 1000 if q else 3000, "repeats": 2 if q else 3,
                            "warmup": 300 if q else 1000, "pin": a.pin}, maxk.report),
        "pmac": (pmac.run, {"n": 1000 if q else 3000, "repeats": 2 if q else 3,
                            "warmup": 300 if q else 1000, "pin": a.pin}, pmac.report),
        "pmac-program": (pmac_program.run, {"n": 1000 if q else 3000, "repeats": 2 if q else 3,
                                            "warmup": 300 if q else 1000, "pin": a.pin},
                         pmac_program.report),
        "shm": (shm.run, {"n": 1000 if q else 5000, "repeats": 2 if q else 3,
                          "warmup": 500 if q else 2000, "pin": a.pin}, shm.report),
        "overload": (overload.run, {"seconds": 3.0 if q else 10.0, "pin": a.pin}, overload.report),
        "rt-cpu": (default_rack.run_cpu, {"seconds": a.realtime_seconds or (10.0 if q else 60.0),
                                          "wake_us": a.wake_us, "waker": a.waker, "pin": a.pin},
                   default_rack.report_cpu),
        "rt-behind": (default_rack.run_behind,
                      {"seconds": a.realtime_seconds or (10.0 if q else 60.0),
                       "wake_us": a.wake_us, "waker": a.waker, "pin": a.pin},
                      default_rack.report_behind),
        "rack": (rack.run, {"seconds": 0.5 if q else 2.0, "repeats": 2 if q else 3,
                            "sets": (1, 4) if q else (1, 2, 4), "pin": a.pin}, rack.report),
        "mx4": (mx4.run, {"n": 1000 if q else 3000, "repeats": 2 if q else 3,
                          "warmup": 300 if q else 1000, "seconds": 2.0 if q else 5.0,
                          "speed_repeats": 2 if q else 3, "pin": a.pin}, mx4.report),
        "aps": (aps.run, {"n": 1000 if q else 3000, "repeats": 2 if q else 3,
                          "warmup": 300 if q else 1000, "seconds": 2.0 if q else 5.0,
                          "speed_repeats": 2 if q else 3, "pin": a.pin}, aps.report),
        "pmac-pvt": (pmac_pvt.run, {"repeats": 2 if q else 3, "pin": a.pin}, pmac_pvt.report),
        "scope": (scope.run, {"ticks": 1000 if q else 2000, "repeats": 5 if q else 15},
                  scope.report),
    }


def summary_rows(results: dict[str, dict[str, Any]]) -> list[list[Any]]:
    rows: list[list[Any]] = []
    for name, r in results.items():
        if "error" in r:
            rows.append([name, "-", "could not run", "-", "ERROR"])
            continue
        if name == "rtt":
            raw, vd = r["series"][rtt.RAW], r["series"][rtt.VDEV]
            rows.append(["rtt p50", "<= 1.25x raw", f"{vd['p50']:.0f} us",
                         f"raw {raw['p50']:.0f} us -> {r['ratio_p50']:.2f}x",
                         verdict(r["ratio_p50"] <= rtt.GOAL_P50)])
            rows.append(["rtt p99", "<= 1.5x raw", f"{vd['p99']:.0f} us",
                         f"raw {raw['p99']:.0f} us -> {r['ratio_p99']:.2f}x",
                         verdict(r["ratio_p99"] <= rtt.GOAL_P99)])
        elif name == "lockstep":
            idle = r["series"]["baseline: daemon, axes idle"]["median"]
            local = r["series"]["in-process, axes moving"]["median"]
            rows.append(["lockstep speed", ">= 50x real time", f"{r['speed_median']:.1f}x",
                         f"idle {idle:.0f}x, in-process {local:.0f}x", verdict(r["pass"])])
        elif name == "realtime":
            rows.append(["realtime behind p99", "<= 2000 us", f"{r['behind_us']['p99']:.0f} us",
                         f"sim-now RTT p50 {r['sim_now_rtt_us']['p50']:.0f} us -> "
                         f"{r['behind_p99_over_rtt_p50']:.1f}x",
                         verdict(r["behind_us"]["p99"] <= realtime.GOAL_BEHIND_P99_US)])
            rows.append(["realtime lost ticks", "0", str(r["lost_ticks"]),
                         f"{r['daemon']['passes']} passes, {r['daemon']['overruns']} overruns",
                         verdict(r["lost_ticks"] == 0 and all(
                             c["ticks"] == c["expected"] for c in r["cards"].values()))])
        elif name == "galil":
            raw = r["series"][rtt.RAW]
            for series, ratio in r["ratios"].items():
                label = "galil DMCCommand p50" if series == galil.DMC else "galil GCommand p50"
                rows.append([label, f"<= {galil.GOAL_P50}x raw",
                             f"{r['series'][series]['p50']:.0f} us",
                             f"raw {raw['p50']:.0f} us -> {ratio['p50']:.2f}x",
                             verdict(ratio["p50"] <= galil.GOAL_P50)])
            prog = r.get("program")
            if prog:
                trips = prog["download_round_trips"]["max"]
                rows.append(["galil 100-line GProgramDownload", f"<= {galil.GOAL_DOWNLOAD_TRIPS} trips",
                             str(trips), "", verdict(trips <= galil.GOAL_DOWNLOAD_TRIPS)])
                mg, ratio = prog["series"][galil.PROGRAM_MG], prog["ratios"][galil.PROGRAM_MG]
                rows.append(["galil MG _TPX p50, program running", f"<= {galil.GOAL_P50}x raw",
                             f"{mg['p50']:.0f} us",
                             f"raw {prog['series'][rtt.RAW]['p50']:.0f} us -> {ratio['p50']:.2f}x",
                             verdict(ratio["p50"] <= galil.GOAL_P50 and prog["thread_ran"])])
            if "vector_speed" in r:
                speed = r["vector_speed"]
                moving, idle = speed["series"][galil.VECTOR], speed["series"][galil.IDLE]["median"]
                rows.append(["galil lockstep (vector move)", f">= {galil.GOAL_SPEED:.0f}x real time",
                             f"{moving['median']:.1f}x", f"idle {idle:.1f}x, "
                             f"{moving['us_per_sample']:.1f} us per sample", verdict(speed["pass"])])
        elif name == "maxk":
            raw, cmd = r["series"][rtt.RAW], r["series"][maxk.MAXK]
            ratio = r["ratios"][maxk.MAXK]["p50"]
            trips = r["round_trips"][maxk.MAXK]["max"]
            rows.append(["maxk send_and_get_string p50", f"<= {maxk.GOAL_P50}x raw",
                         f"{cmd['p50']:.0f} us", f"raw {raw['p50']:.0f} us -> {ratio:.2f}x, "
                         f"{trips} round trip(s)", verdict(ratio <= maxk.GOAL_P50)])
        elif name == "pmac":
            for figure, f in r["figures"].items():
                (series, ratio), = f["ratios"].items()
                raw = f["series"][rtt.RAW]
                trips = f["round_trips"][series]["max"]
                rows.append([f"{figure} p50", f"<= {pmac.GOAL_P50}x raw",
                             f"{f['series'][series]['p50']:.0f} us",
                             f"raw {raw['p50']:.0f} us -> {ratio['p50']:.2f}x, {trips} round trip(s)",
                             verdict(ratio["p50"] <= pmac.GOAL_P50)])
        elif name == "pmac-program":
            for phase, f in r["phases"].items():
                tcp, ratio = f["series"][pmac_program.TCP_RAW], f["ratios"][pmac_program.ETHERNET]
                goal = f"<= {pmac_program.GOAL_P50}x raw TCP" if phase == "busy" else "(reference)"
                rows.append([f"pmac sendCommand p50, {phase}", goal,
                             f"{f['series'][pmac_program.ETHERNET]['p50']:.0f} us",
                             f"raw TCP {tcp['p50']:.0f} us -> {ratio['p50']:.2f}x (p99 "
                             f"{ratio['p99']:.2f}x)", verdict(f["pass"]) if phase == "busy" else "-"])
        elif name == "pmac-pvt":
            rows.append(["pmac 1000-point PVT scan", f">= {pmac_pvt.GOAL_SPEED:.0f}x real time",
                         f"{r['speed_median']:.1f}x", f"jog baseline {r['jog_median']:.1f}x",
                         verdict(r["pass"])])
        elif name == "scope":
            for card, c in r["cards"].items():
                rows.append([f"scope 4 x 8 every tick, {card}", f"<= {scope.GOAL_RATIO}x tick",
                             f"{c['ratio_p50']:.2f}x",
                             f"tick p50 {c['base_ns']['p50'] / 1e3:.2f} us -> "
                             f"{c['scope_ns']['p50'] / 1e3:.2f} us", verdict(c["pass"])])
        elif name == "shm":
            raw, req = r["series"][rtt.RAW], r["series"][shm.REQUEST]
            rows.append(["shm read32 p50", f"<= {shm.GOAL_P50_US:g} us, >= {shm.GOAL_SPEEDUP:.0f}x "
                         "request", f"{r['shm_p50_us']:.2f} us",
                         f"request {req['p50']:.0f} us -> {r['speedup_p50']:.0f}x, raw "
                         f"{raw['p50']:.0f} us", verdict(r["pass"])])
        elif name == "overload":
            rows.extend(overload_rows(r))
        elif name == "rt-cpu":
            idle, empty = r["default_rack"], r["baseline_empty_rack"]
            rows.append(["rt-cpu idle default rack", f"<= {default_rack.GOAL_CPU_PERCENT:.0f} % "
                         "of a core", f"{idle['cpu_percent']:.1f} %",
                         f"empty rack {empty['cpu_percent']:.1f} % -> cards "
                         f"{r['cards_percent']:.1f} %", verdict(r["pass"])])
        elif name == "rt-behind":
            answered, at_send = r["answered_behind_us"], r["behind_at_send_us"]
            rows.append(["rt-behind p99, 8 clients", f"<= {default_rack.GOAL_BEHIND_P99_US:.0f} us",
                         f"{answered['p99']:.0f} us (daemon), {at_send['p99']:.0f} us (client)",
                         f"sim-now RTT p50 {r['sim_now_rtt_us']['p50']:.0f} us, midpoint p99 "
                         f"{r['midpoint_behind_us']['p99']:.0f} us",
                         verdict(answered["p99"] <= default_rack.GOAL_BEHIND_P99_US
                                 and at_send["p99"] <= default_rack.GOAL_BEHIND_P99_US)])
            rows.append(["rt-behind lost ticks", "0", str(r["lost_ticks"]),
                         f"{r['daemon']['overruns_per_minute']:.0f} overruns/min, slipped "
                         f"{r['slipped_ns']} ns", verdict(r["ticks_ok"] and r["slipped_ns"] == 0)])
        elif name == "rack":
            one = next(x for x in r["rows"] if x["sets"] == 1)
            base = f"core tick {r['core_tick_us']:.2f} us"
            rows.append([f"rack idle ({one['cards']} cards)", f">= {rack.GOAL_IDLE:.0f}x real time",
                         f"{one['idle']:.0f}x", base, verdict(r["checks"]["idle"])])
            rows.append([f"rack moving ({one['cards']} cards)", f">= {rack.GOAL_MOVING:.0f}x real time",
                         f"{one['moving']:.1f}x", f"{one['moving_core_ticks']:.0f} core ticks "
                         "per sim s", verdict(r["checks"]["moving"])])
            four = next((x for x in r["rows"] if x["sets"] == 4), None)
            rows.append([f"rack moving ({four['cards'] if four else 4 * one['cards']} cards)",
                         f">= {rack.GOAL_MOVING_16:.0f}x real time",
                         f"{four['moving']:.1f}x" if four else "-",
                         f"{four['moving_core_ticks']:.0f} core ticks per sim s" if four else "-",
                         verdict(r["checks"]["moving_16"])])
        elif name == "mx4":
            rtt_r, speed = r["rtt"], r["speed"]
            raw, cmd = rtt_r["series"][rtt.RAW], rtt_r["series"][mx4.AXMOVE]
            ratio = rtt_r["ratios"][mx4.AXMOVE]["p50"]
            trips = rtt_r["round_trips"][mx4.AXMOVE]["max"]
            floor = rtt_r["series"][mx4.BARE]["p50"]
            rows.append(["mx4 AXMOVE p50", f"<= {mx4.GOAL_P50}x raw", f"{cmd['p50']:.0f} us",
                         f"raw {raw['p50']:.0f} us -> {ratio:.2f}x, {trips} round trip(s); bare RTC "
                         f"batch {floor:.0f} us", verdict(ratio <= mx4.GOAL_P50)])
            moving = speed["series"]["8 axes moving, sim step"]
            idle = speed["series"]["baseline: idle, sim step"]["median"]
            rows.append(["mx4 lockstep (8 axes moving)", f">= {mx4.GOAL_SPEED:.0f}x real time",
                         f"{moving['median']:.1f}x", f"idle {idle:.1f}x, {moving['us_per_sample']:.1f} us "
                         "per sample", verdict(speed["pass"])])
        elif name == "aps":
            rows.extend(aps_rows(r))
    return rows


def aps_rows(r: dict[str, Any]) -> list[list[Any]]:
    """The ADLINK figure's summary rows: the two calls against raw REQ/REP, the lockstep speed."""
    rtt_r, speed = r["rtt"], r["speed"]
    raw = rtt_r["series"][rtt.RAW]
    rows: list[list[Any]] = []
    for series, goal in aps.GOALS.items():
        ratio = rtt_r["ratios"][series]["p50"]
        trips = rtt_r["round_trips"][series]["max"]
        how = ", shared memory" if series == aps.POSITION and rtt_r["position_mapped"] else ""
        label = "aps APS_get_position_f p50" if series == aps.POSITION else "aps APS_ptp p50"
        rows.append([label, f"<= {goal}x raw", f"{rtt_r['series'][series]['p50']:.1f} us",
                     f"raw {raw['p50']:.0f} us -> {ratio:.2f}x, {trips} round trip(s){how}",
                     verdict(ratio <= goal)])
    moving = speed["series"][aps.MOVING]
    idle = speed["series"][aps.IDLE]["median"]
    rows.append(["aps lockstep (8 axes moving)", f">= {aps.GOAL_SPEED:.0f}x real time",
                 f"{moving['median']:.1f}x", f"idle {idle:.0f}x, {moving['us_per_cycle']:.1f} us "
                 "per cycle", verdict(speed["pass"])])
    return rows


def overload_rows(r: dict[str, Any]) -> list[list[Any]]:
    """The overload figure's summary rows: answers, reporting, stopping."""
    o, b, ov = r["overloaded"], r["baseline"], r["overload"]
    goal = f"<= {overload.GOAL_ANSWER_P99_MS:.0f} ms"
    rows = [[f"overload {what} p99", goal, f"{o[key]['p99']:.1f} ms",
             f"1 MAXk 1024 Hz {b[key]['p99']:.2f} ms -> {o[key]['p99'] / b[key]['p99']:.0f}x",
             verdict(o[key]["p99"] <= overload.GOAL_ANSWER_P99_MS)]
            for what, key in (("read", "read_ms"), ("stats", "stats_ms"))]
    rows.append(["overload reported", "active, 1 log/episode, 0 lost",
                 f"episodes {ov['episodes']}, {r['log_lines']} log, lost {r['lost_ticks']}",
                 f"behind {ov['behind_ns'] / 1e6:.0f} ms, sim {o['sim_speed']:.2f}x real time",
                 verdict(r["reported_ok"] and r["lost_ticks"] == 0)])
    rows.append(["overload stop", f"<= {overload.GOAL_STOP_S:.0f} s",
                 f"TERM {r['stop_s']['SIGTERM']:.2f} s, INT {r['stop_s']['SIGINT']:.2f} s",
                 "-", verdict(r["stops_ok"])])
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="short runs, for a smoke test")
    ap.add_argument("--only", default=",".join(FIGURES),
                    help="comma list of " + ", ".join(FIGURES))
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--realtime-seconds", type=float,
                    help="override the length of the realtime, rt-cpu and rt-behind runs")
    ap.add_argument("--wake-us", type=int, default=1000, help="realtime: [clock] wake_us")
    ap.add_argument("--waker", choices=("thread", "timer"), default="thread", help="realtime: [clock] waker")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    only = [x.strip() for x in a.only.split(",") if x.strip()]
    unknown = sorted(set(only) - set(FIGURES))
    if unknown:
        ap.error(f"--only: unknown {', '.join(unknown)} (figures: {', '.join(FIGURES)})")
    facts = machine_facts()
    print(f"# {facts.get('cpu', '?')}, {facts['nproc']} cpus, Python {facts['python']}, "
          f"pyzmq {facts['pyzmq']} / libzmq {facts['libzmq']}, load {' '.join(facts.get('loadavg', []))}")
    results: dict[str, dict[str, Any]] = {}
    started = time.time()
    for name, (fn, kwargs, report) in plan(a).items():
        if name not in only:
            continue
        print(f"\n# {name}: {', '.join(f'{k}={v}' for k, v in kwargs.items())}", flush=True)
        t0 = time.perf_counter()
        try:
            results[name] = fn(**kwargs)
        except Exception as exc:  # one broken benchmark must not hide the others
            traceback.print_exc()
            results[name] = {"figure": name, "error": f"{type(exc).__name__}: {exc}"}
            continue
        results[name]["elapsed_s"] = time.perf_counter() - t0
        report(results[name])
    table(["figure", "goal", "measured", "baseline (same run)", "verdict"], summary_rows(results),
          title=f"summary ({'quick' if a.quick else 'full'} run, placement {a.pin}, "
                f"{time.time() - started:.0f} s)")
    if a.json is not None:
        out = write_json({"args": vars(a), "started": time.strftime(
            "%Y-%m-%dT%H:%M:%S%z", time.localtime(started)), "results": results}, a.json, "bench")
        print(f"results: {out}")
    return 1 if any("error" in r for r in results.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
