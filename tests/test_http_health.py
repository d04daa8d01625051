"""The `[metrics]` HTTP endpoint: Prometheus metrics, /healthz and /readyz, scraped from a live
daemon (issue 22 "Operations"; vdevd/http_health.py, vdevd/prom.py)."""

from __future__ import annotations

import asyncio
import http.client
import json
import re
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest
import vdevclient
import zmq.auth
from prometheus_client.parser import text_string_to_metric_families

from tests.card_ports import Served
from tests.conftest import rack_config
from vdevd import http_health
from vdevd.config import CardSpec, ConfigError, parse
from vdevd.devices import card_class
from vdevd.http_health import Liveness, MetricsConfig, parse_metrics
from vdevd.security import CurveConfig
from vdevd.testing import DaemonThread

MS = 1_000_000


def get(url: str) -> tuple[int, str]:
    """(status, body) of a GET; an HTTP error status is an answer too."""
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status, r.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode()


def scrape(url: str) -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
    """Every sample of /metrics: {(name, sorted labels): value}."""
    status, body = get(url + "/metrics")
    assert status == 200, body
    return {(s.name, tuple(sorted(s.labels.items()))): s.value
            for fam in text_string_to_metric_families(body) for s in fam.samples}


def two_card_config(state_dir: Path | None = None, **metrics: object) -> object:
    """servo0 (generic) and pmac0 (Turbo PMAC, Ethernet on a free loopback port), metrics on a
    free loopback port."""
    cfg = rack_config()
    pmac = {key: opt.default for key, opt in card_class("pmac-turbo").options.items()}
    pmac["ethernet"] = "tcp://127.0.0.1:*"
    cfg.cards.append(CardSpec("pmac-turbo", "pmac0", pmac))
    cfg.metrics = MetricsConfig(listen="127.0.0.1:0", **metrics)  # type: ignore[arg-type]
    cfg.state_dir = str(state_dir) if state_dir else None
    return cfg


@pytest.fixture
def served(tmp_path: Path) -> Iterator[DaemonThread]:
    with DaemonThread(two_card_config(tmp_path)) as d:  # type: ignore[arg-type]
        yield d


def test_metrics_follow_the_rack(served: DaemonThread) -> None:
    assert served.health is not None
    url = served.health.url
    with vdevclient.connect(served.endpoint, served.events) as rack:
        bar0 = rack.card("servo0").region("bar0")
        for _ in range(7):
            bar0.read32(0)
        rack.sim.step(ns=5 * MS)
        rack.card("servo0").control("save")
        stats = rack.stats()
        assert served.server is not None
        pmac_port = served.server.listeners()["cards"]["pmac0"]["ethernet"]
        host, port = pmac_port.removeprefix("tcp://").rsplit(":", 1)
        with socket.create_connection((host, int(port)), timeout=10):
            # the loop accepts the connection in a turn of its own: scrape until it has (a
            # guard, not a timing: the accept is due within a turn or two)
            deadline = time.monotonic() + 10
            while True:
                rack.request("stats")
                m = scrape(url)
                if m[("vdevd_card_connections", (("card", "pmac0"),))] == 1:
                    break
                assert time.monotonic() < deadline, "the connection was never accepted"
    assert all(name.startswith("vdevd_") for name, _ in m)
    for card in ("servo0", "pmac0"):
        label = (("card", card),)
        assert m[("vdevd_card_ticks_total", label)] == stats["cards"][card]["ticks"] > 0
        assert ("vdevd_card_lost_ticks_total", label) in m
        assert ("vdevd_card_interrupts_total", label) in m
        # the scheduler's stalls (issue 22 defect 8), the rack's one scheduler for every card
        assert m[("vdevd_stalls_total", label)] == stats["scheduler"]["stalls"]["count"]
        assert ("vdevd_stall_longest_seconds", label) in m
    assert m[("vdevd_card_connections", (("card", "pmac0"),))] == 1
    assert m[("vdevd_card_connections", (("card", "servo0"),))] == 0
    assert m[("vdevd_card_nv_saves_total", (("card", "servo0"),))] == 1
    assert m[("vdevd_card_nv_saves_total", (("card", "pmac0"),))] == 0
    # the request counters and the latency histogram count the same requests
    reads = m[("vdevd_requests_total", (("op", "read"),))]
    assert reads >= 7
    assert m[("vdevd_request_duration_seconds_count", (("op", "read"),))] == reads
    assert m[("vdevd_request_duration_seconds_bucket", (("le", "+Inf"), ("op", "read")))] == reads
    assert m[("vdevd_request_duration_seconds_sum", (("op", "read"),))] > 0
    assert m[("vdevd_requests_total", (("op", "sim"),))] >= 1
    assert m[("vdevd_simulated_time_seconds", ())] == pytest.approx(5e-3)
    assert ("vdevd_process_resident_memory_bytes", ()) in m


