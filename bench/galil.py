"""Galil DMC-13X8 command round trip: `galil.DMCCommand(h, "TPX")` and `gclib.py().GCommand("TPX")`
against a lockstep daemon with one galil-dmc13x8 card, as ratios of a raw pyzmq REQ/REP round
trip measured in the same run with the same placement.

Goal: p50 <= 2.5x the raw round trip.

Method as bench/rtt.py (its baseline server, bench/raw_server.py, and its block timing): the
servers run on the server cpu, this process is the client; after a warm-up, each repeat times `n`
calls of every series in short blocks in a fresh random order per block. A command is one batch
(PROTOCOL.md) [a repeated write of "TPX\\r" to N+1, a repeated read of 14 bytes of N+1]: the
card (decode = "arrival", its default) decodes TPX when the CR is written, so the reply is there
to read and no servo tick runs. Three diagnostic series split the cost: a one-op
register read of the same card (the round trip floor through vdevd), a lockstep `sim step` of one
tick (what a command would cost more with decode = "sample", which decodes at the next tick) and
DMCCommand's batch replayed through `Rack.call` without the library (what the daemon and the card
take for it). The round trips per call are counted.

Application programs: the round trips `GProgramDownload` takes for a 100-line program (goal <= 20:
the command FIFO's bursts go in one batch), and `GCommand("MG _TPX")` against the raw round trip
while thread 0 runs a loop (goal p50 <= 2.5x), interleaved with a lockstep tick (which runs the
loop's statements) as a diagnostic series.
Second figure: the lockstep speed (simulated s per wall s) of the 4-axis card (servo plant,
TM 1000) running a vector move: VM XY with Z as the tangent axis along a long circle (CR) and
W in linear interpolation in the T plane, every axis moving; goal >= 50x real time.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/galil.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import msgpack  # noqa: E402
import zmq  # noqa: E402

from bench.common import (  # noqa: E402
    BENCH_DIR,
    child,
    connect,
    daemon,
    free_port,
    install_signal_handlers,
    ns_dist_to_us,
    pin_self,
    placement,
    table,
    verdict,
    write_json,
)
from bench.rtt import (  # noqa: E402
    RAW,
    ratios_to_raw,
    report_against_raw,
    report_ratio_goals,
    time_interleaved,
    warm_up,
)

GOAL_P50 = 2.5
GOAL_SPEED = 50.0  # lockstep speed with a vector move running (simulated s / wall s)
VECTOR = "4 axes in a vector move, sim step"
IDLE = "baseline: idle, sim step"
#: the vector move of the speed figure: an XY circle of 20 turns with Z tangent (S plane), and
#: W in linear interpolation (T plane), long enough for every timed step
VECTOR_SETUP = ("VM XYZ;TN 10,0;VS 100000;VA 1000000;VD 1000000;CR 50000,0,7200;VE;"
                "CA T;LM W;VS 50000,50000;VA ,1000000;VD ,1000000;LI,,,2000000;LE;CA S")
COMMAND = "TPX"
CARD = "galil0"

DMC = f'galil.DMCCommand(h, "{COMMAND}")'
GCLIB = f'gclib.py().GCommand("{COMMAND}")'
READ = "diag: Region.read of N+3 (one op)"
TICK = "diag: sim step of one tick"
REPLAY = "diag: DMCCommand's batch via Rack.call"
PROGRAM_MG = 'gclib GCommand("MG _TPX"), a program looping'
PROGRAM_TICK = "diag: sim step of one tick, a program looping"
GOAL_DOWNLOAD_TRIPS = 20
LOOP = "#LOOP\nV1=V1+1\nJP #LOOP"


def hundred_lines() -> str:
    """A 100-line program: labels, moves, trippoints, jumps."""
    lines = []
    for k in range(25):
        lines += [f"#L{k}", f"PR {k * 100},{k * 50}", "BG XY;AM XY", f"JP #L{k + 1},V1<{k}"]
    return "\n".join(lines)


def galil_card(name: str = CARD) -> str:
    """A [[card]] table of one DMC-13X8 with its defaults (4 axes, servo plant, TM 1000)."""
    return f'[[card]]\ntype = "galil-dmc13x8"\nname = "{name}"\n'


def raw_client(stack: contextlib.ExitStack, ctx: zmq.Context[Any], endpoint: str) -> Callable[[], Any]:
    """rtt.py's baseline request: msgpack [op, region, offset, size] to bench/raw_server.py."""
    req = ctx.socket(zmq.REQ)
    stack.callback(req.close)
    req.linger = 0
    req.rcvtimeo = 10_000
    req.connect(endpoint)
    body = msgpack.packb([1, "a16", 3, 1])
    unpackb = msgpack.unpackb

    def raw_read() -> Any:  # the client unpacks the reply, as vdevclient does
        req.send(body)
        return unpackb(req.recv())

    return raw_read


