"""Lockstep speed of a whole rack: simulated seconds per wall second, idle and moving, and how the
cost grows with the number of cards and axes.

Goals (issue 17; the moving ones met with the compiled motion core, decision 0011): the
embedded default rack (generic servo, Galil DMC-13X8, OMS MAXk, Turbo PMAC; since issue 18 the
Octavia too: 5 cards, 32 axes) all idle >= 200x real time and all axes moving >= 30x; four of
each kind (16 cards then, 20 now) moving >= 8x.

Method. `vdevd serve --clock lockstep` runs pinned to the server cpu with N sets of the default
rack's cards (N = 1, 2, 4; the PMAC Ethernet ports off, they cost no tick). "Idle": every card as
powered up. "Moving": through the vendor libraries, as an application does it, every axis of every
card jogs (generic: COMMAND = JOG; Galil: JG, BG; MAXk: AA JG; PMAC: #nJ+/-; Octavia: CTRL,
MAXACC, VELMODE through its DPR), then after an untimed
settling step `rack.sim.step(seconds=S)` is timed from this process (speed = S / wall). A moving
run is valid only if every axis's position changed during it and no card rested (stats
`quiet_ticks` unchanged); an idle run shows how much ran in closed form. Baseline of the same run:
the wall time of one motion-core tick (8 servo axes jogging, no card around it) in this process,
so that the rack's cost reads as "core ticks per simulated second", which the machine's speed of
the moment does not change. Medians of `repeats` runs per configuration; the table and a PNG plot
(matplotlib, the `bench` extra) go to bench/results/.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import statistics
import sys
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run as a script: python bench/rack.py
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from vdevmaps.octavia import BY_NAME, Dpr, axis_offset, pack  # noqa: E402

from bench.common import (  # noqa: E402
    AXIS_BASE,
    AXIS_STRIDE,
    POSITION,
    RESULTS_DIR,
    connect,
    daemon,
    install_signal_handlers,
    jog_axes,
    pin_self,
    placement,
    table,
    verdict,
    write_json,
)

GOAL_IDLE = 200.0
GOAL_MOVING = 30.0
GOAL_MOVING_16 = 8.0
AXES_PER_SET = 4 + 4 + 8 + 8 + 8  # generic, Galil, MAXk, PMAC, Octavia


def rack_config(sets: int) -> str:
    """`sets` copies of the embedded default rack's cards (Ethernet off, boards and devices
    numbered apart)."""
    out = []
    for k in range(sets):
        out.append(f'[[card]]\ntype = "generic-servo"\nname = "servo{k}"\n')
        out.append(f'[[card]]\ntype = "galil-dmc13x8"\nname = "galil{k}"\n')
        out.append(f'[[card]]\ntype = "oms-maxk"\nname = "maxk{k}"\nboard = {k + 1}\n')
        out.append(f'[[card]]\ntype = "pmac-turbo"\nname = "pmac{k}"\ndevice = {k}\n'
                   'ethernet = ""\n')
        out.append(f'[[card]]\ntype = "dspcg-octavia"\nname = "octavia{k}"\ncard = {k + 1}\n')
    return "\n".join(out)


class Hosts:
    """The vendor libraries opened on every card of the rack."""

    def __init__(self, stack: contextlib.ExitStack, rack: Any, endpoint: str, events: str,
                 sets: int) -> None:
        from vdevclient import galil, maxk, pcomm

        self.galil, self.pcomm, self.sets = galil, pcomm, sets
        self.bars = [rack.card(f"servo{k}").region("bar0") for k in range(sets)]
        self.dmc = []
        for k in range(sets):
            h = ctypes.c_long()
            if galil.DMCOpen(k + 1, 0, ctypes.byref(h), endpoint=endpoint, events=events):
                raise RuntimeError(f"DMCOpen({k + 1}) failed")
            stack.callback(galil.DMCClose, h)
            self.dmc.append(h)
        self.maxk = [stack.enter_context(maxk.open(k + 1, endpoint=endpoint)) for k in range(sets)]
        for k in range(sets):
            if not pcomm.OpenPmacDevice(k, endpoint=endpoint):
                raise RuntimeError(f"OpenPmacDevice({k}) failed")
            stack.callback(pcomm.ClosePmacDevice, k)
        self._buf = ctypes.create_string_buffer(4096)
        self.dprs = [rack.card(f"octavia{k}").region("dpr") for k in range(sets)]

    def dmc_command(self, k: int, text: str) -> str:
        if self.galil.DMCCommand(self.dmc[k], text, self._buf, 4096):
            raise RuntimeError(f"DMCCommand({text!r}): {self._buf.value!r}")
        return self._buf.value.decode()

    def pmac(self, k: int, text: str) -> str:
        self.pcomm.PmacGetResponseA(k, self._buf, 4096, text)
        return self._buf.value.decode()

    def jog(self) -> None:
        for k in range(self.sets):
            jog_axes(self.bars[k].write32, 4)
            self.dmc_command(k, "JG 20000,-25000,30000,-35000")
            self.dmc_command(k, "BG ABCD")
            self.maxk[k].send_string("AA JG20000,-25000,30000,-35000,20000,-25000,30000,-35000;")
            self.pmac(k, "".join(f"#{m}J{'+' if m % 2 else '-'}" for m in range(1, 9)))
            gains = {"ki": 100, "kp": 4000, "kf": 3000, "kd": 2500}
            self.octavia(k, "CTRL", {"n": 0xFF}, [gains] * 8)
            self.octavia(k, "MAXACC", {"n": 0xFF}, [{"acc": 0x150}] * 8)
            self.octavia(k, "VELMODE", {"n": 0xFF},
                         [{"vel": (1 if a % 2 else -1) * (0x40000 + 0x8000 * a)} for a in range(8)])

    def octavia(self, k: int, name: str, head: dict[str, int],
                groups: list[dict[str, int]] | None = None) -> None:
        """One RTC through the DPR [Ch6 Real-Time Commands], acknowledged."""
        dpr, rtc = self.dprs[k], BY_NAME[name]
        dpr.write(Dpr.ARGMNTS, pack(rtc, head, groups or []))
        dpr.write8(Dpr.RTC, rtc.code)
        if dpr.wait_value(Dpr.RTC, 0, size=1, timeout_s=1.0) is None:
            raise RuntimeError(f"octavia{k}: {name} not taken")

    def positions(self) -> list[float]:
        out: list[float] = []
        for k in range(self.sets):
            out += [self.bars[k].read32(AXIS_BASE + AXIS_STRIDE * a + POSITION) for a in range(4)]
            out += [float(v) for v in self.dmc_command(k, "TP").rstrip("\r\n:").split(",")]
            out += [float(v) for v in self.maxk[k].send_and_get_string("AA RP").split(",")]
            out += [float(v) for v in self.pmac(k, "".join(f"#{m}P" for m in range(1, 9))).split()]
            out += [float(self.dprs[k].read32(axis_offset(Dpr.ACTPOS, a))) for a in range(1, 9)]
        return out


def core_tick_us(ticks: int = 20_000) -> float:
    """The baseline: one motion-core tick (8 servo axes jogging), median of 5 runs."""
    from vdevd.rt import MotionCore, PlantKind

    core = MotionCore(8, 442_708.37, PlantKind.SERVO)
    core.servo_on(slice(None))
    core.jog(slice(None), 20_000, 500_000, 500_000)
    tick = core.tick
    runs = []
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(ticks):
            tick()
        runs.append((time.perf_counter() - t0) / ticks * 1e6)
    return statistics.median(runs)


def timed_step(rack: Any, seconds: float) -> float:
    t0 = time.perf_counter()
    rack.sim.step(seconds=seconds)
    return seconds / (time.perf_counter() - t0)


def quiet(rack: Any) -> int:
    return sum(c["quiet_ticks"] for c in rack.stats()["cards"].values())


def measure(sets: int, seconds: float, repeats: int, pin: str) -> dict[str, Any]:
    """Idle and moving speeds of `sets` sets of the default rack's cards."""
    server_cpus, client_cpus, where = placement(pin)
    with contextlib.ExitStack() as stack:
        d = stack.enter_context(daemon(rack_config(sets), "lockstep", server_cpus))
        pin_self(client_cpus)
        rack = connect(d, timeout=600)
        stack.callback(rack.close)
        hosts = Hosts(stack, rack, d.endpoint, d.events, sets)
        idle, skipped = [], []
        rack.sim.step(seconds=0.2)
        for _ in range(repeats):
            q0 = quiet(rack)
            idle.append(timed_step(rack, seconds))
            skipped.append(quiet(rack) - q0)
        hosts.jog()
        rack.sim.step(seconds=0.5)  # the axes reach their jog speeds
        moving, valid = [], True
        for _ in range(repeats):
            q0, p0 = quiet(rack), hosts.positions()
            moving.append(timed_step(rack, seconds))
            p1 = hosts.positions()
            valid &= quiet(rack) == q0 and all(a != b for a, b in zip(p0, p1, strict=True))
        cards = len(rack.cards())
    return {"sets": sets, "cards": cards, "axes": AXES_PER_SET * sets, "placement": where,
            "idle": statistics.median(idle), "idle_runs": idle,
            "idle_quiet_ticks": skipped, "moving": statistics.median(moving),
            "moving_runs": moving, "moving_valid": valid}


