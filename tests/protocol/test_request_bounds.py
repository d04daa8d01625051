"""Issue 22 defects 1 and 3: a request is held to the daemon's limits before any work is done
for it (PROTOCOL.md "Size", "control"). A read or a batch whose reply cannot fit `max_message`,
or whose repeated accesses would call register hooks more than MAX_REP_HOOK_CALLS times, is
`too_large` without touching a register, and other clients are served meanwhile; scheduled
backdoor actions are bounded per client and in all (`busy`), and counted in `stats`."""

from __future__ import annotations

from collections.abc import Iterator

import msgpack
import pytest

from tests.conftest import RawClient, error_code, rack_config
from vdevd.bounds import (
    MAX_BATCH_CONTROLS,
    MAX_READ,
    MAX_REP_HOOK_CALLS,
    MAX_SCHEDULED,
    MAX_SCHEDULED_PER_CLIENT,
)
from vdevd.devices.base import Card, CardContext, control
from vdevd.protocol import MAX_MESSAGE
from vdevd.region import Region
from vdevd.testing import DaemonThread, rack_of

MS = 1_000_000
DAY_NS = 86_400 * 1_000_000_000


class CountingFifo(Card):
    """A byte FIFO port at offset 0 of a D08 window (the rest plain memory) that counts the
    reads and writes it serves, 2 MiB of plain memory, and a backdoor action that counts its
    runs."""

    type_name = "counting-fifo"

    def __init__(self, name: str, ctx: CardContext) -> None:
        super().__init__(name, {}, ctx)
        self.pops = 0
        self.pushes = 0
        self.runs = 0
        port = self.add_region(Region("port", 16, widths=(1,), block=False))
        port.hook(0, 1, on_read=self._pop, on_write=self._push)
        self.add_region(Region("mem", 2 << 20, widths=(1, 2, 4)))

    @control()
    def tally(self) -> None:
        """Count a run (a harmless action to schedule)."""
        self.runs += 1

    def _pop(self, offset: int, size: int) -> bytes:
        self.pops += 1
        return b"\x00"

    def _push(self, offset: int, data: bytes) -> None:
        self.pushes += 1


@pytest.fixture
def fifo() -> Iterator[tuple[DaemonThread, CountingFifo]]:
    card: list[CountingFifo] = []

    def make(ctx: CardContext) -> CountingFifo:
        card.append(CountingFifo("f0", ctx))
        return card[0]

    with DaemonThread(rack=rack_of(make)) as d:
        yield d, card[0]


def client(d: DaemonThread) -> RawClient:
    c = RawClient(d.endpoint)
    c.sock.rcvtimeo = 5_000  # a guard: an answer after the work would take far longer
    return c


@pytest.mark.parametrize("size", [MAX_READ + 1, MAX_MESSAGE, 1 << 24, 1 << 28, 1 << 40])
def test_a_repeated_read_too_large_for_its_reply_is_refused_before_one_access(
        fifo: tuple[DaemonThread, CountingFifo], size: int) -> None:
    d, card = fifo
    c = client(d)
    reply = c.call(op="read", card="f0", region="port", offset=0, size=size, rep=True)
    assert error_code(reply) == "too_large" and "max_message" in reply["error"]["message"]
    assert card.pops == 0
    c.close()