def start_raw_server(stack: contextlib.ExitStack, tmp: Path, cpus: set[int] | None) -> tuple[Any, str]:
    """bench/raw_server.py on the server cpus: (the child, its endpoint)."""
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    server = stack.enter_context(child(
        [sys.executable, str(BENCH_DIR / "raw_server.py"), endpoint], cpus, tmp / "raw.log"))
    return server, endpoint


def checked_raw_client(stack: contextlib.ExitStack, ctx: zmq.Context[Any], server: Any,
                       endpoint: str) -> Callable[[], Any]:
    """`raw_client`, after one request has proved the raw server answers."""
    raw_read = raw_client(stack, ctx, endpoint)
    try:
        raw_read()
    except zmq.Again:
        server.check_alive("raw server")
        raise RuntimeError("the raw REP server did not answer") from None
    return raw_read


def run(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5, pin: str = "split",
        diag: bool = True, seed: int = 1, seconds: float = 5.0,
        speed_repeats: int = 3) -> dict[str, Any]:
    """The command figure, with the vector-move lockstep speed (`run_speed`) as `vector_speed`
    (speed_repeats 0: none)."""
    r = run_commands(n, repeats, warmup, block, pin, diag, seed)
    if speed_repeats:
        r["vector_speed"] = speed = run_speed(seconds, speed_repeats, pin)
        r["pass"] = r["pass"] and speed["pass"]
    return r


def run_commands(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5,
                 pin: str = "split", diag: bool = True, seed: int = 1) -> dict[str, Any]:
    from vdevclient import galil, gclib
    from vdevclient.core import Rack

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_server, raw_ep = start_raw_server(stack, tmp, server_cpus)
        d = stack.enter_context(daemon(galil_card(), "lockstep", server_cpus))
        pin_self(client_cpus)  # zmq's I/O threads exist now; keep them with the client
        raw_read = checked_raw_client(stack, ctx, raw_server, raw_ep)

        rack = connect(d)  # waits until the daemon answers
        stack.callback(rack.close)
        h = ctypes.c_long()
        rc = galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=d.endpoint, events=d.events)
        if rc != galil.DMCNOERROR:
            raise RuntimeError(f"DMCOpen returned {rc}")
        stack.callback(galil.DMCClose, h)
        g = gclib.py()
        g.GOpen(f"{CARD} --endpoint {d.endpoint} --events {d.events}")
        stack.callback(g.GClose)
        buf = ctypes.create_string_buffer(256)

        def dmc() -> bytes:
            if galil.DMCCommand(h, COMMAND, buf, 256) != galil.DMCNOERROR:
                raise RuntimeError(f"DMCCommand({COMMAND!r}) failed: {buf.value!r}")
            return buf.value

        def gcommand() -> str:
            return g.GCommand(COMMAND)

        fns: dict[str, Callable[[], Any]] = {RAW: raw_read, DMC: dmc, GCLIB: gcommand}
        batch_ops = 0
        if diag:
            a16 = rack.card(CARD).region("a16")
            fns[READ] = lambda: a16.read(3, 1)
            fns[TICK] = lambda: rack.sim.step(ticks=1)
            fns[REPLAY], batch_ops = replay_of(dmc, rack)

        series, counts, card_ns, stats = measure_commands(
            rack, Rack, fns, {DMC: dmc, GCLIB: gcommand}, n, repeats, warmup, block, seed)
        program = measure_program(rack, Rack, g, raw_read, n, repeats, warmup, block, seed)

    measured = ratios_to_raw(series, {"dmc": DMC, "gclib": GCLIB})
    return command_figure(
        "galil", where, {"n": n, "repeats": repeats, "warmup": warmup, "block": block,
                         "command": COMMAND, "transport": "tcp loopback", "clock": "lockstep"},
        measured, counts, card_ns, stats, f"p50 <= {GOAL_P50}x raw REQ/REP",
        all(r["p50"] <= GOAL_P50 for r in measured[2].values()) and program["pass"],
        batch_ops=batch_ops, program=program)


