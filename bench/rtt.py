"""Register read round trip: a 4-byte `Region.read` through vdevclient against a live daemon, as a
ratio of a raw pyzmq REQ/REP round trip measured in the same run with the same placement.

Goal (issue "Done when"): p50 <= 1.25x and p99 <= 1.5x the raw round trip.

Method. The servers run side by side on the server cpu: the baseline (bench/raw_server.py, a
blocking pyzmq REP loop: msgpack request in, 4-byte bin reply out) and `vdevd serve --clock
lockstep` with one generic-servo card (lockstep: no ticks run, the daemon only serves). This
process is the client: a blocking REQ for the baseline, and for the daemon the public API,
`vdevclient.connect(...).card("servo0").region("bar0").read(0x11C, 4)` (axis 0 POSITION).
Placement `split` (default): servers on cpu0, client on cpu1; `same`: all on cpu0; `none`:
unpinned. After a warm-up, each repeat times `n` round trips of every series in short blocks
(default 5 round trips) in a fresh random order per block, so that drift on a shared host hits
every series alike and no series always runs right after another (a server that has just run
is warmer). Percentiles are over all raw samples; per-repeat ratios show the spread.

Two diagnostic series (not part of the goal; `--no-diag` skips them) split the difference: a bare
DEALER client sending the same read map to vdevd (what the client library costs), and the same
bare client against bench/floor_server.py, the daemon's I/O design (uvloop, ROUTER drained from
add_reader) without its code. The daemon's own timing of each request comes from its `stats`.
"""

from __future__ import annotations

import argparse
import contextlib
import random
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/rtt.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import msgpack  # noqa: E402
import zmq  # noqa: E402

from bench.common import (  # noqa: E402
    BENCH_DIR,
    DIST_HEADERS,
    POSITION,
    axis_reg,
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
    servo_card,
    table,
    verdict,
    write_json,
)

GOAL_P50, GOAL_P99 = 1.25, 1.5
OFFSET = axis_reg(0, POSITION)  # 0x11C: axis 0 POSITION (offset 0x1C of the axis block)


RAW = "raw pyzmq REQ/REP (baseline)"
VDEV = "vdevclient Region.read -> vdevd"
BARE = "diag: bare DEALER -> vdevd"
FLOOR = "diag: bare DEALER -> uvloop ROUTER"


def bare_client(stack: contextlib.ExitStack, ctx: zmq.Context[Any], endpoint: str, offset: int
                ) -> Callable[[], bytes]:
    """The least a protocol-v1 client does for a read: pack a map, DEALER send/recv, unpack."""
    sock = ctx.socket(zmq.DEALER)
    stack.callback(sock.close)
    sock.linger = 0
    sock.rcvtimeo = 10_000
    sock.connect(endpoint)
    ids = iter(range(1, 1 << 62))
    packb, unpackb = msgpack.Packer(use_bin_type=True).pack, msgpack.unpackb

    def read() -> bytes:
        sock.send(packb({"op": "read", "card": "servo0", "region": "bar0", "offset": offset,
                         "size": 4, "id": next(ids)}))
        return unpackb(sock.recv())["ok"]

    return read


def time_block(fn: Callable[[], Any], n: int, out: list[int]) -> None:
    clock = time.perf_counter_ns
    for _ in range(n):
        t0 = clock()
        fn()
        out.append(clock() - t0)


