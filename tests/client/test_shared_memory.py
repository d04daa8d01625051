"""vdevclient's Region over the daemon's shared memory (decision 0010): passive accesses without a
round trip, everything else by requests with the same results; the option that turns it off and
the fallbacks; in lockstep the mapping shows exactly what requests show, after every step."""

from __future__ import annotations

import ctypes
import os
from collections.abc import Iterator
from pathlib import Path

import pytest
import vdevclient
from vdevclient import maxk, pcomm
from vdevmaps.oms import RING_SIZE, Shm
from vdevmaps.pmac import OPEN_USE, READY, RESP_CONTROL, RT_READY, RT_TIMER

from tests.client.galil import card, rack_config, round_trips
from vdevd.testing import DaemonThread

AXIS0 = 0x100  # the generic card's axis 0 block
TARGET, VMAX, ACC, DEC, COMMAND, POSITION = 0x04, 0x08, 0x0C, 0x10, 0x00, 0x1C
MOVE_ABS = 1


@pytest.fixture(scope="module")
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card("generic-servo", "servo0", plant="ideal"),
                      card("oms-maxk", "maxk0", board=1, axes=4),
                      card("pmac-turbo", "pmac0", device=0, ethernet=""))
    with DaemonThread(cfg) as d:
        yield d


@pytest.fixture
def mapped(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint) as rack:
        yield rack


@pytest.fixture
def plain(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint, shm=False) as rack:
        yield rack


def test_passive_accesses_take_no_round_trip_and_requests_see_them(
        mapped: vdevclient.Rack, plain: vdevclient.Rack, monkeypatch: pytest.MonkeyPatch) -> None:
    with round_trips(monkeypatch) as trips:  # regions made inside: they bind Rack.call
        bar, seen = mapped.card("servo0").region("bar0"), plain.card("servo0").region("bar0")
        assert bar.mapped and not seen.mapped
        bar.write32(AXIS0 + TARGET, 0x1234_5678)
        bar.write16(AXIS0 + VMAX, 0xBEEF)
        bar.write(AXIS0 + ACC, b"\1\2\3\4\5\6\7\x08")  # a block access
        assert bar.read32(AXIS0 + TARGET) == 0x1234_5678
        assert bar.read8(AXIS0 + TARGET) == 0x78  # little-endian
        assert bar.read(AXIS0 + ACC, 8) == b"\1\2\3\4\5\6\7\x08"
        assert trips.count == 0
        assert seen.read32(AXIS0 + TARGET) == 0x1234_5678 and seen.read16(AXIS0 + VMAX) == 0xBEEF
        assert seen.read(AXIS0 + ACC, 8) == b"\1\2\3\4\5\6\7\x08"
        trips.reset()
        bar.read32(AXIS0 + POSITION)  # a read-only register: it has a hook
        bar.read(AXIS0 + TARGET, 0x20)  # a block over passive and hooked registers
        assert trips.count == 2


def test_big_endian_regions_read_in_their_order(mapped: vdevclient.Rack) -> None:
    shm = mapped.card("maxk0").region("shm")
    shm.write32(Shm.UTILITY, 0x0102_0304)
    assert shm.read(Shm.UTILITY, 4) == b"\1\2\3\4" and shm.read16(Shm.UTILITY) == 0x0102
    assert shm.read64(Shm.UTILITY) == 0x0102_0304_0000_0000  # 8 bytes: a block access


def test_what_the_bus_refuses_is_refused_through_the_mapping_too(mapped: vdevclient.Rack) -> None:
    bar = mapped.card("servo0").region("bar0")
    assert not bar.is_mapped(AXIS0 + TARGET + 1, 4)  # misaligned: a request, which refuses it
    with pytest.raises(vdevclient.RemoteError) as err:
        bar.read32(AXIS0 + TARGET + 1)
    assert err.value.code == "bad_width"
    with pytest.raises(vdevclient.RemoteError):
        bar.read(0xFFE, 4)


