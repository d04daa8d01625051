"""Mx4 Octavia: an RTC's round trip and the card's lockstep speed (vdevclient.mx4, issue 18).

1. `mx4.AXMOVE(h, 0x0A, ...)` (Ch6 Example 2: axes 2 and 4) against a lockstep daemon with one
   8-axis dspcg-octavia card, as a ratio of a raw pyzmq REQ/REP round trip measured in the same
   run with the same placement. Goal: p50 <= 2.5x. Method as bench/maxk.py (bench/rtt.py's
   baseline server and block timing, a fresh random order of the series in every block). The
   call is one batch: [wait 3C2h = 00h, the arguments at 3C3h, the code at 3C2h, wait 3C2h = 00h
   (the card takes the RTC at its next 200 us sample: the daemon runs one tick of the card), the
   status lock 3FDh, wait 3FCh = 00h, read 000h..00Fh, a guard on DSPSTAT1 b6/b7, the release].
   Diagnostics: a one-op read of 1FFEh (a register with a hook: always a request; the vdevd
   round-trip floor), the call's batch sent through `Rack.call` without the library around it,
   a batch of the bare RTC protocol without the status check, and EN_MOTCP through the library
   (the same post and check around an RTC whose execution plans no move).
2. Lockstep speed of an 8-axis Octavia (servo plant, the manual's CTRL gains) with every axis
   in VELMODE at its own velocity: simulated seconds per wall second of `rack.sim.step` (the
   card's 200 us samples, all of them run), against the same card idle. Goal: >= 20x. A
   diagnostic series waits instead (`mx4.wait_int` for a report that does not come): a pending
   wait on a value makes the daemon run the watched card one tick at a time.

    python bench/mx4.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/mx4.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import zmq  # noqa: E402

from bench.common import (  # noqa: E402
    connect,
    daemon,
    install_signal_handlers,
    pin_self,
    placement,
    table,
    verdict,
    write_json,
)
from bench.galil import (  # noqa: E402
    checked_raw_client,
    command_figure,
    last_request,
    measure_commands,
    start_raw_server,
)
from bench.rtt import (  # noqa: E402
    RAW,
    ratios_to_raw,
    report_against_raw,
    report_ratio_goals,
)

GOAL_P50 = 2.5
GOAL_SPEED = 20.0
CARD = "oct0"
AXMOVE = "mx4.AXMOVE(h, 0x0A, ...) (Ch6 Example 2)"
READ = "diag: Region.read of 1FFEh (one op)"
REPLAY = "diag: AXMOVE's batch via Rack.call"
BARE = "diag: the RTC protocol alone (no status check)"
LIGHT = "diag: mx4.EN_MOTCP(h, 0x01) (an RTC that plans no move)"
#: VELMODE per axis (counts/sample, 16.16): distinct, signed, within the card's 256 counts/sample
VELOCITIES = [(4 + 3 * a) * (1 if a % 2 == 0 else -1) for a in range(8)]


def octavia_card(name: str = CARD, plant: str = "servo") -> str:
    return f'[[card]]\ntype = "dspcg-octavia"\nname = "{name}"\naxes = 8\nplant = "{plant}"\n'


def run_rtt(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5,
            pin: str = "split", seed: int = 1) -> dict[str, Any]:
    from vdevclient import mx4
    from vdevclient.core import Rack
    from vdevmaps.octavia import Dpr

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_server, raw_ep = start_raw_server(stack, tmp, server_cpus)
        d = stack.enter_context(daemon(octavia_card(), "lockstep", server_cpus))
        pin_self(client_cpus)
        raw_read = checked_raw_client(stack, ctx, raw_server, raw_ep)
        rack = connect(d)
        stack.callback(rack.close)
        h = stack.enter_context(mx4.open(1, endpoint=d.endpoint))
        pos = [0, 0x234567, 0, 0x112233]

        def axmove() -> None:
            mx4.AXMOVE(h, 0x0A, 0x150, pos, 0x200000)

        axmove()
        _, last = last_request(rack, axmove)
        ops = list(last["ops"])
        check = len(h.check_ops(h.timeout_ns()))
        bare = {"op": "batch", "ops": ops[:len(ops) - check]}  # without the status check
        dpr = rack.card(CARD).region("dpr")
        fns: dict[str, Callable[[], Any]] = {
            RAW: raw_read, AXMOVE: axmove, READ: lambda: dpr.read(Dpr.HOSTINT1, 1),
            REPLAY: lambda: h.rack.call({"op": "batch", "ops": ops}, 1.0),
            BARE: lambda: h.rack.call(bare, 1.0), LIGHT: lambda: mx4.EN_MOTCP(h, 0x01)}
        series, counts, card_ns, stats = measure_commands(
            rack, Rack, fns, {AXMOVE: axmove}, n, repeats, warmup, block, seed)
    measured = ratios_to_raw(series, {"axmove": AXMOVE})
    return command_figure(
        "mx4", where, {"n": n, "repeats": repeats, "warmup": warmup, "block": block,
                       "transport": "tcp loopback", "clock": "lockstep"},
        measured, counts, card_ns, stats, f"p50 <= {GOAL_P50}x raw REQ/REP",
        measured[2][AXMOVE]["p50"] <= GOAL_P50, batch_ops=len(ops))


def run_speed(seconds: float = 5.0, repeats: int = 3, pin: str = "split") -> dict[str, Any]:
    from vdevclient import mx4
    from vdevmaps.octavia import ACTVEL_SCALE, Window

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    rows: dict[str, list[float]] = {"8 axes moving, sim step": [], "baseline: idle, sim step": [],
                                    "diag: 8 axes moving, server-side wait": []}
    with daemon(octavia_card(), "lockstep", server_cpus) as d:
        pin_self(client_cpus)
        rack = connect(d)
        h = mx4.open(1, endpoint=d.endpoint)
        mx4.CTRL(h, 0xFF, ki=100, kp=4000, kf=3000, kd=2500)
        mx4.MAXACC(h, 0xFF, mx4.acc_to_raw(0.05))

        def step(s: float) -> float:
            t0 = time.perf_counter()
            now = rack.sim.now_ns()
            if rack.sim.step(seconds=s) - now != round(s * 1e9):
                raise RuntimeError("the step did not advance exactly")
            return s / (time.perf_counter() - t0)

        def waited(s: float) -> float:
            t0 = time.perf_counter()
            with contextlib.suppress(mx4.Mx4Timeout):  # the 5 ms interrupt is off: it never comes
                mx4.wait_int(h, dspstat2=mx4.DspStat2.INT5MS, timeout_ms=round(s * 1000))
            return s / (time.perf_counter() - t0)

        for _ in range(repeats):
            mx4.VELMODE(h, 0xFF, [mx4.vel_to_raw(v) for v in VELOCITIES])
            step(0.5)  # untimed: up to speed
            rows["8 axes moving, sim step"].append(step(seconds))
            rows["diag: 8 axes moving, server-side wait"].append(waited(seconds / 5))
            vel = [v / ACTVEL_SCALE for v in mx4.read_axes(h, Window.ACTVEL)]
            if not all(abs(v - w) < 0.05 * abs(w) for v, w in zip(vel, VELOCITIES, strict=True)):
                raise RuntimeError(f"the axes do not run at their velocities: {vel}")
            mx4.VELMODE(h, 0xFF, 0)
            step(1.0)  # untimed: to rest
            rows["baseline: idle, sim step"].append(step(seconds))
        stats = rack.stats()
        h.close()
        rack.close()
        d.child.check_alive("vdevd")
    series = {name: {"median": statistics.median(xs), "min": min(xs), "max": max(xs),
                     "us_per_sample": 1e6 / (statistics.median(xs) * 5000), "runs": xs}
              for name, xs in rows.items()}
    speed = series["8 axes moving, sim step"]["median"]
    lost = stats["scheduler"]["lost_ticks"]
    return {"figure": "mx4-lockstep", "placement": where,
            "params": {"seconds": seconds, "repeats": repeats, "axes": 8, "sample_us": 200,
                       "plant": "servo"},
            "series": series, "speed_median": speed, "lost_ticks": lost,
            "goal": f"median speed >= {GOAL_SPEED:.0f}x real time (8 axes moving)",
            "pass": speed >= GOAL_SPEED and lost == 0}


def run(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5, pin: str = "split",
        seconds: float = 5.0, speed_repeats: int = 3) -> dict[str, Any]:
    rtt = run_rtt(n, repeats, warmup, block, pin)
    speed = run_speed(seconds, speed_repeats, pin)
    return {"figure": "mx4", "rtt": rtt, "speed": speed, "pass": rtt["pass"] and speed["pass"]}


def report(r: dict[str, Any]) -> None:
    rtt, speed = r["rtt"], r["speed"]
    p = rtt["params"]
    report_against_raw(rtt, f"Mx4 Octavia AXMOVE round trip (lockstep), us; {p['repeats']} x {p['n']} "
                            f"per series, placement {rtt['placement']}", {"axmove": "axmove"})
    p50 = {name: d["p50"] for name, d in rtt["series"].items()}
    print(f"where the p50 goes: mx4 library {p50[AXMOVE] - p50[REPLAY]:+.1f} us (the call vs its "
          f"batch replayed), the status check {p50[REPLAY] - p50[BARE]:+.1f} us, the RTC's "
          f"{rtt['batch_ops'] - 5} ops and the card's sample {p50[BARE] - p50[READ]:+.1f} us "
          f"(vs a one-op read), vdevd round trip {p50[READ] - p50[RAW]:+.1f} us (vs raw REQ/REP); "
          f"AXMOVE's execution {p50[AXMOVE] - p50[LIGHT]:+.1f} us (vs EN_MOTCP)")
    report_ratio_goals(rtt, GOAL_P50)
    sp = speed["params"]
    rows = [[name, s["median"], s["min"], s["max"], s["us_per_sample"]]
            for name, s in speed["series"].items()]
    table(["series", "median x", "min x", "max x", "us/sample (median)"], rows,
          title=f"Mx4 Octavia lockstep speed (simulated s / wall s), {sp['axes']} axes, "
                f"{sp['plant']} plant, 200 us samples, {sp['repeats']} x {sp['seconds']:g} s, "
                f"placement {speed['placement']}")
    print(f"speed {speed['speed_median']:.1f}x real time (goal >= {GOAL_SPEED:.0f}x), lost ticks "
          f"{speed['lost_ticks']}  ->  {verdict(speed['pass'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=3000, help="calls per series per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=1000)
    ap.add_argument("--block", type=int, default=5, help="calls per alternating block")
    ap.add_argument("--seconds", type=float, default=5.0, help="simulated seconds per speed step")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--quick", action="store_true", help="n=1000, 2 repeats, 300 warm-up calls, 2 s steps")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    if a.quick:
        a.n, a.repeats, a.warmup, a.seconds = 1000, 2, 300, 2.0
    r = run(a.n, a.repeats, a.warmup, a.block, a.pin, a.seconds, a.repeats)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'mx4')}")


if __name__ == "__main__":
    main()