def test_errors_and_histograms_accumulate_between_scrapes(served: DaemonThread) -> None:
    assert served.health is not None
    url = served.health.url
    with vdevclient.connect(served.endpoint, served.events) as rack:
        first = scrape(url)
        with pytest.raises(vdevclient.VdevClientError):
            rack.card("servo0").region("bar0").read32(1 << 30)
        for _ in range(3):
            rack.request("sim", action="now")
        second = scrape(url)
    assert second[("vdevd_errors_total", ())] == first[("vdevd_errors_total", ())] + 1
    key = ("vdevd_request_duration_seconds_count", (("op", "sim"),))
    assert second[key] == first.get(key, 0) + 3


def test_healthz_fails_while_the_loop_is_blocked(served: DaemonThread) -> None:
    assert served.health is not None and served._loop is not None
    url = served.health.url
    assert get(url + "/healthz") == (200, "ok\n")
    assert get(url + "/readyz") == (200, "ready\n")
    release = threading.Event()
    served._loop.call_soon_threadsafe(release.wait, 10)  # the loop is stuck in a callback
    served.health.liveness.limit_s = 0.0  # any heartbeat not yet run is too late
    try:
        get(url + "/healthz")  # posts a heartbeat the blocked loop cannot run
        status, body = get(url + "/healthz")
        assert status == 503 and "unresponsive" in body
    finally:
        release.set()
    with vdevclient.connect(served.endpoint) as rack:
        rack.stats()  # a round trip through the loop: the heartbeat before it has run
    assert get(url + "/healthz")[0] == 200


def test_readyz_only_while_ready(served: DaemonThread) -> None:
    assert served.health is not None
    url = served.health.url
    assert get(url + "/readyz")[0] == 200
    served.health.ready = False  # as before the listeners are bound, and while stopping
    assert get(url + "/readyz") == (503, "not ready\n")
    assert get(url + "/healthz")[0] == 200  # alive all the same
    assert get(url + "/nothing")[0] == 404


def test_liveness_from_heartbeats() -> None:
    """Sans-I/O with a clock of the test's: a heartbeat waits until the loop runs it."""
    loop = asyncio.new_event_loop()
    now = [100.0]
    live = Liveness(loop, limit_s=5.0, clock=lambda: now[0])
    try:
        assert live.probe() == (True, 0.0)  # posts a heartbeat
        now[0] += 4.0
        assert live.probe() == (True, 4.0)  # still waiting, within the limit; no second one
        now[0] += 2.0
        assert live.probe() == (False, 6.0)
        loop.call_soon(loop.stop)
        loop.run_forever()  # the loop runs the heartbeat
        assert live.last_beat == 106.0
        assert live.probe() == (True, 0.0)
    finally:
        loop.close()
    now[0] += 60.0
    assert live.probe() == (False, 60.0)  # the heartbeat posted last never ran: the loop is gone


