"""Issue 22 defect 10: a subscriber notices a dead daemon (PROTOCOL.md "Heartbeat"). The daemon
publishes a heartbeat on the events socket every `[server] heartbeat_s`; a subscriber that hears
nothing for three periods says so and stops: the client library raises `DaemonGone`, `vdevctl
irq` says it on stderr and exits 1. The daemon here is a process of its own, killed with
SIGKILL (nothing of it says goodbye), its heartbeat made short so the test is quick; the
issue's bound, 10 s, is three periods of the longest heartbeat a configuration allows (3 s)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
import vdevclient
import zmq

from vdevd.config import HEARTBEAT_RANGE_S
from vdevd.heartbeat import TOPIC
from vdevd.rack import Rack
from vdevd.server import Publisher
from vdevd.testing import DaemonThread

HEARTBEAT_S = 0.1
#: a guard only: without the heartbeat the subscriber would wait this long, then fail the test
GUARD_S = 30.0


def start_daemon(tmp_path: Path) -> tuple[subprocess.Popen[bytes], dict[str, Any]]:
    """`vdevd serve` of one lockstep servo card with a 100 ms heartbeat, once it is ready."""
    config = tmp_path / "rack.toml"
    config.write_text(f'[server]\nheartbeat_s = {HEARTBEAT_S}\nshm_dir = ""\n'  # killed: no cleanup
                      '[clock]\nmode = "lockstep"\n[[card]]\ntype = "generic-servo"\nname = "servo0"\n')
    ready = tmp_path / "ready.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "vdevd", "serve", "--config", str(config), "--endpoint",
         "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*", "--ready-file", str(ready)],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while not ready.exists():
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            raise AssertionError("vdevd did not start")
        time.sleep(0.01)
    return proc, json.loads(ready.read_text())


@pytest.fixture
def daemon_process(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[bytes], dict[str, Any]]]:
    proc, info = start_daemon(tmp_path)
    try:
        yield proc, info
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()


def test_the_events_socket_carries_a_heartbeat_on_its_own_topic() -> None:
    period_ns = 50_000_000
    with DaemonThread(rack=Rack([], "lockstep", sink=Publisher(heartbeat_ns=period_ns))) as d:
        sub = zmq.Context.instance().socket(zmq.SUB)
        sub.linger = 0
        sub.rcvtimeo = 10_000
        sub.connect(d.events)
        sub.setsockopt(zmq.SUBSCRIBE, TOPIC.encode())
        beats = [sub.recv_multipart() for _ in range(2)]
        sub.close()
    for topic, body in beats:
        assert topic == TOPIC.encode()
        beat = msgpack.unpackb(body)
        assert beat["kind"] == "heartbeat" and beat["period_ns"] == period_ns
    assert msgpack.unpackb(beats[1][1])["seq"] == msgpack.unpackb(beats[0][1])["seq"] + 1


def test_the_longest_heartbeat_lets_a_subscriber_notice_within_10_s() -> None:
    from vdevclient._liveness import MISSED_BEATS

    assert MISSED_BEATS * HEARTBEAT_RANGE_S[1] <= 10.0


def test_a_subscription_raises_daemon_gone_when_the_daemon_is_killed(
        daemon_process: tuple[subprocess.Popen[bytes], dict[str, Any]]) -> None:
    proc, info = daemon_process
    with vdevclient.connect(info["endpoint"], info["events"], timeout=5) as rack:
        assert rack.heartbeat_ns == int(HEARTBEAT_S * 1e9)
        irq = rack.card("servo0").irq.subscribe()
        assert list(irq.events(timeout_s=3 * HEARTBEAT_S)) == []  # heartbeats are not events
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        killed = time.monotonic()
        with pytest.raises(vdevclient.DaemonGone, match="no heartbeat from the daemon on "):
            for _ in irq.events(timeout_s=GUARD_S):
                pass
        assert time.monotonic() - killed < GUARD_S


def test_vdevctl_irq_says_the_daemon_is_gone_and_exits_1(
        daemon_process: tuple[subprocess.Popen[bytes], dict[str, Any]]) -> None:
    proc, info = daemon_process
    with subprocess.Popen(
        [sys.executable, "-m", "vdevclient.cli", "--endpoint", info["endpoint"], "irq",
         "servo0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    ) as watcher:
        try:
            assert watcher.stderr is not None
            assert watcher.stderr.readline().startswith("vdevctl: watching servo0 on ")
            proc.send_signal(signal.SIGKILL)
            _, err = watcher.communicate(timeout=GUARD_S)
        finally:
            if watcher.poll() is None:
                watcher.kill()
    assert watcher.returncode == 1
    assert err.startswith("vdevctl: no heartbeat from the daemon on ")
    assert "Traceback" not in err
