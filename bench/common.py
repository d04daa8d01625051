"""Shared benchmark plumbing: free ports, pinned daemon subprocesses, percentiles."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

PLACEMENTS = {"split": ({0}, {1}), "same": ({0}, {0}), "none": (None, None)}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def pin(cpus: set[int] | None) -> None:
    """Pin this process (and the threads it starts later) to `cpus`."""
    if cpus is not None and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, cpus)


def cpus_available() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1


def placement(name: str) -> tuple[set[int] | None, set[int] | None]:
    """(server cpus, client cpus); `split` falls back to `none` on a 1-cpu machine."""
    server, client = PLACEMENTS[name]
    if cpus_available() < 2 and name != "none":
        return None, None
    return server, client


def summary(samples_us: Sequence[float]) -> dict[str, float]:
    a = np.asarray(samples_us, dtype=float)
    p50, p90, p99, p999 = np.percentile(a, [50, 90, 99, 99.9])
    return {"n": len(a), "p50": p50, "p90": p90, "p99": p99, "p999": p999, "max": float(a.max())}


def fmt(s: dict[str, float], unit: str = "us") -> str:
    return (f"p50 {s['p50']:8.1f}  p90 {s['p90']:8.1f}  p99 {s['p99']:8.1f}  "
            f"p99.9 {s['p999']:8.1f}  max {s['max']:9.1f} {unit}  (n={int(s['n'])})")


@contextlib.contextmanager
def process(argv: Sequence[str], cpus: set[int] | None) -> Iterator[subprocess.Popen[bytes]]:
    """A subprocess pinned to `cpus`, stopped (TERM, then KILL) on exit."""
    proc = subprocess.Popen(list(argv), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            preexec_fn=(lambda: pin(cpus)) if cpus is not None else None)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        if proc.stderr is not None:
            proc.stderr.close()


@contextlib.contextmanager
def daemon(config: str, cpus: set[int] | None) -> Iterator[tuple[str, str]]:
    """`vdevd serve` with `config` (TOML, without [server]) on free loopback ports."""
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    events = f"tcp://127.0.0.1:{free_port()}"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rack.toml"
        path.write_text(f'[server]\nendpoint = "{endpoint}"\nevents = "{events}"\n{config}')
        argv = [sys.executable, "-m", "vdevd", "serve", "--config", str(path), "--log-level",
                "WARNING"]
        with process(argv, cpus):
            yield endpoint, events


def servo_card(axes: int = 4, plant: str = "servo", period_ns: int = 1_000_000) -> str:
    return (f'[[card]]\ntype = "generic-servo"\nname = "servo0"\naxes = {axes}\n'
            f'plant = "{plant}"\nperiod_ns = {period_ns}\n')


def connect(endpoint: str, timeout: float = 5.0, within: float = 20.0) -> Any:
    """A vdevclient connection, once the daemon just started answers."""
    import vdevclient

    deadline = time.monotonic() + within
    while True:
        try:
            return vdevclient.connect(endpoint, timeout=timeout)
        except vdevclient.VdevClientError:
            if time.monotonic() > deadline:
                raise


def wait_for(fn: object, timeout: float = 20.0) -> None:
    """Call `fn` until it stops raising (the daemon is up)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            fn()  # type: ignore[operator]
            return
        except Exception:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)