def test_the_largest_repeated_read_whose_reply_fits_is_served(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    d, card = fifo
    c = client(d)
    c.call(op="write", card="f0", region="port", offset=1, data=b"\x5a")
    reply = c.call(op="read", card="f0", region="port", offset=1, size=MAX_READ, rep=True)
    assert reply["ok"] == b"\x5a" * MAX_READ and card.pops == 0  # plain memory, again and again
    c.close()


def test_repeated_accesses_through_a_hook_are_bounded_before_the_first_call(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    d, card = fifo
    c = client(d)
    over = MAX_REP_HOOK_CALLS + 1
    reply = c.call(op="read", card="f0", region="port", offset=0, size=over, rep=True)
    assert error_code(reply) == "too_large" and str(MAX_REP_HOOK_CALLS) in reply["error"]["message"]
    reply = c.call(op="write", card="f0", region="port", offset=0, data=bytes(over), rep=True)
    assert error_code(reply) == "too_large"
    assert (card.pops, card.pushes) == (0, 0)
    half = ["R", "f0", "port", 0, MAX_REP_HOOK_CALLS // 2 + 1]  # two of them: one call over
    reply = c.call(op="batch", ops=[half, ["W", "f0", "port", 1, bytes(over)], half])
    assert error_code(reply) == "too_large" and "nothing was run" in reply["error"]["message"]
    assert (card.pops, card.pushes) == (0, 0)
    assert len(c.call(op="read", card="f0", region="port", offset=0, size=MAX_REP_HOOK_CALLS,
                      rep=True)["ok"]) == MAX_REP_HOOK_CALLS
    assert card.pops == MAX_REP_HOOK_CALLS
    c.close()


def test_a_plain_read_too_large_for_its_reply_is_refused_before_the_copy(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    d, _ = fifo
    c = client(d)
    for size in (MAX_READ + 1, 2 << 20):  # the region holds them: only the reply cannot
        assert error_code(c.call(op="read", card="f0", region="mem", offset=0,
                                 size=size)) == "too_large"
    stats = c.call(op="stats")["ok"]
    assert stats["requests"]["errors"] == 2
    c.close()


@pytest.mark.parametrize("form", ["compact", "map"])
def test_a_batch_whose_reads_add_up_beyond_max_message_runs_none_of_its_ops(
        fifo: tuple[DaemonThread, CountingFifo], form: str) -> None:
    d, card = fifo
    c = client(d)
    part = 64 << 10  # 17 reads of 64 KiB: each fits, together they do not
    if form == "compact":
        ops: list[object] = [["w", "f0", "mem", 0, b"\x01"]]
        ops += [["r", "f0", "mem", 0, part]] * 16 + [["R", "f0", "port", 0, 2]]
    else:
        ops = [{"op": "write", "card": "f0", "region": "mem", "offset": 0, "data": b"\x01"}]
        ops += [{"op": "read", "card": "f0", "region": "mem", "offset": 0, "size": part}] * 16
        ops += [{"op": "read", "card": "f0", "region": "port", "offset": 0, "size": 2,
                 "rep": True}]
    reply = c.call(op="batch", ops=ops)
    assert error_code(reply) == "too_large" and "nothing was run" in reply["error"]["message"]
    assert card.pops == 0
    assert c.call(op="read", card="f0", region="mem", offset=0, size=1)["ok"] == b"\x00"
    ok = c.call(op="batch", ops=ops[:15] + ops[-1:])  # 14 reads of 64 KiB fit
    assert [len(r) for r in ok["ok"][1:]] == [part] * 14 + [2] and card.pops == 2
    assert ok["ok"][1][:1] == b"\x01"
    c.close()


def test_other_clients_are_served_while_an_oversized_read_is_refused() -> None:
    """The issue's reproduction on the default servo card: `rep` reads of 16 MiB and 256 MiB,
    each answered `too_large` at once, with another client's requests between them."""
    with DaemonThread(rack_config()) as d:
        a, b = client(d), client(d)
        for size in (1 << 24, 1 << 28):
            a.sock.send(msgpack.packb(
                {"id": size, "op": "read", "card": "servo0", "region": "bar0", "offset": 0,
                 "size": size, "rep": True}))
            assert b.call(op="sim", action="now")["ok"]["mode"] == "lockstep"
            reply = msgpack.unpackb(a.sock.recv())
            assert reply["id"] == size and reply["error"]["code"] == "too_large"
        a.close()
        b.close()


def schedule(c: RawClient, n: int, after_ns: int = DAY_NS) -> dict[str, object]:
    """`n` scheduled controls `after_ns` ahead, in batches of MAX_BATCH_CONTROLS: the results
    of all ({"ok": [...]}), or the first error reply."""
    op = {"op": "control", "card": "f0", "action": "tally", "after_ns": after_ns}
    results: list[object] = []
    while len(results) < n:
        reply = c.call(op="batch", ops=[op] * min(MAX_BATCH_CONTROLS, n - len(results)))
        if "ok" not in reply:
            return reply
        results += reply["ok"]
    return {"ok": results}


def test_scheduled_controls_are_bounded_per_client_and_counted_in_stats(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    d, _ = fifo
    a, b = client(d), client(d)
    assert len(schedule(a, MAX_SCHEDULED_PER_CLIENT)["ok"]) == MAX_SCHEDULED_PER_CLIENT
    reply = a.call(op="control", card="f0", action="tally", after_ns=DAY_NS)
    assert error_code(reply) == "busy" and str(MAX_SCHEDULED_PER_CLIENT) in reply["error"]["message"]
    assert "ok" in b.call(op="control", card="f0", action="tally", after_ns=DAY_NS)
    assert a.call(op="stats")["ok"]["requests"]["scheduled"] == MAX_SCHEDULED_PER_CLIENT + 1
    assert a.call(op="control", card="f0", action="tally")["ok"] is None  # now: no limit
    a.close()
    b.close()


def test_scheduled_controls_are_bounded_in_all_and_free_again_once_run(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    d, card = fifo
    clients = [client(d) for _ in range(MAX_SCHEDULED // MAX_SCHEDULED_PER_CLIENT + 1)]
    for c in clients[:-1]:
        assert "ok" in schedule(c, MAX_SCHEDULED_PER_CLIENT, after_ns=MS)
    last = clients[-1]
    reply = last.call(op="control", card="f0", action="tally", after_ns=MS)
    assert error_code(reply) == "busy" and str(MAX_SCHEDULED) in reply["error"]["message"]
    assert last.call(op="stats")["ok"]["requests"]["scheduled"] == MAX_SCHEDULED
    assert "ok" in last.call(op="sim", action="step", ns=2 * MS)
    assert card.runs == MAX_SCHEDULED
    assert last.call(op="stats")["ok"]["requests"]["scheduled"] == 0
    assert "ok" in last.call(op="control", card="f0", action="tally", after_ns=MS)
    for c in clients:
        c.close()
