"""`read`/`write` with `rep`: repeated single accesses of one register, a FIFO port (PROTOCOL.md
"Register access", decision record 0005)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.conftest import RawClient, error_code
from vdevd.devices.base import Card, CardContext
from vdevd.region import Region
from vdevd.testing import DaemonThread, rack_of


class FifoPort(Card):
    """A byte FIFO at offset 1 of a D08 window and a 16-bit FIFO at offset 0 of a D16 one;
    offset 3 of the D08 window is plain memory."""

    type_name = "fifo-port"

    def __init__(self, name: str, ctx: CardContext) -> None:
        super().__init__(name, {}, ctx)
        self.queue = bytearray(b"HELLO")
        self.got = bytearray()
        a16 = self.add_region(Region("a16", 16, widths=(1,), block=False, endian="big"))
        a16.hook(1, 1, on_read=self._pop, on_write=self._push)
        d16 = self.add_region(Region("d16", 4, widths=(2,), block=False))
        d16.hook(0, 2, on_read=lambda o, n: bytes(self._pop(o, 1) + self._pop(o, 1)),
                 on_write=lambda o, d: self.got.extend(d))

    def _pop(self, offset: int, size: int) -> bytes:
        if not self.queue:
            return b"\xff"
        b = self.queue[0]
        del self.queue[0]
        return bytes((b,))

    def _push(self, offset: int, data: bytes) -> None:
        self.got += data


@pytest.fixture
def fifo() -> Iterator[tuple[RawClient, FifoPort]]:
    card: list[FifoPort] = []

    def make(ctx: CardContext) -> FifoPort:
        card.append(FifoPort("f0", ctx))
        return card[0]

    with DaemonThread(rack=rack_of(make)) as d:
        client = RawClient(d.endpoint)
        yield client, card[0]
        client.close()


A16 = {"card": "f0", "region": "a16"}


def test_rep_read_pops_the_fifo_once_per_byte(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, _ = fifo
    assert raw.call(op="read", offset=1, size=3, rep=True, **A16)["ok"] == b"HEL"
    assert raw.call(op="read", offset=1, size=4, rep=True, **A16)["ok"] == b"LO\xff\xff"


def test_rep_write_pushes_every_byte_in_order(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, card = fifo
    assert raw.call(op="write", offset=1, data=b"TPX\r", rep=True, **A16) == {"id": 1, "ok": None}
    assert bytes(card.got) == b"TPX\r"


def test_rep_on_plain_memory_reads_the_same_byte_again(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, _ = fifo
    raw.call(op="write", offset=3, data=b"\x5a", **A16)
    assert raw.call(op="read", offset=3, size=3, rep=True, **A16)["ok"] == b"\x5a\x5a\x5a"


def test_rep_uses_the_bus_width_of_the_region(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, card = fifo
    where = {"card": "f0", "region": "d16", "offset": 0}
    assert raw.call(op="read", size=4, rep=True, **where)["ok"] == b"HELL"
    assert error_code(raw.call(op="read", size=3, rep=True, **where)) == "bad_width"
    raw.call(op="write", data=b"abcd", rep=True, **where)
    assert bytes(card.got) == b"abcd"


def test_rep_errors(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, _ = fifo
    assert error_code(raw.call(op="read", offset=16, size=1, rep=True, **A16)) == "out_of_range"
    assert error_code(raw.call(op="read", offset=1, size=0, rep=True, **A16)) == "out_of_range"
    assert error_code(raw.call(op="read", offset=1, size=1, rep=1, **A16)) == "malformed"


def test_rep_ops_run_in_a_batch(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, _ = fifo
    ops = [{"op": "write", "offset": 1, "data": b"AB", "rep": True, **A16},
           {"op": "read", "offset": 1, "size": 2, "rep": True, **A16}]
    assert raw.call(op="batch", ops=ops)["ok"] == [None, b"HE"]


def test_compact_repeated_accesses_are_the_rep_maps(fifo: tuple[RawClient, FifoPort]) -> None:
    raw, card = fifo
    ops = [["W", "f0", "a16", 1, b"ab"], ["R", "f0", "a16", 1, 3]]
    assert raw.call(op="batch", ops=ops)["ok"] == [None, b"HEL"]
    assert card.got == b"ab"
