"""The web view's server (issue 23 §3; vdevd/web/): the page and its files, the state it shows
against the rack's own answers, the websocket's pushes, the page's requests served as the
protocol serves them (same effects, same errors), the clock run, and the metrics endpoint's
rules: peers, connections and idle timeouts. A real daemon on loopback, lockstep."""

from __future__ import annotations

import asyncio
import ctypes
import functools
import json
import socket
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest
import vdevclient
from vdevclient import RemoteError, galil

from tests.card_ports import Served
from tests.client.galil import GALIL, card, rack_config
from tests.client.pulser import Pulser
from tests.test_http_health import closed_unanswered, own_address
from vdevd.config import ConfigError, parse
from vdevd.devices.base import control
from vdevd.errors import StartError
from vdevd.testing import DaemonThread, rack_of
from vdevd.web import app as webapp
from vdevd.web import ops as webops
from vdevd.web.config import WebConfig
from vdevd.web.state import IrqWatch

MS = 1_000_000


def web_config(**web: Any) -> Any:
    cfg = rack_config(card(GALIL, "galil0"))
    cfg.web = WebConfig(**{"listen": "127.0.0.1:0", **web})
    return cfg


@pytest.fixture
def served() -> Iterator[DaemonThread]:
    with DaemonThread(web_config()) as d:
        yield d


