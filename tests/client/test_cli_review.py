"""Issue 22 defect 9, tried again as a user and an attacker would (the acceptance review): every
configuration or usage error is one line naming the key or argument, exit status 2, and a
listener that cannot be bound names its key (exit status 1, `vdevd --help`)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from tests.client.test_cli_usage import one_line, run
from tests.conftest import free_endpoint


def serve(tmp_path: Path, toml: bytes, *argv: str) -> subprocess.CompletedProcess[str]:
    """`vdevd serve` of a rack file holding `toml` (it must fail to start: a guard of 120 s)."""
    path = tmp_path / "rack.toml"
    path.write_bytes(toml)
    return run("vdevd", "serve", "--config", str(path), *argv)


LOOPBACK = b'[server]\nendpoint = "tcp://127.0.0.1:0"\nevents = "tcp://127.0.0.1:0"\n'


@pytest.mark.parametrize(("toml", "says"), [
    # ZeroMQ takes a port modulo 65536: 99999 bound 34463
    (b'[server]\nendpoint = "tcp://127.0.0.1:99999"\n', "server.endpoint: 'tcp://127.0.0.1:99999'"),
    (b'[server]\nevents = "tcp://127.0.0.1:65536"\n', "server.events: 'tcp://127.0.0.1:65536'"),
    (LOOPBACK + b'[[card]]\ntype = "pmac-turbo"\nname = "pmac0"\n'
     b'ethernet = "tcp://127.0.0.1:99999"\n', "card[0].ethernet: 'tcp://127.0.0.1:99999'"),
    (LOOPBACK + b'[[card]]\ntype = "galil-dmc13x8"\nname = "g0"\n'
     b'ethernet = "tcp://127.0.0.1:70000"\n', "card[0].ethernet: 'tcp://127.0.0.1:70000'"),
    # the Galil's used to name no card: "ethernet: 'garbage' is not tcp://HOST:PORT"
    (LOOPBACK + b'[[card]]\ntype = "galil-dmc13x8"\nname = "g0"\nethernet = "garbage"\n',
     "card[0].ethernet: 'garbage'"),
    # tomllib's UnicodeDecodeError was a traceback, exit 1
    (b'[server]\nendpoint = "\xff"\n', "not valid TOML: not UTF-8 (byte 21)"),
])
def test_a_bad_value_is_one_line_naming_its_key(tmp_path: Path, toml: bytes, says: str) -> None:
    res = serve(tmp_path, toml)
    assert res.returncode == 2, res.stderr
    line = one_line(res.stderr)
    assert line.startswith("vdevd: configuration error: ") and says in line


@pytest.mark.parametrize(("argv", "key"), [
    (["--endpoint", "ipc:///nonexistent-dir/vdevd", "--events", "tcp://127.0.0.1:0"],
     "server.endpoint ipc:///nonexistent-dir/vdevd: No such file or directory"),
    (["--endpoint", "tcp://127.0.0.1:0", "--events", "ipc:///nonexistent-dir/vdevd-events"],
     "server.events ipc:///nonexistent-dir/vdevd-events: No such file or directory"),
])
def test_an_endpoint_that_cannot_be_bound_names_its_key(argv: list[str], key: str) -> None:
    res = run("vdevd", "serve", "--no-card-ports", "--log-level", "WARNING", *argv)
    assert res.returncode == 1
    assert one_line(res.stderr) == f"vdevd: cannot start: {key}\n"


@pytest.mark.parametrize(("argv", "says"), [
    # float('inf') seconds reached ZeroMQ as an int: an OverflowError traceback
    (["--timeout", "inf", "now"], "argument --timeout: 'inf' is not a number of seconds"),
    (["--timeout", "1e12", "now"], "argument --timeout: '1e12' is not a number of seconds"),
    (["--timeout", "abc", "now"], "argument --timeout: 'abc' is not a number of seconds"),
    (["irq", "--timeout", "inf"], "argument --timeout: 'inf' is not a number of seconds"),
    # an offset msgpack cannot carry: a traceback
    (["peek", "servo0", "bar0", "0x1000000000000000000"],
     "argument offset: '0x1000000000000000000' is not a number in 0..2**63-1"),
    (["peek", "servo0", "bar0", "-4"], "argument offset: '-4' is not a number in 0..2**63-1"),
    (["control", "servo0", "set_limit", "axis=99999999999999999999999"],
     "parameter axis: '99999999999999999999999' holds an integer outside"),
    (["control", "servo0", "set_limit", "axis=[1, 99999999999999999999999]"],
     "parameter axis: '[1, 99999999999999999999999]' holds an integer outside"),
    # ZeroMQ's EINVAL, exit 1; and a port it would have taken modulo 65536
    (["--endpoint", "garbage", "now"], "argument --endpoint: 'garbage' is not an endpoint"),
    (["--endpoint", "tcp://127.0.0.1:99999", "now"],
     "argument --endpoint: 'tcp://127.0.0.1:99999' is not an endpoint"),
    (["--events", "nowhere", "irq"], "argument --events: 'nowhere' is not an endpoint"),
])
def test_vdevctl_usage_errors_are_one_line_exit_2(argv: list[str], says: str) -> None:
    res = run("vdevclient.cli", *argv, env={"VDEVD_ENDPOINT": free_endpoint()})
    assert res.returncode == 2, res.stderr
    assert says in one_line(res.stderr)


@pytest.mark.parametrize("name", ["VDEVD_ENDPOINT", "VDEVD_EVENTS"])
def test_a_bad_endpoint_in_the_environment_is_one_line_naming_it(name: str) -> None:
    env = {"VDEVD_ENDPOINT": free_endpoint(), name: "garbage"}
    res = run("vdevclient.cli", "--timeout", "0.1", "now", env=env)
    assert res.returncode == 2
    assert one_line(res.stderr).startswith(f"vdevctl: ${name}: 'garbage' is not an endpoint")


def test_a_good_endpoint_is_taken() -> None:
    """The check refuses nothing ZeroMQ connects to: no daemon there, so no reply (exit 1)."""
    for endpoint in ("tcp://127.0.0.1:1", "tcp://localhost:1", "tcp://[::1]:1", "ipc:///tmp/x"):
        res = run("vdevclient.cli", "--endpoint", endpoint, "--timeout", "0.05", "now")
        assert res.returncode == 1 and "no reply" in one_line(res.stderr), (endpoint, res.stderr)