def run(seconds: float = 2.0, repeats: int = 3, sets: tuple[int, ...] = (1, 2, 4),
        pin: str = "split") -> dict[str, Any]:
    from vdevd.rt import kernel

    base = core_tick_us()
    core = "compiled" if kernel.compiled() is not None else "numpy"
    rows = [measure(k, seconds, repeats, pin) for k in sets]
    one = next(r for r in rows if r["sets"] == 1)
    four = next((r for r in rows if r["sets"] == 4), None)
    checks = {
        "idle": one["idle"] >= GOAL_IDLE,
        "moving": one["moving"] >= GOAL_MOVING and one["moving_valid"],
        "moving_16": four is not None and four["moving"] >= GOAL_MOVING_16 and four["moving_valid"],
    }
    for r in rows:  # wall time per simulated second, in core ticks of the baseline
        r["moving_core_ticks"] = 1e6 / r["moving"] / base
        r["idle_core_ticks"] = 1e6 / r["idle"] / base
    plot = _plot(rows)
    return {"figure": "rack", "seconds": seconds, "repeats": repeats, "core_tick_us": base,
            "motion_core": core,
            "rows": rows, "checks": checks, "pass": all(checks.values()),
            "plot": str(plot) if plot else None}


def _plot(rows: list[dict[str, Any]]) -> Path | None:
    """Speed against axes, idle and moving, as bench/results/rack-<time>.png (None without
    matplotlib)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    axes = [r["axes"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(axes, [r["idle"] for r in rows], "o-", label="idle")
    ax.plot(axes, [r["moving"] for r in rows], "s-", label="all axes moving")
    ax.axhline(GOAL_MOVING, ls=":", c="gray")
    ax.axhline(GOAL_MOVING_16, ls=":", c="gray")
    ax.set_xlabel("axes (cards = axes / 6)")
    ax.set_ylabel("simulated s per wall s")
    ax.set_yscale("log")
    ax.set_title("vdevd lockstep speed: sets of the default rack")
    ax.legend()
    RESULTS_DIR.mkdir(exist_ok=True)
    out = RESULTS_DIR / f"rack-{time.strftime('%Y%m%d-%H%M%S')}.png"
    fig.savefig(out, dpi=100, bbox_inches="tight")
    plt.close(fig)
    return out


def report(r: dict[str, Any]) -> None:
    table(["cards", "axes", "idle x", "moving x", "moving: core ticks per sim s",
           "moving runs", "valid"],
          [[x["cards"], x["axes"], x["idle"], x["moving"], x["moving_core_ticks"],
            ", ".join(f"{v:.1f}" for v in x["moving_runs"]), x["moving_valid"]]
           for x in r["rows"]],
          title=f"rack lockstep speed ({r['rows'][0]['placement']}; {r['seconds']} s steps, "
                f"median of {r['repeats']}; baseline core tick {r['core_tick_us']:.2f} us, "
                f"{r['motion_core']} motion core)")
    print(f"idle quiet ticks per run: {[x['idle_quiet_ticks'] for x in r['rows']]}")
    if r["plot"]:
        print(f"plot: {r['plot']}")
    c = r["checks"]
    print(f"idle >= {GOAL_IDLE:.0f}x: {verdict(c['idle'])}; moving >= {GOAL_MOVING:.0f}x: "
          f"{verdict(c['moving'])}; four sets moving >= {GOAL_MOVING_16:.0f}x: "
          f"{verdict(c['moving_16'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sets", default="1,2,4")
    ap.add_argument("--pin", choices=("split", "same", "none"), default="split")
    ap.add_argument("--json", nargs="?", const="")
    a = ap.parse_args()
    install_signal_handlers()
    r = run(a.seconds, a.repeats, tuple(int(x) for x in a.sets.split(",")), a.pin)
    report(r)
    if a.json is not None:
        print(f"wrote {write_json(r, a.json, 'rack')}")


if __name__ == "__main__":
    main()
