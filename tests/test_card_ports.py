"""The cards' TCP ports on a live `vdevd serve` (issue 22 §2, §5, §7, §11; vdevd/tcp_listener.py):
a port that cannot be bound stops the daemon before it says ready, connections are bounded and
time out when idle, a flooding client neither stalls the clock and the other clients nor grows
the daemon without bound, and bad packets do not flood the log."""

from __future__ import annotations

import configparser
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import vdevclient

from tests.card_ports import (
    GUARD_S,
    Served,
    closed_by_peer,
    connect,
    notifications,
    notify_socket,
    pmac_ask,
)
from vdevd.config import default_config
from vdevd.devices import card_class
from vdevd.devices.pmac.ethernet import (
    REPLY_INVALID,
    VR_DOWNLOAD,
    VR_PMAC_SENDLINE,
    Header,
    packet,
)

PMAC_RACK = """
[clock]
mode = "lockstep"

[[card]]
type = "generic-servo"
name = "servo0"

[[card]]
type = "pmac-turbo"
name = "pmac0"
ethernet = "tcp://127.0.0.1:0"
{keys}
"""

GALIL_RACK = """
[clock]
mode = "lockstep"

[[card]]
type = "galil-dmc13x8"
name = "galil0"
ethernet = "{endpoint}"
"""


#: the bound of a connection's pending output (issue 22 §2: 1 MiB)
MAX_PENDING = 1 << 20


def pmac_rack(**keys: object) -> str:
    return PMAC_RACK.format(keys="\n".join(f"{k} = {v!r}" for k, v in keys.items()))


# -- §5: a port that cannot be bound -----------------------------------------------------------------


@pytest.mark.parametrize("second", ["pmac", "galil"])
def test_a_second_rack_on_a_taken_card_port_exits_2_naming_card_and_key_before_ready(
        tmp_path: Path, second: str) -> None:
    """Issue 22 §5: a card listener that cannot bind is a start-up error: one line naming the
    card as the configuration counts it and the key, exit 2 (systemd does not restart it), and
    no READY=1."""
    (tmp_path / "first").mkdir()
    first = Served(tmp_path / "first", pmac_rack())
    try:
        host, port = first.port("pmac0")
        taken = f"tcp://{host}:{port}"
        rack = (GALIL_RACK.format(endpoint=taken) if second == "galil"
                else PMAC_RACK.replace("tcp://127.0.0.1:0", taken).format(keys=""))
        (tmp_path / "rack.toml").write_text(rack)
        notify, env = notify_socket(tmp_path)
        with notify:
            proc = subprocess.run(
                [sys.executable, "-m", "vdevd", "serve", "--config", str(tmp_path / "rack.toml"),
                 "--endpoint", "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*"],
                capture_output=True, text=True, timeout=GUARD_S, env=env)
            sent = notifications(notify)
        card = "card[0] (galil0)" if second == "galil" else "card[1] (pmac0)"
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.splitlines()[-1] == (
            f"vdevd: cannot start: {card} ethernet: {host}:{port} already in use")
        assert b"READY=1" not in sent
        with connect((host, port)) as s:  # the first daemon's card still answers there
            assert pmac_ask(s, "i6=1 i3=2 cid") == b"603382\r\x06"
    finally:
        first.stop()


# -- §7: connection limit, idle timeout --------------------------------------------------------------


def test_the_port_keys_are_declared_with_the_cards_options() -> None:
    """`vdevd types` prints them (the declaration is the card's)."""
    out = subprocess.run([sys.executable, "-m", "vdevd", "types"], capture_output=True,
                         text=True, timeout=GUARD_S, check=True).stdout
    for ctype, limit in (("pmac-turbo", 64), ("galil-dmc13x8", 8)):
        options = card_class(ctype).options
        assert options["max_connections"].default == limit
        assert options["idle_timeout_s"].default == 600
        lines = out.splitlines()
        start = next(i for i, line in enumerate(lines) if line.startswith(f"{ctype} "))
        section = "\n".join(lines[start + 1:]).split("\n" + next(
            (line for line in lines[start + 1:] if not line.startswith("  ")), "\0"))[0]
        assert f"  max_connections = {limit}  int; 1..1024" in section
        assert "  idle_timeout_s = 600.0  float; 0..86400" in section


