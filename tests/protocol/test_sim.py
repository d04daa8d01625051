"""`sim`: the clock. Lockstep advances only on step or wait; the same requests give the same
bytes (DESIGN.md "Clock and scheduler")."""

from __future__ import annotations

import hashlib

import msgpack
import pytest

from tests.conftest import RawClient, error_code, rack_config
from tests.protocol.motion import BAR, axis_reg, move_ops, u32
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg
from vdevd.testing import DaemonThread

MS = 1_000_000


def test_now_reports_mode_and_base_tick(raw: RawClient) -> None:
    assert raw.call(op="sim", action="now")["ok"] == {"now_ns": 0, "mode": "lockstep",
                                                      "tick_ns": MS}


def test_step_by_ns_ticks_and_seconds(raw: RawClient) -> None:
    assert raw.call(op="sim", action="step", ns=1500)["ok"]["now_ns"] == 1500
    assert raw.call(op="sim", action="step", ticks=3)["ok"]["now_ns"] == 1500 + 3 * MS
    assert raw.call(op="sim", action="step", seconds=0.25)["ok"]["now_ns"] == 253 * MS + 1500


def test_ticks_run_are_exactly_the_ticks_due(raw: RawClient) -> None:
    raw.call(op="sim", action="step", ns=10 * MS - 1)
    assert raw.call(op="read", offset=R.TICK_LO, size=4, **BAR)["ok"] == u32(9)
    raw.call(op="sim", action="step", ns=1)
    assert raw.call(op="read", offset=R.TICK_LO, size=4, **BAR)["ok"] == u32(10)


def test_time_does_not_advance_without_step_or_wait(raw: RawClient) -> None:
    raw.call(op="batch", ops=move_ops(0, 100_000))
    for _ in range(3):
        assert raw.call(op="read", offset=R.TICK_LO, size=4, **BAR)["ok"] == u32(0)
    assert raw.call(op="sim", action="now")["ok"]["now_ns"] == 0


def test_step_in_realtime_is_refused() -> None:
    with DaemonThread(rack_config(clock="realtime")) as d:
        client = RawClient(d.endpoint)
        try:
            assert error_code(client.call(op="sim", action="step", ns=1)) == "wrong_mode"
            assert client.call(op="sim", action="now")["ok"]["mode"] == "realtime"
        finally:
            client.close()


def _scenario() -> str:
    """Run a fixed scenario against a fresh lockstep daemon; a digest of every reply."""
    digest = hashlib.sha256()
    with DaemonThread(rack_config(plant="servo")) as d:
        client = RawClient(d.endpoint)
        try:
            requests = [
                {"op": "write", **BAR, "offset": R.IRQ_ENABLE, "data": u32(0xFFFF)},
                {"op": "batch", "ops": move_ops(0, 12_345) + move_ops(1, -777, vmax=20_000)},
                {"op": "sim", "action": "step", "ns": 37 * MS + 123},
                {"op": "read", **BAR, "offset": R.AXIS_BASE, "size": 0x80},
                {"op": "control", "card": "servo0", "action": "set_limit",
                 "params": {"axis": 1, "negative": True}},
                {"op": "wait", "card": "servo0", "on": "irq", "after_seq": 0,
                 "timeout_ns": 2 * 10**9},
                {"op": "read", **BAR, "offset": 0, "size": 0x200},
                {"op": "control", "card": "servo0", "action": "axis_state",
                 "params": {"axis": 0}},
                {"op": "wait", "card": "servo0", "on": "value",
                 "region": "bar0", "offset": axis_reg(0, AxisReg.STATUS), "mask": 1 << 31,
                 "value": 1 << 31, "timeout_ns": 3 * 10**8},  # bit 31 is never set: times out
                {"op": "read", **BAR, "offset": 0, "size": 0x200},
            ]
            for i, req in enumerate(requests):
                reply = client.call(id=i, **req)
                assert "ok" in reply, reply
                digest.update(msgpack.packb(reply))
        finally:
            client.close()
    return digest.hexdigest()


@pytest.mark.slow
def test_same_requests_give_the_same_bytes() -> None:
    assert _scenario() == _scenario()


@pytest.mark.parametrize("seconds", [float("inf"), float("-inf"), float("nan"), 1e300])
def test_step_by_a_non_finite_or_huge_number_of_seconds_is_a_bad_param(
        raw: RawClient, seconds: float) -> None:
    reply = raw.call(op="sim", action="step", seconds=seconds)
    assert reply["error"]["code"] == "bad_param"
    assert raw.call(op="sim", action="now")["ok"]["now_ns"] == 0


@pytest.mark.parametrize("fields", [{"ticks": -3, "card": "servo0"}, {"ticks": -3},
                                    {"ns": 1000, "card": "servo0"}])
def test_a_negative_step_or_a_card_without_ticks_is_a_bad_param(
        raw: RawClient, fields: dict[str, object]) -> None:
    reply = raw.call(op="sim", action="step", **fields)
    assert reply["error"]["code"] == "bad_param"
    assert raw.call(op="sim", action="now")["ok"]["now_ns"] == 0


def test_set_limit_with_a_nil_active_is_a_bad_param(raw: RawClient) -> None:
    reply = raw.call(op="control", card="servo0", action="set_limit",
                     params={"axis": 0, "active": None})
    assert reply["error"]["code"] == "bad_param"
    assert "active: expected true or false" in reply["error"]["message"]
