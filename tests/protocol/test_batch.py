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


# -- compact accesses: [kind, card, region, offset, size|data] (PROTOCOL.md "Compact accesses") --
def test_compact_accesses_do_what_their_maps_do(raw: RawClient) -> None:
    card, region = BAR["card"], BAR["region"]
    compact = [["w", card, region, R.OUTPUTS, u32(7)],
               ["r", card, region, R.OUTPUTS, 4],
               {"op": "read", **BAR, "offset": R.ID, "size": 4},  # the two forms mix
               ["r", card, region, R.ID, 8]]
    maps = [{"op": "write", **BAR, "offset": R.OUTPUTS, "data": u32(7)},
            {"op": "read", **BAR, "offset": R.OUTPUTS, "size": 4},
            {"op": "read", **BAR, "offset": R.ID, "size": 4},
            {"op": "read", **BAR, "offset": R.ID, "size": 8}]
    expected = raw.call(op="batch", ops=maps)["ok"]
    assert expected[:3] == [None, u32(7), u32(R.CARD_ID)]
    assert raw.call(op="batch", ops=compact)["ok"] == expected


def test_compact_accesses_wait_and_resume_like_maps(raw: RawClient) -> None:
    status = axis_reg(0, AxisReg.STATUS)
    ops = [*move_ops(0, 3000),
           {"op": "wait", **BAR, "on": "value", "offset": status, "mask": int(AxisFlag.DONE),
            "value": int(AxisFlag.DONE), "timeout_ns": 10**9},
           ["r", BAR["card"], BAR["region"], axis_reg(0, AxisReg.POSITION), 4]]
    results = raw.call(op="batch", ops=ops)["ok"]
    assert results[5]["fired"] is True
    assert int.from_bytes(results[6], "little", signed=True) == 3000


def test_a_bad_compact_access_is_an_error_of_its_op(raw: RawClient) -> None:
    card, region = BAR["card"], BAR["region"]
    good = ["r", card, region, R.ID, 4]
    cases = [
        (["x", card, region, 0, 4], "malformed"),  # no such kind
        (["r", card, region, 0], "malformed"),  # four fields
        (["r", card, region, 0, 4, True], "malformed"),  # six
        (["r", card, region, 0, b"\0\0\0\0"], "malformed"),  # a read takes a size
        (["w", card, region, 0, 4], "malformed"),  # a write takes data
        (["r", card, region, "0", 4], "malformed"),
        (["r", 1, region, 0, 4], "malformed"),
        (["r", "nope", region, 0, 4], "no_card"),
        (["r", card, "nope", 0, 4], "no_region"),
        (["r", card, region, 0x1000, 4], "out_of_range"),
        (["r", card, region, 2, 4], "bad_width"),
        (["R", card, region, 0x1000, 4], "out_of_range"),
        (["W", card, region, -4, b"\0"], "out_of_range"),
    ]
    for op, code in cases:
        reply = raw.call(op="batch", ops=[good, op])
        assert error_code(reply) == code, op
        assert reply["error"]["message"].startswith("batch op 1: "), reply
    assert raw.call(op="batch", ops=[good])["ok"] == [u32(R.CARD_ID)]  # still serving


def test_many_waits_that_resolve_at_once_run_in_one_batch(raw: RawClient) -> None:
    """A client's long FIFO write is a batch of hundreds of waits for room, most of them true
    already: each goes on at once (no nesting per wait), and one that must wait resumes them."""
    outputs = {"op": "wait", **BAR, "on": "value", "offset": R.OUTPUTS, "value": 7,
               "timeout_ns": 10**9}
    status = axis_reg(0, AxisReg.STATUS)
    done = {"op": "wait", **BAR, "on": "value", "offset": status, "mask": int(AxisFlag.DONE),
            "value": int(AxisFlag.DONE), "timeout_ns": 10**9}
    ops = [{"op": "write", **BAR, "offset": R.OUTPUTS, "data": u32(7)},
           *[outputs] * 3000, *move_ops(0, 2000), done, *[outputs] * 3000,
           {"op": "read", **BAR, "offset": axis_reg(0, AxisReg.POSITION), "size": 4}]
    results = raw.call(op="batch", ops=ops)["ok"]
    assert len(results) == len(ops)
    assert all(r["fired"] for r in results[1:3001] + results[-3001:-1])
    assert int.from_bytes(results[-1], "little", signed=True) == 2000
