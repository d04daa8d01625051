"""A 1000-point PVT scan on a lockstep Turbo PMAC: simulated seconds per wall second.

Goal (issue 21 "Performance"): >= 20x faster than real time.

Method. `vdevd serve --clock lockstep` with one pmac-turbo card (plant `servo`: the PID and the
motor model run every servo cycle at I10's 442.7 us) runs pinned to the server cpu. Through
vdevclient.pcomm the scan is set up as a beamline would: motors 1 and 2 as X and Y (1000 counts per
unit), 1000 points and end velocities in P1000-P2999 / P3000-P4999 (written with `P{n}=` commands,
5 to a line), and a program that reads them in a WHILE loop in PVT10 mode (10 ms a point: 10 s of
motion). `&1B1R` starts it, then `rack.sim.step(seconds=S)` runs the whole scan and is timed from
this process (speed = S / wall seconds). Each repeat starts the scan afresh from the origin.
Baseline of each repeat: the same two motors jogging for S seconds without a program, after the
scans (the card's own cost per servo cycle). Sanity checks: the program has ended at the end of the
step and both motors stand within 5 counts of the last point.

    python bench/pmac_pvt.py [--repeats N] [--json]
"""

from __future__ import annotations

import argparse
import ctypes
import statistics
import sys
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/pmac_pvt.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from bench.common import (  # noqa: E402
    connect,
    daemon,
    free_port,
    install_signal_handlers,
    pin_self,
    placement,
    table,
    verdict,
    write_json,
)
from bench.pmac import pmac_card  # noqa: E402

GOAL_SPEED = 20.0
POINTS = 1000
SEGMENT_MS = 10
DEVICE = 0
PROGRAM = [
    "OPEN PROG 1 CLEAR",
    "ABS PVT10",
    "P1=0",
    "WHILE (P1 < 1000)",
    "X(P(1000+P1)):(P(3000+P1)) Y(P(2000+P1)):(P(4000+P1))",
    "P1=P1+1",
    "ENDWHILE",
    "CLOSE",
]


def scan_points() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A Lissajous scan (units) and its velocities (units/s = per Isx90 = 1000 ms), from and
    back to rest."""
    t = np.arange(1, POINTS + 1) * SEGMENT_MS / 1000
    w = 2 * np.pi / (POINTS * SEGMENT_MS / 1000)
    x, y = 2 * np.sin(w * t) ** 2, np.sin(2 * w * t)
    vx, vy = 2 * w * np.sin(2 * w * t), 2 * w * np.cos(2 * w * t)
    vx[-1] = vy[-1] = 0.0
    return x, y, vx, vy


def run(repeats: int = 3, pin: str = "split") -> dict[str, Any]:
    from vdevclient import pcomm

    server_cpus, client_cpus, where = placement(pin)
    pin_self(client_cpus)
    config = pmac_card(f"tcp://127.0.0.1:{free_port()}").replace(
        'ethernet =', 'plant = "servo"\nethernet =')
    buf = ctypes.create_string_buffer(4096)

    def ask(line: str) -> str:
        pcomm.PmacGetResponseA(DEVICE, buf, 4096, line)
        reply = buf.value.decode("latin-1")
        if "\x07" in reply:
            raise RuntimeError(f"{line!r} answered {reply!r}")
        return reply.strip("\r\x06")

    with daemon(config, "lockstep", server_cpus) as d:
        pin_self(client_cpus)
        rack = connect(d)
        try:
            if not pcomm.OpenPmacDevice(DEVICE, endpoint=d.endpoint):
                raise RuntimeError(f"OpenPmacDevice({DEVICE}) failed on {d.endpoint}")
            x, y, vx, vy = scan_points()
            ask("&1#1->1000X #2->1000Y #1J/ #2J/")
            for base, values in ((1000, x), (2000, y), (3000, vx), (4000, vy)):
                for k in range(0, POINTS, 5):
                    ask(" ".join(f"P{base + k + j}={v:.6f}" for j, v in enumerate(values[k:k + 5])))
            for line in PROGRAM:
                ask(line)
            seconds = POINTS * SEGMENT_MS / 1000 + 0.2
            speeds: list[float] = []
            jogs: list[float] = []
            for _ in range(repeats):
                ask("#1J=0 #2J=0")
                rack.sim.step(seconds=1.0)   # back at the origin, settled
                ask("&1B1R")
                t0 = time.perf_counter()
                rack.sim.step(seconds=seconds)
                wall = time.perf_counter() - t0
                status = int(ask("&1??")[:6], 16)
                p1, p2 = float(ask("#1P")), float(ask("#2P"))
                if status & 1 or abs(p1 - 1000 * x[-1]) > 5 or abs(p2 - 1000 * y[-1]) > 5:
                    raise RuntimeError(f"scan did not end on its last point: status {status:06x}, "
                                       f"#1P {p1}, #2P {p2}")
                speeds.append(seconds / wall)
            ask("#1J+ #2J+")   # the baseline: the same motors jogging, no program
            for _ in range(repeats):
                t0 = time.perf_counter()
                rack.sim.step(seconds=seconds)
                jogs.append(seconds / (time.perf_counter() - t0))
        finally:
            pcomm.ClosePmacDevice(DEVICE)
            rack.close()
    median = statistics.median(speeds)
    return {"params": {"points": POINTS, "segment_ms": SEGMENT_MS, "repeats": repeats,
                       "seconds": seconds},
            "placement": where, "speeds": speeds, "speed_median": median, "jog_speeds": jogs,
            "jog_median": statistics.median(jogs),
            "pass": median >= GOAL_SPEED}


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    table(["repeat", "PVT scan x", "jog baseline x"],
          [[k + 1, s, j] for k, (s, j) in enumerate(zip(r["speeds"], r["jog_speeds"], strict=True))],
          title=f"PVT scan, {p['points']} points of {p['segment_ms']} ms on two servo motors "
                f"({p['seconds']:g} s simulated per repeat), placement {r['placement']}")
    print(f"jog baseline (motors 1 and 2 jogging, no program) {r['jog_median']:.1f}x")
    print(f"speed {r['speed_median']:.1f}x real time (goal >= {GOAL_SPEED:.0f}x)  ->  "
          f"{verdict(r['pass'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(a.repeats, a.pin)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'pmac_pvt')}")


if __name__ == "__main__":
    main()
