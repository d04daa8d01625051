"""`hello`: version, capabilities, cards with regions and irq lines, events endpoint (PROTOCOL.md)."""

from __future__ import annotations

import ipaddress
import os
import socket
import tempfile

import pytest
import vdevclient

from tests.conftest import RawClient, rack_config
from vdevd.testing import DaemonThread

#: PROTOCOL.md, `hello`: what a v1 server implements, and the 1 MiB maximum message
V1_CAPABILITIES = {"read", "write", "rep", "batch", "batch.compact", "wait.irq", "wait.value", "sim",
                   "control", "stats", "sync", "shm", "heartbeat", "scope",
                   "snapshot"}


def test_hello_reports_version_capabilities_and_limits(raw: RawClient) -> None:
    info = raw.call(op="hello", client="test")["ok"]
    assert info["protocol"] == 1
    assert set(info["capabilities"]) == V1_CAPABILITIES
    assert info["max_message"] == 1 << 20
    assert info["events"].startswith("tcp://127.0.0.1:")
    assert info["heartbeat_ns"] == 2_000_000_000  # [server] heartbeat_s's default
    assert info["clock"] == {"mode": "lockstep", "now_ns": 0, "tick_ns": 1_000_000}


def test_hello_lists_cards_with_regions_irq_lines_and_controls(raw: RawClient) -> None:
    (card,) = raw.call(op="hello")["ok"]["cards"]
    assert card["name"] == "servo0"
    assert card["type"] == "generic-servo"
    assert card["endian"] == "little"
    assert card["irq"] == ["inta"]
    bar, config = card["regions"]
    assert (bar["name"], bar["size"], bar["widths"]) == ("bar0", 0x1000, [1, 2, 4])
    assert (config["name"], config["size"], config["widths"]) == ("config", 256, [1, 2, 4])
    assert {"set_limit", "amp_fault", "encoder_loss"} <= set(card["controls"])
    assert "axis" in card["controls"]["set_limit"]["params"]
    assert card["deprecated"]["amp_fault"] == "set_amp_fault"


# -- shared memory (decision 0010) ------------------------------------------------------------------
def test_regions_list_their_passive_ranges(raw: RawClient) -> None:
    bar, config = raw.call(op="hello")["ok"]["cards"][0]["regions"]
    assert bar["passive"][0] == [0x2C, 0x30]  # OUTPUTS, then each axis's parameters
    assert bar["passive"][1:] == [[0x104 + 0x40 * a, 0x118 + 0x40 * a] for a in range(4)]
    assert config["passive"] == []


def test_hello_to_a_local_client_announces_the_shared_memory(raw: RawClient) -> None:
    shm = raw.call(op="hello")["ok"]["shm"]
    assert shm["regions"] == {"servo0": {"bar0": 4096}}  # after the header page; config: hooks
    st = os.stat(shm["path"])
    assert (st.st_dev, st.st_ino) == (shm["dev"], shm["ino"]) and st.st_size == shm["size"]
    assert st.st_mode & 0o777 == 0o600


def test_an_ipc_endpoint_is_local() -> None:
    with tempfile.TemporaryDirectory(prefix="vd", dir="/tmp") as tmp:
        cfg = rack_config()
        cfg.endpoint, cfg.events = f"ipc://{tmp}/rack", f"ipc://{tmp}/events"
        with DaemonThread(cfg) as d:
            client = RawClient(d.endpoint)
            try:
                assert "shm" in client.call(op="hello")["ok"]
            finally:
                client.close()


def host_address() -> str | None:
    """This machine's address on its default route, if it has one that is not loopback."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.connect(("192.0.2.1", 9))  # no packet is sent: the kernel only picks the route
            host = str(s.getsockname()[0])
        except OSError:
            return None
    return None if ipaddress.ip_address(host).is_loopback else host


def test_hello_to_a_remote_client_has_no_shared_memory() -> None:
    """A TCP peer that is not loopback (this machine's own address stands in for another
    machine's) gets no mapping; the same daemon's loopback peers would."""
    host = host_address()
    if host is None:
        pytest.skip("no non-loopback address")
    cfg = rack_config()
    cfg.endpoint = f"tcp://{host}:*"
    with DaemonThread(cfg) as d:
        client = RawClient(d.endpoint)
        try:
            info = client.call(op="hello")["ok"]
        finally:
            client.close()
        assert "shm" not in info and info["cards"][0]["regions"][0]["passive"]
        with vdevclient.connect(d.endpoint) as rack:
            assert rack.shm is None and not rack.card("servo0").region("bar0").mapped