def measure_program(rack: Any, rack_class: Any, g: Any, raw_read: Callable[[], Any], n: int,
                    repeats: int, warmup: int, block: int, seed: int) -> dict[str, Any]:
    """The application program figures: the round trips of a 100-line download, then
    GCommand("MG _TPX") against RAW while thread 0 loops (a tick series runs the loop)."""
    download = count_round_trips(rack_class, {"download": lambda: g.GProgramDownload(hundred_lines())},
                                 5)["download"]
    g.GProgramDownload(LOOP)
    g.GCommand("V1=0;XQ #LOOP")
    fns: dict[str, Callable[[], Any]] = {RAW: raw_read, PROGRAM_MG: lambda: g.GCommand("MG _TPX"),
                                         PROGRAM_TICK: lambda: rack.sim.step(ticks=1)}
    warm_up(fns, warmup, block)
    series = time_interleaved(fns, n, repeats, block, seed)
    running = g.GCommand("MG _XQ0") != "-0000000001.0000"
    g.GCommand("HX")
    dists, per_repeat, ratios = ratios_to_raw(series, {"program": PROGRAM_MG})
    return {"download_round_trips": download, "series": dists, "per_repeat": per_repeat,
            "ratios": ratios, "thread_ran": running,
            "pass": (download["max"] <= GOAL_DOWNLOAD_TRIPS and running
                     and ratios[PROGRAM_MG]["p50"] <= GOAL_P50)}


def run_speed(seconds: float = 5.0, repeats: int = 3, pin: str = "split") -> dict[str, Any]:
    """The lockstep speed of the card with every axis in a vector move, against the card idle."""
    from vdevclient import gclib

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    rows: dict[str, list[float]] = {VECTOR: [], IDLE: []}
    with daemon(galil_card(), "lockstep", server_cpus) as d:
        pin_self(client_cpus)
        rack = connect(d)
        g = gclib.py()
        g.GOpen(f"{CARD} --endpoint {d.endpoint} --events {d.events}")

        def step(s: float) -> float:
            t0 = time.perf_counter()
            now = rack.sim.now_ns()
            if rack.sim.step(seconds=s) - now != round(s * 1e9):
                raise RuntimeError("the step did not advance exactly")
            return s / (time.perf_counter() - t0)

        for _ in range(repeats):
            g.GCommand(VECTOR_SETUP)
            g.GCommand("BG ST")
            step(0.2)  # untimed: up to speed
            rows[VECTOR].append(step(seconds))
            if g.GCommand("MG _BGS,_BGT").split() != ["0000000001.0000"] * 2:
                raise RuntimeError("the vector move ended before the timed step did")
            g.GCommand("AB")
            step(1.0)  # untimed: to rest
            rows[IDLE].append(step(seconds))
        stats = rack.stats()
        g.GClose()
        rack.close()
        d.child.check_alive("vdevd")
    series = {name: {"median": statistics.median(xs), "min": min(xs), "max": max(xs),
                     "us_per_sample": 1e6 / (statistics.median(xs) * 1000), "runs": xs}
              for name, xs in rows.items()}
    speed = series[VECTOR]["median"]
    lost = stats["scheduler"]["lost_ticks"]
    return {"figure": "galil-vector-lockstep", "placement": where,
            "params": {"seconds": seconds, "repeats": repeats, "axes": 4, "sample_us": 1000,
                       "plant": "servo", "move": VECTOR_SETUP},
            "series": series, "speed_median": speed, "lost_ticks": lost,
            "goal": f"median speed >= {GOAL_SPEED:.0f}x real time (4 axes in a vector move)",
            "pass": speed >= GOAL_SPEED and lost == 0}


