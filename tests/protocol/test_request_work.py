"""Issue 22 defects 1 and 3, the work a request may make (PROTOCOL.md "Size", "control"): a
batch's block accesses of a window of registers count their hook calls as repeated accesses
do, a repeated access of a register outside a card's FIFO fast path counts one call per single
access, a batch holds at most MAX_BATCH_CONTROLS `control` ops, and scheduled actions due at
one time run TIMERS_A_SERVICE at a time, the waits answered once all have run."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import msgpack
import pytest

from tests.conftest import RawClient, error_code, rack_config
from tests.protocol.test_request_bounds import CountingFifo, client
from vdevd.bounds import MAX_BATCH_CONTROLS, MAX_HELD_OPS, MAX_REP_HOOK_CALLS
from vdevd.config import CardSpec
from vdevd.devices import card_class
from vdevd.devices.base import CardContext
from vdevd.devices.galil.bus import A16Reg
from vdevd.testing import DaemonThread, rack_of
from vdevd.waits import TIMERS_A_SERVICE, Waiter, Waits

DATA, CONTROL = int(A16Reg.DATA), int(A16Reg.CONTROL)


@pytest.fixture
def galil() -> Iterator[RawClient]:
    """A live daemon with a Galil DMC-13X8 `galil0`: its A16 window is one hook of 16 D08
    registers, the FIFO port N+1 with a repeated-access fast path."""
    cfg = rack_config()
    options = {key: opt.default for key, opt in card_class("galil-dmc13x8").options.items()}
    cfg.cards = [CardSpec("galil-dmc13x8", "galil0", options)]
    with DaemonThread(cfg) as d:
        c = client(d)
        yield c
        c.close()


def command(c: RawClient, line: bytes) -> None:
    """A command line into the FIFO N+1 (the card decodes it as its terminator arrives)."""
    reply = c.call(op="write", card="galil0", region="a16", offset=DATA, data=line, rep=True)
    assert reply["ok"] is None


def test_block_reads_of_a_register_window_count_every_register(galil: RawClient) -> None:
    """16-byte block reads of the Galil's window are 16 hook calls each (one a register): a
    batch of them over MAX_REP_HOOK_CALLS is refused before the first, the reply FIFO intact."""
    command(galil, b"MG 7\r")
    over = MAX_REP_HOOK_CALLS // 16 + 1
    reply = galil.call(op="batch", ops=[["r", "galil0", "a16", 0, 16]] * over)
    assert error_code(reply) == "too_large" and "nothing was run" in reply["error"]["message"]
    assert str(MAX_REP_HOOK_CALLS) in reply["error"]["message"]
    answer = galil.call(op="read", card="galil0", region="a16", offset=DATA, size=64, rep=True)
    assert answer["ok"].split(b"\xff")[0].endswith(b"7.0000\r\n:")  # MG 7, unread till now
    fit = galil.call(op="batch", ops=[["r", "galil0", "a16", 0, 16]] * (over - 1))
    assert len(fit["ok"]) == over - 1


def test_repeated_accesses_beside_the_fifo_port_are_bounded(galil: RawClient) -> None:
    """The Galil's fast path serves the FIFO port N+1 only: a repeated read of N+3 (status) or
    a repeated write of N+3 is one hook call per byte, bounded; the FIFO port's fast path is
    not (one call, whatever the size)."""
    for args in ({"op": "read", "size": MAX_REP_HOOK_CALLS + 1},
                 {"op": "write", "data": bytes(MAX_REP_HOOK_CALLS + 1)}):
        reply = galil.call(card="galil0", region="a16", offset=CONTROL, rep=True, **args)
        assert error_code(reply) == "too_large" and "register hooks" in reply["error"]["message"]
    status = galil.call(op="read", card="galil0", region="a16", offset=CONTROL,
                        size=MAX_REP_HOOK_CALLS, rep=True)["ok"]
    assert len(status) == MAX_REP_HOOK_CALLS and len(set(status)) == 1  # the same status byte
    empty = galil.call(op="read", card="galil0", region="a16", offset=DATA,
                       size=4 * MAX_REP_HOOK_CALLS, rep=True)["ok"]
    assert empty == b"\xff" * (4 * MAX_REP_HOOK_CALLS)  # an empty FIFO reads 0xFF


@pytest.fixture
def fifo() -> Iterator[tuple[DaemonThread, CountingFifo]]:
    card: list[CountingFifo] = []

    def make(ctx: CardContext) -> CountingFifo:
        card.append(CountingFifo("f0", ctx))
        return card[0]

    with DaemonThread(rack=rack_of(make)) as d:
        yield d, card[0]


def test_a_batch_holds_at_most_max_batch_controls_control_ops(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    d, card = fifo
    c = client(d)
    op = {"op": "control", "card": "f0", "action": "tally"}
    reply = c.call(op="batch", ops=[op] * (MAX_BATCH_CONTROLS + 1))
    assert error_code(reply) == "too_large" and "nothing was run" in reply["error"]["message"]
    assert str(MAX_BATCH_CONTROLS) in reply["error"]["message"] and card.runs == 0
    assert len(c.call(op="batch", ops=[op] * MAX_BATCH_CONTROLS)["ok"]) == MAX_BATCH_CONTROLS
    assert card.runs == MAX_BATCH_CONTROLS
    c.close()


class _Tally:
    name = "t0"

    def __init__(self) -> None:
        self.runs = 0

    def control(self, action: str, params: dict[str, Any]) -> None:
        self.runs += 1


def test_scheduled_actions_due_together_run_in_parts_before_the_waits_are_answered() -> None:
    """Sans-I/O: 2.5 services' worth of actions due at one time; each `service` runs
    TIMERS_A_SERVICE of them and answers no wait until the last has run."""
    waits = Waits(lambda exc, where: exc)  # type: ignore[arg-type, return-value]
    card = _Tally()
    total = 2 * TIMERS_A_SERVICE + TIMERS_A_SERVICE // 2
    for _ in range(total):
        waits.schedule_control(10, card, "tally", {})  # type: ignore[arg-type]
    answered: list[Any] = []
    waits.add(Waiter(deadline_ns=10, reply=answered.append), now_ns=0)
    waits.service(10)
    assert (card.runs, answered) == (TIMERS_A_SERVICE, [])
    assert waits.next_due_ns() == 10
    waits.service(10)
    assert (card.runs, answered) == (2 * TIMERS_A_SERVICE, [])
    waits.service(10)
    assert card.runs == total and answered == [{"now_ns": 10}]
    assert waits.next_due_ns() is None


def test_a_step_over_many_actions_due_together_replies_once_all_ran(
        fifo: tuple[DaemonThread, CountingFifo]) -> None:
    """Through the daemon: actions of several clients at one `at_ns` all run before the
    `sim step` to that time replies; the step is answered."""
    d, card = fifo
    clients = [client(d) for _ in range(3)]
    at = 5_000_000
    for c in clients:
        for _ in range(TIMERS_A_SERVICE // MAX_BATCH_CONTROLS + 2):
            op = {"op": "control", "card": "f0", "action": "tally", "at_ns": at}
            assert "ok" in c.call(op="batch", ops=[op] * (MAX_BATCH_CONTROLS // 2))
    scheduled = clients[0].call(op="stats")["ok"]["requests"]["scheduled"]
    assert scheduled > 2 * TIMERS_A_SERVICE and card.runs == 0
    assert clients[0].call(op="sim", action="step", ns=at)["ok"]["now_ns"] == at
    assert card.runs == scheduled
    assert clients[1].call(op="stats")["ok"]["requests"]["scheduled"] == 0
    for c in clients:
        c.close()


def test_batches_held_by_their_waits_hold_at_most_max_held_ops() -> None:
    """1,024 waits may be pending, each suspending a batch of up to 1 MiB (60,000 ops, some
    14 MB decoded): the ops held by batches with a wait are bounded in all (`busy` past it), and
    counted free again once those batches are answered."""
    card: list[CountingFifo] = []

    def make(ctx: CardContext) -> CountingFifo:
        card.append(CountingFifo("f0", ctx))
        return card[0]

    per = 60_000
    each = MAX_HELD_OPS // per  # batches that fit; one more does not
    wait = {"op": "wait", "card": "f0", "on": "value", "region": "mem", "offset": 0,
            "value": 1, "timeout_ns": 86_400 * 1_000_000_000}
    ops = [wait] + [["r", "f0", "mem", 4, 4]] * (per - 1)
    with DaemonThread(rack=rack_of(make, mode="realtime")) as d:
        a, b = client(d), client(d)
        for i in range(each):
            a.sock.send(msgpack.packb({"id": i, "op": "batch", "ops": ops}))
        # a's own request after them: answered once they have been served (one connection)
        assert a.call(op="stats")["ok"]["requests"]["pending_waits"] == each
        reply = b.call(op="batch", ops=ops)
        assert error_code(reply) == "busy" and str(MAX_HELD_OPS) in reply["error"]["message"]
        assert b.call(op="write", card="f0", region="mem", offset=0, data=b"\x01\0\0\0")["ok"] is None
        for _ in range(each):  # the condition holds: each batch runs its reads and is answered
            answer = msgpack.unpackb(a.sock.recv())
            assert answer["ok"][0]["fired"] and len(answer["ok"]) == per
        assert len(b.call(op="batch", ops=ops)["ok"]) == per  # room again
        a.close()
        b.close()
