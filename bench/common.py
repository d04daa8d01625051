"""Shared plumbing of the benchmarks: placement, child processes, the daemon, percentiles, output.

Conventions (as in ../shared/bench/benchlib.py, which measured this machine's floors):
* time is `time.perf_counter_ns()` = CLOCK_MONOTONIC, comparable across processes;
* latencies are percentiles of raw samples, in microseconds;
* every child process is pinned as asked, stopped by its own PID (TERM, then KILL after a
  timeout) and its temporary files removed; endpoints are free ports on 127.0.0.1 only.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

BENCH_DIR = Path(__file__).resolve().parent
RESULTS_DIR = BENCH_DIR / "results"
ALL_CPUS: frozenset[int] = frozenset(os.sched_getaffinity(0))
PLACEMENTS = ("split", "same", "none")

_children: list[subprocess.Popen[bytes]] = []


# -- placement --------------------------------------------------------------------------------------
def placement(name: str) -> tuple[set[int] | None, set[int] | None, str]:
    """(server cpus, client cpus, description); None = not pinned (every cpu).

    split: server cpu0, client cpu1 (the default); same: both on cpu0; none: the kernel's choice.
    On a machine with one cpu, `split` becomes `same`.
    """
    cpus = sorted(ALL_CPUS)
    if name == "none":
        return None, None, "none (unpinned, kernel's choice)"
    if name == "same" or len(cpus) < 2:
        return {cpus[0]}, {cpus[0]}, f"same (server and client on cpu{cpus[0]})"
    if name == "split":
        return {cpus[0]}, {cpus[1]}, f"split (server cpu{cpus[0]}, client cpu{cpus[1]})"
    raise ValueError(f"placement {name!r} not in {PLACEMENTS}")


def pin_self(cpus: set[int] | None) -> None:
    """Pin every thread of this process (libzmq's I/O threads too) to `cpus`; None = all cpus.

    sched_setaffinity(0) moves only the calling thread, so the threads already started (a zmq
    context's) are moved one by one through /proc/self/task.
    """
    target = set(cpus) if cpus is not None else set(ALL_CPUS)
    for tid in os.listdir("/proc/self/task"):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.sched_setaffinity(int(tid), target)
    os.sched_setaffinity(0, target)


def pinned_argv(argv: Sequence[str], cpus: set[int] | None) -> list[str]:
    """`argv` run under an affinity of `cpus` (all cpus for None): a tiny exec wrapper, so no
    preexec_fn in a process that has threads and no dependency on taskset."""
    target = sorted(cpus if cpus is not None else ALL_CPUS)
    code = f"import os,sys; os.sched_setaffinity(0, {target!r}); os.execv(sys.argv[1], sys.argv[1:])"
    return [sys.executable, "-c", code, *argv]


# -- child processes --------------------------------------------------------------------------------
@dataclass
class Child:
    """A started child process and the file its stderr goes to."""

    proc: subprocess.Popen[bytes]
    log: Path

    def tail(self, lines: int = 20) -> str:
        try:
            return "\n".join(self.log.read_text(errors="replace").splitlines()[-lines:])
        except OSError:
            return ""

    def check_alive(self, what: str) -> None:
        if self.proc.poll() is not None:
            raise RuntimeError(f"{what} exited with status {self.proc.returncode}:\n{self.tail()}")

    def cpu_seconds(self) -> float:
        """User + system CPU time of the child so far (its threads included)."""
        try:
            fields = Path(f"/proc/{self.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            return float("nan")
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def stop(proc: subprocess.Popen[bytes], timeout: float = 5.0) -> None:
    """Stop one child by its PID: SIGTERM, wait, SIGKILL after `timeout`."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                proc.kill()
            proc.wait()
    if proc in _children:
        _children.remove(proc)


@contextlib.contextmanager
def child(argv: Sequence[str], cpus: set[int] | None, log: Path) -> Iterator[Child]:
    """A pinned child process with stderr (and stdout) to `log`, always stopped on exit."""
    with open(log, "wb") as out:
        proc = subprocess.Popen(pinned_argv(argv, cpus), stdin=subprocess.DEVNULL, stdout=out,
                                stderr=subprocess.STDOUT)
    _children.append(proc)
    try:
        yield Child(proc, log)
    finally:
        stop(proc)


def _on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)  # unwinds the context managers, which stop the children


def install_signal_handlers() -> None:
    """SIGTERM (e.g. from a CI timeout) unwinds like Ctrl-C, so that no child is left behind."""
    signal.signal(signal.SIGTERM, _on_sigterm)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# -- the daemon -------------------------------------------------------------------------------------
@dataclass
class Daemon:
    endpoint: str
    events: str
    child: Child
    config: str


def servo_card(name: str = "servo0", axes: int = 4, plant: str = "servo",
               period_ns: int = 1_000_000) -> str:
    """A [[card]] table of one generic-servo card (the default rack's card, made explicit)."""
    return (f'[[card]]\ntype = "generic-servo"\nname = "{name}"\naxes = {axes}\n'
            f'plant = "{plant}"\nperiod_ns = {period_ns}\n')


@contextlib.contextmanager
def daemon(config: str, clock: str, cpus: set[int] | None) -> Iterator[Daemon]:
    """`vdevd serve --config FILE --clock CLOCK --endpoint ... --events ...` on free loopback
    ports, pinned to `cpus`; the config file and the log live in a temporary directory."""
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    events = f"tcp://127.0.0.1:{free_port()}"
    with tempfile.TemporaryDirectory(prefix="vdevd-bench-") as tmp:
        path = Path(tmp) / "rack.toml"
        path.write_text(config)
        argv = [sys.executable, "-m", "vdevd", "serve", "--config", str(path), "--clock", clock,
                "--endpoint", endpoint, "--events", events, "--log-level", "WARNING"]
        with child(argv, cpus, Path(tmp) / "vdevd.log") as c:
            yield Daemon(endpoint, events, c, config)


def connect(d: Daemon, within: float = 30.0, timeout: float = 10.0,
            shm: bool | None = None) -> Any:
    """A vdevclient.Rack on the daemon once it answers `hello` (it was just started); `shm`:
    as `vdevclient.connect`'s (False: every access is a request)."""
    import vdevclient

    deadline = time.monotonic() + within
    while True:
        d.child.check_alive("vdevd")
        try:
            rack = vdevclient.connect(d.endpoint, d.events, timeout=1.0, shm=shm)
        except vdevclient.VdevClientError:
            if time.monotonic() > deadline:
                raise RuntimeError(f"vdevd did not answer within {within:.0f} s:\n"
                                   f"{d.child.tail()}") from None
            continue
        rack.timeout = timeout
        return rack


# -- the generic-servo card's registers (vdevd/devices/generic/regions.py) ---------------------------
AXIS_BASE, AXIS_STRIDE = 0x100, 0x40
COMMAND, TARGET, VMAX, ACC, DEC = 0x00, 0x04, 0x08, 0x0C, 0x10
STATUS, POSITION, VELOCITY, ERROR = 0x18, 0x1C, 0x28, 0x30
JOG, STOP = 3, 4


def axis_reg(axis: int, reg: int) -> int:
    return AXIS_BASE + AXIS_STRIDE * axis + reg


def jog_velocity(axis: int) -> int:
    """A distinct signed jog velocity per axis (counts/s), so that no two axes are alike."""
    return (20_000 + 5_000 * axis) * (1 if axis % 2 == 0 else -1)


def jog_axes(write32: Any, axes: int) -> None:
    """Every axis jogs (COMMAND = JOG, TARGET = signed velocity) until told to stop."""
    for axis in range(axes):
        write32(axis_reg(axis, TARGET), jog_velocity(axis))
        write32(axis_reg(axis, VMAX), 200_000)
        write32(axis_reg(axis, ACC), 500_000)
        write32(axis_reg(axis, DEC), 500_000)
        write32(axis_reg(axis, COMMAND), JOG)


def stop_axes(write32: Any, axes: int) -> None:
    for axis in range(axes):
        write32(axis_reg(axis, COMMAND), STOP)


def signed32(value: int) -> int:
    return value - (1 << 32) if value & 0x8000_0000 else value


# -- statistics and output --------------------------------------------------------------------------
def dist(samples: Sequence[float] | np.ndarray) -> dict[str, float]:
    """n, p50, p90, p99, p99.9, min, max, mean of raw samples (in their own unit)."""
    a = np.asarray(samples, dtype=np.float64)
    if a.size == 0:
        return {"n": 0}
    p50, p90, p99, p999 = np.percentile(a, [50, 90, 99, 99.9])
    return {"n": int(a.size), "p50": float(p50), "p90": float(p90), "p99": float(p99),
            "p999": float(p999), "min": float(a.min()), "max": float(a.max()),
            "mean": float(a.mean())}


def ns_dist_to_us(d: dict[str, int]) -> dict[str, float]:
    """A daemon `stats` distribution ({count, p50.. max} in ns) in us."""
    return {k: (v if k == "count" else v / 1000) for k, v in d.items()}


def fnum(v: Any) -> str:
    """~3 significant digits; ints verbatim; None as '-'."""
    if v is None:
        return "-"
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    av = abs(float(v))
    if av != av:
        return "nan"
    if av >= 1000:
        return f"{v:.0f}"
    if av >= 100:
        return f"{v:.1f}"
    if av >= 10:
        return f"{v:.2f}"
    return f"{v:.3f}"


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], title: str | None = None) -> None:
    cells = [[fnum(c) for c in r] for r in rows]
    widths = [max([len(h), *(len(r[i]) for r in cells)]) for i, h in enumerate(headers)]
    if title:
        print(f"\n## {title}")
    print("| " + " | ".join(h.rjust(w) for h, w in zip(headers, widths, strict=True)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in cells:
        print("| " + " | ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) + " |")
    sys.stdout.flush()


def dist_row(name: str, d: dict[str, float]) -> list[Any]:
    return [name, d.get("p50"), d.get("p90"), d.get("p99"), d.get("p999"), d.get("max"), d.get("n")]


DIST_HEADERS = ["series", "p50", "p90", "p99", "p99.9", "max", "n"]


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def machine_facts() -> dict[str, Any]:
    import msgpack
    import zmq

    facts: dict[str, Any] = {
        "nproc": os.cpu_count(), "affinity": sorted(ALL_CPUS),
        "python": platform.python_version(), "kernel": platform.release(),
        "pyzmq": zmq.__version__, "libzmq": zmq.zmq_version(), "numpy": np.__version__,
        "msgpack": ".".join(map(str, msgpack.version)),
    }
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                facts["cpu"] = line.split(":", 1)[1].strip()
                break
    with contextlib.suppress(OSError):
        facts["loadavg"] = Path("/proc/loadavg").read_text().split()[:3]
    return facts


def write_json(result: dict[str, Any], path: str | None, name: str) -> Path:
    """Write `result` to `path`, or to bench/results/NAME-YYYYmmdd-HHMMSS.json when it is empty."""
    if path:
        out = Path(path)
    else:
        RESULTS_DIR.mkdir(exist_ok=True)
        out = RESULTS_DIR / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"machine": machine_facts(), **result}, indent=1, default=float))
    return out
