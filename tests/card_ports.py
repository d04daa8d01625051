"""A `vdevd serve` process of a test's own rack (lockstep), for the tests of the cards' TCP ports
(issue 22): a process of its own, so that its stderr is the log a test counts and a burst it
serves does not share the test's interpreter."""

from __future__ import annotations

import json
import os
import resource
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from vdevd.devices.pmac.ethernet import VR_DOWNLOAD, VR_PMAC_GETRESPONSE, packet
from vdevd.devices.pmac.ethernet_server import parse_endpoint

GUARD_S = 60.0  # a guard against a hung daemon, never a measured wait


class Served:
    """`vdevd serve --config RACK` until `stop`; `info` is its ready file."""

    def __init__(self, tmp_path: Path, rack: str, nofile: int | None = None) -> None:
        """`nofile`: the daemon's file limit (RLIMIT_NOFILE), else the test's."""
        self.dir = tmp_path
        (tmp_path / "rack.toml").write_text(rack)
        ready = tmp_path / "ready.json"
        self.log_path = tmp_path / "vdevd.log"
        self._log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "vdevd", "serve", "--config", str(tmp_path / "rack.toml"),
             "--endpoint", "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*",
             "--ready-file", str(ready)], stderr=self._log,
            preexec_fn=None if nofile is None else lambda: resource.setrlimit(
                resource.RLIMIT_NOFILE, (nofile, nofile)))
        deadline = time.monotonic() + GUARD_S
        while not ready.exists():
            try:  # polls the file while watching for an early exit
                code = self.proc.wait(timeout=0.01)
            except subprocess.TimeoutExpired:
                if time.monotonic() > deadline:
                    self.stop()
                    raise AssertionError("no ready file") from None
                continue
            raise AssertionError(f"vdevd exited {code}: {self.log_path.read_text()}")
        self.info: dict[str, Any] = json.loads(ready.read_text())

    def port(self, card: str) -> tuple[str, int]:
        return parse_endpoint(self.info["cards"][card]["ethernet"])

    def rss_kib(self) -> int:
        """The daemon's resident set (VmRSS), KiB."""
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
        raise AssertionError("no VmRSS")

    def stop(self) -> str:
        """SIGTERM, wait for the exit; the whole log."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            assert self.proc.wait(timeout=GUARD_S) == 0
        self._log.close()
        return self.log_path.read_text()


def connect(address: tuple[str, int]) -> socket.socket:
    s = socket.create_connection(address, timeout=GUARD_S)
    s.settimeout(GUARD_S)
    return s


def pmac_ask(s: socket.socket, line: str) -> bytes:
    """GETRESPONSE of one line; the reply (one recv, as dls-pmaclib reads it)."""
    s.sendall(packet(VR_DOWNLOAD, VR_PMAC_GETRESPONSE, data=line.encode()))
    return s.recv(2048)


def closed_by_peer(s: socket.socket) -> bool:
    """Read until the daemon closes the connection (True) or the guard expires (False)."""
    try:
        while s.recv(65536):
            pass
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False
    return True


def notify_socket(tmp_path: Path) -> tuple[socket.socket, dict[str, str]]:
    """A NOTIFY_SOCKET of the test's, and the environment that hands it to a daemon."""
    notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    notify.bind(str(tmp_path / "notify"))
    return notify, {**os.environ, "NOTIFY_SOCKET": str(tmp_path / "notify")}


def notifications(notify: socket.socket) -> list[bytes]:
    notify.setblocking(False)
    sent = []
    while True:
        try:
            sent.append(notify.recv(4096))
        except BlockingIOError:
            return sent