def test_metrics_reachable_when_zeromq_requires_curve(tmp_path: Path) -> None:
    allowed = tmp_path / "allowed"
    allowed.mkdir()
    _, server_secret = zmq.auth.create_certificates(tmp_path, "server")
    client_public, _ = zmq.auth.create_certificates(tmp_path, "client")
    Path(client_public).rename(allowed / "client.key")
    cfg = rack_config()
    cfg.curve = CurveConfig(str(server_secret), str(allowed))
    cfg.metrics = MetricsConfig(listen="127.0.0.1:0")
    with DaemonThread(cfg) as d:
        assert d.health is not None
        assert get(d.health.url + "/healthz")[0] == 200
        assert get(d.health.url + "/readyz")[0] == 200
        assert ("vdevd_card_ticks_total", (("card", "servo0"),)) in scrape(d.health.url)


def own_address() -> str:
    """A non-loopback IPv4 address of this machine (the route to a documentation network;
    nothing is sent), or skip."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("203.0.113.1", 9))
            address = str(s.getsockname()[0])
    except OSError:
        pytest.skip("no non-loopback address")
    if address.startswith("127."):
        pytest.skip("no non-loopback address")
    return address


def test_off_loopback_only_the_allowed_networks_are_answered() -> None:
    address = own_address()
    cfg = rack_config()
    for allow, answered in ((("10.0.0.0/8",), False), ((f"{address}/32",), True)):
        cfg.metrics = MetricsConfig(listen="0.0.0.0:0", allow=allow)
        with DaemonThread(cfg) as d:
            assert d.health is not None
            port = int(d.health.url.rsplit(":", 1)[1])
            if answered:
                assert get(f"http://{address}:{port}/healthz")[0] == 200
            else:  # closed as it is accepted: no thread, no read, no answer
                assert closed_unanswered((address, port))
            assert get(f"http://127.0.0.1:{port}/healthz")[0] == 200  # loopback always


def closed_unanswered(address: tuple[str, int], request: bytes = b"") -> bool:
    """Whether a connection to `address` (sending `request`) is closed by the server without a
    byte of answer (within 10 s, a guard)."""
    with socket.create_connection(address, timeout=10) as conn:
        try:
            if request:
                conn.sendall(request)
            return conn.recv(100) == b""
        except ConnectionResetError:
            return True


def handler_threads() -> int:
    """The metrics endpoint's connection threads in this process (the daemon is in-process)."""
    return sum("process_request_thread" in t.name for t in threading.enumerate())


