"""`snapshot` (PROTOCOL.md "snapshot"): the fields it takes and the errors of a transfer out of
its order; a save while scheduled actions are pending; a load of a rack no server serves. The
transfers themselves, the refusals and the replay are tests/client/test_snapshot_cli.py's and
test_snapshot_cards.py's."""

from __future__ import annotations

from typing import Any

import msgpack
import pytest
from vdevclient.errors import RemoteError

from tests.conftest import RawClient, error_code, rack_config
from vdevd import snapshot
from vdevd.daemon import build_rack
from vdevd.errors import ErrorCode, VdevError
from vdevd.protocol import Request
from vdevd.testing import DaemonThread


def message(reply: dict[str, Any]) -> str:
    return str(reply["error"]["message"])


@pytest.mark.parametrize(("fields", "code", "says"), [
    ({"action": "rewind"}, "bad_param", "snapshot: unknown action 'rewind' (save, load)"),
    ({"action": "load", "offset": 0, "data": b"x"}, "malformed", "give size and data"),
    ({"action": "load", "offset": 0, "size": 0, "data": b""}, "bad_snapshot",
     "a snapshot of 0 bytes"),
    ({"action": "save", "offset": 10}, "bad_param", "no save under way (begin at offset 0)"),
    ({"action": "save", "offset": "0"}, "malformed", "field 'offset' has the wrong type"),
    ({"action": "load", "offset": 0, "size": 5, "data": b"VDEVSNAP"}, "bad_snapshot",
     "snapshot load: chunks beyond the size given (5)"),
])
def test_bad_fields_are_refused_naming_them(raw: RawClient, fields: dict[str, Any], code: str,
                                            says: str) -> None:
    reply = raw.call(op="snapshot", **fields)
    assert error_code(reply) == code and says in message(reply), reply


def test_a_save_reads_to_its_end_and_past_it_is_refused(raw: RawClient) -> None:
    first = raw.call(op="snapshot", action="save", offset=0)["ok"]
    assert first["data"].startswith(snapshot.MAGIC) and first["size"] == len(first["data"])
    again = raw.call(op="snapshot", action="save", offset=first["size"])
    assert error_code(again) == "bad_param"  # its last chunk was read: the save is over


def test_a_save_with_scheduled_actions_pending_is_busy(raw: RawClient) -> None:
    raw.call(op="control", card="servo0", action="set_inputs", params={"value": 5},
             after_ns=1_000_000)
    reply = raw.call(op="snapshot", action="save", offset=0)
    assert error_code(reply) == "busy" and "1 scheduled control actions pending" in message(reply)


def test_a_rack_no_server_serves_cannot_load() -> None:
    rack = build_rack(rack_config())
    data = rack.snapshot()
    got: list[Any] = []
    rack.execute(Request(1, "snapshot", {"action": "load", "offset": 0, "size": len(data),
                                         "data": data}), got.append)
    assert isinstance(got[0], VdevError) and got[0].code == ErrorCode.WRONG_MODE
    restored = rack.restore(data)  # in process: a new rack, this one as it was
    assert restored is not rack and list(restored.cards) == ["servo0"]
    assert restored.cards["servo0"] is not rack.cards["servo0"]


def test_a_load_answers_the_waits_pending_on_the_rack_it_replaces(daemon: DaemonThread,
                                                                  raw: RawClient) -> None:
    """Another client's wait is answered `busy` at once, not at its timeout."""
    data = raw.call(op="snapshot", action="save", offset=0)["ok"]["data"]
    waiter = RawClient(daemon.endpoint)
    try:
        waiter.sock.send(msgpack.packb({"id": 7, "op": "wait", "card": "servo0", "on": "irq",
                                        "timeout_ns": 10**12}))
        for _ in range(1000):  # until the daemon holds the wait (another connection)
            if raw.call(op="stats")["ok"]["requests"]["pending_waits"]:
                break
        else:
            pytest.fail("the wait never reached the daemon")
        reply = raw.call(op="snapshot", action="load", offset=0, size=len(data), data=data)
        assert reply["ok"]["now_ns"] == 0
        dropped = msgpack.unpackb(waiter.sock.recv())
        assert error_code(dropped) == "busy" and "snapshot load" in message(dropped)
    finally:
        waiter.close()
    assert raw.call(op="sim", action="step", ns=1000)["ok"]["now_ns"] == 1000  # the new rack


def test_a_snapshot_of_the_other_clock_mode_is_refused_and_realtime_goes_on_from_it() -> None:
    """A lockstep snapshot does not load into a realtime daemon (nor the reverse); a realtime
    daemon's own snapshot loads, and its clock goes on from the snapshot's time."""
    import vdevclient

    with DaemonThread(rack_config()) as lock, vdevclient.connect(lock.endpoint) as rack:
        rack.sim.step(seconds=5)
        locked = rack.snapshot()
    with DaemonThread(rack_config(clock="realtime")) as real, \
            vdevclient.connect(real.endpoint) as rack:
        with pytest.raises(RemoteError, match="bad_snapshot: saved with the lockstep clock, this "
                                              "daemon runs the realtime clock"):
            rack.restore(locked)
        own = rack.snapshot()
        taken = snapshot.read_header(own)[0]["now_ns"]
        rack.restore(own)
        assert taken <= rack.sim.now_ns() < taken + 5_000_000_000  # not from 0, not ahead


def test_a_scope_armed_at_the_save_records_on_after_the_load(raw: RawClient) -> None:
    """The recorder is part of the card's state: after the load it is where it was, and it
    records the same samples as the run the snapshot was taken from."""
    def scope(**fields: Any) -> Any:
        return raw.call(op="scope", card="servo0", **fields)["ok"]

    bar = {"card": "servo0", "region": "bar0"}
    raw.call(op="write", offset=0x104, data=(9000).to_bytes(4, "little"), **bar)  # TARGET
    raw.call(op="write", offset=0x100, data=(1).to_bytes(4, "little"), **bar)  # MOVE_ABS
    scope(action="arm", axes=[0], signals=["position", "command"], samples=300)
    raw.call(op="sim", action="step", ns=100_000_000)
    taken = scope(action="status")
    assert taken["state"] == "recording" and taken["available"] == 100
    data = raw.call(op="snapshot", action="save", offset=0)["ok"]["data"]
    raw.call(op="sim", action="step", ns=300_000_000)
    first = scope(action="read")
    raw.call(op="snapshot", action="load", offset=0, size=len(data), data=data)
    assert scope(action="status") == taken
    raw.call(op="sim", action="step", ns=300_000_000)
    assert scope(action="read") == first and first["available"] == 300