def test_connections_past_max_connections_are_refused_and_logged_once_per_episode(
        tmp_path: Path) -> None:
    served = Served(tmp_path, pmac_rack(max_connections=3))
    try:
        address = served.port("pmac0")
        held = [connect(address) for _ in range(3)]
        for s in held:
            assert pmac_ask(s, "i6=1 i3=2 cid") == b"603382\r\x06"
        refused = [connect(address) for _ in range(40)]  # a burst past the limit
        assert all(closed_by_peer(s) for s in refused)
        with vdevclient.connect(served.info["endpoint"], timeout=10) as rack:
            rack.sim.step(ns=1_000_000)  # the ZeroMQ endpoint is served meanwhile
        held.pop().close()
        later = connect(address)  # episode over: served again
        assert pmac_ask(later, "i6=1 i3=2 cid") == b"603382\r\x06"
        for s in [*held, *refused, later]:
            s.close()
    finally:
        log = served.stop()
    refusing = [line for line in log.splitlines() if "refusing more" in line]
    assert len(refusing) == 1, log
    assert "pmac0 ethernet: 3 connections open (max_connections)" in refusing[0]
    assert "pmac0 ethernet: accepting connections again; 40 refused meanwhile" in log


def test_idle_connections_past_the_limit_do_not_starve_the_zeromq_clients(tmp_path: Path) -> None:
    """Issue 22 §7 as reported: a daemon with a file limit of 256 and 300 idle PMAC connections
    still serves a new ZeroMQ client (on main every descriptor went to the PMAC port)."""
    served = Served(tmp_path, pmac_rack(), nofile=256)
    idle: list[socket.socket] = []
    try:
        address = served.port("pmac0")
        for _ in range(300):
            idle.append(connect(address))
        assert pmac_ask(idle[0], "i6=1 i3=2 cid") == b"603382\r\x06"  # among the 64 served
        with vdevclient.connect(served.info["endpoint"], timeout=10) as rack:
            assert rack.sim.step(ns=1_000_000) > 0
    finally:
        for s in idle:
            s.close()
        log = served.stop()
    assert len([line for line in log.splitlines() if "refusing more" in line]) == 1


def test_a_connection_idle_for_idle_timeout_s_is_closed_and_logged(tmp_path: Path) -> None:
    served = Served(tmp_path, pmac_rack(idle_timeout_s=0.2))
    try:
        with connect(served.port("pmac0")) as s:
            assert pmac_ask(s, "i6=1 i3=2 cid") == b"603382\r\x06"
            assert closed_by_peer(s)  # nothing sent since: the daemon closes it
    finally:
        log = served.stop()
    assert "pmac0 ethernet: connection from 127.0.0.1:" in log
    assert "closed, idle for 0.2s (idle_timeout_s)" in log


def test_a_galil_connection_held_by_a_trippoint_is_not_idle(tmp_path: Path) -> None:
    """A connection waiting on `WT` (lockstep: the card's time stands still) is waiting on the
    card, not idle: it outlives `idle_timeout_s`, while a connection opened after it that sent
    nothing is closed (its deadline falls after the held one's)."""
    rack = GALIL_RACK.format(endpoint="tcp://127.0.0.1:0") + "idle_timeout_s = 0.2\n"
    served = Served(tmp_path, rack)
    try:
        address = served.port("galil0")
        with connect(address) as held:
            held.sendall(b"WT 100000\r")
            with connect(address) as idle:
                assert closed_by_peer(idle)
            held.setblocking(False)
            with pytest.raises(BlockingIOError):  # open, nothing to read: the WT still holds it
                held.recv(16)
    finally:
        log = served.stop()
    assert log.count("closed, idle for 0.2s (idle_timeout_s)") == 1


def test_the_systemd_unit_opens_files_for_every_connection_the_default_rack_allows() -> None:
    """LimitNOFILE covers the default rack's card ports at their max_connections, with room for
    the ZeroMQ clients and the daemon's own files."""
    unit = configparser.ConfigParser(strict=False, interpolation=None)
    unit.read(Path(__file__).parents[1] / "systemd" / "vdevd.service")
    limit = int(unit["Service"]["LimitNOFILE"])
    ports = sum(card_class(spec.type).options["max_connections"].default
                for spec in default_config().cards if "max_connections" in card_class(spec.type).options)
    assert limit >= 8 * ports + 4096