@pytest.fixture
def client(served: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(served.endpoint, served.events, timeout=10) as r:
        yield r


def url(d: DaemonThread) -> str:
    assert d.web is not None
    return d.web.url


def get(address: str, headers: dict[str, str] | None = None) -> tuple[int, dict[str, str], bytes]:
    req = urllib.request.Request(address, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def post(address: str, body: Any, content_type: str = "application/json",
         headers: dict[str, str] | None = None) -> tuple[int, Any]:
    data = body if isinstance(body, bytes) else json.dumps(body).encode()
    req = urllib.request.Request(address, data, {"Content-Type": content_type, **(headers or {})})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, json.load(r)
    except urllib.error.HTTPError as exc:
        body = exc.read()
        return exc.code, json.loads(body) if exc.headers.get_content_type() == "application/json" \
            else body.decode()


def state(d: DaemonThread) -> dict[str, Any]:
    status, _, body = get(url(d) + "/api/state")
    assert status == 200
    return json.loads(body)  # type: ignore[no-any-return]


def command(h: Any, text: str) -> bytes:
    buf = ctypes.create_string_buffer(1024)
    assert galil.DMCCommand(h, text, buf, 1024) == galil.DMCNOERROR, text
    return buf.value.strip(b": \r\n")


@pytest.fixture
def dmc(served: DaemonThread) -> Iterator[ctypes.c_long]:
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=served.endpoint) == galil.DMCNOERROR
    yield h
    galil.DMCClose(h)


# -- the page ------------------------------------------------------------------------------------
def test_the_page_and_its_files_are_served_from_the_package(served: DaemonThread) -> None:
    status, headers, page = get(url(served) + "/")
    assert status == 200 and headers["Content-Type"].startswith("text/html")
    assert b'<script src="/static/app.js"' in page
    assert "default-src 'self'" in headers["Content-Security-Policy"]  # nothing from elsewhere
    for name, kind in (("app.js", "javascript"), ("style.css", "text/css")):
        status, headers, body = get(url(served) + "/static/" + name)
        assert status == 200 and kind in headers["Content-Type"] and body
    assert get(url(served) + "/static/../config.py")[0] == 404
    assert get(url(served) + "/static/%2e%2e/config.py")[0] in (403, 404)
    assert get(url(served) + "/nothing")[0] == 404


def test_the_layout_names_the_cards_axes_and_actions(served: DaemonThread) -> None:
    status, _, body = get(url(served) + "/api/layout")
    layout = json.loads(body)
    assert status == 200
    assert [c["name"] for c in layout["hello"]["cards"]] == ["galil0"]
    assert layout["axes"] == {"galil0": ["X", "Y", "Z", "W"]}
    assert {"set_limit", "set_home", "set_amp_fault", "set_estop"} <= set(
        layout["hello"]["cards"][0]["controls"])
    assert layout["flags"]["4"] == "HARD_LIMIT_POS"


# -- the state shown -------------------------------------------------------------------------------
def test_the_state_is_the_cards_own(served: DaemonThread, client: vdevclient.Rack,
                                    dmc: ctypes.c_long) -> None:
    """After a profiled move (PR 1000; BGX) and 0.3 s: the clock, X's position (TP), command
    (RP) and following error (TE), the move done (_BG 0, the core's DONE bit)."""
    command(dmc, "PR 1000;BGX")
    client.sim.step(seconds=0.3)
    s = state(served)
    assert s["clock"] == {"now_ns": client.sim.now_ns(), "mode": "lockstep", "tick_ns": MS}
    x = s["cards"]["galil0"]
    assert x["ticks"] == 300
    assert round(x["position"][0]) == int(command(dmc, "TPX"))
    assert round(x["command"][0]) == int(command(dmc, "RPX"))
    assert round(x["error"][0]) == int(command(dmc, "TEX"))
    assert float(command(dmc, "MG _BGX")) == 0 and x["flags"][0] & (1 << 12)  # DONE
    assert x["position"][1:] == [0, 0, 0]
    assert not s["running"]


def test_reading_the_state_changes_nothing(served: DaemonThread, client: vdevclient.Rack,
                                           dmc: ctypes.c_long) -> None:
    command(dmc, "PR 500;BGX")
    client.sim.step(seconds=0.05)
    first = state(served)
    for _ in range(20):
        assert state(served)["cards"] == first["cards"]
    client.sim.step(seconds=0.05)
    assert state(served)["cards"]["galil0"]["ticks"] == 100


# -- the page's requests ---------------------------------------------------------------------------
def test_a_backdoor_button_acts_as_the_control_op(served: DaemonThread, client: vdevclient.Rack,
                                                  dmc: ctypes.c_long) -> None:
    assert int(command(dmc, "TSX")) & 0x08  # forward limit not tripped (1)
    status, reply = post(url(served) + "/api/op", {
        "op": "control", "card": "galil0", "action": "set_limit",
        "params": {"axis": "X", "side": "positive", "active": True}})
    assert (status, reply) == (200, {"ok": None})
    assert not int(command(dmc, "TSX")) & 0x08  # tripped: the card's own switch bit
    assert state(served)["cards"]["galil0"]["flags"][0] & 0x10  # HARD_LIMIT_POS
    command(dmc, "JG -1000;BGX")
    client.sim.step(seconds=0.05)
    assert float(command(dmc, "MG _BGX")) == 1
    post(url(served) + "/api/op", {"op": "control", "card": "galil0", "action": "set_estop",
                                   "params": {"active": True}})
    client.sim.step(seconds=0.05)
    assert float(command(dmc, "MG _BGX")) == 0  # the abort input stopped the jog


def test_bad_requests_get_the_protocols_errors_and_change_nothing(
        served: DaemonThread, client: vdevclient.Rack) -> None:
    """Each as the ZeroMQ endpoint answers it (code and message), the daemon serving on."""
    op = url(served) + "/api/op"
    same = [
        {"op": "control", "card": "galil0", "action": "no_such", "params": {}},
        {"op": "control", "card": "galil0", "action": "set_limit", "params": {"axis": "Q"}},
        {"op": "control", "card": "galil0", "action": "set_limit",
         "params": {"axis": "X", "active": "false"}},
        {"op": "control", "card": "nope", "action": "set_estop"},
        {"op": "sim", "action": "step", "ns": "10"},
        {"op": "sim", "action": "step"},
        {"op": "sim", "action": "jump", "ns": 1},
        {"op": "scope", "card": "galil0", "action": "arm", "signals": ["nope"], "samples": 4},
    ]
    for body in same:
        status, reply = post(op, body)
        with pytest.raises(RemoteError) as err:
            client.call({k: v for k, v in body.items()})
        assert status == 400, body
        assert reply["error"] == {"code": err.value.code, "message": err.value.message}, body
    assert post(op, {"op": "read", "card": "galil0", "region": "a16", "offset": 0, "size": 1}
                )[1]["error"]["code"] == "unknown_op"
    assert post(op, b"{not json")[1]["error"]["code"] == "malformed"
    assert post(op, [1, 2])[1]["error"]["code"] == "malformed"
    assert post(op, {"op": "sim", "action": "now"}, content_type="text/plain")[1]["error"] == {
        "code": "malformed", "message": "send the request as application/json"}
    status, reply = post(op, {"op": "sim", "action": "now", "pad": "x" * webapp.MAX_BODY})
    assert status == 413 and reply["error"]["code"] == "too_large"
    assert client.sim.now_ns() == 0 and state(served)["cards"]["galil0"]["flags"] == [4] * 4
    assert post(op, {"op": "sim", "action": "now"}) == (200, {"ok": {
        "now_ns": 0, "mode": "lockstep", "tick_ns": MS}})


def test_step_in_realtime_is_wrong_mode() -> None:
    cfg = web_config()
    cfg.clock = "realtime"
    with DaemonThread(cfg) as d:
        status, reply = post(url(d) + "/api/op", {"op": "sim", "action": "step", "ns": MS})
        assert (status, reply["error"]["code"]) == (400, "wrong_mode")
        status, reply = post(url(d) + "/api/clock", {"action": "run"})
        assert (status, reply["error"]["code"]) == (400, "wrong_mode")


def test_the_scope_panel_reads_what_the_protocol_reads(served: DaemonThread,
                                                        client: vdevclient.Rack,
                                                        dmc: ctypes.c_long) -> None:
    op = url(served) + "/api/op"
    status, reply = post(op, {"op": "scope", "card": "galil0", "action": "arm", "samples": 50,
                              "axes": ["X"], "signals": ["position", "error", "status"]})
    assert status == 200 and reply["ok"]["columns"] == ["X.position", "X.error", "X.status"]
    command(dmc, "PR 300;BGX")
    client.sim.step(seconds=0.06)
    web = post(op, {"op": "scope", "card": "galil0", "action": "read"})[1]["ok"]
    raw = client.call({"op": "scope", "card": "galil0", "action": "read"})
    assert web["count"] == raw["count"] == 50 and web["state"] == "done"
    assert web["time_s"] == (np.frombuffer(raw["time_ns"], "<i8") / 1e9).tolist()
    for name, kind in raw["types"].items():
        assert web["columns"][name] == np.frombuffer(raw["columns"][name], "<" + kind).tolist()
    assert max(web["columns"]["X.position"]) > 0


# -- the clock -------------------------------------------------------------------------------------
def test_run_steps_the_clock_until_paused(served: DaemonThread, client: vdevclient.Rack) -> None:
    clock = url(served) + "/api/clock"
    assert post(clock, {"action": "run"}) == (200, {"ok": {"running": True}})
    assert post(clock, {"action": "run"}) == (200, {"ok": {"running": True}})  # one run
    deadline = time.monotonic() + 30  # a guard against a run that never steps, not a measure
    while client.sim.now_ns() == 0:  # it runs at real-time pace: some steps will come
        assert time.monotonic() < deadline, "the run did not step the clock"
    assert state(served)["running"]
    assert post(clock, {"action": "pause"}) == (200, {"ok": {"running": False}})
    paused = client.sim.now_ns()
    client.sim.step(ns=MS)  # nothing of the run is left to move the clock
    assert client.sim.now_ns() == paused + MS
    assert not state(served)["running"]
    status, reply = post(clock, {"action": "jog"})
    assert status == 400 and reply["error"]["code"] == "bad_param"


# -- the websocket ---------------------------------------------------------------------------------
async def _frames(address: str, n: int, until: Any = None) -> list[dict[str, Any]]:
    """The first message, then states until `until(state)` (or n states)."""
    got: list[dict[str, Any]] = []
    async with aiohttp.ClientSession() as session, session.ws_connect(address + "/ws") as ws:
        async with asyncio.timeout(20):
            async for msg in ws:
                got.append(json.loads(msg.data))
                states = [m for m in got if m["kind"] == "state"]
                if until is not None and states and until(states[-1]):
                    break
                if until is None and len(states) >= n:
                    break
    return got


def test_the_websocket_sends_the_layout_then_the_live_state(served: DaemonThread,
                                                            client: vdevclient.Rack) -> None:
    assert served.web is not None and served.web.pushes == 0  # no page open: nothing read
    state(served)  # nor for a GET
    assert served.web.pushes == 0
    client.sim.step(seconds=0.25)
    got = asyncio.run(_frames(url(served), 2))
    assert got[0]["kind"] == "layout" and got[0]["axes"] == {"galil0": ["X", "Y", "Z", "W"]}
    for s in got[1:]:
        assert s["kind"] == "state" and s["clock"]["now_ns"] == 250 * MS
        assert s["cards"]["galil0"]["ticks"] == 250


def test_interrupts_are_pushed_as_they_come() -> None:
    with DaemonThread(web_config(), rack=rack_of(functools.partial(Pulser, "p0"))) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:

        async def watch() -> list[dict[str, Any]]:
            task = asyncio.ensure_future(_frames(url(d), 0, until=lambda s: s["irqs"]))
            await asyncio.sleep(0)
            while d.web is None or not d.web.clients:  # the page is connected
                await asyncio.sleep(0.01)
            await asyncio.to_thread(rack.control, "p0", "pulse", status=0x5A)
            return await task

        states = [m for m in asyncio.run(watch()) if m["kind"] == "state"]
        assert states[-1]["irqs"] == [{"card": "p0", "line": "irq", "seq": 1, "sim_time_ns": 0,
                                       "status": 0x5A}]
        assert all(not s["irqs"] for s in states[:-1])
        assert states[-1]["cards"]["p0"] == {"ticks": 0}  # a card without axes


def test_the_irq_watch_shows_each_lines_latest_and_counts_the_rest() -> None:
    rack = rack_of(functools.partial(Pulser, "p0"), functools.partial(Pulser, "p1"))
    watch = IrqWatch()
    assert watch.poll(rack) == ([], 0)
    for status in (1, 2, 3):
        rack.cards["p0"].control("pulse", {"status": status})
    rack.cards["p1"].control("pulse", {"status": 9})
    events, missed = watch.poll(rack)
    assert [(e["card"], e["seq"], e["status"]) for e in events] == [("p0", 3, 3), ("p1", 1, 9)]
    assert missed == 2
    assert watch.poll(rack) == ([], 0)
    fresh = rack_of(functools.partial(Pulser, "p0"))  # a new rack (reset): counted afresh
    fresh.cards["p0"].control("pulse", {"status": 7})
    assert [e["seq"] for e in watch.poll(fresh)[0]] == [1]


def test_websockets_are_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(webapp, "MAX_CLIENTS", 2)
    with DaemonThread(web_config()) as d:

        async def three() -> int:
            async with aiohttp.ClientSession() as session:
                a = await session.ws_connect(url(d) + "/ws")
                b = await session.ws_connect(url(d) + "/ws")
                await a.receive_json()
                await b.receive_json()
                with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
                    await session.ws_connect(url(d) + "/ws")
                await a.close()
                await b.close()
                return refused.value.status

        assert asyncio.run(three()) == 503


def test_a_busy_page_is_refused_past_its_requests_in_flight(
        monkeypatch: pytest.MonkeyPatch, served: DaemonThread) -> None:
    monkeypatch.setattr(webops, "MAX_IN_FLIGHT", 1)
    assert served.web is not None
    served.web.ops.in_flight = 1  # one long step under way
    status, reply = post(url(served) + "/api/op", {"op": "sim", "action": "now"})
    served.web.ops.in_flight = 0
    assert status == 503 and reply["error"]["code"] == "busy"


# -- who may connect -------------------------------------------------------------------------------
def test_other_sites_in_the_browser_are_refused(served: DaemonThread) -> None:
    base = url(served)
    port = base.rsplit(":", 1)[1]
    assert get(base + "/", {"Host": f"evil.example:{port}"})[0] == 421  # DNS rebinding
    assert get(base + "/", {"Host": f"localhost:{port}"})[0] == 200
    host, _ = base.removeprefix("http://").rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=10) as conn:  # no Host at all
        conn.sendall(b"GET / HTTP/1.0\r\n\r\n")
        assert conn.recv(100).startswith(b"HTTP/1.0 400 ")
    assert post(base + "/api/op", {"op": "sim", "action": "now"},
                headers={"Origin": "http://evil.example"})[0] == 403
    assert post(base + "/api/op", {"op": "sim", "action": "now"},
                headers={"Origin": base})[0] == 200


