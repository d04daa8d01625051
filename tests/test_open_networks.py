"""`[security] allow_unauthenticated_networks`: a non-loopback endpoint without CURVE, for a
private network named explicitly (a CI cluster's), its peers only; logged as a warning
(issue 22 "Containers")."""

from __future__ import annotations

import logging

import pytest
import vdevclient

from tests.conftest import rack_config
from tests.test_http_health import own_address
from vdevd.config import ConfigError, parse
from vdevd.testing import DaemonThread

ANY = "tcp://0.0.0.0:*"


def test_configuration() -> None:
    cfg = parse({"server": {"endpoint": "tcp://0.0.0.0:5555", "events": "tcp://0.0.0.0:5556"},
                 "security": {"allow_unauthenticated_networks": ["10.0.0.0/8", "192.168.1.7"]}})
    assert cfg.open_networks == ("10.0.0.0/8", "192.168.1.7") and cfg.curve is None
    with pytest.raises(ConfigError, match=r"server\.endpoint: .* allow_unauthenticated_networks"):
        parse({"server": {"endpoint": "tcp://0.0.0.0:5555"}})  # CURVE stays the default
    for value in ([], "10.0.0.0/8", ["10.0.0.0/33"], ["ten"]):
        with pytest.raises(ConfigError, match=r"security\.allow_unauthenticated_networks"):
            parse({"security": {"allow_unauthenticated_networks": value}})
    with pytest.raises(ConfigError, match=r"allow_unauthenticated_networks: .*server_secret_key"):
        parse({"security": {"allow_unauthenticated_networks": ["10.0.0.0/8"],
                            "server_secret_key": "k", "client_keys_dir": "d"}})


def connects(endpoint: str) -> bool:
    try:
        with vdevclient.connect(endpoint, timeout=1.0) as rack:
            return bool(rack.card("servo0").region("bar0").read32(0) == 0x56444556)
    except vdevclient.VdevTimeout:
        return False


def test_only_the_named_networks_are_served(caplog: pytest.LogCaptureFixture) -> None:
    address = own_address()
    for networks, reached in ((("10.0.0.0/8",), False), ((f"{address}/32",), True)):
        cfg = rack_config()
        cfg.endpoint = cfg.events = ANY
        cfg.open_networks = networks
        with caplog.at_level(logging.WARNING, logger="vdevd.security"), DaemonThread(cfg) as d:
            port = d.endpoint.rsplit(":", 1)[1]
            assert connects(f"tcp://127.0.0.1:{port}")  # loopback always
            assert connects(f"tcp://{address}:{port}") is reached
        assert any("WITHOUT CURVE" in r.message and networks[0] in r.message
                   for r in caplog.records)
        caplog.clear()
