"""`write`: plain registers store, read-only registers ignore writes, side effects run."""

from __future__ import annotations

import vdevclient

from tests.conftest import RawClient

BAR = {"card": "servo0", "region": "bar0"}
IRQ_ENABLE, OUTPUTS = 0x24, 0x2C
TARGET0 = 0x104


def test_write_then_read_back(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    bar.write32(OUTPUTS, 0xDEADBEEF)
    assert bar.read32(OUTPUTS) == 0xDEADBEEF
    bar.write16(OUTPUTS, 0x1234)
    assert bar.read32(OUTPUTS) == 0xDEAD1234
    bar.write32(TARGET0, -5)
    assert bar.read32(TARGET0) == 0xFFFFFFFB


def test_read_only_registers_ignore_writes(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    bar.write32(0x000, 0)
    assert bar.read32(0x000) == 0x56444556


def test_write_reply_is_nil(raw: RawClient) -> None:
    assert raw.call(op="write", offset=IRQ_ENABLE, data=b"\1\0\0\0", **BAR) == {"id": 1, "ok": None}