def test_off_loopback_only_the_allowed_networks_are_answered() -> None:
    address = own_address()
    for allow, answered in ((("10.0.0.0/8",), False), ((f"{address}/32",), True)):
        with DaemonThread(web_config(listen="0.0.0.0:0", allow=allow)) as d:
            port = int(url(d).rsplit(":", 1)[1])
            if answered:
                assert get(f"http://{address}:{port}/api/layout")[0] == 200
            else:  # closed as it is accepted: nothing read, nothing answered
                assert closed_unanswered((address, port), b"GET / HTTP/1.0\r\n\r\n")
            assert get(f"http://127.0.0.1:{port}/api/layout")[0] == 200  # loopback always


def test_connections_are_bounded_and_idle_ones_closed(monkeypatch: pytest.MonkeyPatch,
                                                      caplog: pytest.LogCaptureFixture) -> None:
    """Slowloris: connections that send part of a request hold at most MAX_CONNECTIONS; one
    past it is closed at accept (logged once); each is closed after the idle timeout."""
    monkeypatch.setattr(webapp, "MAX_CONNECTIONS", 4)
    monkeypatch.setattr(webapp, "IDLE_TIMEOUT_S", 1.0)
    with DaemonThread(web_config()) as d:
        host, port = url(d).removeprefix("http://").rsplit(":", 1)
        address = (host, int(port))
        idle = [socket.create_connection(address, timeout=10) for _ in range(4)]
        for conn in idle:
            conn.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n")  # and never the end of the headers
        with caplog.at_level("WARNING", logger="vdevd.web"):
            for _ in range(3):
                assert closed_unanswered(address, b"GET / HTTP/1.0\r\n\r\n")
        assert [r.getMessage() for r in caplog.records].count(
            "web view: 4 connections open, the most it serves at once; closing new ones until "
            "one ends") == 1
        for conn in idle:  # closed by the server once silent for the timeout
            assert conn.recv(100) == b""
            conn.close()
        for _ in range(100):  # a slot is free once its handler has finished
            try:
                if get(url(d) + "/api/layout")[0] == 200:
                    break
            except OSError:
                continue
        else:
            pytest.fail("the web view did not serve again")