def test_shared_memory_off_by_argument_or_environment(daemon: DaemonThread,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VDEVD_SHM", "off")
    with vdevclient.connect(daemon.endpoint) as rack:
        assert rack.shm is None and not rack.card("maxk0").region("shm").mapped
    monkeypatch.delenv("VDEVD_SHM")
    with vdevclient.connect(daemon.endpoint) as rack:
        assert rack.shm is not None and rack.card("maxk0").region("shm").mapped


def test_a_file_that_is_not_the_daemons_segment_is_not_mapped(daemon: DaemonThread,
                                                              mapped: vdevclient.Rack) -> None:
    path = Path(mapped.info["shm"]["path"])
    aside = path.with_name(path.name + ".aside")
    path.rename(aside)
    try:
        path.write_bytes(bytes(mapped.info["shm"]["size"]))
        with vdevclient.connect(daemon.endpoint) as rack:
            assert rack.shm is None
            assert rack.card("maxk0").region("shm").read32(Shm.FIRMWARE_STATE) & 0x4
    finally:
        aside.replace(path)


@pytest.mark.skipif(os.geteuid() == 0, reason="root opens a file of any mode")
def test_a_segment_this_user_cannot_open_is_not_mapped(daemon: DaemonThread,
                                                       mapped: vdevclient.Rack) -> None:
    path = Path(mapped.info["shm"]["path"])
    path.chmod(0)
    try:
        with vdevclient.connect(daemon.endpoint) as rack:
            assert rack.shm is None
    finally:
        path.chmod(0o600)


def test_a_closed_rack_refuses_mapped_accesses(daemon: DaemonThread) -> None:
    rack = vdevclient.connect(daemon.endpoint)
    bar = rack.card("servo0").region("bar0")
    rack.close()
    with pytest.raises(vdevclient.RackClosed):
        bar.read32(AXIS0 + TARGET)
    with pytest.raises(vdevclient.RackClosed):
        bar.write32(AXIS0 + TARGET, 1)


def test_writes_through_the_mapping_reach_the_card_at_its_next_tick(
        mapped: vdevclient.Rack, plain: vdevclient.Rack) -> None:
    """The PMAC posts a real-time sample at the next servo cycle after the host clears the
    data-ready bit; the generic card takes the parameters when its command register is written."""
    assert pcomm.OpenPmacDevice(0, endpoint=plain.endpoint)
    try:
        assert pcomm.PmacDPRRealTimeEx(0, 0x1, 1, 1)
        dpram = mapped.card("pmac0").region("dpram")
        plain.sim.step(ticks=1, card="pmac0")
        assert dpram.read16(RT_READY) & READY
        timer = dpram.read16(RT_TIMER)
        dpram.write16(RT_READY, 0)
        assert plain.card("pmac0").region("dpram").read16(RT_READY) == 0  # no tick yet
        plain.sim.step(ticks=1, card="pmac0")
        assert dpram.read16(RT_READY) & READY and dpram.read16(RT_TIMER) == (timer + 1) & 0xFFFF
        assert pcomm.PmacDPRRealTimeEx(0, 0x1, 1, 0)
    finally:
        pcomm.ClosePmacDevice(0)
    bar = mapped.card("servo0").region("bar0")
    for reg, value in ((TARGET, 500), (VMAX, 100_000), (ACC, 1_000_000), (DEC, 1_000_000)):
        bar.write32(AXIS0 + reg, value)
    bar.write32(AXIS0 + COMMAND, MOVE_ABS)
    plain.sim.step(seconds=0.1)
    assert bar.read32(AXIS0 + POSITION) == 500


def test_in_lockstep_the_mapping_shows_what_requests_show_after_every_step(
        mapped: vdevclient.Rack, plain: vdevclient.Rack) -> None:
    """Moves on three cards, the PMAC's reporting buffers on: after each step every passive byte
    read through the mapping equals the same bytes read by requests."""
    assert pcomm.OpenPmacDevice(0, endpoint=plain.endpoint)
    board = maxk.open(1, endpoint=plain.endpoint)
    try:
        assert pcomm.PmacDPRRealTimeEx(0, 0xFF, 1, 1) and pcomm.PmacDPRBackgroundEx(0, 1, 1, 16)
        out = ctypes.create_string_buffer(256)
        pcomm.PmacGetResponseA(0, out, 256, "#1J+")
        board.send_string("AX MR20000 GO AY MR-5000 GO")
        bar = plain.card("servo0").region("bar0")
        for reg, value in ((TARGET, 10_000), (VMAX, 50_000), (ACC, 500_000), (DEC, 500_000)):
            bar.write32(AXIS0 + reg, value)
        bar.write32(AXIS0 + COMMAND, MOVE_ABS)
        shared = [(c, r) for c, regions in mapped.info["shm"]["regions"].items() for r in regions]
        assert sorted(shared) == [("maxk0", "shm"), ("pmac0", "dpram"), ("servo0", "bar0")]
        ready = plain.card("pmac0").region("dpram")
        for step in range(12):
            plain.sim.step(ticks=3 + step)
            for card_name, name in shared:
                via_map = mapped.card(card_name).region(name)
                via_req = plain.card(card_name).region(name)
                for start, end in via_map.info.passive:
                    assert via_map.is_mapped(start, end - start)
                    assert via_map.read(start, end - start) == via_req.read(start, end - start), (
                        f"{card_name}/{name} {start:#x}..{end:#x} after step {step}")
            ready.write16(RT_READY, 0)  # ask for the next real-time sample
        positions = mapped.card("maxk0").region("shm").read(Shm.MOTOR_POSITION, 8)
        assert positions != bytes(8)  # things moved
    finally:
        board.close()
        pcomm.ClosePmacDevice(0)


def test_maxk_writes_its_command_ring_through_the_mapping(daemon: DaemonThread,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    with maxk.open(1, endpoint=daemon.endpoint) as board, round_trips(monkeypatch) as trips:
        for _ in range(RING_SIZE // 8):  # around the ring, wrapping
            assert board.send_and_get_string("AX RP") == str(board.get_positions().motor[0])
        ring = range(Shm.COMMAND_RING, Shm.COMMAND_RING + RING_SIZE)
        offsets = [op[3] if isinstance(op, list) else op["offset"]
                   for sent in trips.sent for op in sent["ops"]]
        assert offsets and not any(o in ring for o in offsets)


def test_pcomm_dpram_reads_take_no_round_trip_but_beside_a_deferred_ack(
        daemon: DaemonThread, monkeypatch: pytest.MonkeyPatch) -> None:
    assert pcomm.OpenPmacDevice(0, endpoint=daemon.endpoint)
    try:
        out = ctypes.create_string_buffer(256)
        with round_trips(monkeypatch) as trips:
            pcomm.PmacGetResponseA(0, out, 256, "I10")  # leaves its ACK to acknowledge
            trips.reset()
            assert pcomm.PmacDPRSetMem(0, OPEN_USE, 4, b"\1\2\3\4")
            assert pcomm.PmacDPRGetMem(0, OPEN_USE, 4) == b"\1\2\3\4"
            pcomm.PmacDPRSetFloat(0, OPEN_USE + 4, 1.5)
            assert pcomm.PmacDPRGetFloat(0, OPEN_USE + 4) == 1.5
            pcomm.PmacDPRGetDataReadyBit(0)
            assert trips.count == 0
            pcomm.PmacDPRGetMem(0, RESP_CONTROL + 2, 2)  # the slot the ack frees: after it
            assert trips.count == 1 and trips.sent[0]["ops"][0]["offset"] == RESP_CONTROL
            pcomm.PmacDPRGetMem(0, RESP_CONTROL + 2, 2)  # nothing deferred now
            assert trips.count == 1
    finally:
        pcomm.ClosePmacDevice(0)


def test_when_the_daemon_stops_its_mapping_is_no_longer_used() -> None:
    with DaemonThread(rack_config(card("oms-maxk", "maxk0", board=1))) as d:
        rack = vdevclient.connect(d.endpoint, timeout=0.5)
        shm = rack.card("maxk0").region("shm")
        assert shm.is_mapped(Shm.FIRMWARE_STATE, 4)
    try:
        assert not shm.is_mapped(Shm.FIRMWARE_STATE, 4)  # not frozen memory: a request
        with pytest.raises(vdevclient.VdevTimeout):
            shm.read32(Shm.FIRMWARE_STATE)
    finally:
        rack.close()
