"""`vdevd serve --ready-file`: written atomically once every listener is bound, the cards' own
ports first, then PUB, then the endpoint last (DESIGN.md "Operations"); at the moment the file
appears, each endpoint it lists accepts a connection."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import msgpack
import zmq

from vdevd.daemon import write_ready_file

RACK = """
[clock]
mode = "lockstep"

[[card]]
type = "generic-servo"
name = "servo0"

[[card]]
type = "pmac-turbo"
name = "pmac0"
ethernet = "tcp://127.0.0.1:0"
"""


def tcp_address(endpoint: str) -> tuple[str, int]:
    host, port = endpoint.removeprefix("tcp://").rsplit(":", 1)
    return host, int(port)


def test_the_ready_file_lists_every_listener_and_each_accepts_at_once(tmp_path: Path) -> None:
    (tmp_path / "rack.toml").write_text(RACK)
    ready = tmp_path / "run" / "ready.json"
    ready.parent.mkdir()
    log = (tmp_path / "vdevd.log").open("w")
    proc = subprocess.Popen(
        [sys.executable, "-m", "vdevd", "serve", "--config", str(tmp_path / "rack.toml"),
         "--endpoint", "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*",
         "--ready-file", str(ready)], stderr=log)
    try:
        deadline = time.monotonic() + 60  # a guard against a hung daemon, not a measured wait
        while not ready.exists():
            try:  # polls the file while watching for an early exit
                code = proc.wait(timeout=0.01)
            except subprocess.TimeoutExpired:
                assert time.monotonic() < deadline, "no ready file"
                continue
            raise AssertionError(f"vdevd exited {code}: {(tmp_path / 'vdevd.log').read_text()}")
        info = json.loads(ready.read_text())
        ethernet = info["cards"]["pmac0"]["ethernet"]
        with socket.create_connection(tcp_address(ethernet), timeout=5):
            pass
        with socket.create_connection(tcp_address(info["events"]), timeout=5):
            pass
        ctx = zmq.Context()
        try:
            req = ctx.socket(zmq.REQ)
            req.linger = 0
            req.connect(info["endpoint"])
            req.send(msgpack.packb({"id": 1, "op": "hello"}))
            assert req.poll(10_000), "no reply from the endpoint"
            hello = msgpack.unpackb(req.recv())["ok"]
            req.close()
        finally:
            ctx.term()
        assert set(info) == {"endpoint", "events", "cards"}
        assert info["cards"] == {"servo0": {}, "pmac0": {"ethernet": ethernet}}
        assert tcp_address(ethernet)[1] != 0 and "*" not in info["endpoint"] + info["events"]
        assert hello["events"] == info["events"]
        pmac = next(c for c in hello["cards"] if c["name"] == "pmac0")
        assert pmac["ethernet"] == ethernet
        assert sorted(os.listdir(ready.parent)) == ["ready.json"]  # no temporary file left
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 0
        log.close()
    assert not ready.exists(), "the ready file outlived the listeners it lists"


def serve_until_exit(tmp_path: Path, rack: str, ready: Path) -> tuple[int, str, list[bytes]]:
    """Run `vdevd serve` under a NOTIFY_SOCKET of the test's until it exits: its status, its
    stderr and the systemd notifications it sent."""
    (tmp_path / "rack.toml").write_text(rack)
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as notify:
        notify.bind(str(tmp_path / "notify"))
        proc = subprocess.run(
            [sys.executable, "-m", "vdevd", "serve", "--config", str(tmp_path / "rack.toml"),
             "--endpoint", "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*",
             "--ready-file", str(ready)], capture_output=True, text=True, timeout=60,
            env={**os.environ, "NOTIFY_SOCKET": str(tmp_path / "notify")})
        notify.setblocking(False)
        sent = []
        while True:
            try:
                sent.append(notify.recv(4096))
            except BlockingIOError:
                break
    return proc.returncode, proc.stderr, sent


def test_a_card_port_in_use_is_a_start_failure_and_nothing_says_ready(tmp_path: Path) -> None:
    """Issue 16 §5: ready only once every listener accepts; the PMAC's Ethernet port taken by
    another process stops `vdevd serve` with one line naming the card and the key, exit status 2
    (issue 22 §5: a configuration error, systemd does not restart it)."""
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        endpoint = f"tcp://127.0.0.1:{taken.getsockname()[1]}"
        code, err, sent = serve_until_exit(
            tmp_path, RACK.replace("tcp://127.0.0.1:0", endpoint), tmp_path / "ready.json")
    assert code == 2
    assert (f"vdevd: cannot start: card[1] (pmac0) ethernet: {endpoint.removeprefix('tcp://')} "
            "already in use") in err.splitlines()
    assert not (tmp_path / "ready.json").exists()
    assert b"READY=1" not in sent


def test_a_ready_file_that_cannot_be_written_is_named_as_given(tmp_path: Path) -> None:
    ready = tmp_path / "missing" / "ready.json"
    code, err, sent = serve_until_exit(tmp_path, RACK, ready)
    assert code == 2
    assert err.splitlines()[-1] == f"vdevd: cannot start: ready file {ready}: No such file or directory"
    assert b"READY=1" not in sent


def test_write_ready_file_replaces_the_file_whole(tmp_path: Path) -> None:
    path = tmp_path / "ready.json"
    path.write_text("stale")
    write_ready_file(path, {"endpoint": "tcp://127.0.0.1:1", "events": "", "cards": {}})
    assert json.loads(path.read_text())["endpoint"] == "tcp://127.0.0.1:1"
    assert os.listdir(tmp_path) == ["ready.json"]