# -- configuration -----------------------------------------------------------------------------------
def test_web_configuration() -> None:
    assert parse({}).web is None  # off by default
    assert parse({"web": {}}).web == WebConfig("127.0.0.1:8080")
    ok = parse({"web": {"listen": "0.0.0.0:8080", "allow": ["10.0.0.0/8"]}}).web
    assert ok is not None and ok.allow == ("10.0.0.0/8",)
    for table, key in (({"listen": "0.0.0.0:8080"}, "web.listen"),
                       ({"listen": "nowhere"}, "web.listen"),
                       ({"listen": 8080}, "web.listen"),
                       ({"allow": ["not-a-net"]}, "web.allow"),
                       ({"allow": "10.0.0.0/8"}, "web.allow"),
                       ({"port": 1}, "web.port")):
        with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
            parse({"web": table})


def test_a_web_port_in_use_stops_the_start() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(StartError, match=f"web.listen 127.0.0.1:{port}: "):
            DaemonThread(web_config(listen=f"127.0.0.1:{port}")).start()


def test_vdevd_serve_serves_the_page_and_lists_it_in_its_ready_file(tmp_path: Path) -> None:
    daemon = Served(tmp_path, '[clock]\nmode = "lockstep"\n[web]\nlisten = "127.0.0.1:0"\n'
                              '[[card]]\ntype = "generic-servo"\nname = "servo0"\n')
    try:
        page = daemon.info["web"]
        status, _, body = get(page + "/api/layout")
        assert status == 200 and json.loads(body)["axes"] == {"servo0": ["0", "1", "2", "3"]}
    finally:
        log = daemon.stop()  # SIGTERM; asserts exit status 0
    assert "web view on http://127.0.0.1:" in log


