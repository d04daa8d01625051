"""The client core against a real daemon: connect rules, regions, irq, sim, control, stats."""

from __future__ import annotations

import itertools
from typing import Any

import pytest
import vdevclient
import zmq

from tests.protocol.motion import axis_reg, move_ops
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg
from vdevd.rt import AxisFlag
from vdevd.testing import DaemonThread


def test_connect_takes_the_endpoint_from_the_environment(
    daemon: DaemonThread, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
    monkeypatch.delenv("VDEVD_EVENTS", raising=False)
    with vdevclient.connect() as rack:
        assert rack.endpoint == daemon.endpoint
        assert rack.events_endpoint == daemon.events  # from hello
        assert [c.name for c in rack.cards()] == ["servo0"]


def test_connect_takes_the_events_endpoint_given_else_from_the_environment(
    pulsers: DaemonThread, monkeypatch: pytest.MonkeyPatch
) -> None:
    nowhere = "tcp://127.0.0.1:9"
    daemons = pulsers.events.replace("127.0.0.1", "localhost")  # the daemon's, spelt otherwise
    monkeypatch.setenv("VDEVD_EVENTS", daemons)
    with vdevclient.connect(pulsers.endpoint, events=nowhere) as rack:
        assert rack.events_endpoint == nowhere  # the argument beats the environment
    with vdevclient.connect(pulsers.endpoint) as rack:
        assert rack.events_endpoint == daemons != rack.info["events"]
        card = rack.card("p0")
        card.irq.subscribe()
        card.control("pulse", status=5)
        event = next(card.irq.events(timeout_s=5.0))
    assert (event["card"], event["status"]) == ("p0", 5)


def test_cards_describe_regions_and_irq_lines(rack: vdevclient.Rack) -> None:
    (info,) = rack.cards()
    assert (info.name, info.type, info.irq) == ("servo0", "generic-servo", ("inta",))
    assert info.regions[0].size == 0x1000
    with pytest.raises(KeyError):
        rack.card("nope")
    with pytest.raises(KeyError):
        rack.card("servo0").region("bar9")


def test_card_info_reads_as_a_mapping_beside_attributes(rack: vdevclient.Rack) -> None:
    (info,) = rack.cards()
    assert (info["name"], info["type"], info["irq"]) == (info.name, info.type, info.irq)
    assert info["regions"] is info.regions
    region = info["regions"][0]
    assert (region["name"], region["size"], region["widths"]) == ("bar0", 0x1000, (1, 2, 4))
    assert dict(region) == {"name": "bar0", "size": 0x1000, "widths": (1, 2, 4), "endian": "little",
                            "aligned": True, "block": True,
                            "passive": ((0x2C, 0x30), *((0x104 + 0x40 * a, 0x118 + 0x40 * a)
                                                        for a in range(4)))}
    assert list(info.keys()) == ["name", "type", "endian", "period_ns", "regions", "irq", "controls"]
    assert "set_limit" in info["controls"]
    assert info.get("period_ns") == 1_000_000 and info.get("bus") is None and "bus" not in info
    with pytest.raises(KeyError):
        info["bus"]


def test_remote_errors_raise_with_the_code(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    with pytest.raises(vdevclient.RemoteError) as info:
        bar.read32(0x1000)
    assert info.value.code == "out_of_range"
    assert bar.read32(0) == R.CARD_ID  # the connection still works


def test_a_request_over_max_message_is_refused_without_being_sent(rack: vdevclient.Rack) -> None:
    assert rack.max_message == rack.info["max_message"] == 1 << 20
    bar = rack.card("servo0").region("bar0")
    with pytest.raises(vdevclient.RequestTooLarge) as info:
        bar.write(0, bytes(2 << 20))
    err = info.value
    assert isinstance(err, vdevclient.VdevClientError) and err.code == "too_large"
    assert err.limit == 1 << 20 and err.size > 2 << 20
    assert str(err).startswith(f"too_large: write request of {err.size} bytes exceeds")
    assert "write" not in rack.stats()["requests"]["by_op"]  # the daemon never saw it
    bar.write32(R.OUTPUTS, 7)  # the connection still works
    assert bar.read32(R.OUTPUTS) == 7


def test_a_prepared_request_is_sent_again_and_again_with_a_new_id(rack: vdevclient.Rack) -> None:
    """Rack.prepare packs a request once; each call adds its own id, so the replies match."""
    where = {"card": "servo0", "region": "bar0"}
    ops = [{"op": "write", "offset": R.OUTPUTS, "data": (5).to_bytes(4, "little"), **where},
           {"op": "read", "offset": R.OUTPUTS, "size": 4, **where},
           {"op": "read", "offset": 0, "size": 4, **where}]
    prepared = rack.prepare({"op": "batch", "ops": ops})
    assert prepared.op == "batch" and prepared.message["ops"] is ops
    expected = [None, (5).to_bytes(4, "little"), R.CARD_ID.to_bytes(4, "little")]
    for _ in range(3):
        assert rack.call(prepared) == expected
    assert rack.call({"op": "batch", "ops": ops}) == expected  # as the map itself gives
    bad = rack.prepare({"op": "batch", "ops": [{"op": "read", "offset": 0x1000, "size": 4, **where}]})
    with pytest.raises(vdevclient.RemoteError) as info:
        rack.call(bad)
    assert info.value.code == "out_of_range"
    assert rack.call(prepared) == expected  # the connection still works


def test_a_prepared_request_has_no_id_and_fits_a_small_map(rack: vdevclient.Rack) -> None:
    with pytest.raises(ValueError):
        rack.prepare({"op": "stats", "id": 1})
    with pytest.raises(ValueError):
        rack.prepare({"op": "stats", **{f"f{i}": i for i in range(14)}})


def test_big_endian_register_access_is_in_the_cards_byte_order(pulsers: DaemonThread) -> None:
    with vdevclient.connect(pulsers.endpoint) as rack:
        card = rack.card("p0")
        regs = card.region("regs")
        assert card.info.endian == regs.info.endian == "big"
        card.control("load", offset=0, value=0x12345678)  # set by the card's firmware
        assert regs.read(0, 4) == bytes.fromhex("12345678")  # on the bus: most significant first
        assert regs.read32(0) == 0x12345678
        assert (regs.read16(0), regs.read16(2), regs.read8(3)) == (0x1234, 0x5678, 0x78)
        regs.write32(4, 0xCAFEF00D)
        regs.write16(8, 0xBEEF)
        assert regs.read(4, 6) == bytes.fromhex("cafef00dbeef")
        assert card.control("value", offset=4) == 0xCAFEF00D  # what the card's firmware reads
        assert card.control("value", offset=8) == 0xBEEF0000


def test_close_really_closes_and_closing_again_is_harmless(rack: vdevclient.Rack) -> None:
    card = rack.card("servo0")
    card.irq.subscribe()
    bar = card.region("bar0")
    rack.close()
    rack.close()
    with pytest.raises(vdevclient.RackClosed, match=f"^read: the connection to {rack.endpoint} is closed$"):
        bar.read32(R.ID)
    with pytest.raises(vdevclient.RackClosed):
        rack.stats()
    with pytest.raises(vdevclient.RackClosed):
        next(card.irq.events(timeout_s=0))  # the subscription went with the connection


def test_irq_wait_sees_the_done_interrupt_of_a_move(rack: vdevclient.Rack) -> None:
    card = rack.card("servo0")
    card.region("bar0").write32(R.IRQ_ENABLE, 0x1)
    assert rack.batch(move_ops(0, 500)) == [None] * 5
    event = card.irq.wait(timeout_s=1.0)
    assert event is not None and event["line"] == "inta" and event["status"] == 1
    assert rack.sim.now_ns() == event["sim_time_ns"]
    assert card.irq.wait(timeout_s=0.01) is None  # nothing new: times out
    assert rack.sim.now_ns() == event["sim_time_ns"] + 10_000_000


def test_irq_subscription_receives_published_assertions(rack: vdevclient.Rack) -> None:
    card = rack.card("servo0")
    card.irq.subscribe()
    bar = card.region("bar0")
    bar.write32(R.IRQ_ENABLE, 0x3)
    rack.batch(move_ops(0, 200) + move_ops(1, -300))
    done = int(AxisFlag.DONE)
    assert bar.wait_value(axis_reg(1, AxisReg.STATUS), done, mask=done, timeout_s=2.0)
    events = list(itertools.islice(card.irq.events(timeout_s=5.0), 2))
    assert [(e["seq"], e["status"]) for e in events] == [(1, 0x1), (2, 0x3)]
    assert all(e["card"] == "servo0" and e["kind"] == "irq" for e in events)


def test_an_interrupt_published_while_subscribe_syncs_is_the_first_event(
    pulsers: DaemonThread, monkeypatch: pytest.MonkeyPatch
) -> None:
    with vdevclient.connect(pulsers.endpoint) as rack:
        card = rack.card("p0")
        subs: list[zmq.Socket[bytes]] = []
        make_socket, request = rack.socket, rack.request

        def socket(kind: int) -> zmq.Socket[bytes]:
            subs.append(make_socket(kind))
            return subs[-1]

        def sync_after_an_interrupt(op: str, /, **fields: Any) -> Any:
            """Before the daemon publishes the sync, interrupt until one reaches the subscriber."""
            if op == "sync":
                for status in range(1, 100):
                    request("control", card="p0", action="pulse", params={"status": status})
                    if subs[0].poll(50):
                        break
                else:
                    pytest.fail("the subscriber never joined")
            return request(op, **fields)

        monkeypatch.setattr(rack, "socket", socket)
        monkeypatch.setattr(rack, "request", sync_after_an_interrupt)
        card.irq.subscribe()
        monkeypatch.undo()
        card.control("pulse", status=0xFF)  # right after subscribe() returned
        statuses = []
        for event in card.irq.events(timeout_s=5.0):
            assert (event["kind"], event["card"]) == ("irq", "p0")
            statuses.append(event["status"])
            if event["status"] == 0xFF:
                break
    assert len(statuses) >= 2 and statuses[-1] == 0xFF, statuses  # the sync-time ones came first


def test_sim_step_mode_and_now(rack: vdevclient.Rack) -> None:
    assert rack.sim.mode == "lockstep"
    assert rack.sim.step(ticks=2) == 2_000_000
    assert rack.sim.step(seconds=0.5) == 502_000_000
    assert rack.sim.step(ns=7) == 502_000_007
    assert rack.sim.now_ns() == 502_000_007


def test_wait_value_returns_none_on_timeout(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    assert bar.wait_value(R.ID, 0, timeout_s=0.002) is None
    assert rack.sim.now_ns() == 2_000_000


def test_stats_and_context_manager(daemon: DaemonThread) -> None:
    with vdevclient.connect(daemon.endpoint) as rack:
        assert rack.stats()["cards"]["servo0"]["lost_ticks"] == 0
