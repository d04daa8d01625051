"""Malformed requests get exactly one error reply and the daemon keeps serving (PROTOCOL.md, Errors)."""

from __future__ import annotations

from collections.abc import Iterator

import msgpack
import pytest

from tests.conftest import RawClient, error_code
from vdevd.devices.base import Card, CardContext
from vdevd.protocol import MAX_MESSAGE
from vdevd.region import Region
from vdevd.testing import DaemonThread, rack_of

BAR = {"card": "servo0", "region": "bar0"}


def assert_alive(raw: RawClient) -> None:
    reply = raw.call(op="read", offset=0, size=4, **BAR)
    assert reply["ok"] == bytes.fromhex("56454456")


@pytest.mark.parametrize(
    ("body", "code"),
    [
        (b"", "malformed"),
        (b"\xc1", "malformed"),  # never-used msgpack byte
        (b"\x92\x01", "malformed"),  # truncated array
        (msgpack.packb([1, 2, 3]), "malformed"),  # not a map
        (msgpack.packb("read"), "malformed"),
        (msgpack.packb({"id": 1}), "malformed"),  # no op
        (msgpack.packb({"id": 1, "op": 7}), "malformed"),
        (msgpack.packb({"id": 1, "op": "frobnicate"}), "unknown_op"),
        (msgpack.packb({"id": 1, "op": "read", "v": 2, **BAR, "offset": 0, "size": 4}),
         "bad_version"),
        (msgpack.packb({"id": [1], "op": "hello"}), "malformed"),
    ],
)
def test_undecodable_or_unknown_requests_get_an_error_reply(
    raw: RawClient, body: bytes, code: str
) -> None:
    assert error_code(raw.send_raw(body)) == code
    assert_alive(raw)


@pytest.mark.parametrize(
    ("request_fields", "code"),
    [
        ({"op": "read", **BAR, "offset": 0}, "malformed"),  # missing size
        ({"op": "read", **BAR, "offset": "0", "size": 4}, "malformed"),  # wrong type
        ({"op": "read", **BAR, "offset": True, "size": 4}, "malformed"),  # bool is not int
        ({"op": "read", **BAR, "offset": 0, "size": 4, "extra": 1}, "malformed"),
        ({"op": "write", **BAR, "offset": 0x24, "data": "text"}, "malformed"),
        ({"op": "read", "card": "nope", "region": "bar0", "offset": 0, "size": 4}, "no_card"),
        ({"op": "read", "card": "servo0", "region": "nope", "offset": 0, "size": 4}, "no_region"),
        ({"op": "read", **BAR, "offset": 0x1000, "size": 4}, "out_of_range"),
        ({"op": "read", **BAR, "offset": 0xFFE, "size": 4}, "out_of_range"),
        ({"op": "read", **BAR, "offset": -4, "size": 4}, "out_of_range"),
        ({"op": "read", **BAR, "offset": 0, "size": 0}, "out_of_range"),
        ({"op": "read", **BAR, "offset": 2, "size": 4}, "bad_width"),  # misaligned
        ({"op": "write", **BAR, "offset": 1, "data": b"\0\0"}, "bad_width"),
        ({"op": "wait", "card": "servo0", "on": "irq", "timeout_ns": -1}, "bad_param"),
        ({"op": "wait", "card": "servo0", "on": "irq", "line": "intz", "timeout_ns": 1},
         "no_irq"),
        ({"op": "wait", "card": "servo0", "on": "value", "timeout_ns": 1}, "malformed"),
        ({"op": "wait", "card": "servo0", "on": "smoke", "timeout_ns": 1}, "bad_param"),
        ({"op": "sim", "action": "warp"}, "bad_param"),
        ({"op": "sim", "action": "step"}, "bad_param"),
        ({"op": "sim", "action": "step", "ns": 1, "ticks": 1}, "bad_param"),
        ({"op": "control", "card": "servo0", "action": "self_destruct"}, "bad_action"),
        ({"op": "control", "card": "servo0", "action": "set_limit",
          "params": {"axis": 9, "positive": True}}, "bad_param"),
        ({"op": "control", "card": "servo0", "action": "set_limit",
          "params": {"wheel": 1}}, "bad_param"),
        ({"op": "batch", "ops": [{"op": "hello"}]}, "malformed"),
        ({"op": "batch", "ops": [7]}, "malformed"),
        ({"op": "batch", "ops": [{"op": "read", **BAR, "offset": 0x2000, "size": 4}]},
         "out_of_range"),
    ],
)
def test_invalid_requests_get_the_right_error_code(
    raw: RawClient, request_fields: dict[str, object], code: str
) -> None:
    reply = raw.call(id=42, **request_fields)
    assert reply["id"] == 42
    assert error_code(reply) == code
    assert reply["error"]["message"]
    assert_alive(raw)


