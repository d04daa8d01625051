"""Configuration: a bad file fails at start with one clear message naming the key."""

from __future__ import annotations

from pathlib import Path

import pytest
import zmq.auth

from vdevd import config
from vdevd.config import ConfigError


def load_text(tmp_path: Path, text: str) -> config.Config:
    path = tmp_path / "rack.toml"
    path.write_text(text)
    return config.load(path)


def test_full_file_loads(tmp_path: Path) -> None:
    cfg = load_text(tmp_path, """
[server]
endpoint = "tcp://127.0.0.1:6000"
events = "ipc:///tmp/vdevd-events"
shm_dir = "/run/vdevd"
[clock]
mode = "lockstep"
[state]
dir = "/var/lib/vdevd"
[[card]]
type = "generic-servo"
name = "x1"
axes = 2
plant = "stepper"
period_ns = 250000
""")
    assert cfg.endpoint == "tcp://127.0.0.1:6000" and cfg.clock == "lockstep"
    assert cfg.state_dir == "/var/lib/vdevd" and cfg.shm_dir == "/run/vdevd"
    (card,) = cfg.cards
    assert (card.type, card.name, card.options["axes"], card.options["plant"]) == (
        "generic-servo", "x1", 2, "stepper")
    assert card.options["period_ns"] == 250000


def test_default_rack_has_one_card_of_each_type() -> None:
    from vdevd.devices import CARD_TYPES

    cfg = config.load(None)
    assert sorted(c.type for c in cfg.cards) == sorted(CARD_TYPES)
    assert cfg.endpoint == "tcp://127.0.0.1:5555" and cfg.events == "tcp://127.0.0.1:5556"
    assert cfg.clock == "realtime" and cfg.shm_dir == "/dev/shm"


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('[[card]]\ntype = "warp-drive"\nname = "a"', "card[0].type"),
        ('[[card]]\ntype = ["generic-servo"]\nname = "a"', "card[0].type"),
        ('[[card]]\ntype = "generic-servo"\nname = "servo\u00b2"', "card[0].name"),
        ('[[card]]\ntype = "generic-servo"\nname = "a b"', "card[0].name"),
        ('[security]\n', "security.server_secret_key"),
        ('[[card]]\ntype = "generic-servo"\nname = "a"\n[[card]]\ntype = "generic-servo"\n'
         'name = "a"', "card[1].name"),
        ('[[card]]\ntype = "generic-servo"\nname = "a"\naxes = 99', "card[0].axes"),
        ('[[card]]\ntype = "generic-servo"\nname = "a"\naxes = "two"', "card[0].axes"),
        ('[[card]]\ntype = "generic-servo"\nname = "a"\nplant = "steam"', "card[0].plant"),
        ('[[card]]\ntype = "generic-servo"\nname = "a"\ncolour = 1', "card[0].colour"),
        ('[[card]]\ntype = "generic-servo"', "card[0].name"),
        ('[clock]\nmode = "fast"', "clock.mode"),
        ('[clock]\nwake_us = 5', "clock.wake_us"),
        ('[server]\nendpoint = 5555', "server.endpoint"),
        ('[server]\nendpoint = "tcp://0.0.0.0:5555"', "server.endpoint"),
        ('[server]\nport = 1', "server.port"),
        ('[server]\nshm_dir = false', "server.shm_dir"),
        ('[bogus]\nx = 1', "bogus"),
        ("[[card]\n", "not valid TOML"),
        ('[[card]]\ntype = "pmac-turbo"\nname = "p"\nethernet = "tcp://0.0.0.0:1025"\n'
         'ethernet_allow = ["not-an-ip"]', "card[0].ethernet_allow[0]: 'not-an-ip' is not an IP"),
        ('[[card]]\ntype = "pmac-turbo"\nname = "p"\nethernet = "tcp://0.0.0.0:1025"',
         "card[0].ethernet: 'tcp://0.0.0.0:1025' is not loopback: add ethernet_allow"),
        ('[[card]]\ntype = "pmac-turbo"\nname = "p"\nethernet = "garbage"',
         "card[0].ethernet: 'garbage' is not tcp://HOST:PORT"),
        ('[server]\nendpoint = "tcp://127.0.0.1:notaport"', "server.endpoint: 'tcp://127.0.0.1"),
        ('[server]\nevents = "127.0.0.1:5556"', "server.events: '127.0.0.1:5556' is not a ZeroMQ"),
        ('[server]\nmax_scheduled = -1', "server.max_scheduled"),
        ('[server]\nmax_scheduled_per_client = "many"', "server.max_scheduled_per_client"),
        ('[server]\nheartbeat_s = 10', "server.heartbeat_s"),
        ('[server]\nheartbeat_s = true', "server.heartbeat_s"),
    ],
)
def test_bad_files_name_the_key(tmp_path: Path, text: str, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_text(tmp_path, text)
    assert key in str(info.value)


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="No such file"):
        config.load(tmp_path / "absent.toml")


def test_security_key_files_are_checked_when_the_file_is_loaded(tmp_path: Path) -> None:
    """A bad key file fails at start like any bad key (exit status 2), naming the key."""
    public, secret = zmq.auth.create_certificates(tmp_path, "server")
    keys = tmp_path / "clients"
    keys.mkdir()

    def security(secret_file: str, keys_dir: str) -> str:
        return f'[security]\nserver_secret_key = "{secret_file}"\nclient_keys_dir = "{keys_dir}"\n'

    for text, key in [
        (security(str(tmp_path / "absent.key_secret"), str(keys)), "security.server_secret_key"),
        (security(public, str(keys)), "security.server_secret_key"),  # a public key only
        (security(secret, str(tmp_path / "absent")), "security.client_keys_dir"),
    ]:
        with pytest.raises(ConfigError) as info:
            load_text(tmp_path, text)
        assert str(info.value).startswith(key + ":"), info.value
    assert load_text(tmp_path, security(secret, str(keys))).curve is not None
