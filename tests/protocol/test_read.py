"""`read`: plain memory, register widths, byte order, block reads (PROTOCOL.md, Register access)."""

from __future__ import annotations

import vdevclient

from tests.conftest import RawClient

BAR = {"card": "servo0", "region": "bar0"}


def test_read_returns_the_identity_register_in_little_endian(raw: RawClient) -> None:
    assert raw.call(op="read", offset=0, size=4, **BAR)["ok"] == (0x56444556).to_bytes(4, "little")


def test_reads_of_each_bus_width(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    assert bar.read32(0x000) == 0x56444556
    assert bar.read16(0x002) == 0x5644
    assert bar.read8(0x000) == 0x56
    assert bar.read32(0x008) == 4  # AXES
    assert bar.read32(0x00C) == 1_000_000  # PERIOD_NS


def test_block_read_spans_registers_and_plain_memory(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    block = bar.read(0, 16)
    assert block[:4] == (0x56444556).to_bytes(4, "little")
    assert int.from_bytes(block[8:12], "little") == 4
    assert len(bar.read(0, 0x1000)) == 0x1000
