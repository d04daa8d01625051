"""Issue 22 defect 9 and the CLI: every configuration or usage error is one line naming the key
or argument, exit status 2; `--version` on both commands; every argument's help gives its unit
and default; card ports moved or switched off from the command line; IPv6 loopback endpoints."""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import vdevclient
import zmq.auth
from vdevclient.cli import main as vdevctl
from vdevclient.cli import parser as vdevctl_parser

from tests.conftest import free_endpoint
from vdevd import card_ports
from vdevd.cli import main as vdevd_main
from vdevd.cli import parser as vdevd_parser
from vdevd.config import DEFAULT_ENDPOINT, DEFAULT_EVENTS, ConfigError, default_config
from vdevd.devices.generic import regions as R
from vdevd.testing import DaemonThread


def run(*argv: str, env: dict[str, str] | None = None,
        stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", *argv], capture_output=True, text=True,
                          timeout=120, env={**os.environ, **(env or {})}, input=stdin)


def one_line(text: str) -> str:
    assert text.endswith("\n") and text.count("\n") == 1 and "Traceback" not in text, text
    return text


@pytest.mark.parametrize(("main", "name"), [(vdevd_main, "vdevd"), (vdevctl, "vdevctl")])
def test_version_on_both_commands(main: object, name: str,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    from importlib import metadata

    with pytest.raises(SystemExit) as exit_:
        main(["--version"])  # type: ignore[operator]
    assert exit_.value.code == 0
    assert capsys.readouterr().out == f"{name} {metadata.version('vdevd')}\n"


def every_argument(p: argparse.ArgumentParser, where: str = "") -> Iterator[
        tuple[str, argparse.Action]]:
    for action in p._actions:
        if isinstance(action, argparse._SubParsersAction):
            assert action.help, f"{where} COMMAND: no help"
            for name, sub in action.choices.items():
                yield from every_argument(sub, f"{where} {name}")
        elif not isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            yield f"{where} {'/'.join(action.option_strings) or action.dest}", action


@pytest.mark.parametrize("make", [vdevd_parser, vdevctl_parser])
def test_every_argument_has_help_with_its_default(make: object) -> None:
    for where, action in every_argument(make()):  # type: ignore[operator]
        assert action.help, f"{where}: no help"
        takes_value = action.nargs != 0
        if takes_value or action.option_strings:
            assert "default" in action.help or "required" in action.help, \
                f"{where}: the help says neither its default nor that it is required"


def test_serve_help_shows_the_default_endpoints_and_clock() -> None:
    out = run("vdevd", "serve", "--help").stdout
    flat = " ".join(out.split())
    assert DEFAULT_ENDPOINT in flat and DEFAULT_EVENTS in flat and "clock realtime" in flat


def test_types_into_a_pipe_closed_early_ends_without_a_traceback() -> None:
    with subprocess.Popen([sys.executable, "-m", "vdevd", "types"], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, bufsize=0) as proc:
        assert proc.stdout is not None and proc.stderr is not None
        proc.stdout.close()  # as `| head -2` does once it has its lines: before the output
        err = proc.stderr.read().decode()
        proc.wait(timeout=60)
    assert "Traceback" not in err and "BrokenPipeError" not in err, err


def test_a_control_parameter_without_a_value_is_a_usage_error_before_any_connection(
        capsys: pytest.CaptureFixture[str]) -> None:
    """No daemon listens there: the usage error comes first (it used to be exit 1, no reply)."""
    with pytest.raises(SystemExit) as exit_:
        vdevctl(["--endpoint", free_endpoint(), "--timeout", "0.1", "control", "servo0",
                 "set_limit", "axis"])
    assert exit_.value.code == 2
    err = one_line(capsys.readouterr().err)
    assert err.startswith("vdevctl control: argument KEY=VALUE: parameter 'axis' is not ")


@pytest.mark.parametrize("argv", [["serve", "--log-level", "bogus"], ["serve", "--clock", "x"],
                                  ["bogus"]])
def test_vdevd_usage_errors_are_one_line_exit_2(argv: list[str]) -> None:
    res = run("vdevd", *argv)
    assert res.returncode == 2
    one_line(res.stderr)


@pytest.fixture
def keys(tmp_path: Path) -> dict[str, Path]:
    server_public, _ = zmq.auth.create_certificates(tmp_path, "server")
    client_public, client_secret = zmq.auth.create_certificates(tmp_path, "client")
    return {"server": Path(server_public), "client_public": Path(client_public),
            "client_secret": Path(client_secret)}


def test_a_server_key_without_a_client_key_is_an_error_naming_the_missing_one(
        keys: dict[str, Path]) -> None:
    env = {"VDEVD_SERVER_KEY": str(keys["server"]), "VDEVD_CLIENT_KEY": ""}
    res = run("vdevclient.cli", "--endpoint", free_endpoint(), "--timeout", "0.1", "now",
              env=env)
    assert res.returncode == 2
    assert one_line(res.stderr).startswith(
        "vdevctl: $VDEVD_SERVER_KEY is set but $VDEVD_CLIENT_KEY is not")
    with pytest.raises(vdevclient.ConfigurationError, match="client_key is set but "):
        vdevclient.connect(free_endpoint(), client_key=str(keys["client_secret"]))


def test_a_public_key_given_as_the_client_key_is_an_error_naming_it(
        keys: dict[str, Path]) -> None:
    env = {"VDEVD_SERVER_KEY": str(keys["server"]),
           "VDEVD_CLIENT_KEY": str(keys["client_public"])}
    res = run("vdevclient.cli", "--endpoint", free_endpoint(), "--timeout", "0.1", "now",
              env=env)
    assert res.returncode == 2
    assert one_line(res.stderr) == (f"vdevctl: $VDEVD_CLIENT_KEY: {keys['client_public']} holds "
                                    "no secret key (a public key file? give this client's "
                                    ".key_secret file)\n")


def test_an_unreadable_key_file_is_an_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(vdevclient.ConfigurationError, match="server_key: .*absent"):
        vdevclient.connect(free_endpoint(), server_key=str(tmp_path / "absent"),
                           client_key=str(tmp_path / "absent2"))


def test_a_pmac_allow_list_entry_that_is_no_address_stops_the_start_naming_it(
        tmp_path: Path) -> None:
    """It used to log "listening", then exit 1 with the ipaddress module's words."""
    cfg = tmp_path / "rack.toml"
    cfg.write_text('[[card]]\ntype = "pmac-turbo"\nname = "pmac0"\n'
                   'ethernet = "tcp://0.0.0.0:0"\nethernet_allow = ["not-an-ip"]\n')
    res = run("vdevd", "serve", "--config", str(cfg))
    assert res.returncode == 2
    assert one_line(res.stderr) == (
        "vdevd: configuration error: card[0].ethernet_allow[0]: 'not-an-ip' is not an IP "
        "address or network (\"192.168.1.0/24\", \"10.0.0.5\")\n")


def ipv6_loopback() -> bool:
    try:
        with socket.socket(socket.AF_INET6) as s:
            s.bind(("::1", 0))
        return True
    except OSError:
        return False


@pytest.mark.skipif(not ipv6_loopback(), reason="no IPv6 loopback on this machine")
def test_an_ipv6_loopback_endpoint_serves() -> None:
    """The README calls tcp://[::1]:PORT loopback; it used to fail with "No such device"."""
    with DaemonThread(endpoint="tcp://[::1]:*", events="tcp://[::1]:*") as d:
        assert d.endpoint.startswith("tcp://[::1]:") and d.events.startswith("tcp://[::1]:")
        with vdevclient.connect(d.endpoint, timeout=10) as rack:
            assert rack.card("servo0").region("bar0").read32(0) == R.CARD_ID
            assert rack.events_endpoint == d.events
            assert rack.shm is not None  # a loopback peer is local: the shared memory too


@pytest.mark.parametrize(("argv", "says"), [
    (["pmac0"], "--card-port pmac0: not CARD.KEY=VALUE"),
    (["pmac9.ethernet=0"], "--card-port pmac9.ethernet=0: no card 'pmac9'"),
    (["maxk0.ethernet=1"], "--card-port maxk0.ethernet=1: maxk0 (oms-maxk) has no port key"),
    (["pmac0.device=1"], "has no port key 'device' (port keys: ethernet)"),
    (["pmac0.ethernet=70000"], "'70000' is not a port (0..65535), tcp://HOST:PORT or off"),
    (["pmac0.ethernet=tcp://0.0.0.0:1"], "--card-port pmac0.ethernet: 'tcp://0.0.0.0:1' is "
                                         "not loopback"),
    (["galil0.ethernet=tcp://0.0.0.0:1"], "--card-port galil0.ethernet: 'tcp://0.0.0.0:1' is "
                                          "not loopback"),
])
def test_a_bad_card_port_argument_names_it(argv: list[str], says: str) -> None:
    with pytest.raises(ConfigError, match=None) as info:
        card_ports.apply(default_config(), argv)
    assert says in str(info.value)


def ports(cfg: object) -> dict[str, str]:
    return {spec.name: spec.options["ethernet"] for spec in cfg.cards  # type: ignore[attr-defined]
            if "ethernet" in spec.options}


def test_card_ports_move_and_switch_off() -> None:
    cfg = default_config()
    assert ports(cfg)["pmac0"] == "tcp://127.0.0.1:1025"
    card_ports.apply(cfg, ["pmac0.ethernet=1026", "galil0.ethernet=0"])
    assert ports(cfg) == {"galil0": "tcp://127.0.0.1:0", "pmac0": "tcp://127.0.0.1:1026"}
    card_ports.apply(cfg, ["pmac0.ethernet=off"])
    assert ports(cfg)["pmac0"] == ""
    cfg = default_config()
    card_ports.apply(cfg, ["galil0.ethernet=tcp://[::1]:0"], all_off=True)
    assert ports(cfg) == {"galil0": "tcp://[::1]:0", "pmac0": ""}


def test_serve_with_a_card_port_moved_binds_it_there(tmp_path: Path) -> None:
    ready = tmp_path / "ready.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "vdevd", "serve", "--clock", "lockstep", "--endpoint",
         "tcp://127.0.0.1:*", "--events", "tcp://127.0.0.1:*", "--card-port", "pmac0.ethernet=0",
         "--ready-file", str(ready)], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60  # a guard against a daemon that never starts
        while not ready.exists():
            assert proc.poll() is None and time.monotonic() < deadline, "vdevd did not start"
            time.sleep(0.01)
        cards = json.loads(ready.read_text())["cards"]
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    port = int(cards["pmac0"]["ethernet"].rpartition(":")[2])
    assert cards["pmac0"]["ethernet"].startswith("tcp://127.0.0.1:") and port not in (0, 1025)
