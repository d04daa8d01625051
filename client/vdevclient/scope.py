"""The scope from a client (issue 23 §1; proto/PROTOCOL.md "Scope"): arm a card's recorder,
step the lockstep clock, read the trace as numpy arrays with the simulated time base, and write
it as CSV (nothing beyond numpy) or as a PNG (matplotlib: `pip install vdevd[plot]`).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from vdevclient.core import Card

#: the signals, in the order the daemon knows them (PROTOCOL.md "Scope")
SIGNALS = ("position", "command", "velocity", "command_velocity", "error", "output", "status",
           "inputs", "outputs")
#: what each signal is in, for plot labels
UNITS = {"position": "counts", "command": "counts", "velocity": "counts/s",
         "command_velocity": "counts/s", "error": "counts", "output": "card units",
         "status": "bits", "inputs": "bits", "outputs": "bits"}


@dataclass
class Trace:
    """A recording: `time_ns` (simulated, int64) and one array per column `AXIS.signal`."""

    time_ns: np.ndarray
    columns: dict[str, np.ndarray]
    state: str = "done"
    #: the sample at which the trigger fired (index into the arrays), None when not fired
    trigger_index: int | None = None
    status: dict[str, Any] = field(default_factory=dict)

    @property
    def time(self) -> np.ndarray:
        """Simulated time, seconds (float64)."""
        return self.time_ns / 1e9

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.time_ns)

    def signals(self) -> list[str]:
        """The signals recorded, in SIGNALS order."""
        found = {name.split(".", 1)[1] for name in self.columns}
        return [s for s in SIGNALS if s in found]

    def axes(self) -> list[str]:
        """The axes recorded, in the card's order."""
        return list(dict.fromkeys(name.split(".", 1)[0] for name in self.columns))

    def to_csv(self, path: str | Path) -> None:
        """A `time_s` column (simulated seconds), then one column per axis and signal."""
        names = list(self.columns)
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["time_s", *names])
            cols = [self.columns[n] for n in names]
            for i, t in enumerate(self.time_ns.tolist()):
                w.writerow([f"{t / 1e9:.9f}", *(_cell(c[i]) for c in cols)])

    def to_png(self, path: str | Path, title: str = "") -> None:
        """One panel per signal against simulated time, a line per axis (matplotlib)."""
        try:
            import matplotlib
        except ImportError:
            raise ImportError("writing a PNG needs matplotlib: pip install 'vdevd[plot]'") from None
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        signals = self.signals()
        fig, panels = plt.subplots(len(signals), 1, sharex=True, squeeze=False,
                                   figsize=(8, 2.2 * len(signals) + 0.6))
        t = self.time
        for ax, s in zip(panels[:, 0], signals, strict=True):
            for axis in self.axes():
                name = f"{axis}.{s}"
                if name in self.columns:
                    ax.plot(t, self.columns[name], label=f"axis {axis}",
                            drawstyle="steps-post" if self.columns[name].dtype.kind == "i"
                            else "default")
            ax.set_ylabel(f"{s}\n({UNITS[s]})")
            ax.grid(True, alpha=0.3)
            if (self.trigger_index is not None and 0 < self.trigger_index < len(t)
                    and self.status.get("trigger", {}).get("kind") != "now"):
                ax.axvline(t[self.trigger_index], color="grey", linestyle=":")
        panels[0, 0].legend(loc="best", fontsize="small")
        panels[-1, 0].set_xlabel("simulated time (s)")
        if title:
            fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(path, dpi=100)
        plt.close(fig)


def _cell(v: Any) -> str:
    return str(int(v)) if isinstance(v, np.integer) else repr(float(v))


