"""vdevctl and vdevd as a user runs them."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import vdevclient
from vdevclient.cli import main as vdevctl

from tests.client.pulser import serve_pulsers
from tests.conftest import free_endpoint
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg
from vdevd.rt import AxisFlag
from vdevd.testing import DaemonThread


def ctl(daemon: DaemonThread, capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    assert vdevctl(["--endpoint", daemon.endpoint, *argv]) == 0
    return capsys.readouterr().out


def test_cards_lists_regions_and_lines(daemon: DaemonThread, capsys: pytest.CaptureFixture[str]) -> None:
    out = ctl(daemon, capsys, "cards")
    assert "servo0  generic-servo" in out
    assert "region bar0  0x1000 bytes  widths 1/2/4" in out
    assert "irq inta" in out


def test_poke_then_peek(daemon: DaemonThread, capsys: pytest.CaptureFixture[str]) -> None:
    ctl(daemon, capsys, "poke", "servo0", "bar0", hex(R.OUTPUTS), "78563412")
    out = ctl(daemon, capsys, "peek", "servo0", "bar0", hex(R.OUTPUTS), "4")
    assert out.strip() == f"{R.OUTPUTS:08x}  78 56 34 12"


def test_step_control_now_and_stats(daemon: DaemonThread, capsys: pytest.CaptureFixture[str]) -> None:
    assert ctl(daemon, capsys, "step", "0.25").strip() == "250000000"
    assert ctl(daemon, capsys, "now").startswith("250000000 ns (lockstep")
    ctl(daemon, capsys, "control", "servo0", "set_inputs", "value=9")
    assert ctl(daemon, capsys, "peek", "servo0", "bar0", hex(R.INPUTS)).split()[1] == "09"
    state = json.loads(ctl(daemon, capsys, "control", "servo0", "axis_state", "axis=1"))
    assert state["encoder"] == 0
    assert json.loads(ctl(daemon, capsys, "stats"))["cards"]["servo0"]["ticks"] == 250


def test_control_takes_pythons_true_and_false_as_booleans(
        daemon: DaemonThread, capsys: pytest.CaptureFixture[str]) -> None:
    """Users type True/False as readily as true/false; sent as strings, "False" would be a
    bad_param (or, before flags were checked, an active switch)."""
    status = hex(R.AXIS_BASE + R.AXIS_STRIDE * 1 + AxisReg.STATUS)

    def limit() -> bool:
        out = ctl(daemon, capsys, "peek", "servo0", "bar0", status)
        return bool(int.from_bytes(bytes.fromhex("".join(out.split()[1:])), "little")
                    & AxisFlag.HARD_LIMIT_POS)

    ctl(daemon, capsys, "control", "servo0", "set_limit", "axis=1", "side=positive", "active=True")
    assert limit()
    ctl(daemon, capsys, "control", "servo0", "set_limit", "axis=1", "side=positive", "active=False")
    assert not limit()


@pytest.mark.parametrize(("argv", "message"), [
    (["peek", "servo0", "bar0", "0x1000"], "out_of_range: "),
    (["control", "servo0", "set_limit", "axis=99"], "bad_param: "),
    (["peek", "servo9", "bar0", "0"], "no card 'servo9' (cards: servo0)"),
    (["poke", "servo0", "bar0", "0", "00" * (2 << 20)], "too_large: write request of "),
    (["--endpoint", free_endpoint(), "--timeout", "0.1", "now"],
     "hello: no reply from "),
    (["step", "nan"], "bad_param: "),
    (["step", "inf"], "bad_param: "),
], ids=["error-reply", "bad-param", "unknown-card", "too-large", "no-daemon", "step-nan",
        "step-inf"])  # a malformed endpoint is a usage error, exit 2: test_cli_review.py
def test_errors_are_one_line_and_exit_1(daemon: DaemonThread, capsys: pytest.CaptureFixture[str],
                                        argv: list[str], message: str) -> None:
    assert vdevctl(["--endpoint", daemon.endpoint, *argv]) == 1
    captured = capsys.readouterr()
    assert captured.err.startswith(f"vdevctl: {message}") and captured.err.count("\n") == 1, captured.err
    assert captured.out == ""


@pytest.mark.parametrize(("argv", "message"), [
    (["poke", "servo0", "bar0", "0", "0x1"], "'0x1' is not hex bytes"),
    (["peek", "servo0", "bar0", "xyz"], "'xyz' is not a number (decimal or 0x hex)"),
    (["--timeout", "-1", "now"], "'-1' is not a number of seconds >= 0"),
], ids=["hex-bytes", "offset", "timeout"])
def test_bad_arguments_are_a_usage_error_naming_the_value(
        daemon: DaemonThread, capsys: pytest.CaptureFixture[str], argv: list[str], message: str) -> None:
    with pytest.raises(SystemExit) as exit_:
        vdevctl(["--endpoint", daemon.endpoint, *argv])
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_irq_prints_events(daemon: DaemonThread, capsys: pytest.CaptureFixture[str]) -> None:
    import threading

    from tests.protocol.motion import move_ops

    with vdevclient.connect(daemon.endpoint) as rack:
        bar = rack.card("servo0").region("bar0")
        bar.write32(R.IRQ_ENABLE, 1)
        watcher = threading.Thread(
            target=vdevctl,
            args=(["--endpoint", daemon.endpoint, "irq", "servo0", "--count", "1",
                   "--timeout", "20"],))
        watcher.start()
        # the watcher subscribes asynchronously: interrupt again (acknowledge, move back and
        # forth) until it has printed one event
        for i in range(200):
            if not watcher.is_alive():
                break
            bar.write32(R.IRQ_STATUS, 0xFFFFFFFF)
            rack.batch(move_ops(0, 100 * (i % 2)))
            rack.sim.step(seconds=0.05)
            watcher.join(0.05)
        watcher.join(20)
    out = capsys.readouterr().out
    assert re.search(r"^\s*\d+ servo0 inta seq=\d+ status=0x1$", out, re.M), out


def test_irq_without_a_card_watches_every_card(pulsers: DaemonThread) -> None:
    with subprocess.Popen(
        [sys.executable, "-m", "vdevclient.cli", "--endpoint", pulsers.endpoint, "irq",
         "--count", "2", "--timeout", "20"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    ) as proc:
        try:
            assert proc.stderr is not None
            assert proc.stderr.readline().startswith("vdevctl: watching p0, p1 on ")  # live
            with vdevclient.connect(pulsers.endpoint) as rack:
                rack.control("p1", "pulse", status=1)
                rack.control("p0", "pulse", status=2)
            out, _ = proc.communicate(timeout=20)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 0
    assert [line.split()[1:] for line in out.splitlines()] == [
        ["p1", "irq", "seq=1", "status=0x1"], ["p0", "irq", "seq=1", "status=0x2"]]


def test_irq_on_a_rack_without_cards_is_an_error(capsys: pytest.CaptureFixture[str]) -> None:
    with serve_pulsers() as empty:
        assert vdevctl(["--endpoint", empty.endpoint, "irq"]) == 1
    err = capsys.readouterr().err
    assert err == f"vdevctl: no cards to watch: the rack at {empty.endpoint} has none\n"


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_vdevd_serve_starts_serves_and_exits_cleanly_on_a_signal(sig: int) -> None:
    endpoint = free_endpoint()
    events = free_endpoint()
    with subprocess.Popen(
        [sys.executable, "-m", "vdevd", "serve", "--clock", "lockstep", "--endpoint", endpoint,
         "--events", events], stderr=subprocess.PIPE, text=True, env={**os.environ},
    ) as proc:
        try:
            with vdevclient.connect(endpoint, timeout=20) as rack:
                assert rack.card("servo0").region("bar0").read32(0) == R.CARD_ID
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=20)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 0
    assert "listening on" in err


def test_vdevd_serve_refuses_an_unknown_log_level() -> None:
    res = subprocess.run([sys.executable, "-m", "vdevd", "serve", "--log-level", "bogus"],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2
    assert "--log-level: invalid choice: 'BOGUS'" in res.stderr


def test_vdevd_serve_refuses_a_bad_config_naming_the_key(tmp_path: Path) -> None:
    cfg = tmp_path / "bad.toml"
    cfg.write_text('[[card]]\ntype = "generic-servo"\nname = "a"\naxes = 0\n')
    res = subprocess.run([sys.executable, "-m", "vdevd", "serve", "--config", str(cfg)],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 2
    assert "card[0].axes" in res.stderr
