"""CURVE: with a [security] section only clients with an allowed key are served (DESIGN.md)."""

from __future__ import annotations

from pathlib import Path

import pytest
import vdevclient
import zmq.auth

from tests.conftest import rack_config
from vdevd.security import CurveConfig, is_local
from vdevd.testing import DaemonThread


def test_loopback_detection() -> None:
    assert is_local("tcp://127.0.0.1:5555") and is_local("tcp://localhost:1")
    assert is_local("tcp://[::1]:5555") and is_local("ipc:///tmp/x")
    assert not is_local("tcp://0.0.0.0:5555") and not is_local("tcp://10.1.2.3:5555")
    assert not is_local("tcp://*:5555")


def test_only_allowed_client_keys_are_served(tmp_path: Path) -> None:
    allowed, other = tmp_path / "allowed", tmp_path / "other"
    allowed.mkdir()
    other.mkdir()
    _, server_secret = zmq.auth.create_certificates(tmp_path, "server")
    client_public, client_secret = zmq.auth.create_certificates(tmp_path, "client")
    _, stranger_secret = zmq.auth.create_certificates(other, "stranger")
    Path(client_public).rename(allowed / "client.key")
    cfg = rack_config()
    cfg.curve = CurveConfig(str(server_secret), str(allowed))
    server_public = str(tmp_path / "server.key")
    with DaemonThread(cfg) as d:
        with vdevclient.connect(d.endpoint, server_key=server_public,
                                client_key=str(client_secret)) as rack:
            assert rack.card("servo0").region("bar0").read32(0) == 0x56444556
            assert rack.card("servo0").region("bar0").mapped  # CURVE too: the file mode decides
        with pytest.raises(vdevclient.VdevTimeout):
            vdevclient.connect(d.endpoint, server_key=server_public,
                               client_key=str(stranger_secret), timeout=0.5)
        with pytest.raises(vdevclient.VdevTimeout):
            vdevclient.connect(d.endpoint, timeout=0.5)