# -- §2: a flood of requests -------------------------------------------------------------------------


def sendline(line: str) -> bytes:
    return packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=line.encode())


def test_a_burst_of_requests_yields_to_the_clock_and_the_other_clients(tmp_path: Path) -> None:
    """Issue 22 §2: a burst on one connection runs a request a turn of the daemon's loop: another
    client's requests and a step of the clock are served between two of its requests, not after
    the burst."""
    served = Served(tmp_path, pmac_rack())
    n = 2000
    try:
        address = served.port("pmac0")
        burst = connect(address)
        burst.sendall(b"".join(sendline(f"P1={k} P2..2000={k}") for k in range(1, n + 1)))
        with connect(address) as other, vdevclient.connect(served.info["endpoint"],
                                                           timeout=60) as rack:
            assert pmac_ask(other, "i6=1 i3=2") == b"\x06"
            first = int(pmac_ask(other, "P1").split(b"\r")[0])
            before = rack.sim.now_ns()
            assert rack.sim.step(ns=1_000_000) == before + 1_000_000
            second = int(pmac_ask(other, "P1").split(b"\r")[0])
        assert 0 < first <= second < n  # the burst still runs
        assert second - first < 100  # a few of its requests ran between the other client's
        burst.close()
    finally:
        served.stop()


def test_replies_never_fetched_close_the_connection_past_the_bound(tmp_path: Path) -> None:
    """Issue 22 §2: 10,000 SENDLINE of P0..8191, their output never fetched: past MAX_PENDING
    bytes of pending output the connection is closed, logged once; the daemon's memory stays
    bounded and another client is served."""
    served = Served(tmp_path, pmac_rack())
    try:
        address = served.port("pmac0")
        rss = served.rss_kib()
        flood = connect(address)
        sender = threading.Thread(target=_send_quietly, args=(flood, sendline("P0..8191") * 10_000))
        sender.start()
        assert closed_by_peer(flood)
        sender.join(GUARD_S)
        flood.close()
        assert served.rss_kib() - rss < 64 * 1024
        with connect(address) as other:
            assert pmac_ask(other, "i6=1 i3=2 cid") == b"603382\r\x06"
        with vdevclient.connect(served.info["endpoint"], timeout=10) as rack:
            rack.sim.step(ns=1_000_000)
    finally:
        log = served.stop()
    closing = [line for line in log.splitlines() if "pending output passed" in line]
    assert len(closing) == 1, log
    assert "pmac0 ethernet: connection from 127.0.0.1:" in closing[0]
    assert f"passed {MAX_PENDING} bytes" in closing[0]


def test_max_pending_sets_the_bound(tmp_path: Path) -> None:
    served = Served(tmp_path, pmac_rack(max_pending_kib=64))
    try:
        with connect(served.port("pmac0")) as flood:
            _send_quietly(flood, sendline("P0..8191") * 10)  # 16 KiB of output each
            assert closed_by_peer(flood)
    finally:
        log = served.stop()
    assert "pending output passed 65536 bytes" in log


def _send_quietly(s: socket.socket, data: bytes) -> None:
    """sendall, the daemon closing the connection part-way being expected."""
    try:
        s.sendall(data)
    except OSError:
        pass


# -- §11: bad packets --------------------------------------------------------------------------------


def test_bad_packets_are_answered_each_and_logged_a_few_times(tmp_path: Path) -> None:
    """Issue 22 §11: 5,000 bad packets on a connection give fewer than 100 log lines, each packet
    still answered BELL; the total is logged when the connection ends."""
    served = Served(tmp_path, pmac_rack())
    try:
        with connect(served.port("pmac0")) as s:
            s.sendall(Header(0x20, 0xB0).pack() * 5000)  # RequestType neither 0x40 nor 0xC0
            got = b""
            while len(got) < 5000:
                chunk = s.recv(65536)
                assert chunk
                got += chunk
            assert got == REPLY_INVALID * 5000
    finally:
        log = served.stop()
    lines = [line for line in log.splitlines() if "PMAC Ethernet" in line]
    assert 5 <= len(lines) < 100
    assert "5000 bad requests on the connection" in lines[-1]