def warm_up(fns: dict[str, Callable[[], Any]], warmup: int, block: int) -> None:
    """Call every series in blocks, interleaved like the timed part, before timing."""
    for _ in range(max(1, warmup // block)):
        for fn in fns.values():
            time_block(fn, block, [])


def time_interleaved(fns: dict[str, Callable[[], Any]], n: int, repeats: int, block: int,
                     seed: int) -> dict[str, list[list[int]]]:
    """Per series, one list of call times (ns) per repeat: each repeat times about `n` calls of
    every series in blocks of `block`, in a fresh random order per block (no series always
    follows another)."""
    names = list(fns)
    rng = random.Random(seed)
    series: dict[str, list[list[int]]] = {name: [] for name in names}
    for _ in range(repeats):
        runs: dict[str, list[int]] = {name: [] for name in names}
        for _ in range(max(1, n // block)):
            order = names[:]
            rng.shuffle(order)
            for name in order:
                time_block(fns[name], block, runs[name])
        for name in names:
            series[name].append(runs[name])
    return series


def us(samples: list[int]) -> list[float]:
    return [s / 1000 for s in samples]


def ratios_to_raw(series: dict[str, list[list[int]]], compared: dict[str, str]
                  ) -> tuple[dict[str, Any], list[dict[str, float]], dict[str, dict[str, float]]]:
    """The distributions of every series (us), and for the series `compared` (row key -> series
    name) their p50/p99 ratios to the RAW series: per repeat and over all repeats."""
    dists = {name: dist(us([s for run_ in runs for s in run_])) for name, runs in series.items()}
    raw = dists[RAW]
    per_repeat = []
    for i, raw_run in enumerate(series[RAW]):
        raw_r = dist(us(raw_run))
        row = {"raw_p50": raw_r["p50"], "raw_p99": raw_r["p99"]}
        for key, name in compared.items():
            d_r = dist(us(series[name][i]))
            row[f"{key}_ratio_p50"] = d_r["p50"] / raw_r["p50"]
            row[f"{key}_ratio_p99"] = d_r["p99"] / raw_r["p99"]
        per_repeat.append(row)
    ratios = {name: {"p50": dists[name]["p50"] / raw["p50"], "p99": dists[name]["p99"] / raw["p99"]}
              for name in compared.values()}
    return dists, per_repeat, ratios


def report_against_raw(r: dict[str, Any], title: str, compared: dict[str, str]) -> None:
    """Print a command figure's series (us, and their ratios to RAW), the per-repeat ratios of
    the series `compared` (row key -> label), the round trips per call and the daemon's own
    handling time (the result of a run that used `ratios_to_raw`)."""
    raw = r["series"][RAW]
    table([*DIST_HEADERS, "p50/raw", "p99/raw"],
          [[*dist_row(name, d), d["p50"] / raw["p50"], d["p99"] / raw["p99"]]
           for name, d in r["series"].items()], title=title)
    rows = [[i + 1, x["raw_p50"], *(x[f"{k}_ratio_p50"] for k in compared), x["raw_p99"],
             *(x[f"{k}_ratio_p99"] for k in compared)] for i, x in enumerate(r["per_repeat"])]
    table(["repeat", "raw p50", *(f"{label} p50/raw" for label in compared.values()), "raw p99",
           *(f"{label} p99/raw" for label in compared.values())], rows)
    trips = ", ".join(f"{name}: {c['mean']:.2f} (max {c['max']})" for name, c in r["round_trips"].items())
    print(f"round trips per call: {trips}; card time per command {r['card_ns_per_command'] / 1e6:g} ms")
    lat = r["daemon_latency_us"]
    print(f"daemon's own handling time per request (stats, last 64k): p50 {lat.get('p50', 0):.1f} us, "
          f"p99 {lat.get('p99', 0):.1f} us")


def report_ratio_goals(r: dict[str, Any], goal_p50: float) -> None:
    """One verdict line per compared series: its p50 ratio against the goal."""
    for name, ratio in r["ratios"].items():
        print(f"{name} / raw: p50 {ratio['p50']:.2f}x (goal <= {goal_p50}), p99 {ratio['p99']:.2f}x"
              f"  ->  {verdict(ratio['p50'] <= goal_p50)}")


def run(n: int = 5000, repeats: int = 3, warmup: int = 2000, block: int = 5,
        pin: str = "split", offset: int = OFFSET, diag: bool = True, seed: int = 1) -> dict[str, Any]:
    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_ep = f"tcp://127.0.0.1:{free_port()}"
        raw_server = stack.enter_context(child(
            [sys.executable, str(BENCH_DIR / "raw_server.py"), raw_ep], server_cpus, tmp / "raw.log"))
        if diag:
            floor_ep = f"tcp://127.0.0.1:{free_port()}"
            stack.enter_context(child([sys.executable, str(BENCH_DIR / "floor_server.py"), floor_ep],
                                      server_cpus, tmp / "floor.log"))
        d = stack.enter_context(daemon(servo_card(), "lockstep", server_cpus))
        pin_self(client_cpus)  # zmq's I/O threads exist now; keep them with the client
        req = ctx.socket(zmq.REQ)
        stack.callback(req.close)
        req.linger = 0
        req.rcvtimeo = 10_000
        req.connect(raw_ep)
        raw_body = msgpack.packb([1, "bar0", offset, 4])
        unpackb = msgpack.unpackb

        def raw_read() -> bytes:  # the client unpacks the reply, as vdevclient does
            req.send(raw_body)
            return unpackb(req.recv())

        try:
            raw_read()
        except zmq.Again:
            raw_server.check_alive("raw server")
            raise RuntimeError("the raw REP server did not answer") from None

        rack = connect(d)
        stack.callback(rack.close)
        region = rack.card("servo0").region("bar0")

        def vdev_read() -> bytes:
            return region.read(offset, 4)

        fns: dict[str, Callable[[], Any]] = {RAW: raw_read, VDEV: vdev_read}
        if diag:
            fns[BARE] = bare_client(stack, ctx, d.endpoint, offset)
            fns[FLOOR] = bare_client(stack, ctx, floor_ep, offset)
        for name, fn in fns.items():
            if len(fn()) != 4:
                raise RuntimeError(f"{name}: the reply is not 4 bytes")

        warm_up(fns, warmup, block)
        stats_before = rack.stats()["requests"]["by_op"].get("read", 0)
        series = time_interleaved(fns, n, repeats, block, seed)
        stats = rack.stats()

    dists = {name: dist(us([s for run_ in runs for s in run_])) for name, runs in series.items()}
    raw_name, vdev_name = RAW, VDEV
    raw, vdev = dists[raw_name], dists[vdev_name]
    per_repeat = [
        {"raw_p50": dist(us(rr))["p50"], "vdevd_p50": dist(us(vr))["p50"],
         "raw_p99": dist(us(rr))["p99"], "vdevd_p99": dist(us(vr))["p99"]}
        for rr, vr in zip(series[raw_name], series[vdev_name], strict=True)
    ]
    for p in per_repeat:
        p["ratio_p50"] = p["vdevd_p50"] / p["raw_p50"]
        p["ratio_p99"] = p["vdevd_p99"] / p["raw_p99"]
    ratio_p50, ratio_p99 = vdev["p50"] / raw["p50"], vdev["p99"] / raw["p99"]
    return {
        "figure": "rtt",
        "placement": where,
        "params": {"n": n, "repeats": repeats, "warmup": warmup, "block": block,
                   "offset": offset, "size": 4, "transport": "tcp loopback"},
        "series": dists,
        "per_repeat": per_repeat,
        "daemon_latency_us": ns_dist_to_us(stats["requests"]["latency_ns"]),
        "daemon_reads": stats["requests"]["by_op"].get("read", 0) - stats_before,
        "ratio_p50": ratio_p50,
        "ratio_p99": ratio_p99,
        "goal": f"p50 <= {GOAL_P50}x and p99 <= {GOAL_P99}x raw REQ/REP",
        "pass": ratio_p50 <= GOAL_P50 and ratio_p99 <= GOAL_P99,
    }


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    raw = r["series"][RAW]
    table([*DIST_HEADERS, "p50/raw", "p99/raw"],
          [[*dist_row(name, d), d["p50"] / raw["p50"], d["p99"] / raw["p99"]]
           for name, d in r["series"].items()],
          title=f"register read round trip, {p['size']} bytes at 0x{p['offset']:X}, us; "
                f"{p['repeats']} x {p['n']} per series, placement {r['placement']}")
    rows = [[i + 1, x["raw_p50"], x["vdevd_p50"], x["ratio_p50"], x["raw_p99"], x["vdevd_p99"],
             x["ratio_p99"]] for i, x in enumerate(r["per_repeat"])]
    table(["repeat", "raw p50", "vdevd p50", "ratio p50", "raw p99", "vdevd p99", "ratio p99"],
          rows)
    lat = r["daemon_latency_us"]
    print(f"daemon's own handling time per request (stats, last 64k): p50 {lat.get('p50', 0):.1f} us, "
          f"p99 {lat.get('p99', 0):.1f} us")
    if BARE in r["series"]:
        p50 = {name: d["p50"] for name, d in r["series"].items()}
        print(f"where the p50 goes: client library {p50[VDEV] - p50[BARE]:+.1f} us (vdevclient vs bare "
              f"DEALER), vdevd's server code {p50[BARE] - p50[FLOOR]:+.1f} us (vdevd vs a bare uvloop "
              f"ROUTER), uvloop/ROUTER/map protocol {p50[FLOOR] - p50[RAW]:+.1f} us (vs raw REQ/REP)")
    ratios = [x["ratio_p50"] for x in r["per_repeat"]]
    print(f"RTT ratio vdevd / raw: p50 {r['ratio_p50']:.2f}x (goal <= {GOAL_P50}; per repeat "
          f"{min(ratios):.2f}-{max(ratios):.2f}), p99 {r['ratio_p99']:.2f}x (goal <= {GOAL_P99})"
          f"  ->  {verdict(r['pass'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=5000, help="round trips per series per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=2000)
    ap.add_argument("--block", type=int, default=5, help="round trips per alternating block")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--offset", type=lambda s: int(s, 0), default=OFFSET, help="register offset")
    ap.add_argument("--no-diag", action="store_true", help="skip the two diagnostic series")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(a.n, a.repeats, a.warmup, a.block, a.pin, a.offset, diag=not a.no_diag)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'rtt')}")


if __name__ == "__main__":
    main()
