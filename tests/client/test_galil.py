"""vdevclient.galil, the DMC library functions, against a lockstep daemon with two DMC-13X8 cards
(and a generic-servo card between them, which controller numbers skip)."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from typing import Any

import pytest
import vdevclient
from vdevclient import galil
from vdevmaps.galil import A16Reg, ControlStatus, InterruptStatus

from tests.client.galil import GALIL, card, rack_config, round_trips
from vdevd.testing import DaemonThread

OK = galil.DMCNOERROR
Y_COMPLETE = InterruptStatus.AXIS_COMPLETE + 1  # D1 [M Ch4 §Servicing Interrupts]


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card(GALIL, "galil0"), card("generic-servo", "servo0", plant="ideal"),
                      card(GALIL, "galil1"))
    with DaemonThread(cfg) as d:
        yield d


def open_controller(daemon: DaemonThread, number: int = 1, hwnd: Any = 0) -> ctypes.c_long:
    h = ctypes.c_long()
    assert galil.DMCOpen(number, hwnd, ctypes.byref(h), endpoint=daemon.endpoint) == OK
    return h


@pytest.fixture
def h(daemon: DaemonThread) -> Iterator[ctypes.c_long]:
    handle = open_controller(daemon)
    yield handle
    galil.DMCClose(handle)


def command(h: Any, text: str | bytes, size: int = 1024) -> tuple[int, bytes]:
    buf = ctypes.create_string_buffer(size)
    rc = galil.DMCCommand(h, text, buf, size)
    return rc, buf.value


def error_text(h: Any, code: int) -> bytes:
    buf = ctypes.create_string_buffer(256)
    galil.DMCError(h, code, buf, 256)
    return buf.value


# -- opening ----------------------------------------------------------------------------------------
def test_controller_2_is_the_second_galil_card_in_hello_order(daemon: DaemonThread,
                                                               rack: vdevclient.Rack) -> None:
    rack.control("galil1", "set_input", input=1, level=0)
    first, second = open_controller(daemon, 1), open_controller(daemon, 2)
    assert command(first, "MG @IN[1]") == (OK, b" 0000000001.0000\r\n:")
    assert command(second, "MG @IN[1]") == (OK, b" 0000000000.0000\r\n:")
    assert first.value != second.value
    assert galil.DMCClose(first) == OK and galil.DMCClose(second) == OK


def test_a_controller_number_past_the_galil_cards_is_DMCERROR_CONTROLLER(daemon: DaemonThread) -> None:
    h = ctypes.c_long(99)
    assert galil.DMCOpen(3, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCERROR_CONTROLLER
    assert h.value == -1
    assert galil.DMCOpen(0, 0, ctypes.byref(h), endpoint=daemon.endpoint) == galil.DMCERROR_CONTROLLER


def test_open_takes_the_endpoint_from_VDEVD_ENDPOINT(daemon: DaemonThread,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, h) == OK  # the ctypes object itself is accepted too
    assert command(h, "TPX") == (OK, b"0000000000\r\n:")
    assert galil.DMCClose(h) == OK


def test_open_desc_opens_a_card_by_name_and_tells_its_controller_number(daemon: DaemonThread) -> None:
    h, number = ctypes.c_long(), ctypes.c_ushort()
    assert galil.DMCOpenDesc("galil1", 0, ctypes.pointer(h), ctypes.byref(number),
                             endpoint=daemon.endpoint) == OK
    assert number.value == 2
    assert galil.DMCClose(h) == OK
    assert galil.DMCOpenDesc("servo0", 0, ctypes.byref(h), endpoint=daemon.endpoint) \
        == galil.DMCERROR_CONTROLLER


def test_a_closed_or_unknown_handle_is_DMCERROR_HANDLE(h: ctypes.c_long) -> None:
    assert galil.DMCClose(h) == OK
    assert command(h, "TPX")[0] == galil.DMCERROR_HANDLE
    assert galil.DMCClose(h) == galil.DMCERROR_HANDLE
    assert galil.DMCClear(12345) == galil.DMCERROR_HANDLE


# -- commands ---------------------------------------------------------------------------------------
def test_tpx_answers_the_position_then_colon(h: ctypes.c_long) -> None:
    assert command(h, "TPX") == (OK, b"0000000000\r\n:")
    assert command(h, b"DP 1234;") == (OK, b":")
    assert command(h, "TP") == (OK, b"0000001234,0000000000,0000000000,0000000000\r\n:")


def test_a_question_mark_is_DMCERROR_COMMAND_and_DMCError_tells_the_tc1_reason(h: ctypes.c_long) -> None:
    assert command(h, "XYZ") == (galil.DMCERROR_COMMAND, b"?")
    assert error_text(h, galil.DMCERROR_COMMAND) == b"1 Unrecognized command."
    assert command(h, "KP 2000") == (galil.DMCERROR_COMMAND, b"?")
    assert error_text(h, galil.DMCERROR_COMMAND) == b"6 Number out of range."


def test_DMCError_texts_of_library_codes(h: ctypes.c_long) -> None:
    assert error_text(h, galil.DMCERROR_TIMEOUT) == \
        b"A time-out occurred while waiting for a response from the controller."
    assert error_text(h, galil.DMCERROR_HANDLE) == b"Invalid Galil controller handle."
    assert error_text(h, -99) == b"Unknown error."


def test_each_command_of_a_line_gets_its_reply(h: ctypes.c_long) -> None:
    assert command(h, "DP 10,20;TPX;TPY;XYZ;TPZ") == \
        (galil.DMCERROR_COMMAND, b":0000000010\r\n:0000000020\r\n:?0000000000\r\n:")


def test_binary_pr_1000_blank_minus_500(h: ctypes.c_long) -> None:
    buf = ctypes.create_string_buffer(64)
    pr = (ctypes.c_ubyte * 8)(*bytes.fromhex("A7 02 00 05 03 E8 FE 0C"))  # manual ch. 5
    assert galil.DMCBinaryCommand(h, pr, 8, buf, 64) == OK
    assert buf.value == b":"
    assert command(h, "PR ?,?,?,?") == (OK, b"0000001000,0000000000,-0000000500,0000000000\r\n:")
    assert galil.DMCBinaryCommand(h, b"\xfe\x00\x00\x00", 4, buf, 64) == galil.DMCERROR_COMMAND
    assert error_text(h, galil.DMCERROR_COMMAND) == b"99 Bad binary command number."


def test_a_reply_longer_than_the_buffer_is_DMCERROR_BUFFERFULL_with_the_rest_kept(h: ctypes.c_long) -> None:
    rc, head = command(h, "TP", size=11)
    assert (rc, head) == (galil.DMCERROR_BUFFERFULL, b"0000000000")
    n = ctypes.c_ulong()
    assert galil.DMCGetAdditionalResponseLen(h, ctypes.byref(n)) == OK
    rest = ctypes.create_string_buffer(64)
    assert galil.DMCGetAdditionalResponse(h, rest, 64) == OK
    assert head + rest.value == b"0000000000,0000000000,0000000000,0000000000\r\n:"
    assert n.value == len(rest.value)


def test_fast_command_replies_go_to_the_unsolicited_buffer(h: ctypes.c_long) -> None:
    assert galil.DMCFastCommand(h, "MG 7") == OK
    assert command(h, "TPX") == (OK, b"0000000000\r\n:")
    buf = ctypes.create_string_buffer(64)
    assert galil.DMCGetUnsolicitedResponse(h, buf, 64) == OK
    assert buf.value == b" 0000000007.0000\r\n:"
    assert galil.DMCGetUnsolicitedResponse(h, buf, 64) == OK
    assert buf.value == b""


def test_clear_empties_both_fifos(h: ctypes.c_long, rack: vdevclient.Rack) -> None:
    a16 = rack.card("galil0").region("a16")
    assert galil.DMCFastCommand(h, "WT 1000;MG 7") == OK  # no sample ran: both wait in the FIFO
    assert galil.DMCClear(h) == OK
    cleared_and_empty = ControlStatus.CLEARED | ControlStatus.READ_EMPTY
    assert a16.read8(A16Reg.CONTROL) & cleared_and_empty == cleared_and_empty  # bits 7 and 5
    rack.sim.step(seconds=2.0)
    assert a16.read8(A16Reg.CONTROL) & ControlStatus.READ_EMPTY  # MG 7 was cleared before it ran
    assert command(h, "TPX") == (OK, b"0000000000\r\n:")


def test_reset_restores_the_defaults(h: ctypes.c_long) -> None:
    assert command(h, "KP 10;EO 1") == (OK, b"::")
    assert galil.DMCReset(h) == OK
    assert command(h, "KP ?;MG _EO") == (OK, b"0006.00\r\n: 0000000000.0000\r\n:")
    assert command(h, "KP 10") == (OK, b":")
    assert galil.DMCMasterReset(h) == OK
    assert command(h, "KP ?") == (OK, b"0006.00\r\n:")


def test_version_is_the_first_line_of_the_rv_answer(h: ctypes.c_long) -> None:
    buf = ctypes.create_string_buffer(64)
    assert galil.DMCVersion(h, buf, 64) == OK
    assert buf.value == b"DMC1348 Rev 1.1a"


# -- interrupts -------------------------------------------------------------------------------------
def test_y_motion_complete_interrupt_reads_d1(daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    """Manual ch. 4 "Example - Interrupts": host enable (2, 4 to N+3: a non-zero hwnd at open),
    EI 2,,255, PR,5000, BGY; at the end of the move write 6 to N+3 and read D1 from N+3."""
    h = open_controller(daemon, hwnd=1)
    status = ctypes.c_ushort(0xAA)
    assert galil.DMCGetInterruptStatus(h, ctypes.byref(status)) == OK
    assert status.value == 0
    assert command(h, "EI 2,,255;PR,5000;BGY") == (OK, b":::")
    event = rack.card("galil0").irq.wait(timeout_s=5.0)
    assert event is not None and event["status"] == Y_COMPLETE | 255 << 8 | 5 << 16
    assert galil.DMCGetInterruptStatus(h, ctypes.byref(status)) == OK
    assert status.value == Y_COMPLETE
    assert galil.DMCGetInterruptStatus(h, ctypes.byref(status)) == OK
    assert status.value == 0
    assert galil.DMCClose(h) == OK


# -- data record ------------------------------------------------------------------------------------
def test_data_record_after_a_move(h: ctypes.c_long) -> None:
    assert command(h, "PR 1000,,-300;BG XZ;AM XZ") == (OK, b":::")
    assert command(h, "WT 20") == (OK, b":")  # DR-4: a record loaded after the move ended
    assert galil.DMCRefreshDataRecord(h, 0) == OK
    size = ctypes.c_ushort()
    assert galil.DMCGetDataRecordSize(h, ctypes.byref(size)) == OK and size.value == 152
    kind, value = ctypes.c_ushort(0), ctypes.c_long()
    assert galil.DMCGetDataRecord(h, galil.DRREV4GenOffAxis1, galil.DRREV4AxisOffAxisReferencePosition,
                                  ctypes.byref(kind), ctypes.byref(value)) == OK
    assert (kind.value, value.value) == (galil.DRTypeLONG, 1000)
    kind.value = 0
    assert galil.DMCGetDataRecordByItemId(h, galil.DRIdAxisReferencePosition, galil.DRIdAxis3,
                                          ctypes.byref(kind), ctypes.byref(value)) == OK
    assert (kind.value, value.value) == (galil.DRTypeLONG, -300)
    assert galil.DMCGetDataRecordByItemId(h, galil.DRIdAxisStopCode, galil.DRIdAxis1,
                                          ctypes.byref(kind), ctypes.byref(value)) == OK
    assert (kind.value, value.value) == (galil.DRTypeUCHAR, 1)  # stopped at the commanded position
    kind.value = 0
    assert galil.DMCGetDataRecord(h, galil.DRREV4GenOffGeneralInput0, 0, ctypes.byref(kind),
                                  ctypes.byref(value)) == OK
    assert (kind.value, value.value) == (galil.DRTypeUCHAR, 0xFF)  # open inputs read 1
    copy = ctypes.create_string_buffer(152)
    assert galil.DMCCopyDataRecord(h, copy) == OK
    assert int.from_bytes(copy.raw[44:48], "little", signed=True) == 1000
    revision = ctypes.c_ushort()
    assert galil.DMCGetDataRecordRevision(h, ctypes.byref(revision)) == OK and revision.value == 4


def test_the_data_record_is_turned_on_when_first_needed_and_again_after_a_reset(
        h: ctypes.c_long) -> None:
    assert command(h, "MG _DR") == (OK, b" 0000000000.0000\r\n:")  # open leaves the card alone
    size = ctypes.c_ushort()
    assert galil.DMCGetDataRecordSize(h, ctypes.byref(size)) == OK and size.value == 152
    assert command(h, "MG _DR") == (OK, b" 0000000004.0000\r\n:")  # DR-4, the library default
    assert galil.DMCReset(h) == OK  # RS turns the record off
    assert galil.DMCRefreshDataRecord(h, 0) == OK
    assert command(h, "MG _DR") == (OK, b" 0000000004.0000\r\n:")


def test_data_record_items_outside_the_record_are_DMCERROR_DATARECORD(h: ctypes.c_long) -> None:
    kind, value = ctypes.c_ushort(0), ctypes.c_long()
    assert galil.DMCGetDataRecord(h, 0, 0, ctypes.byref(kind), ctypes.byref(value)) \
        == galil.DMCERROR_DATARECORD  # no record read yet
    assert galil.DMCRefreshDataRecord(h, 0) == OK
    assert galil.DMCGetDataRecordByItemId(h, galil.DRIdAxisMotorPosition, galil.DRIdAxis5,
                                          ctypes.byref(kind), ctypes.byref(value)) \
        == galil.DMCERROR_DATARECORD  # a 4-axis card
    assert galil.DMCGetDataRecordByItemId(h, galil.DRIdUserVariable, galil.DRIdAxis1,
                                          ctypes.byref(kind), ctypes.byref(value)) \
        == galil.DMCERROR_DATARECORD  # not in revision 4


def test_without_data_record_access_refresh_is_DMCERROR_DATARECORD(daemon: DaemonThread) -> None:
    h = ctypes.c_long()
    assert galil.DMCOpen(1, 0, ctypes.byref(h), endpoint=daemon.endpoint, refresh_rate=0) == OK
    assert galil.DMCRefreshDataRecord(h, 0) == galil.DMCERROR_DATARECORD
    assert command(h, "MG _DR") == (OK, b" 0000000000.0000\r\n:")
    assert galil.DMCClose(h) == OK


# -- timeouts -----------------------------------------------------------------------------------------
def test_a_missing_reply_times_out_after_the_timeout_of_card_time(h: ctypes.c_long,
                                                                  rack: vdevclient.Rack) -> None:
    timeout = ctypes.c_long()
    assert galil.DMCGetTimeout(h, ctypes.byref(timeout)) == OK and timeout.value == 1000
    assert galil.DMCSetTimeout(h, 100) == OK
    start = rack.sim.now_ns()
    assert command(h, "WT 5000") == (galil.DMCERROR_TIMEOUT, b"")
    assert rack.sim.now_ns() - start == 100_000_000
    assert galil.DMCSetTimeout(h, 10_000) == OK
    assert command(h, "TPX") == (OK, b"0000000000\r\n:")  # WT's late ':' is not TPX's reply
    buf = ctypes.create_string_buffer(16)
    assert galil.DMCGetUnsolicitedResponse(h, buf, 16) == OK and buf.value == b":"


def test_timeout_zero_ignores_time_outs(h: ctypes.c_long, rack: vdevclient.Rack) -> None:
    assert galil.DMCSetTimeout(h, 0) == OK
    start = rack.sim.now_ns()
    assert command(h, "WT 100000") == (OK, b"")
    assert rack.sim.now_ns() - start == galil.ZERO_TIMEOUT_BOUND_MS * 1_000_000
    timeout = ctypes.c_long(-1)
    assert galil.DMCGetTimeout(h, ctypes.byref(timeout)) == OK and timeout.value == 0


# -- the register protocol ----------------------------------------------------------------------------
def test_commands_cost_at_most_two_round_trips(h: ctypes.c_long, monkeypatch: pytest.MonkeyPatch) -> None:
    with round_trips(monkeypatch) as trips:
        for text in ("TPX", "TPX", "TP", "PR 1000;BGX;AMX", "KP ?,?,?,?;KD ?,?,?,?;KI ?,?,?,?",
                     "MG 1,2,3,4,5,6,7,8,9;MG 10,11,12,13,14,15,16", "XYZ", "TPX"):
            trips.reset()
            assert command(h, text)[0] in (OK, galil.DMCERROR_COMMAND)
            assert trips.count <= 2, text
        assert trips.count == 1  # a command seen before: exactly one
        trips.reset()
        assert galil.DMCFastCommand(h, "MG 7") == OK
        assert command(h, "TPY") == (OK, b"0000000000\r\n:")
        assert trips.count == 2
        assert galil.DMCRefreshDataRecord(h, 0) == OK  # the first: QZ and DR-4 besides
        trips.reset()
        status = ctypes.c_ushort()
        assert galil.DMCGetInterruptStatus(h, ctypes.byref(status)) == OK
        assert galil.DMCRefreshDataRecord(h, 0) == OK
        assert trips.count == 2


def test_each_burst_of_16_command_bytes_waits_for_the_almost_full_bit(
        h: ctypes.c_long, monkeypatch: pytest.MonkeyPatch) -> None:
    line = ";".join(f"KP {i}" for i in range(1, 10))  # 44 bytes + CR
    with round_trips(monkeypatch) as trips:
        assert command(h, line) == (OK, b":" * 9)
    ops = trips.sent[-1]["ops"]
    bursts: list[tuple[bool, int]] = []  # (a wait on bit 4 before it, bytes)
    waited = False
    for op in ops:
        if op["op"] == "wait" and op.get("mask") == ControlStatus.WRITE_ALMOST_FULL:
            waited = True
        elif op["op"] == "write" and op["offset"] == A16Reg.DATA:
            assert op["rep"]  # one repeated write to N+1 per burst
            bursts.append((waited, len(op["data"])))
            waited = False
    assert [n for _, n in bursts] == [16, 16, 13]
    assert all(w for w, _ in bursts[1:])  # the first burst knew from the last status read


def test_a_full_command_fifo_holds_the_writes_until_the_card_drains_it(
        h: ctypes.c_long, rack: vdevclient.Rack) -> None:
    """WT holds the interpreter, so 600 more bytes overfill the 512-byte FIFO: the bursts past
    the almost-full level wait (card time passes) until WT ends, instead of losing bytes."""
    assert galil.DMCSetTimeout(h, 5000) == OK
    start = rack.sim.now_ns()
    assert galil.DMCFastCommand(h, "WT 1000") == OK
    assert galil.DMCFastCommand(h, "KP 1;" * 120) == OK
    assert rack.sim.now_ns() - start >= 1_000_000_000
    assert command(h, "KP ?") == (OK, b"0001.00\r\n:")
    buf = ctypes.create_string_buffer(512)
    assert galil.DMCGetUnsolicitedResponse(h, buf, 512) == OK
    assert buf.value == b":" * 121  # WT's and every KP's


def test_output_parameters_may_be_byref_pointer_or_the_object(h: ctypes.c_long) -> None:
    for out in (ctypes.byref, ctypes.pointer, lambda x: x):
        status = ctypes.c_ushort(7)
        assert galil.DMCGetInterruptStatus(h, out(status)) == OK
        assert status.value == 0
    buf = ctypes.create_string_buffer(32)
    assert galil.DMCCommand(h.value, b"TPY", ctypes.byref(buf), 32) == OK
    assert buf.value == b"0000000000\r\n:"
    assert galil.DMCGetInterruptStatus(h, None) == galil.DMCERROR_ARGUMENT