def report_speed(speed: dict[str, Any]) -> None:
    sp = speed["params"]
    rows = [[name, s["median"], s["min"], s["max"], s["us_per_sample"]]
            for name, s in speed["series"].items()]
    table(["series", "median x", "min x", "max x", "us/sample (median)"], rows,
          title=f"Galil DMC-13X8 lockstep speed (simulated s / wall s), {sp['axes']} axes in a "
                f"vector move, {sp['plant']} plant, 1 ms samples, {sp['repeats']} x "
                f"{sp['seconds']:g} s, placement {speed['placement']}")
    print(f"speed {speed['speed_median']:.1f}x real time (goal >= {GOAL_SPEED:.0f}x), lost ticks "
          f"{speed['lost_ticks']}  ->  {verdict(speed['pass'])}")


def last_request(rack: Any, fn: Callable[[], Any]) -> tuple[Any, Any]:
    """Run `fn` with `rack`'s class spied on: (what fn returned, the last request it sent, a map
    or a vdevclient.core.Prepared)."""
    seen: list[Any] = []
    call = type(rack).call

    def spy(self: Any, message: Any, wait_s: float = 0.0) -> Any:
        seen.append(message)
        return call(self, message, wait_s)

    type(rack).call = spy
    try:
        result = fn()
    finally:
        type(rack).call = call
    return result, seen[-1]


def replay_of(dmc: Callable[[], Any], rack: Any) -> tuple[Callable[[], Any], int]:
    """A call that sends the batch DMCCommand sends once it knows the reply's length, through
    `rack` (no library around it), and the number of ops in that batch."""
    from vdevclient.core import Prepared

    dmc()  # the first call reads 32 bytes; from the second on, as many as the reply has
    _, last = last_request(rack, dmc)
    ops = list((last.message if isinstance(last, Prepared) else last)["ops"])
    message = last if isinstance(last, Prepared) else None  # sent as the library sends it

    def replay() -> Any:
        return rack.call(message or {"op": "batch", "ops": ops}, 1.0)

    return replay, len(ops)


def measure_commands(rack: Any, rack_class: Any, fns: dict[str, Callable[[], Any]],
                     counted: dict[str, Callable[[], Any]], n: int, repeats: int, warmup: int,
                     block: int, seed: int) -> tuple[dict[str, Any], dict[str, Any], int, dict[str, Any]]:
    """What every command bench measures, in order: the round trips per call of `counted`, the
    card time one call of the first of them takes, then the interleaved block timing of `fns`.
    Returns (series, round trips, card ns per command, the daemon's stats)."""
    counts = count_round_trips(rack_class, counted, 200)
    now0 = rack.sim.now_ns()
    next(iter(counted.values()))()
    card_ns = rack.sim.now_ns() - now0
    warm_up(fns, warmup, block)
    series = time_interleaved(fns, n, repeats, block, seed)
    return series, counts, card_ns, rack.stats()


