"""`hello`: version, capabilities, cards with regions and irq lines, events endpoint (PROTOCOL.md)."""

from __future__ import annotations

from tests.conftest import RawClient

#: PROTOCOL.md, `hello`: what a v1 server implements, and the 1 MiB maximum message
V1_CAPABILITIES = {"read", "write", "rep", "batch", "batch.compact", "wait.irq", "wait.value", "sim",
                   "control", "stats", "sync", "shm"}


def test_hello_reports_version_capabilities_and_limits(raw: RawClient) -> None:
    info = raw.call(op="hello", client="test")["ok"]
    assert info["protocol"] == 1
    assert set(info["capabilities"]) == V1_CAPABILITIES
    assert info["max_message"] == 1 << 20
    assert info["events"].startswith("tcp://127.0.0.1:")
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