def test_the_page_follows_the_rack_a_reset_serves(served: DaemonThread,
                                                  client: vdevclient.Rack) -> None:
    """`DaemonThread.reset` (the pytest plugin's, between tests) swaps in a fresh rack: the
    page shows and drives that one."""
    client.sim.step(seconds=0.1)
    assert state(served)["clock"]["now_ns"] == 100 * MS
    served.reset()
    assert state(served)["clock"]["now_ns"] == 0
    assert post(url(served) + "/api/op", {"op": "sim", "action": "step", "ns": MS})[0] == 200
    assert state(served)["cards"]["galil0"]["ticks"] == 1
    assert client.sim.now_ns() == MS


class _Odd(Pulser):
    """A card whose action answers what neither msgpack nor JSON can carry (a bug)."""

    @control()
    def odd(self) -> set[int]:
        """A set."""
        return {1, 2}


def test_an_unencodable_result_is_an_internal_error_as_on_the_endpoint() -> None:
    with DaemonThread(web_config(), rack=rack_of(functools.partial(_Odd, "p0"))) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        status, reply = post(url(d) + "/api/op", {"op": "control", "card": "p0",
                                                  "action": "odd"})
        with pytest.raises(RemoteError) as err:
            rack.control("p0", "odd")
        assert status == 500 and reply["error"]["code"] == err.value.code == "internal"
        assert reply["error"]["message"].startswith("unencodable: ")
        assert post(url(d) + "/api/op", {"op": "sim", "action": "now"})[0] == 200