def parse_trigger(text: str) -> dict[str, Any]:
    """`now`, `irq[:LINE]`, `position:AXIS:LEVEL[:rising|falling|either]` or
    `register:REGION:OFFSET[:WIDTH[:MASK[:VALUE]]]` (integers decimal or 0x hex) as the
    request's `trigger` map; ValueError naming what is wrong."""
    kind, _, rest = text.partition(":")
    parts = rest.split(":") if rest else []
    if kind == "now" and not parts:
        return {"kind": "now"}
    if kind == "irq" and len(parts) <= 1:
        return {"kind": "irq", **({"line": parts[0]} if parts else {})}
    if kind == "position" and len(parts) in (2, 3):
        level = float(parts[1])
        if not math.isfinite(level):
            raise ValueError(f"trigger {text!r}: level {parts[1]!r} is not finite")
        spec: dict[str, Any] = {"kind": "position", "axis": parts[0], "level": level}
        if len(parts) == 3:
            spec["direction"] = parts[2]
        return spec
    if kind == "register" and 2 <= len(parts) <= 5:
        spec = {"kind": "register", "region": parts[0]}
        for key, value in zip(("offset", "width", "mask", "value"), parts[1:], strict=False):
            spec[key] = int(value, 0)
        return spec
    raise ValueError(f"trigger {text!r} is not now, irq[:LINE], position:AXIS:LEVEL[:DIRECTION] "
                     "or register:REGION:OFFSET[:WIDTH[:MASK[:VALUE]]]")


class Scope:
    """A card's recorder: `arm`, `status`, `read`, `clear` (the `scope` request's actions)."""

    def __init__(self, card: Card) -> None:
        self.card = card

    def _request(self, action: str, **fields: Any) -> Any:
        fields = {k: v for k, v in fields.items() if v is not None}
        return self.card.rack.request("scope", card=self.card.name, action=action, **fields)

    def arm(self, axes: Sequence[str | int] | None = None, signals: Sequence[str] | None = None,
            *, seconds: float | None = None, samples: int | None = None, every: int = 1,
            trigger: dict[str, Any] | str | None = None, pre: int = 0) -> dict[str, Any]:
        """Arm the recorder (replacing any); its status."""
        if isinstance(trigger, str):
            trigger = parse_trigger(trigger)
        return self._request(
            "arm", axes=[str(a) for a in axes] if axes is not None else None,
            signals=list(signals) if signals is not None else None,
            seconds=float(seconds) if seconds is not None else None, samples=samples,
            every=every, trigger=trigger, pre=pre)

    def status(self) -> dict[str, Any]:
        return self._request("status")

    def clear(self) -> None:
        self._request("clear")

    def read(self) -> Trace:
        """Every sample kept so far, read in replies within the maximum message."""
        times: list[np.ndarray] = []
        parts: dict[str, list[np.ndarray]] = {}
        start, reply = 0, None
        while True:
            reply = self._request("read", start=start)
            times.append(np.frombuffer(reply["time_ns"], dtype="<i8"))
            for name, data in reply["columns"].items():
                parts.setdefault(name, []).append(
                    np.frombuffer(data, dtype="<" + reply["types"][name]))
            start += reply["count"]
            if reply["count"] == 0 or start >= reply["available"]:
                break
        status = self.status()
        columns = {name: np.concatenate(p) for name, p in parts.items()}
        return Trace(np.concatenate(times), columns, status["state"],
                     status.get("trigger_index"), status)


def record(card: Card, axes: Sequence[str | int] | None = None,
           signals: Sequence[str] | None = None, *, seconds: float, every: int = 1,
           trigger: dict[str, Any] | str | None = None, pre: int = 0,
           step: bool = True, wait_s: float | None = None,
           trigger_s: float = 10.0) -> Trace:
    """Arm `seconds` of samples, step the lockstep clock `seconds`, read the trace; with a
    trigger, step on `seconds` at a time while the recording is not done, `trigger_s` simulated
    seconds at most. With `step` false or a realtime clock, wait (at most `wait_s` wall
    seconds, default 2 x seconds + 1) for the recording to be done instead. Then read what
    there is (`Trace.state` says whether it is done)."""
    import time

    scope = Scope(card)
    scope.arm(axes, signals, seconds=seconds, every=every, trigger=trigger, pre=pre)
    if step and card.rack.sim.mode == "lockstep":
        card.rack.sim.step(seconds=seconds)
        waited = 0.0
        while waited < trigger_s and scope.status()["state"] != "done":
            card.rack.sim.step(seconds=min(seconds, trigger_s - waited))
            waited += seconds
    else:  # time runs by itself, or someone else steps it: wait (wall time) until done
        deadline = time.monotonic() + (wait_s if wait_s is not None else 2 * seconds + 1)
        while scope.status()["state"] != "done" and time.monotonic() < deadline:
            time.sleep(0.02)
    return scope.read()