def test_idle_connections_are_bounded_and_closed_after_their_timeout(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """Slowloris: connections that send part of a request and then nothing hold at most
    MAX_CONNECTIONS threads, a connection past it is closed at once (logged once), each idle one
    is closed after the idle timeout, and then probes are answered again."""
    monkeypatch.setattr(http_health, "MAX_CONNECTIONS", 4)
    monkeypatch.setattr(http_health._Quiet, "timeout", 3.0)
    cfg = rack_config()
    cfg.metrics = MetricsConfig(listen="127.0.0.1:0")
    with DaemonThread(cfg) as d:
        assert d.health is not None
        url = d.health.url
        host, port = url.removeprefix("http://").rsplit(":", 1)
        address = (host, int(port))
        idle = [socket.create_connection(address, timeout=10)]
        idle[0].sendall(b"GET /healthz HTTP/1.1\r\n")  # and never the rest
        assert get(url + "/healthz")[0] == 200  # one idle connection keeps no one out
        idle += [socket.create_connection(address, timeout=10) for _ in range(3)]
        for conn in idle[1:]:
            conn.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
        # the endpoint accepts in order: these come after the four, which hold every slot
        with caplog.at_level("WARNING", logger="vdevd.http"):
            for _ in range(5):
                assert closed_unanswered(address, b"GET /healthz HTTP/1.0\r\n\r\n")
        assert handler_threads() <= 4
        assert [r.getMessage() for r in caplog.records].count(
            "metrics endpoint: 4 connections open, the most it serves at once; closing new "
            "ones until one ends") == 1
        for conn in idle:  # each closed by the server once silent for its timeout
            assert conn.recv(100) == b""
            conn.close()
        status = 0
        for _ in range(100):  # the last slot is freed just after its connection is closed
            try:
                status = get(url + "/healthz")[0]
            except (OSError, http.client.HTTPException):  # refused: no slot free yet
                continue
            break
        assert status == 200


def test_an_idle_connection_is_closed_after_the_idle_timeout(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(http_health._Quiet, "timeout", 0.5)
    cfg = rack_config()
    cfg.metrics = MetricsConfig(listen="127.0.0.1:0")
    with DaemonThread(cfg) as d:
        assert d.health is not None
        host, port = d.health.url.removeprefix("http://").rsplit(":", 1)
        with socket.create_connection((host, int(port)), timeout=10) as conn:
            conn.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")  # no end of headers
            assert conn.recv(100) == b""  # closed by the server, long before the 10 s guard


def test_metrics_configuration() -> None:
    assert parse({}).metrics is None  # off by default
    cfg = parse({"metrics": {}})
    assert cfg.metrics == MetricsConfig("127.0.0.1:9750", (), 5.0)
    assert parse({"metrics": {"listen": "[::1]:9000"}}).metrics is not None
    ok = parse({"metrics": {"listen": "0.0.0.0:9750", "allow": ["10.0.0.0/8"]}}).metrics
    assert ok is not None and ok.allow == ("10.0.0.0/8",)
    for table, key in (({"listen": "0.0.0.0:9750"}, "metrics.listen"),
                       ({"listen": "9750"}, "metrics.listen"),
                       ({"listen": "example.org:9750"}, "metrics.listen"),
                       ({"allow": ["not-a-net"]}, "metrics.allow"),
                       ({"allow": "10.0.0.0/8"}, "metrics.allow"),
                       ({"unresponsive_s": 0}, "metrics.unresponsive_s"),
                       ({"port": 1}, "metrics.port")):
        with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
            parse({"metrics": table})
    with pytest.raises(ValueError, match="must be a table"):
        parse_metrics("127.0.0.1:9750")


def test_a_metrics_port_in_use_stops_the_start() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        cfg = replace(rack_config(), metrics=MetricsConfig(
            listen=f"127.0.0.1:{taken.getsockname()[1]}"))
        with pytest.raises(Exception, match="metrics.listen"):
            DaemonThread(cfg).start()


def test_vdevd_serve_announces_the_endpoint_in_its_ready_file(tmp_path: Path) -> None:
    daemon = Served(tmp_path, '[clock]\nmode = "lockstep"\n[metrics]\nlisten = "127.0.0.1:0"\n'
                              '[[card]]\ntype = "generic-servo"\nname = "servo0"\n')
    try:
        url = daemon.info["metrics"]
        assert get(url + "/readyz")[0] == 200 and get(url + "/healthz")[0] == 200
        assert ("vdevd_card_ticks_total", (("card", "servo0"),)) in scrape(url)
    finally:
        log = daemon.stop()  # SIGTERM; asserts exit status 0
    assert "metrics and health on http://127.0.0.1:" in log


def test_the_image_health_check_asks_healthz(served: DaemonThread) -> None:
    """docker/Dockerfile's HEALTHCHECK command, run as written: 0 while the loop answers,
    non-zero when it does not."""
    assert served.health is not None and served._loop is not None
    dockerfile = (Path(__file__).resolve().parents[1] / "docker" / "Dockerfile").read_text()
    cmd = json.loads(dockerfile.split("HEALTHCHECK", 1)[1].split("CMD", 1)[1].split("\n")[0])
    default = re.search(r"^ENV VDEVD_HEALTH_URL=(\S+)", dockerfile, re.M)
    assert default is not None and default.group(1).endswith(":9750/healthz")
    cmd[0] = sys.executable if cmd[0] == "python" else cmd[0]
    env = {"VDEVD_HEALTH_URL": served.health.url + "/healthz"}
    assert subprocess.run(cmd, env=env, timeout=60).returncode == 0
    release = threading.Event()
    served._loop.call_soon_threadsafe(release.wait, 30)
    served.health.liveness.limit_s = 0.0
    try:
        get(served.health.url + "/healthz")  # a heartbeat the blocked loop cannot run
        assert subprocess.run(cmd, env=env, timeout=60, capture_output=True).returncode != 0
    finally:
        release.set()


class _Ring:
    """What `LatencyHistograms.update` reads of a rack: its tagged latency ring."""

    def __init__(self, capacity: int) -> None:
        from vdevd.metrics import TaggedSamples

        self.latency = TaggedSamples(capacity)


def test_latency_histograms_from_the_ring() -> None:
    from vdevd.metrics import OP_TAGS
    from vdevd.prom import LatencyHistograms

    ring, hist = _Ring(8), LatencyHistograms()
    read, write = OP_TAGS["read"], OP_TAGS["write"]
    for ns, tag in ((4_000, read), (30_000, read), (2_000_000_000, write)):
        ring.latency.add(ns, tag)
    hist.update(ring)  # type: ignore[arg-type]
    assert list(hist.buckets["read"][:4]) == [1, 0, 0, 1]  # <= 5, 10, 20, 50 us
    assert hist.buckets["read"].sum() == 2 and hist.sum_ns["read"] == 34_000
    assert hist.buckets["write"][-1] == 1  # above the last bucket: +Inf only
    hist.update(ring)  # type: ignore[arg-type]
    assert hist.buckets["read"].sum() == 2  # nothing new: nothing counted twice
    for _ in range(20):  # more than the ring holds between two scrapes: scaled to the count
        ring.latency.add(4_000, read)
    hist.update(ring)  # type: ignore[arg-type]
    assert hist.buckets["read"].sum() == 22 and hist.buckets["read"][0] == 21
    assert hist.sum_ns["read"] == 34_000 + 20 * 4_000
    samples = {(s.name, s.labels.get("op"), s.labels.get("le")): s.value
               for s in hist.family().samples}
    assert samples[("vdevd_request_duration_seconds_bucket", "read", "+Inf")] == 22
    assert samples[("vdevd_request_duration_seconds_bucket", "read", "5e-06")] == 21
    assert samples[("vdevd_request_duration_seconds_count", "read", None)] == 22


def test_tagged_samples_since_a_count_across_the_ring_wrap() -> None:
    from vdevd.metrics import TaggedSamples

    ring = TaggedSamples(5)
    for i in range(1, 4):
        ring.add(i * 10, i)
    values, tags, added = ring.since(0)
    assert (list(values), list(tags), added) == ([10, 20, 30], [1, 2, 3], 3)
    for i in range(4, 9):
        ring.add(i * 10, i)
    assert [list(x) if not isinstance(x, int) else x for x in ring.since(3)] == [
        [40, 50, 60, 70, 80], [4, 5, 6, 7, 8], 5]
    values, _, added = ring.since(0)  # 8 added, the last 5 held
    assert (list(values), added) == ([40, 50, 60, 70, 80], 8)
    assert list(ring.since(6)[0]) == [70, 80]
    assert (len(ring.since(8)[0]), ring.since(8)[2]) == (0, 0)
    assert ring.summary()["count"] == 8 and ring.added == 8


def test_metrics_follow_a_rack_a_snapshot_load_swaps_in(served: DaemonThread) -> None:
    """After a `snapshot load` the endpoint reports the rack served, not the one replaced."""
    assert served.health is not None
    url = served.health.url
    with vdevclient.connect(served.endpoint, served.events) as rack:
        snap = rack.snapshot()  # at time 0: no ticks
        rack.sim.step(ns=5 * MS)
        assert scrape(url)[("vdevd_card_ticks_total", (("card", "servo0"),))] == 5
        rack.restore(snap)
        assert scrape(url)[("vdevd_card_ticks_total", (("card", "servo0"),))] == 0
