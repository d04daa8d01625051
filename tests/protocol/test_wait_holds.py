"""`waits.holds_now`, the batch's shortcut for a wait on a value that already holds: the answer
`Waits.add` gives its waiter at once, or None where the general path must decide (a wait that
does not hold, another kind, a field `make_waiter` refuses); and a batch answers the same with
it as without."""

from __future__ import annotations

from typing import Any

import pytest

from vdevd.devices.base import CardContext
from vdevd.devices.octavia.card import OctaviaCard
from vdevd.errors import VdevError
from vdevd.rack import Rack
from vdevd.waits import holds_now

BASE = {"op": "wait", "card": "oct0", "region": "dpr", "on": "value", "timeout_ns": 10**8}


def rack() -> Rack:
    r = Rack([], "lockstep")
    r.add_card(OctaviaCard("oct0", {}, CardContext(emit=r.emit)))
    r.card("oct0").regions["dpr"].mem[0x3C2:0x3C4] = b"\x00\x5a"  # 3C2h 00h, 3C3h 5Ah
    return r


def general(r: Rack, args: dict[str, Any]) -> Any:
    """What make_waiter and Waits.add answer at once: the result, "pending", or the error code."""
    seen: list[Any] = []
    try:
        w = r._make_waiter(args, seen.append)
        kept = r.waits.add(w, r.now_ns)
    except VdevError as exc:
        return exc.code
    if kept:
        r.waits.pending.remove(w)
        return "pending"
    return seen[0]


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
def test_holds_now_answers_what_the_general_path_answers_at_once(case: dict[str, Any]) -> None:
    r = rack()
    args = {**BASE, **case}
    del args["op"]
    want = general(r, args)
    got = holds_now(args, r._regions, r.now_ns)
    if got is None:
        assert want == "pending" or isinstance(want, str) or not want.get("fired"), (case, want)
    else:
        assert got == want and list(got) == list(want), (case, got, want)


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
    monkeypatch.setattr("vdevd.rack.holds_now", lambda *a: None)
    assert post(rack()) == fast
    assert fast[0][0] == {"fired": True, "value": 0, "now_ns": 0}