def command_figure(figure: str, where: str, params: dict[str, Any], measured: tuple[Any, ...],
                   counts: dict[str, Any], card_ns: int, stats: dict[str, Any], goal: str,
                   passed: bool, **extra: Any) -> dict[str, Any]:
    """A command figure's result record; `measured` is ratios_to_raw's (dists, per repeat,
    ratios)."""
    dists, per_repeat, ratios = measured
    return {
        "figure": figure, "placement": where, "params": params, "series": dists,
        "per_repeat": per_repeat, "ratios": ratios, "round_trips": counts, **extra,
        "card_ns_per_command": card_ns,
        "daemon_latency_us": ns_dist_to_us(stats["requests"]["latency_ns"]),
        "goal": goal, "pass": passed,
    }


def count_round_trips(rack_class: Any, fns: dict[str, Callable[[], Any]], n: int) -> dict[str, Any]:
    """Requests per call of each function over `n` calls: {name: {mean, max}}."""
    call = rack_class.call
    counts: list[int] = []

    def spy(self: Any, message: dict[str, Any], wait_s: float = 0.0) -> Any:
        counts[-1] += 1
        return call(self, message, wait_s)

    out: dict[str, Any] = {}
    rack_class.call = spy
    try:
        for name, fn in fns.items():
            per_call = []
            for _ in range(n):
                counts.append(0)
                fn()
                per_call.append(counts[-1])
            out[name] = {"mean": sum(per_call) / n, "max": max(per_call)}
    finally:
        rack_class.call = call
    return out


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    report_against_raw(r, f'Galil "{p["command"]}" round trip (lockstep), us; {p["repeats"]} x '
                          f'{p["n"]} per series, placement {r["placement"]}',
                       {"dmc": "DMC", "gclib": "gclib"})
    if r["batch_ops"]:
        p50 = {name: d["p50"] for name, d in r["series"].items()}
        print(f"where the p50 goes: galil library {p50[DMC] - p50[REPLAY]:+.1f} us (DMCCommand vs its "
              f"batch replayed), the batch's {r['batch_ops']} ops and TPX's decoding "
              f"{p50[REPLAY] - p50[READ]:+.1f} us (vs a one-op read), vdevd round trip "
              f"{p50[READ] - p50[RAW]:+.1f} us (vs raw REQ/REP); a lockstep tick would add "
              f"{p50[TICK] - p50[READ]:+.1f} us (sim step vs a one-op read)")
    report_ratio_goals(r, GOAL_P50)
    prog = r.get("program")
    if prog:
        trips = prog["download_round_trips"]
        print(f"GProgramDownload of 100 lines: {trips['mean']:.0f} round trip(s) (max {trips['max']}, "
              f"goal <= {GOAL_DOWNLOAD_TRIPS})  ->  {verdict(trips['max'] <= GOAL_DOWNLOAD_TRIPS)}")
        for name, d in prog["series"].items():
            print(f"  {name}: p50 {d['p50']:.1f} us, p99 {d['p99']:.1f} us")
        ratio = prog["ratios"][PROGRAM_MG]
        print(f"{PROGRAM_MG} / raw: p50 {ratio['p50']:.2f}x (goal <= {GOAL_P50}), p99 "
              f"{ratio['p99']:.2f}x, thread ran: {prog['thread_ran']}  ->  "
              f"{verdict(ratio['p50'] <= GOAL_P50 and prog['thread_ran'])}")
    if "vector_speed" in r:
        report_speed(r["vector_speed"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=3000, help="calls per series per repeat")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=1000)
    ap.add_argument("--block", type=int, default=5, help="calls per alternating block")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--no-diag", action="store_true", help="skip the two diagnostic series")
    ap.add_argument("--seconds", type=float, default=5.0, help="simulated seconds per speed step")
    ap.add_argument("--speed-repeats", type=int, default=3)
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(a.n, a.repeats, a.warmup, a.block, a.pin, diag=not a.no_diag, seconds=a.seconds,
            speed_repeats=a.speed_repeats)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'galil')}")


if __name__ == "__main__":
    main()