def test_oversize_request_gets_too_large_and_the_connection_survives(raw: RawClient) -> None:
    big = msgpack.packb({"id": 5, "op": "write", **BAR, "offset": 0, "data": bytes(MAX_MESSAGE)})
    reply = raw.send_raw(big)
    assert error_code(reply) == "too_large"
    assert_alive(raw)


def test_undecodable_request_reply_has_nil_id(raw: RawClient) -> None:
    assert raw.send_raw(b"\xc1")["id"] is None


@pytest.mark.parametrize(("body", "says"), [
    (b"\xc1", "not msgpack: a byte that begins no msgpack object (the body of 1 bytes begins c1)"),
    (b"", "not msgpack: Unpack failed: incomplete input (the body is empty)"),
    (b"\x92\x01", "not msgpack: Unpack failed: incomplete input (the body of 2 bytes begins 92 01)"),
])
def test_an_undecodable_request_is_told_what_was_wrong(raw: RawClient, body: bytes,
                                                       says: str) -> None:
    """Issue 22: `malformed: not msgpack: ` ended in nothing for a byte msgpack never uses."""
    assert raw.send_raw(body)["error"]["message"] == says


def test_one_bad_client_does_not_disturb_another(daemon: object) -> None:
    endpoint = daemon.endpoint  # type: ignore[attr-defined]
    good, bad = RawClient(endpoint), RawClient(endpoint)
    try:
        for _ in range(20):
            bad.sock.send(b"\xc1garbage")
        assert_alive(good)
        replies = [bad.sock.recv() for _ in range(20)]
        assert len(replies) == 20
        assert all(error_code(msgpack.unpackb(r)) == "malformed" for r in replies)
    finally:
        good.close()
        bad.close()


def test_request_frame_from_req_socket_keeps_its_envelope(daemon: object) -> None:
    import zmq

    sock = zmq.Context.instance().socket(zmq.REQ)
    sock.linger = 0
    sock.rcvtimeo = 5000
    sock.connect(daemon.endpoint)  # type: ignore[attr-defined]
    try:
        sock.send(msgpack.packb({"id": 9, "op": "read", **BAR, "offset": 0, "size": 4}))
        reply = msgpack.unpackb(sock.recv())
        assert reply == {"id": 9, "ok": bytes.fromhex("56454456")}
    finally:
        sock.close()


class BusWidths(Card):
    """A card with the bus rules of the vendor cards: a VME A16 window of byte registers
    (D08(O)), and a PCI BAR of 32-bit registers only, with no block transfers."""

    type_name = "bus-widths"

    def __init__(self, name: str, ctx: CardContext) -> None:
        super().__init__(name, {}, ctx)
        self.add_region(Region("a16", 16, widths=(1,), block=False, endian="big"))
        self.add_region(Region("bar", 64, widths=(4,), block=False))


@pytest.fixture
def widths_raw() -> Iterator[RawClient]:
    with DaemonThread(rack=rack_of(lambda ctx: BusWidths("vme0", ctx))) as d:
        client = RawClient(d.endpoint)
        yield client
        client.close()


@pytest.mark.parametrize(
    ("region", "offset", "size"),
    [("a16", 0, 2), ("a16", 2, 4), ("a16", 0, 16), ("bar", 0, 1), ("bar", 0, 2), ("bar", 0, 8),
     ("bar", 2, 4)],
)
def test_an_access_width_the_bus_forbids_gets_bad_width(
        widths_raw: RawClient, region: str, offset: int, size: int) -> None:
    where = {"card": "vme0", "region": region, "offset": offset}
    assert error_code(widths_raw.call(op="read", size=size, **where)) == "bad_width"
    assert error_code(widths_raw.call(op="write", data=bytes(size), **where)) == "bad_width"
    allowed = 1 if region == "a16" else 4  # the width the bus takes still works
    assert "ok" in widths_raw.call(op="read", offset=4, size=allowed, card="vme0", region=region)
