"""`batch`: ops run in order between two ticks; a wait suspends the rest (PROTOCOL.md, batch)."""

from __future__ import annotations

from tests.conftest import RawClient, error_code
from tests.protocol.motion import BAR, axis_reg, move_ops, u32
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg
from vdevd.rt import AxisFlag


def test_batch_of_reads_and_writes_returns_one_result_per_op(raw: RawClient) -> None:
    ops = [
        {"op": "write", **BAR, "offset": R.OUTPUTS, "data": u32(7)},
        {"op": "read", **BAR, "offset": R.OUTPUTS, "size": 4},
        {"op": "read", **BAR, "offset": R.ID, "size": 4},
    ]
    assert raw.call(op="batch", ops=ops)["ok"] == [None, u32(7), u32(R.CARD_ID)]


def test_batch_runs_between_ticks_so_time_does_not_move(raw: RawClient) -> None:
    ops = [*move_ops(0, 5000), {"op": "read", **BAR, "offset": R.TICK_LO, "size": 4}]
    assert raw.call(op="batch", ops=ops)["ok"][-1] == u32(0)


def test_command_wait_read_in_one_round_trip(raw: RawClient) -> None:
    status = axis_reg(0, AxisReg.STATUS)
    ops = [
        *move_ops(0, 3000),
        {"op": "wait", **BAR, "on": "value", "offset": status, "mask": int(AxisFlag.DONE),
         "value": int(AxisFlag.DONE), "timeout_ns": 10**9},
        {"op": "read", **BAR, "offset": axis_reg(0, AxisReg.POSITION), "size": 4},
    ]
    results = raw.call(op="batch", ops=ops)["ok"]
    assert results[5]["fired"] is True
    assert int.from_bytes(results[6], "little", signed=True) == 3000


def test_ops_after_a_timed_out_wait_are_not_run(raw: RawClient) -> None:
    ops = [
        {"op": "wait", **BAR, "on": "value", "offset": R.ID, "value": 0, "timeout_ns": 1000},
        {"op": "write", **BAR, "offset": R.OUTPUTS, "data": u32(9)},
    ]
    results = raw.call(op="batch", ops=ops)["ok"]
    assert results == [{"fired": False, "now_ns": 1000}, None]
    assert raw.call(op="read", **BAR, offset=R.OUTPUTS, size=4)["ok"] == u32(0)


def test_an_error_fails_the_batch_and_names_the_op(raw: RawClient) -> None:
    ops = [
        {"op": "write", **BAR, "offset": R.OUTPUTS, "data": u32(1)},
        {"op": "read", **BAR, "offset": 3, "size": 4},
    ]
    reply = raw.call(op="batch", ops=ops)
    assert error_code(reply) == "bad_width"
    assert "batch op 1" in reply["error"]["message"]


def test_a_malformed_or_failing_op_is_named_by_its_index(raw: RawClient) -> None:
    read = {"op": "read", **BAR, "offset": 0, "size": 4}
    cases = [
        ([read, {"op": "read", **BAR, "offset": 0}], "malformed"),  # no size
        ([read, read, {"op": "sim", "action": "now"}], "malformed"),  # cannot be batched
        ([read, {"op": "wait", "card": "nope", "on": "irq", "timeout_ns": 1}], "no_card"),
        ([{"op": "wait", **BAR, "on": "value", "offset": 0, "value": 1, "mask": 0x1_0000_0000,
           "timeout_ns": 1}], "bad_param"),
    ]
    for ops, code in cases:
        reply = raw.call(op="batch", ops=ops)
        assert error_code(reply) == code
        assert reply["error"]["message"].startswith(f"batch op {len(ops) - 1}: "), reply
