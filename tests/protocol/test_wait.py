"""`wait`: on interrupts and on register values; lockstep time advances to the event or the
timeout, whichever comes first (PROTOCOL.md, wait)."""

from __future__ import annotations

from tests.conftest import RawClient
from tests.protocol.motion import BAR, axis_reg, move_ops, u32
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg
from vdevd.rt import AxisFlag

MS = 1_000_000


def start_move(raw: RawClient, target: int) -> None:
    raw.call(op="write", offset=R.IRQ_ENABLE, data=u32(0xFFFFFFFF), **BAR)
    assert "ok" in raw.call(op="batch", ops=move_ops(0, target))


def test_wait_irq_times_out_at_exactly_the_timeout(raw: RawClient) -> None:
    reply = raw.call(op="wait", card="servo0", on="irq", timeout_ns=25 * MS)["ok"]
    assert reply == {"fired": False, "now_ns": 25 * MS}


def test_wait_irq_stops_time_at_the_interrupting_tick(raw: RawClient) -> None:
    start_move(raw, 1000)  # 1000 counts at 500000 c/s^2 from rest: a triangle of ~89.4 ms
    reply = raw.call(op="wait", card="servo0", on="irq", timeout_ns=10**9)["ok"]
    assert reply["fired"] is True
    event = reply["event"]
    assert event["line"] == "inta" and event["seq"] == 1 and event["status"] & 1
    assert event["sim_time_ns"] == reply["now_ns"]
    assert 80 * MS <= reply["now_ns"] <= 100 * MS
    position = raw.call(op="read", offset=axis_reg(0, AxisReg.POSITION), size=4, **BAR)["ok"]
    assert int.from_bytes(position, "little", signed=True) == 1000


def test_wait_irq_after_seq_never_misses_an_assertion(raw: RawClient) -> None:
    start_move(raw, 10)
    assert raw.call(op="sim", action="step", ns=500 * MS)["ok"]["now_ns"] == 500 * MS
    missed = raw.call(op="wait", card="servo0", on="irq", after_seq=0, timeout_ns=MS)["ok"]
    assert missed["fired"] and missed["event"]["seq"] == 1
    assert missed["now_ns"] == 500 * MS  # fired at once: no time passed


def test_wait_value_fires_when_the_masked_register_matches(raw: RawClient) -> None:
    start_move(raw, 2000)
    reply = raw.call(op="wait", on="value", offset=axis_reg(0, AxisReg.STATUS),
                     mask=int(AxisFlag.DONE), value=int(AxisFlag.DONE), timeout_ns=10**9,
                     **BAR)["ok"]
    assert reply["fired"] and reply["value"] & AxisFlag.DONE
    pos = raw.call(op="read", offset=axis_reg(0, AxisReg.POSITION), size=4, **BAR)["ok"]
    assert int.from_bytes(pos, "little", signed=True) == 2000


def test_wait_value_already_true_fires_at_once(raw: RawClient) -> None:
    reply = raw.call(op="wait", on="value", offset=R.ID, value=R.CARD_ID, timeout_ns=MS,
                     **BAR)["ok"]
    assert reply == {"fired": True, "value": R.CARD_ID, "now_ns": 0}


def test_wait_value_ne_and_timeout(raw: RawClient) -> None:
    reply = raw.call(op="wait", on="value", offset=R.ID, value=R.CARD_ID, cmp="ne",
                     timeout_ns=3 * MS, **BAR)["ok"]
    assert reply == {"fired": False, "now_ns": 3 * MS}


def test_wait_value_that_could_never_fire_is_bad_param(raw: RawClient) -> None:
    where = {"op": "wait", "on": "value", **BAR, "offset": R.INPUTS, "timeout_ns": 10**9}
    for fields in ({"size": 2, "mask": 0x1FFFF, "value": 1},  # mask wider than 2 bytes
                   {"mask": -1, "value": 0},
                   {"mask": 0xFF, "value": 0x100},  # a value bit outside the mask
                   {"value": -1}):
        reply = raw.call(**where, **fields)
        assert reply["error"]["code"] == "bad_param", fields
    assert raw.call(op="sim", action="now")["ok"]["now_ns"] == 0  # no time went by
