"""vdevclient.maxk, the MAXk host library (spec oms.md §6.1), against a real daemon holding
oms-maxk cards: lockstep unless a test says otherwise."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import pytest
import vdevclient
from vdevclient import maxk
from vdevclient._maxk_bus import (
    capture_entries,
    frame,
    ring_pieces,
    ring_slice,
    strip_reply,
)
from vdevmaps.oms import CAPTURE_ENTRY_SIZE, RING_SIZE, Shm

from tests.client.galil import card, rack_config, round_trips
from vdevd.testing import DaemonThread

MAXK = "oms-maxk"
MOVE_MS = 5000  # a wait long enough for the moves here (card time)


def maxk_card(name: str = "maxk0", **options: Any) -> Any:
    return card(MAXK, name, **{"board": 1, "axes": 4, **options})


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(maxk_card())) as d:
        yield d


@pytest.fixture
def m(daemon: DaemonThread) -> Iterator[maxk.Maxk]:
    with maxk.open(1, endpoint=daemon.endpoint) as board:
        yield board


# -- the pure parts -------------------------------------------------------------------------------
def test_frame_appends_the_terminator_and_refuses_more_than_1023_bytes() -> None:
    assert frame("AX RP") == b"AX RP;"
    assert frame(b"AX RP;") == b"AX RP;"
    assert len(frame("A" * 1022)) == 1023
    with pytest.raises(maxk.MessageTooLong):
        frame("A" * 1023)


def test_ring_pieces_split_where_the_ring_wraps() -> None:
    assert ring_pieces(10, 6) == [(10, 0, 6)]
    assert ring_pieces(1020, 6) == [(1020, 0, 4), (0, 4, 2)]
    assert ring_pieces(1018, 6) == [(1018, 0, 6)]
    assert ring_pieces(6, 4) == [(6, 0, 1), (7, 1, 3)]  # "#WS;": a 4-byte access must be aligned
    assert ring_pieces(1023, 2) == [(1023, 0, 1), (0, 1, 1)]
    assert ring_pieces(8, 4) == [(8, 0, 4)]
    ring = bytes(range(256)) * 4
    assert ring_slice(ring, 1022, 2) == bytes([254, 255, 0, 1])
    assert strip_reply(b"1000\n") == "1000"
    assert strip_reply(b"PNNN\n\0") == "PNNN"  # fw <= 1.29 ended some replies LF NUL


def test_status_flags_put_w_and_k_after_s() -> None:
    flags = maxk.StatusFlags.from_words(0x0100_0201 | 1 << 25, 0x0000_0001, 0x0001_0000)
    assert flags == maxk.StatusFlags(done=0x101, overtravel=0x2, slip=0x200, cmd_error=True)
    assert flags.only(0x100) == maxk.StatusFlags(done=0x100)


# -- opening ------------------------------------------------------------------------------------------
def test_open_finds_the_card_by_its_board_number_not_its_place() -> None:
    cfg = rack_config(maxk_card("maxk0", board=2, serial=2), card("generic-servo", "servo0"),
                      maxk_card("maxk1", board=1, serial=1))
    with DaemonThread(cfg) as d:
        with maxk.open(1, endpoint=d.endpoint) as board:
            assert board.card == "maxk1"
            assert board.send_and_get_string("WY").endswith("S/N: 000001, FPGA:20")
        with maxk.open(2, endpoint=d.endpoint) as board:
            assert board.card == "maxk0"
        with maxk.open(7, endpoint=d.endpoint, name="maxk0") as board:  # a name wins
            assert board.card == "maxk0"
        with pytest.raises(maxk.MaxkError, match="no oms-maxk card with board 3"):
            maxk.open(3, endpoint=d.endpoint)


def test_open_takes_the_endpoint_from_VDEVD_ENDPOINT(daemon: DaemonThread,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
    with maxk.open(1) as board:
        assert board.send_and_get_string("AX RP") == "0"


def test_open_masks_om0i_and_close_gives_omimr_back(daemon: DaemonThread,
                                                    rack: vdevclient.Rack) -> None:
    """Replies are polled (spec §3.3): a reply must not toggle INTA while the library runs."""
    mu = rack.card("maxk0").region("mu")
    board = maxk.open(1, endpoint=daemon.endpoint)
    board.send_and_get_string("WY")
    assert mu.read32(0x034) == 0x1
    assert rack.stats()["cards"]["maxk0"]["irq_seq"] == 0
    board.close()
    assert mu.read32(0x034) == 0x0
    board.close()  # again: nothing


# -- text commands ------------------------------------------------------------------------------------
def test_wy_names_a_maxk_4000(m: maxk.Maxk) -> None:
    assert m.send_and_get_string("WY").startswith("MAXk-4000")


def test_rp_of_a_fresh_card_is_0(m: maxk.Maxk) -> None:
    assert m.send_and_get_string("AX RP") == "0"


def test_mr1000_go_id_sets_done_and_rp_reads_1000(m: maxk.Maxk) -> None:
    m.send_string("AX MR1000 GO ID")
    assert m.wait_done(0b1, MOVE_MS) == maxk.StatusFlags(done=0b1)
    assert m.send_and_get_string("AX RP") == "1000"
    assert m.send_and_get_string("AA RP") == "1000,0,0,0"
    assert m.get_status_flags() == maxk.StatusFlags()  # wait_done cleared X's flags


def test_a_command_error_raises_and_the_card_keeps_answering(m: maxk.Maxk) -> None:
    with pytest.raises(maxk.CommandError, match="XYZZY"):
        m.send_and_get_string("XYZZY")
    assert m.send_and_get_string("AX RP") == "0"
    with pytest.raises(maxk.CommandError):
        m.send_string("AX VB300000")  # VB must stay below VL (200000) [spec §4.4]
    assert m.send_and_get_string("AX RP") == "0"
    assert not m.get_status_flags().cmd_error  # the exceptions took the flag


def test_mo_moves_one_count_in_the_direction_mp_or_mm_set(m: maxk.Maxk) -> None:
    """MO (the issue's motion list; proposed, card README): one count, plus after power-up."""
    m.send_string("AX MO ID")
    m.wait_done(0b1, MOVE_MS)
    assert m.send_and_get_string("AX RP") == "1"
    m.send_string("AX MM MO MO ID")
    m.wait_done(0b1, MOVE_MS)
    assert m.send_and_get_string("AX RP") == "-1"
    m.send_string("AX MP MO ID")
    m.wait_done(0b1, MOVE_MS)
    assert m.send_and_get_string("AX RP") == "0"
    assert m.send_and_get_string("AY RP") == "0"
    with pytest.raises(maxk.CommandError):
        m.send_string("AX MO5")


def test_an_mo_the_queue_has_no_room_for_queues_nothing(m: maxk.Maxk) -> None:
    """All or nothing: X's queue, held by a WT, has 5 units left; MO needs 6 (an MR and a GO)."""
    m.send_string("AX WT200")  # 2 units of X's 2559
    for n in (100,) * 12 + (76,):  # 1276 VLs of 2 units
        m.send_string("AX " + "VL1000 " * n)
    with pytest.raises(maxk.CommandError):
        m.send_string("AX MO")
    m.send_string("AX ID")
    m.wait_done(0b1, MOVE_MS)
    m.send_string("AX GO ID")  # a GO with no target loaded by the refused MO
    m.wait_done(0b1, MOVE_MS)
    assert m.send_and_get_string("AX RP") == "0"


def test_ws_and_its_hash_form_report_the_watchdog_counter(m: maxk.Maxk) -> None:
    assert m.send_and_get_string("WS") == "=0"
    assert m.send_and_get_string("#WS") == "=0"


def test_es_and_se_are_set_per_axis_and_queried(m: maxk.Maxk) -> None:
    """ES (encoder slip tolerance) and SE (aux output settle time, ms): spec §4.3 proposals
    for S §2.14's power-up parameters, queued as VL is; a value out of range changes
    nothing."""
    assert m.send_and_get_string("AA ES?") == "=0,=0,=0,=0"
    m.send_string("AA ES5,,7 SE20,30 ID")
    m.wait_done(0b1111, MOVE_MS)  # the queues have run them
    assert m.send_and_get_string("AA ES?") == "=5,=0,=7,=0"
    assert m.send_and_get_string("AY SE?") == "=30"
    with pytest.raises(maxk.CommandError):
        m.send_string("AX SE1001")
    assert m.send_and_get_string("AX SE?") == "=20"
    with pytest.raises(maxk.CommandError):
        m.send_and_get_string("AX VL?")  # no query of VL is known


def test_vb_above_a_vl_later_in_the_same_string_is_an_error(m: maxk.Maxk) -> None:
    with pytest.raises(maxk.CommandError):
        m.send_string("AX VB5000 VL1000")  # after it VB 5000 >= VL 1000 [spec §4.4]


def test_an_error_beside_a_reply_is_kept_for_get_status_flags(m: maxk.Maxk) -> None:
    assert m.send_and_get_string("XYZZY AX RP") == "0"
    assert m.get_status_flags().cmd_error
    assert not m.get_status_flags().cmd_error


def test_the_rings_wrap_under_a_long_stream_of_commands(m: maxk.Maxk, rack: vdevclient.Rack) -> None:
    shm = rack.card("maxk0").region("shm")
    for _ in range(200):  # 2000 bytes: the command ring wraps once, and more
        m.send_string("AX VL5000;")
    assert shm.read32(Shm.COMMAND_INSERT) == 2000 % RING_SIZE
    assert shm.read32(Shm.COMMAND_PROCESS) == 2000 % RING_SIZE
    for _ in range(150):  # "0\n" and "=M\n": the response ring wraps too
        assert m.send_and_get_string("AX RP") == "0"
        assert m.send_and_get_string("AX PS?") == "=M"
    assert m.send_and_get_string("WY").startswith("MAXk-4000")


def test_a_command_string_that_wraps_the_ring_arrives_whole(m: maxk.Maxk) -> None:
    m.send_string("AX " + "VL5000 " * 140)  # to 984: the next string crosses 1023
    assert m.send_and_get_string("AX " + "VL6000 " * 20 + "RP") == "0"


def test_two_and_four_byte_commands_at_any_ring_place(m: maxk.Maxk) -> None:
    for put in range(8):  # "AX;" moves the insert index by 3: every place modulo 4 comes
        assert m.send_and_get_string("#WS") == "=0", put  # 4 bytes with its ';'
        m.send_string(";;")  # 2 bytes, two empty commands
        m.send_string("AX")


def test_a_reply_to_send_string_is_flushed_not_taken_for_the_next_one(m: maxk.Maxk) -> None:
    m.send_string("WY")
    assert m.send_and_get_string("AX RP") == "0"  # flushed by the housekeeping, as E-drvMAXv does
    assert len(m.unsolicited) == 1 and m.unsolicited[0].startswith("MAXk-4000")


def test_a_second_reply_of_one_string_is_unsolicited(m: maxk.Maxk) -> None:
    """EPICS allows one reply per string; the library does not hand the second to the next call."""
    m.send_string("AY LP77 ID")  # LP is queued: let it run
    m.wait_done(0b10, MOVE_MS)
    assert m.send_and_get_string("WY;AY RP").startswith("MAXk-4000")
    assert m.send_and_get_string("AX RP") == "0"
    assert list(m.unsolicited) == ["77"]


def test_no_reply_in_time_is_MaxkTimeout(m: maxk.Maxk) -> None:
    with pytest.raises(maxk.MaxkTimeout):
        m.send_and_get_string("AX VL5000", timeout_ms=10)  # a command without a reply
    assert m.send_and_get_string("AX RP") == "0"


# -- flags, motion, mailboxes -----------------------------------------------------------------------
def test_wait_done_returns_overtravel_of_an_axis_a_limit_stopped(m: maxk.Maxk,
                                                                 rack: vdevclient.Rack) -> None:
    m.send_string("AY MR100000 GO ID")
    rack.sim.step(seconds=0.05)
    rack.control("maxk0", "set_limits", axis="Y", positive=True)
    assert m.wait_done(0b10, MOVE_MS) == maxk.StatusFlags(overtravel=0b10)  # the ID was flushed
    assert m.read_limits() & (1 << 9) == 0  # active low: the active switch reads 0
    assert m.send_and_get_string("AY QA") == "PNLN"


def test_a_move_into_an_active_limit_sets_overtravel_and_no_done(m: maxk.Maxk,
                                                                 rack: vdevclient.Rack) -> None:
    """Spec §3.4: over-travel flushes the axis' queue, "so a pending ID is discarded and no done
    flag is set"."""
    rack.control("maxk0", "set_limits", axis="Y", positive=True)
    m.send_string("AY MR1000 GO ID")
    assert m.wait_done(0b10, MOVE_MS) == maxk.StatusFlags(overtravel=0b10)


def test_wait_done_times_out_when_nothing_moves(m: maxk.Maxk, rack: vdevclient.Rack) -> None:
    t0 = rack.sim.now_ns()
    with pytest.raises(maxk.MaxkTimeout):
        m.wait_done(0b1, 50)
    assert rack.sim.now_ns() - t0 == 50_000_000  # lockstep: the wait ran the clock to its end
    m.send_string("AX MR10 GO ID")
    with pytest.raises(maxk.MaxkTimeout, match="XY not done"):
        m.wait_done(0b11, 50)  # X's wait fires, Y's runs out
    assert m.get_status_flags().done == 0b1  # nothing was cleared


def test_get_status_flags_reads_and_clears_in_one_batch(m: maxk.Maxk,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    m.send_string("AA MR100,200 GO ID")
    m.wait_done(0b1, MOVE_MS)
    with round_trips(monkeypatch) as trips:
        assert m.get_status_flags() == maxk.StatusFlags(done=0b10)
    assert trips.count == 1
    assert m.get_status_flags() == maxk.StatusFlags()


def test_kill_all_stops_a_long_move(m: maxk.Maxk, rack: vdevclient.Rack) -> None:
    m.send_string("AX VL100000 MR10000000 GO ID")
    rack.sim.step(seconds=0.2)
    moving = m.get_positions().motor[0]
    assert moving > 0
    m.kill_all()
    stopped = m.get_positions().motor[0]
    rack.sim.step(seconds=0.2)
    assert m.get_positions().motor[0] == stopped < 10_000_000
    with pytest.raises(maxk.MaxkTimeout):
        m.wait_done(0b1, 100)  # the queue was flushed: its ID never runs


def test_coherent_positions_equal_plain_ones_at_rest(m: maxk.Maxk) -> None:
    m.send_string("AA MR100,-200,300,-400 GO ID")
    m.wait_done(0b1111, MOVE_MS)
    plain, coherent = m.get_positions(), m.get_positions(coherent=True)
    assert plain == coherent
    assert plain.motor == (100, -200, 300, -400)


def test_fresh_card_runs_with_factory_parameters(m: maxk.Maxk) -> None:
    assert m.read_fw_status() == 0x00040004
    assert maxk.FirmwareState(m.read_fw_status()) == (maxk.FirmwareState.RUNNING
                                                      | maxk.FirmwareState.FACTORY_SET)


def test_limit_home_and_gpio_words(m: maxk.Maxk, rack: vdevclient.Rack) -> None:
    idle_limits = m.read_limits()
    assert idle_limits & 0xFFFF == 0x0F0F  # 4 axes, idle active-low inputs read high
    rack.control("maxk0", "set_limits", axis="Z", negative=True)
    assert m.read_limits() == idle_limits & ~(1 << 2)
    home = m.read_home()
    rack.control("maxk0", "set_home", axis="T", active=True)
    assert m.read_home() ^ home == 1 << 3
    rack.control("maxk0", "set_input", bit=2, level=1)
    assert m.read_gpio() & (1 << 2)


def test_rt_capture_drains_the_ring_from_removal_to_insert(m: maxk.Maxk, rack: vdevclient.Rack) -> None:
    """The ring's wrap, with entries stored here where the card stores them [S Table 3-5]:
    removal 53, insert 1."""
    shm = rack.card("maxk0").region("shm")
    entries = [(-5, 0, 0x01, 0, 0), (123456, 1, 0x02, 0x0004, 0), (7, 3, 0, 0, 0x8000)]
    for slot, (pos, axis, home, rising, falling) in zip((53, 54, 0), entries, strict=True):
        shm.write(Shm.CAPTURE_ENTRIES + slot * CAPTURE_ENTRY_SIZE,
                  pos.to_bytes(4, "big", signed=True) + bytes([axis, home])
                  + rising.to_bytes(2, "big") + falling.to_bytes(2, "big"))
    shm.write(Shm.CAPTURE_INSERT, bytes([1, 53]))
    got = m.get_rt_capture()
    assert [(e.encoder, e.axis, e.home, e.io_rising, e.io_falling) for e in got] == entries
    assert shm.read8(Shm.CAPTURE_REMOVAL) == 1
    assert m.get_rt_capture() == []
    assert capture_entries(shm.read(Shm.CAPTURE_INSERT, 552))[2] == []


def test_a_capture_on_an_input_edge_comes_with_om1i(m: maxk.Maxk, rack: vdevclient.Rack) -> None:
    """CPR (the card's proposed trigger command, README): X's encoder on IO3 rising."""
    mu = rack.card("maxk0").region("mu")
    m.send_string("AX LP1234 ID")
    m.wait_done(0b1, MOVE_MS)
    m.send_string("AX CPR0008")
    rack.control("maxk0", "set_input", bit=3, level=0)  # the inputs idle high
    rack.sim.step(ticks=2)
    assert m.get_rt_capture() == []
    rack.control("maxk0", "set_input", bit=3, level=1)
    rack.sim.step(ticks=2)
    assert mu.read32(0x030) & 0x2 and mu.read32(0x05C) == 2  # OM1I, OMR1 = 2 [S §3.7]
    assert m.get_rt_capture() == [maxk.CaptureEntry(encoder=1234, axis=0, home=0, io_rising=0x8,
                                                    io_falling=0)]
    assert not mu.read32(0x030) & 0x2
    assert m.get_rt_capture() == []


def test_w_and_k_events_go_through_their_status_words() -> None:
    with DaemonThread(rack_config(maxk_card(axes=10, plant="ideal"))) as d, \
            maxk.open(1, endpoint=d.endpoint) as board:
        assert board.axes == 10
        board.send_string("AW MR100 GO ID")
        board.send_string("AK MR-50 GO ID")
        assert board.wait_done(0b11 << 8, MOVE_MS) == maxk.StatusFlags(done=0b11 << 8)
        assert board.get_status_flags() == maxk.StatusFlags()  # ODBR bits 25, 26 cleared too
        positions = board.get_positions()
        assert positions.motor[8:] == (100, -50)
        assert board.get_positions(coherent=True) == positions


def test_the_axis_count_comes_from_wy(m: maxk.Maxk) -> None:
    assert m.axes == 4
    assert len(m.get_positions().encoder) == 4


# -- round trips -----------------------------------------------------------------------------------------
QUERIES = ("WY", "AX RP", "AX RP", "AA RP", "AX PS?", "AY RP", "AX RP")


def test_a_command_and_its_reply_cost_one_round_trip(m: maxk.Maxk,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    assert m.axes == 4  # learnt from WY once
    with round_trips(monkeypatch) as trips:
        for text in QUERIES:
            trips.reset()
            m.send_and_get_string(text)
            assert trips.count == 1, text
        for call in (m.get_status_flags, m.kill_all, lambda: m.get_positions(coherent=True)):
            trips.reset()
            call()
            assert trips.count == 1
        for call in (m.read_fw_status, m.read_limits, m.get_positions):  # shared memory
            trips.reset()
            call()
            assert trips.count == 0
        trips.reset()
        with pytest.raises(maxk.CommandError):
            m.send_and_get_string("XYZZY")
        assert trips.count == 1


def test_without_shared_memory_the_status_poll_is_one_round_trip(
        daemon: DaemonThread, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VDEVD_SHM", "0")
    with maxk.open(1, endpoint=daemon.endpoint) as board, round_trips(monkeypatch) as trips:
        board.send_string("AX MR7 GO ID")
        for call in (board.read_fw_status, board.read_limits, board.get_positions):
            trips.reset()
            call()
            assert trips.count == 1
        assert not board.rack.card(board.card).region("shm").mapped


def test_releasing_at_once_costs_a_second_round_trip(daemon: DaemonThread,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    with maxk.open(1, endpoint=daemon.endpoint, defer_release=False) as board, \
            round_trips(monkeypatch) as trips:
        for text in QUERIES:
            trips.reset()
            board.send_and_get_string(text)
            assert trips.count == 2, text
        assert board.send_and_get_string("AX RP") == "0"


@pytest.mark.parametrize("clock", ["lockstep", "realtime"])
@pytest.mark.parametrize("decode", ["arrival", "cycle"])
def test_at_most_two_round_trips_in_both_clock_modes(clock: str, decode: str,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """decode = "cycle" parses at the next update cycle: the reply (or the command error) is
    waited for in the daemon, in a second batch."""
    cfg = replace(rack_config(maxk_card(decode=decode)), clock=clock)  # type: ignore[arg-type]
    with DaemonThread(cfg) as d, maxk.open(1, endpoint=d.endpoint) as board, \
            round_trips(monkeypatch) as trips:
        for text in QUERIES:
            trips.reset()
            assert board.send_and_get_string(text)
            assert trips.count <= 2, text
            if decode == "arrival":
                assert trips.count == 1, text
        trips.reset()
        with pytest.raises(maxk.CommandError):
            board.send_and_get_string("XYZZY")
        assert trips.count <= 2
        board.send_string("AX MR500 GO ID")
        board.wait_done(0b1, MOVE_MS)
        assert board.send_and_get_string("AX RP") == "500"
