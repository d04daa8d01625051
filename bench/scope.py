"""The scope's cost on the tick: a 4-signal, 8-axis trace sampled at every tick, against the same
run without recording.

Goal (issue 23 §1): recording adds <= 10 % to the tick cost.

Method. Each 8-axis card type (generic-servo with 8 servo axes, the ADLINK AMP-208C, the Mx4
Octavia, the Turbo PMAC with 8 motors, the MAXk with 8 axes) is built in this process
(no sockets: the recorder's cost is in the tick, not the transport), every axis jogging at its
own speed so that every tick runs in full (none at rest), and `Rack.sched.advance` runs T ticks
at a time, timed (wall ns per tick). Each repeat runs the card once without a recorder and once
with one armed (signals position, command, velocity, error of the 8 axes, every tick, trigger
`now`, as many samples as the run's ticks), in turn, so the host's slow phases hit both series
alike. Figures: p50 over the repeats of ns per tick, and the ratio of the p50s. Sanity: the
recorder took every tick of its run, and the axes were still moving at the end.

    python bench/scope.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/scope.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from bench.common import dist, install_signal_handlers, table, verdict, write_json  # noqa: E402
from vdevd.devices import card_class  # noqa: E402
from vdevd.devices.base import CardContext  # noqa: E402
from vdevd.rack import Rack  # noqa: E402
from vdevd.rt import kernel  # noqa: E402
from vdevd.scope.op import Scopes  # noqa: E402

GOAL_RATIO = 1.10
SIGNALS = ["position", "command", "velocity", "error"]
#: the 8-axis cards and the options that give them 8 axes
CARDS: dict[str, dict[str, Any]] = {
    "generic-servo": {"axes": 8, "plant": "servo"},
    "adlink-amp20xc": {},
    "dspcg-octavia": {},
    "pmac-turbo": {"motors": 8},
    "oms-maxk": {"axes": 8},
}


def build(type_name: str) -> tuple[Any, Rack, Any]:
    """The card in a rack of its own, every axis jogging (card, rack, its motion core)."""
    card = card_class(type_name)("c", CARDS[type_name], CardContext(emit=lambda e: None))
    rack = Rack([card])
    core = card.scope_signals().core(card)
    assert core.n == 8, f"{type_name}: {core.n} axes"
    for a in range(core.n):
        core.servo_on(a)
        core.jog(a, 1000.0 * (a + 1), 1e5, 1e5, 0)
    card.touched()
    return card, rack, core


def per_tick(card: Any, rack: Rack, ticks: int) -> float:
    """Wall ns per tick of `ticks` ticks of the card."""
    t0 = time.perf_counter_ns()
    rack.sched.advance(rack.now_ns + int(card.period * ticks))
    return (time.perf_counter_ns() - t0) / ticks


def run_card(type_name: str, ticks: int, repeats: int) -> dict[str, Any]:
    card, rack, core = build(type_name)
    scopes = Scopes()
    per_tick(card, rack, ticks)  # warm up (the compiled kernel, the caches)
    base: list[float] = []
    scoped: list[float] = []
    for _ in range(repeats):
        base.append(per_tick(card, rack, ticks))
        scopes.op(card, {"action": "arm", "signals": SIGNALS, "samples": ticks})
        scoped.append(per_tick(card, rack, ticks))
        status = scopes.op(card, {"action": "status"})
        assert status is not None and status["state"] == "done" and status["taken"] == ticks, \
            status
        scopes.op(card, {"action": "clear"})
    assert (np.abs(core.axes.cmd_vel) > 0).all(), f"{type_name}: an axis stopped"
    b, s = dist(base), dist(scoped)
    ratio = s["p50"] / b["p50"]
    return {"base_ns": b, "scope_ns": s, "ratio_p50": ratio, "pass": ratio <= GOAL_RATIO,
            "columns": 8 * len(SIGNALS)}


def run(ticks: int = 2000, repeats: int = 15, cards: tuple[str, ...] = tuple(CARDS)
        ) -> dict[str, Any]:
    results = {name: run_card(name, ticks, repeats) for name in cards}
    return {"params": {"ticks": ticks, "repeats": repeats, "signals": SIGNALS, "axes": 8},
            "motion_core": "compiled" if kernel.compiled() is not None else "numpy",
            "cards": results, "pass": all(r["pass"] for r in results.values())}


def report(r: dict[str, Any]) -> None:
    p = r["params"]
    rows = [[name, c["base_ns"]["p50"] / 1e3, c["scope_ns"]["p50"] / 1e3, c["ratio_p50"],
             verdict(c["pass"])] for name, c in r["cards"].items()]
    table(["card (8 axes moving)", "tick p50 us", "tick + scope p50 us", "ratio", "<= 1.10"],
          rows, title=f"scope: {len(p['signals'])} signals x {p['axes']} axes every tick, "
                      f"{p['repeats']} x {p['ticks']} ticks, motion core {r['motion_core']}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer, shorter repeats")
    ap.add_argument("--json", nargs="?", const="", help="write JSON (default: bench/results/)")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(ticks=1000 if a.quick else 2000, repeats=5 if a.quick else 15)
    report(r)
    if a.json is not None:
        print(f"results: {write_json(r, a.json, 'scope')}")


if __name__ == "__main__":
    main()
