"""`waits.value_wait`, the batch's shortcut for a wait on a value: the answer `Waits.add` gives
at once when it holds, else the waiter `make_waiter` makes, or None where the general path must
decide (another kind of wait, a field `make_waiter` refuses); and a batch answers the same with
it as without."""

from __future__ import annotations

from typing import Any

import pytest

from vdevd.devices.base import CardContext
from vdevd.devices.octavia.card import OctaviaCard
from vdevd.errors import VdevError
from vdevd.rack import Rack
from vdevd.waits import Waiter, make_waiter, value_wait

BASE = {"op": "wait", "card": "oct0", "region": "dpr", "on": "value", "timeout_ns": 10**8}


def rack() -> Rack:
    r = Rack([], "lockstep")
    r.add_card(OctaviaCard("oct0", {}, CardContext(emit=r.emit)))
    r.card("oct0").regions["dpr"].mem[0x3C2:0x3C4] = b"\x00\x5a"  # 3C2h 00h, 3C3h 5Ah
    return r


def general(r: Rack, args: dict[str, Any]) -> Any:
    """What make_waiter and Waits.add answer at once: the result, the waiter kept, or the error
    code."""
    seen: list[Any] = []
    try:
        w = r._make_waiter(args, seen.append)
        kept = r.waits.add(w, r.now_ns)
    except VdevError as exc:
        return exc.code
    if kept:
        r.waits.pending.remove(w)
        return w
    return seen[0]


def fields(w: Waiter) -> tuple[Any, ...]:
    return (w.deadline_ns, w.card, w.on, w.line, w.after_seq, w.region, w.offset, w.size, w.mask,
            w.value, w.equal, w.extra)


CASES: list[dict[str, Any]] = [
    {"offset": 0x3C2, "size": 1, "value": 0},
    {"offset": 0x3C2, "size": 1, "mask": 0xFF, "value": 0, "cmp": "eq"},
    {"offset": 0x3C2, "size": 2, "mask": 0xFF00, "value": 0x5A00},
    {"offset": 0x3C2, "size": 1, "value": 1, "cmp": "ne"},
    {"offset": 0x3C2, "size": 1, "value": 0, "cmp": "ne"},  # does not hold
    {"offset": 0x3C2, "size": 1, "value": 7},  # does not hold
    {"offset": 0x3C2, "size": 3, "value": 0},  # bad width
    {"offset": 0x3C2, "size": 1, "mask": 0x1FF, "value": 0},  # mask too wide
    {"offset": 0x3C2, "size": 1, "mask": 0x0F, "value": 0x10},  # value outside the mask
    {"offset": 0x3C2, "size": 1, "value": 0, "cmp": "lt"},
    {"offset": 0x3C2, "size": 1, "value": 0, "timeout_ns": -1},
    {"offset": 0x3C2, "size": 1, "value": 0, "region": "nowhere"},
    {"offset": 0x3C2, "size": 1, "value": 0, "card": "nobody"},
    {"offset": 0x10_0000, "size": 1, "value": 0},  # out of bounds
    {"offset": 0x1FFE, "size": 1, "value": 0},  # a register with a peek hook (1FFEh)
    {"offset": 0x3C2, "value": 0x5A00},  # size 4 by default
    {"on": "irq"},
]


@pytest.mark.parametrize("case", CASES)
def test_value_wait_answers_or_waits_as_the_general_path(case: dict[str, Any]) -> None:
    r = rack()
    args = {**BASE, **case}
    del args["op"]
    want = general(r, args)
    got = value_wait(args, r.cards, r._regions, r.now_ns)
    if got is None:  # the general path decides: an error, or another kind of wait
        assert isinstance(want, str) or args["on"] != "value", (case, want)
    elif isinstance(got, Waiter):
        assert isinstance(want, Waiter), (case, want)
        assert fields(got) == fields(want), case
    else:
        assert got == want and list(got) == list(want), (case, got, want)


def test_make_waiter_is_what_value_wait_makes() -> None:
    r = rack()
    args = {**BASE, "offset": 0x3C3, "size": 1, "mask": 0xF0, "value": 0x10, "cmp": "eq"}
    del args["op"]
    made = make_waiter(args, r.card("oct0"), lambda n: r.region("oct0", n), r.now_ns, print)
    quick = value_wait(args, r.cards, r._regions, r.now_ns)
    assert isinstance(quick, Waiter) and fields(quick) == fields(made)


def test_a_post_batch_answers_alike_with_and_without_the_shortcut(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """An RTC post (wait 3C2h = 00h, arguments, code, wait again, read): the same results."""
    def post(r: Rack) -> Any:
        wait = {**BASE, "offset": 0x3C2, "size": 1, "mask": 0xFF, "value": 0, "cmp": "eq"}
        ops = [wait, ["w", "oct0", "dpr", 0x3C3, b"\x01"], ["w", "oct0", "dpr", 0x3C2, b"\x5e"],
               wait, ["r", "oct0", "dpr", 0, 16]]
        from vdevd import protocol
        out: list[Any] = []
        r.execute(protocol.request_from({"op": "batch", "id": 1, "ops": ops}), out.append)
        return out

    fast = post(rack())
    monkeypatch.setattr("vdevd.rack.value_wait", lambda *a: None)
    assert post(rack()) == fast
    assert fast[0][0] == {"fired": True, "value": 0, "now_ns": 0}
