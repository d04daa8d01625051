"""Registers at memory speed for a local client (decision 0010): `Region.read32` of a passive word
through the daemon's shared memory, against the same read by a request and a raw pyzmq REQ/REP
round trip measured in the same run with the same placement.

Goal (issue 17): p50 <= 2 us through the mapping, and >= 50x faster than the read by request.

Method as bench/rtt.py: the baseline server (bench/raw_server.py) and `vdevd serve --clock
lockstep` with one oms-maxk card on the server cpu, this process the client on the other. The
word is the MAXk's firmware state (0x048, the status poll's), read by
`connect(...).card("maxk0").region("shm").read32(0x48)` once with the mapping (the default on
this machine) and once with `connect(..., shm=False)` (every access a request). Each call is
timed alone, the series interleaved in short blocks in a fresh random order per block.

    python bench/shm.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/shm.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import vdevclient  # noqa: E402
import zmq  # noqa: E402
from vdevmaps.oms import Shm  # noqa: E402

from bench.common import (  # noqa: E402
    DIST_HEADERS,
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
from bench.galil import checked_raw_client, start_raw_server  # noqa: E402
from bench.rtt import RAW, time_interleaved, us, warm_up  # noqa: E402

GOAL_P50_US, GOAL_SPEEDUP = 2.0, 50.0
CARD = "maxk0"
WORD = int(Shm.FIRMWARE_STATE)
SHM = "Region.read32 via shared memory"
REQUEST = "Region.read32 via request"


def run(n: int = 5000, repeats: int = 3, warmup: int = 2000, block: int = 5, pin: str = "split",
        seed: int = 1) -> dict[str, Any]:
    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_server, raw_ep = start_raw_server(stack, tmp, server_cpus)
        card = f'[[card]]\ntype = "oms-maxk"\nname = "{CARD}"\nboard = 1\naxes = 4\n'
        d = stack.enter_context(daemon(card, "lockstep", server_cpus))
        pin_self(client_cpus)  # zmq's I/O threads exist now; keep them with the client
        raw_read = checked_raw_client(stack, ctx, raw_server, raw_ep)
        rack = connect(d)
        stack.callback(rack.close)
        plain = stack.enter_context(vdevclient.connect(d.endpoint, d.events, shm=False))
        mapped, requested = rack.card(CARD).region("shm"), plain.card(CARD).region("shm")
        if not mapped.is_mapped(WORD, 4):
            raise RuntimeError("the daemon offered no shared memory to this client "
                               f"(hello: {sorted(rack.info)})")
        if mapped.read32(WORD) != requested.read32(WORD):
            raise RuntimeError("the mapping and a request read different values")
        fns: dict[str, Callable[[], Any]] = {RAW: raw_read, SHM: lambda: mapped.read32(WORD),
                                             REQUEST: lambda: requested.read32(WORD)}
        warm_up(fns, warmup, block)
        reads_before = rack.stats()["requests"]["by_op"].get("read", 0)
        series = time_interleaved(fns, n, repeats, block, seed)
        reads = rack.stats()["requests"]["by_op"].get("read", 0) - reads_before

    dists = {name: dist(us([s for run_ in runs for s in run_])) for name, runs in series.items()}
    per_repeat = []
    for shm_run, req_run, raw_run in zip(series[SHM], series[REQUEST], series[RAW], strict=True):
        s, q, r = (dist(us(x))["p50"] for x in (shm_run, req_run, raw_run))
        per_repeat.append({"shm_p50": s, "request_p50": q, "raw_p50": r, "speedup": q / s})
    shm_p50, speedup = dists[SHM]["p50"], dists[REQUEST]["p50"] / dists[SHM]["p50"]
    return {
        "figure": "shm",
        "placement": where,
        "params": {"n": n, "repeats": repeats, "warmup": warmup, "block": block,
                   "offset": WORD, "size": 4, "transport": "tcp loopback", "clock": "lockstep"},
        "series": dists,
        "per_repeat": per_repeat,
        "daemon_reads": reads,  # the requests of the request series only
        "shm_p50_us": shm_p50,
        "speedup_p50": speedup,
        "raw_over_shm_p50": dists[RAW]["p50"] / shm_p50,
        "goal": f"p50 <= {GOAL_P50_US} us and >= {GOAL_SPEEDUP:.0f}x faster than a request",
        "pass": shm_p50 <= GOAL_P50_US and speedup >= GOAL_SPEEDUP,
    }


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    shm = r["series"][SHM]
    table([*DIST_HEADERS, "p50/shm"],
          [[*dist_row(name, d), d["p50"] / shm["p50"]] for name, d in r["series"].items()],
          title=f"read32 of a passive word (MAXk 0x{p['offset']:03X}), us; {p['repeats']} x "
                f"{p['n']} per series, placement {r['placement']}")
    table(["repeat", "shm p50", "request p50", "raw p50", "request/shm"],
          [[i + 1, x["shm_p50"], x["request_p50"], x["raw_p50"], x["speedup"]]
           for i, x in enumerate(r["per_repeat"])])
    print(f"daemon reads served during the timing: {r['daemon_reads']} (the request series')")
    print(f"shm read32 p50 {r['shm_p50_us']:.2f} us (goal <= {GOAL_P50_US} us), "
          f"{r['speedup_p50']:.0f}x faster than by request (goal >= {GOAL_SPEEDUP:.0f}x), "
          f"{r['raw_over_shm_p50']:.0f}x faster than raw REQ/REP  ->  {verdict(r['pass'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=5000, help="reads per series per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=2000)
    ap.add_argument("--block", type=int, default=5, help="reads per alternating block")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--quick", action="store_true", help="n=1000, 2 repeats, 500 warm-up reads")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    if a.quick:
        a.n, a.repeats, a.warmup = 1000, 2, 500
    r = run(a.n, a.repeats, a.warmup, a.block, a.pin)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'shm')}")


if __name__ == "__main__":
    main()
