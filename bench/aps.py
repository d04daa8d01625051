"""ADLINK AMP-204C/208C: the APS library's round trips and the card's lockstep speed
(vdevclient.aps, issue 19).

1. `APS_get_position_f(0, &pos)` and `APS_ptp(0, OPT_RELATIVE, +-d, NULL)` (alternating small
   relative moves: the axis stays in range; a PTP on a moving axis re-plans on the fly) against
   a lockstep daemon with one AMP-208C, as ratios of a raw pyzmq REQ/REP round trip measured in
   the same run with the same placement. Goals: p50 <= 1.5x and <= 2.5x. Method as
   bench/mx4.py (bench/rtt.py's baseline server and block timing, a fresh random order of the
   series in every block). The library is used as an application uses it: APS_initial on the
   daemon's endpoint (a process-wide session, APS_close at the end), servo on.
   APS_ptp is one batch: [the code, length and arguments to the mailbox, the doorbell with a
   sequence number (the kernel runs the command there and then), the acknowledgement with the
   return code]. APS_get_position_f reads the status block, a passive range: a local client
   maps the daemon's shared memory, so it is no request at all (the figure says which it is).
   Diagnostics: the position read with the mapping off (the same call on a session whose rack
   does not map: one request), a one-op read of the status block by request (the vdevd
   round-trip floor), APS_ptp's batch replayed through `Rack.call` without the library around
   it, and APS_get_axis_param_f (a light command: the same post, nothing planned).
2. Lockstep speed of an 8-axis AMP-208C at its 1 ms cycle with every axis in a velocity move
   (`APS_vel`, servo on, distinct velocities): simulated seconds per wall second of
   `rack.sim.step` (every cycle run), against the same card idle. Goal: >= 50x. The simulated
   seconds per CPU second of the daemon are shown too: on a machine other work shares, the
   wall figure falls with the share the daemon gets, this one much less.

    python bench/aps.py [--quick] [--json]
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

if __package__ in (None, ""):  # run as a script: python bench/aps.py
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
from bench.rtt import RAW, ratios_to_raw, report_against_raw  # noqa: E402

GOAL_POSITION_P50 = 1.5
GOAL_PTP_P50 = 2.5
GOAL_SPEED = 50.0
CARD = "amp0"
POSITION = "APS_get_position_f(0, &pos)"
PTP = "APS_ptp(0, OPT_RELATIVE, +-d, NULL)"
UNMAPPED = "diag: APS_get_position_f, mapping off"
READ = "diag: Region.read of the status block (request)"
REPLAY = "diag: APS_ptp's batch via Rack.call"
LIGHT = "diag: APS_get_axis_param_f(0, PRA_VM, &v)"
GOALS = {POSITION: GOAL_POSITION_P50, PTP: GOAL_PTP_P50}
STEP = 100.0  # the relative PTP's distance, pulses (unit factor 1)
#: APS_vel per axis (pulses/s): distinct, signed, below PRA_VM's default 1e5
VELOCITIES = [(10_000.0 + 3_000.0 * a) * (1 if a % 2 == 0 else -1) for a in range(8)]
MOVING, IDLE = "8 axes moving, sim step", "baseline: idle, sim step"


def amp_card(name: str = CARD, model: str = "AMP-208C") -> str:
    return f'[[card]]\ntype = "adlink-amp20xc"\nname = "{name}"\nmodel = "{model}"\n'


@contextlib.contextmanager
def aps_opened(endpoint: str) -> Any:
    """APS_initial on `endpoint` (the process-wide session), APS_close at the end."""
    from ctypes import byref, c_int32

    from vdevclient import aps

    bits = c_int32()
    rc = aps.APS_initial(byref(bits), 0, endpoint=endpoint)
    if rc != aps.ERR_NoError:
        raise RuntimeError(f"APS_initial returned {rc}")
    try:
        yield aps
    finally:
        aps.APS_close()


def run_rtt(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5,
            pin: str = "split", seed: int = 1) -> dict[str, Any]:
    from ctypes import byref, c_double

    from vdevclient import _aps_session
    from vdevclient._aps_bus import Board, Links, Session
    from vdevclient.core import Rack
    from vdevmaps.adlink import Axis, axis_offset
    from vdevmaps.aps_defs import OPT_RELATIVE, PRA_VM

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    ctx: zmq.Context[Any] = zmq.Context.instance()
    with contextlib.ExitStack() as stack:
        tmp = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="vdevd-bench-")))
        raw_server, raw_ep = start_raw_server(stack, tmp, server_cpus)
        d = stack.enter_context(daemon(amp_card(), "lockstep", server_cpus))
        pin_self(client_cpus)
        raw_read = checked_raw_client(stack, ctx, raw_server, raw_ep)
        rack = connect(d)
        stack.callback(rack.close)
        plain = connect(d, shm=False)  # every access a request
        stack.callback(plain.close)
        aps = stack.enter_context(aps_opened(d.endpoint))
        if aps.APS_set_servo_on(0, 1) != aps.ERR_NoError:
            raise RuntimeError("APS_set_servo_on(0, 1) failed")
        mapped = _aps_session.session()
        board, local = mapped.axis(0) or (None, 0)
        assert board is not None
        unmapped_board = Board(Links(plain), board.card, board.board_id, board.first_axis, board.axes,
                               board.card_id, board.model)
        unmapped = Session(unmapped_board.links, {board.board_id: unmapped_board},
                           [(unmapped_board, a) for a in range(board.axes)])
        pos, value = c_double(), c_double()
        sign = [1.0]

        def position() -> None:
            aps.APS_get_position_f(0, byref(pos))

        def position_unmapped() -> None:
            _aps_session.open_session(unmapped)
            try:
                aps.APS_get_position_f(0, byref(pos))
            finally:
                _aps_session.open_session(mapped)

        def ptp() -> None:
            sign[0] = -sign[0]
            if aps.APS_ptp(0, OPT_RELATIVE, STEP * sign[0], None) != aps.ERR_NoError:
                raise RuntimeError("APS_ptp failed")

        ptp()
        ptp()
        _, last = last_request(rack, ptp)
        ops = list(last["ops"])
        status = plain.card(CARD).region("bar0")
        fbk = axis_offset(local, Axis.FBK_POS)
        fns: dict[str, Callable[[], Any]] = {
            RAW: raw_read, POSITION: position, PTP: ptp, UNMAPPED: position_unmapped,
            READ: lambda: status.read(fbk, 8),
            REPLAY: lambda: board.rack.call({"op": "batch", "ops": ops}, 1.0),
            LIGHT: lambda: aps.APS_get_axis_param_f(0, PRA_VM, byref(value))}
        series, counts, card_ns, stats = measure_commands(
            rack, Rack, fns, {POSITION: position, PTP: ptp}, n, repeats, warmup, block, seed)
        is_mapped = board.bar.mapped and board.bar.is_mapped(fbk, 8)
        if unmapped_board.bar.mapped:
            raise RuntimeError("the session without the mapping maps the status block")
        if aps.APS_get_position_f(0, byref(pos)) != aps.ERR_NoError:
            raise RuntimeError("APS_get_position_f failed")
        d.child.check_alive("vdevd")
    measured = ratios_to_raw(series, {"position": POSITION, "ptp": PTP, "unmapped": UNMAPPED})
    ratios = measured[2]
    return command_figure(
        "aps", where, {"n": n, "repeats": repeats, "warmup": warmup, "block": block,
                       "transport": "tcp loopback", "clock": "lockstep", "model": "AMP-208C"},
        measured, counts, card_ns, stats,
        f"{POSITION} p50 <= {GOAL_POSITION_P50}x, {PTP} p50 <= {GOAL_PTP_P50}x raw REQ/REP",
        all(ratios[name]["p50"] <= goal for name, goal in GOALS.items()),
        batch_ops=len(ops), position_mapped=is_mapped)


def run_speed(seconds: float = 5.0, repeats: int = 3, pin: str = "split") -> dict[str, Any]:
    from ctypes import byref, c_double

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    rows: dict[str, list[float]] = {MOVING: [], IDLE: []}
    cpu: dict[str, list[float]] = {MOVING: [], IDLE: []}  # sim s, daemon CPU s, ...
    with daemon(amp_card(), "lockstep", server_cpus) as d:
        pin_self(client_cpus)
        rack = connect(d)
        with aps_opened(d.endpoint) as aps:
            for a in range(8):
                if aps.APS_set_servo_on(a, 1) != aps.ERR_NoError:
                    raise RuntimeError(f"APS_set_servo_on({a}, 1) failed")

            def step(s: float, cpu: list[float] | None = None) -> float:
                """Simulated s per wall s of one step; `cpu` collects (sim s, daemon CPU s)."""
                c0 = d.child.cpu_seconds()
                t0 = time.perf_counter()
                now = rack.sim.now_ns()
                if rack.sim.step(seconds=s) - now != round(s * 1e9):
                    raise RuntimeError("the step did not advance exactly")
                wall = time.perf_counter() - t0
                if cpu is not None:
                    cpu.extend((s, d.child.cpu_seconds() - c0))
                return s / wall

            for _ in range(repeats):
                for a, v in enumerate(VELOCITIES):
                    if aps.APS_vel(a, 0, v, None) != aps.ERR_NoError:
                        raise RuntimeError(f"APS_vel({a}) failed")
                step(0.5)  # untimed: up to speed
                rows[MOVING].append(step(seconds, cpu[MOVING]))
                vel = []
                for a in range(8):
                    v = c_double()
                    aps.APS_get_command_velocity_f(a, byref(v))
                    vel.append(v.value)
                if not all(abs(v - w) < 1e-6 * abs(w) for v, w in zip(vel, VELOCITIES, strict=True)):
                    raise RuntimeError(f"the axes do not run at their velocities: {vel}")
                for a in range(8):
                    aps.APS_stop_move(a)
                step(1.0)  # untimed: to rest
                if any(aps.APS_motion_status(a) & (1 << aps.MTS_MDN) == 0 for a in range(8)):
                    raise RuntimeError("the axes did not stop")
                rows[IDLE].append(step(seconds, cpu[IDLE]))
        stats = rack.stats()
        rack.close()
        d.child.check_alive("vdevd")
    series = {name: {"median": statistics.median(xs), "min": min(xs), "max": max(xs),
                     "us_per_cycle": 1e6 / (statistics.median(xs) * 1000), "runs": xs}
              for name, xs in rows.items()}
    for name, xs in cpu.items():  # simulated s per daemon CPU s: what a busy machine hides
        used = sum(xs[1::2])
        series[name]["per_cpu"] = sum(xs[0::2]) / used if used > 0 else None  # < a clock tick
    speed = series[MOVING]["median"]
    lost = stats["scheduler"]["lost_ticks"]
    return {"figure": "aps-lockstep", "placement": where,
            "params": {"seconds": seconds, "repeats": repeats, "axes": 8, "cycle_us": 1000,
                       "model": "AMP-208C", "drive": "ideal"},
            "series": series, "speed_median": speed, "lost_ticks": lost,
            "goal": f"median speed >= {GOAL_SPEED:.0f}x real time (8 axes moving)",
            "pass": speed >= GOAL_SPEED and lost == 0}


def run(n: int = 3000, repeats: int = 3, warmup: int = 1000, block: int = 5, pin: str = "split",
        seconds: float = 5.0, speed_repeats: int = 3) -> dict[str, Any]:
    rtt = run_rtt(n, repeats, warmup, block, pin)
    speed = run_speed(seconds, speed_repeats, pin)
    return {"figure": "aps", "rtt": rtt, "speed": speed, "pass": rtt["pass"] and speed["pass"]}


def report(r: dict[str, Any]) -> None:
    rtt, speed = r["rtt"], r["speed"]
    p = rtt["params"]
    report_against_raw(rtt, f"ADLINK AMP-208C APS round trips (lockstep), us; {p['repeats']} x "
                            f"{p['n']} per series, placement {rtt['placement']}",
                       {"position": "position", "ptp": "ptp", "unmapped": "pos unmapped"})
    p50 = {name: d["p50"] for name, d in rtt["series"].items()}
    how = "the daemon's shared memory (no request)" if rtt["position_mapped"] else "a request"
    print(f"APS_get_position_f reads through {how}; with the mapping off (one request) "
          f"{p50[UNMAPPED]:.1f} us ({p50[UNMAPPED] - p50[READ]:+.1f} us vs a one-op read)")
    print(f"where APS_ptp's p50 goes: aps library {p50[PTP] - p50[REPLAY]:+.1f} us (the call vs "
          f"its batch replayed), the batch's {rtt['batch_ops']} ops and the kernel's command "
          f"{p50[REPLAY] - p50[READ]:+.1f} us (vs a one-op read), vdevd round trip "
          f"{p50[READ] - p50[RAW]:+.1f} us (vs raw REQ/REP); the PTP's planning "
          f"{p50[PTP] - p50[LIGHT]:+.1f} us (vs APS_get_axis_param_f)")
    for name, goal in GOALS.items():
        ratio = rtt["ratios"][name]
        print(f"{name} / raw: p50 {ratio['p50']:.2f}x (goal <= {goal}), p99 {ratio['p99']:.2f}x"
              f"  ->  {verdict(ratio['p50'] <= goal)}")
    sp = speed["params"]
    rows = [[name, s["median"], s["min"], s["max"], s["us_per_cycle"], s["per_cpu"]]
            for name, s in speed["series"].items()]
    table(["series", "median x", "min x", "max x", "us/cycle (median)", "sim s / daemon CPU s"],
          rows,
          title=f"ADLINK {sp['model']} lockstep speed (simulated s / wall s), {sp['axes']} axes, "
                f"{sp['drive']} drive, {sp['cycle_us']} us cycle, {sp['repeats']} x "
                f"{sp['seconds']:g} s, placement {speed['placement']}")
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
        print(f"results: {write_json(r, a.json, 'aps')}")


if __name__ == "__main__":
    main()
