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


def test_write_ready_file_replaces_the_file_whole(tmp_path: Path) -> None:
    path = tmp_path / "ready.json"
    path.write_text("stale")
    write_ready_file(path, {"endpoint": "tcp://127.0.0.1:1", "events": "", "cards": {}})
    assert json.loads(path.read_text())["endpoint"] == "tcp://127.0.0.1:1"
    assert os.listdir(tmp_path) == ["ready.json"]
