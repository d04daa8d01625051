"""The DMC-13X8 A16 window, driven through the manual's procedures (manual ch. 4)."""

from __future__ import annotations

import pytest
from vdevmaps.galil import A16Reg, ControlStatus, SecondaryStatus

from vdevd.devices.galil.bus import FREEZE_MODES, A16Window

DATA = A16Reg.DATA
CONTROL = A16Reg.CONTROL
FIFO2 = A16Reg.SECONDARY_DATA
FIFO2_STATUS = A16Reg.SECONDARY_STATUS
ALMOST_FULL = ControlStatus.WRITE_ALMOST_FULL
READ_EMPTY = ControlStatus.READ_EMPTY
CLEARED = ControlStatus.CLEARED
RECORD = bytes(range(152))  # a 4-axis data record [M Ch4 §DMA / Secondary FIFO Memory Map]


def host_send(w: A16Window, data: bytes) -> int:
    """[M Ch4 §Write Procedure]: while bit 4 reads 0, write up to almost-full-level bytes; returns the
    number of bytes sent before bit 4 read 1."""
    sent = 0
    while sent < len(data) and not w.read(CONTROL) & ALMOST_FULL:
        for b in data[sent : sent + w.almost_full_level]:
            w.write(DATA, b)
            sent += 1
    return sent


def host_receive(w: A16Window) -> bytes:
    """[M Ch4 §Read Procedure]: check bit 5 for every character, read until it signifies empty."""
    out = bytearray()
    while not w.read(CONTROL) & READ_EMPTY:
        out.append(w.read(DATA))
    return bytes(out)


def write_control(w: A16Window, *values: int) -> None:
    for v in values:
        w.write(CONTROL, v)


# -- communication registers --------------------------------------------------------------------
def test_power_on_status_reads_empty_and_ok_to_write() -> None:
    w = A16Window()
    assert w.read(CONTROL) == READ_EMPTY
    assert w.almost_full_level == 16


def test_write_procedure_with_default_level_fills_the_fifo_in_16s_and_loses_nothing() -> None:
    w = A16Window()
    message = bytes(range(256)) * 4
    sent = host_send(w, message)
    assert sent == 512  # the last chunk starts with exactly 16 free
    assert w.command_bytes() == message[:512]
    assert w.read(CONTROL) & ALMOST_FULL
    w.consume(16)
    assert host_send(w, message[sent:]) == 16


def test_bit_4_sets_when_free_space_drops_below_the_level() -> None:
    w = A16Window()
    for _ in range(512 - 16):
        w.write(DATA, ord("A"))
    assert not w.read(CONTROL) & ALMOST_FULL  # 16 free: OK to write up to 16
    w.write(DATA, ord("A"))
    assert w.read(CONTROL) & ALMOST_FULL


def test_consuming_commands_clears_bit_4() -> None:
    w = A16Window()
    host_send(w, bytes(600))
    w.consume(100)
    assert not w.read(CONTROL) & ALMOST_FULL


def test_byte_written_to_full_command_fifo_is_lost() -> None:
    w = A16Window()
    for _ in range(512):
        w.write(DATA, ord("A"))
    w.write(DATA, ord("B"))
    assert w.command_bytes() == b"A" * 512


def test_5_then_240_sets_almost_full_level_256_and_write_procedure_sends_256_at_a_time() -> None:
    w = A16Window()
    write_control(w, 0x05, 240)
    assert w.almost_full_level == 256
    w.write(DATA, 0)
    assert not w.read(CONTROL) & ALMOST_FULL  # 511 free
    for _ in range(256):
        w.write(DATA, 0)
    assert w.read(CONTROL) & ALMOST_FULL  # 255 free < 256
    w.consume(1)
    assert not w.read(CONTROL) & ALMOST_FULL


def test_write_procedure_with_level_256_sends_256_byte_chunks_and_loses_nothing() -> None:
    w = A16Window()
    write_control(w, 0x05, 240)
    message = bytes(range(256)) * 4
    sent = host_send(w, message)
    assert sent == 512
    assert w.command_bytes() == message[:512]
    w.consume(255)
    assert host_send(w, message[sent:]) == 0  # 255 free < 256: do not send
    w.consume(1)
    assert host_send(w, message[sent:]) == 256


def test_almost_full_level_16_to_256_in_multiples_of_16() -> None:
    w = A16Window()
    for m in range(16, 257, 16):
        write_control(w, 0x05, m - 16)
        assert w.almost_full_level == m


@pytest.mark.parametrize("arg", [1, 8, 250, 255])
def test_invalid_almost_full_argument_is_ignored(arg: int) -> None:
    w = A16Window()
    write_control(w, 0x05, 32, 0x05, arg)
    assert w.almost_full_level == 48


def test_read_procedure_reads_until_bit_5_is_1_and_empty_read_gives_ff() -> None:
    w = A16Window()
    assert w.respond(b"1000\r\n:") == 7
    assert not w.read(CONTROL) & READ_EMPTY
    assert host_receive(w) == b"1000\r\n:"
    assert w.read(CONTROL) & READ_EMPTY
    assert w.read(DATA) == 0xFF
    w.respond(b":")
    assert w.read(DATA) == ord(":")  # the empty read popped nothing


def test_respond_takes_only_what_fits() -> None:
    w = A16Window(fifo_size=8)
    assert w.respond(b"0123456789") == 8
    assert w.response_space() == 0
    assert w.respond(b"x") == 0
    assert host_receive(w) == b"01234567"
    assert w.response_space() == 8


def test_card_consumes_command_bytes_from_the_front() -> None:
    w = A16Window()
    for b in b"TPX;BGX\r":
        w.write(DATA, b)
    w.consume(4)
    assert w.command_bytes() == b"BGX\r"
    with pytest.raises(ValueError):
        w.consume(5)


def test_clear_sequence_empties_both_fifos_and_bit_7_reads_1() -> None:
    w = A16Window()
    for b in b"PR 1000;":
        w.write(DATA, b)
    w.respond(b"1000\r\n:")
    told: list[bool] = []
    w.on_clear = lambda: told.append(True)
    w.read(CONTROL)  # the no-op read [M Ch4 §Clearing FIFO Buffer]
    write_control(w, 0x01, 0x80, 0x01, 0x80)
    assert w.read(CONTROL) == CLEARED | READ_EMPTY
    assert w.command_bytes() == b""
    assert w.read(DATA) == 0xFF
    assert told == [True]  # the firmware learns of it (it drops a held command)


def test_reads_of_control_inside_the_clear_sequence_do_not_break_it() -> None:
    w = A16Window()
    w.write(DATA, ord("A"))
    for v in (0x01, 0x80, 0x01, 0x80):
        w.read(CONTROL)
        w.write(CONTROL, v)
    assert w.command_bytes() == b""


def test_bit_7_stays_1_until_a_byte_enters_a_fifo() -> None:
    w = A16Window()
    write_control(w, 0x01, 0x80, 0x01, 0x80)
    assert w.read(CONTROL) & CLEARED
    assert w.read(CONTROL) & CLEARED
    w.write(DATA, ord("R"))
    assert not w.read(CONTROL) & CLEARED
    write_control(w, 0x01, 0x80, 0x01, 0x80)
    w.respond(b":")
    assert not w.read(CONTROL) & CLEARED


def test_clear_keeps_the_almost_full_level_and_interrupt_queue() -> None:
    w = A16Window()
    write_control(w, 0x05, 240)
    w.post_interrupt(0xD0)
    write_control(w, 0x01, 0x80, 0x01, 0x80)
    assert w.almost_full_level == 256
    assert w.pending_interrupts == (0xD0,)


def test_broken_clear_sequence_clears_nothing() -> None:
    w = A16Window()
    w.write(DATA, ord("A"))
    told: list[bool] = []
    w.on_clear = lambda: told.append(True)
    write_control(w, 0x01, 0x80, 0x33, 0x01, 0x80)
    assert w.command_bytes() == b"A"
    assert told == []


def test_byte_that_breaks_a_sequence_starts_its_own() -> None:
    w = A16Window()
    write_control(w, 0x01, 0x80, 0x05, 48)
    assert w.almost_full_level == 64


# -- interrupts -----------------------------------------------------------------------------------
def test_2_then_4_enables_interrupts() -> None:
    w = A16Window()
    w.write(CONTROL, 0x02)
    assert not w.interrupts_enabled
    w.write(CONTROL, 0x04)
    assert w.interrupts_enabled


@pytest.mark.parametrize("sequence", [[0x04], [0x04, 0x02], [0x02, 0x07, 0x04]])
def test_other_orders_do_not_enable_interrupts(sequence: list[int]) -> None:
    w = A16Window()
    write_control(w, *sequence)
    assert not w.interrupts_enabled


def test_write_6_then_read_control_returns_queued_codes_in_order_then_00() -> None:
    w = A16Window()
    write_control(w, 0x02, 0x04)
    w.post_interrupt(0xD1)
    w.post_interrupt(0xF1)
    got = []
    for _ in range(3):
        w.write(CONTROL, 0x06)
        got.append(w.read(CONTROL))
    assert got == [0xD1, 0xF1, 0x00]


def test_only_the_read_after_6_is_the_interrupt_status() -> None:
    w = A16Window()
    w.post_interrupt(0xDA)
    w.respond(b":")
    w.write(CONTROL, 0x06)
    assert w.read(CONTROL) == 0xDA
    assert w.read(CONTROL) == 0  # status byte again: data available, not almost full


def test_interrupt_queue_is_8_deep_and_drops_new_codes_when_full() -> None:
    w = A16Window()
    calls: list[int] = []
    w.on_assert = calls.append
    write_control(w, 0x02, 0x04)
    for code in range(0xF0, 0xFA):
        w.post_interrupt(code)
    assert w.pending_interrupts == tuple(range(0xF0, 0xF8))
    assert calls == list(range(0xF0, 0xF8))


def test_on_assert_is_called_for_each_code_queued_while_enabled() -> None:
    w = A16Window()
    calls: list[int] = []
    w.on_assert = calls.append
    w.post_interrupt(0xD0)
    assert calls == []
    write_control(w, 0x02, 0x04)
    assert calls == [0xD0]  # enabling with a code queued asserts the head once
    w.post_interrupt(0xD8)
    assert calls == [0xD0, 0xD8]
    write_control(w, 0x02, 0x04)
    assert calls == [0xD0, 0xD8]  # already enabled: nothing new


def test_line_is_asserted_while_enabled_and_queue_non_empty() -> None:
    w = A16Window()
    w.post_interrupt(0xC8)
    assert not w.line_asserted
    write_control(w, 0x02, 0x04)
    assert w.line_asserted
    w.post_interrupt(0xC0)
    w.write(CONTROL, 0x06)
    w.read(CONTROL)
    assert w.line_asserted
    w.write(CONTROL, 0x06)
    w.read(CONTROL)
    assert not w.line_asserted


def test_ei0_clears_the_queue_and_drops_the_line() -> None:
    w = A16Window()
    write_control(w, 0x02, 0x04)
    w.post_interrupt(0xD0)
    w.clear_interrupts()
    assert w.pending_interrupts == ()
    assert not w.line_asserted
    w.write(CONTROL, 0x06)
    assert w.read(CONTROL) == 0x00


def test_interrupt_code_outside_1_to_255_is_refused() -> None:
    w = A16Window()
    for code in (0, 256):
        with pytest.raises(ValueError):
            w.post_interrupt(code)


# -- secondary FIFO ------------------------------------------------------------------------------
FREEZE_OFFSETS = {  # mode -> (write to freeze, write to resume)
    "toggle_n5": (FIFO2, FIFO2),  # the numbered procedure [M Ch4 §Polling Mode Read Procedure]
    "table": (FIFO2, FIFO2_STATUS),  # the table [M Ch4 §Overview of Secondary FIFO Procedure]
    "prose": (FIFO2_STATUS, FIFO2),  # the bit 1 prose, same section
}


def test_every_freeze_mode_is_covered() -> None:
    assert set(FREEZE_OFFSETS) == set(FREEZE_MODES)


@pytest.mark.parametrize("mode", FREEZE_MODES)
def test_secondary_fifo_read_procedure(mode: str) -> None:
    freeze, resume = FREEZE_OFFSETS[mode]
    w = A16Window(freeze_mode=mode)
    assert not w.read(FIFO2_STATUS) & SecondaryStatus.NOT_EMPTY
    assert w.load_record(RECORD)
    assert w.read(FIFO2_STATUS) & SecondaryStatus.NOT_EMPTY  # 1. wait for not-empty
    w.write(freeze, 0x00)  # 2. freeze
    status = w.read(FIFO2_STATUS)
    assert status & SecondaryStatus.FREEZE
    assert not status & SecondaryStatus.BUSY  # 3. loaded whole at a tick: never busy
    out = bytearray()
    while w.read(FIFO2_STATUS) & SecondaryStatus.NOT_EMPTY:  # 4-5. read to the end
        out.append(w.read(FIFO2))
    assert bytes(out) == RECORD
    assert w.read(FIFO2) == 0xFF
    w.write(resume, 0x00)  # 6. resume
    assert not w.read(FIFO2_STATUS) & SecondaryStatus.FREEZE
    assert w.load_record(b"next")
    assert w.record_pending == b"next"


@pytest.mark.parametrize("mode", FREEZE_MODES)
def test_record_load_while_frozen_is_refused_and_unread_bytes_stay(mode: str) -> None:
    freeze, _ = FREEZE_OFFSETS[mode]
    w = A16Window(freeze_mode=mode)
    w.load_record(RECORD)
    w.write(freeze, 0x00)
    w.read(FIFO2)
    assert not w.load_record(b"new")
    assert w.frozen
    assert w.record_pending == RECORD[1:]


def test_unread_record_is_replaced_by_the_next_load() -> None:
    w = A16Window()
    w.load_record(RECORD)
    w.read(FIFO2)
    w.load_record(b"\x01\x02")
    assert w.record_pending == b"\x01\x02"


def test_toggle_n5_write_to_n7_always_clears_freeze() -> None:
    w = A16Window()
    w.write(FIFO2, 0)
    w.write(FIFO2_STATUS, 0)
    assert not w.frozen
    w.write(FIFO2_STATUS, 0)
    assert not w.frozen


def test_table_mode_runs_the_numbered_procedure_frozen_to_the_end() -> None:
    # the CONFLICT of spec §2.5: under the table's reading the second N+5 write does not resume
    w = A16Window(freeze_mode="table")
    w.write(FIFO2, 0)
    w.write(FIFO2, 0)
    assert w.frozen


def test_unknown_freeze_mode_is_refused() -> None:
    with pytest.raises(ValueError):
        A16Window(freeze_mode="sometimes")


# -- decoding, peek, reset -------------------------------------------------------------------------
@pytest.mark.parametrize("offset", [0, 2, 4, 6, 8, 9, 10, 11, 12, 13, 14, 15])
def test_undecoded_offsets_read_ff_and_ignore_writes(offset: int) -> None:
    w = A16Window()
    before = w.peek(CONTROL)
    w.write(offset, 0x01)
    assert w.read(offset) == 0xFF
    assert w.peek(CONTROL) == before
    assert w.command_bytes() == b""


def test_offset_outside_the_window_is_an_error() -> None:
    w = A16Window()
    with pytest.raises(ValueError):
        w.read(16)
    with pytest.raises(ValueError):
        w.write(-1, 0)


def test_peek_has_no_side_effects() -> None:
    w = A16Window()
    w.respond(b"ok")
    w.load_record(b"\x07\x08")
    w.post_interrupt(0xD0)
    w.write(CONTROL, 0x06)
    for _ in range(2):
        assert w.peek(DATA) == ord("o")
        assert w.peek(CONTROL) == 0  # the status byte, not the interrupt status
        assert w.peek(FIFO2) == 0x07
        assert w.peek(FIFO2_STATUS) == SecondaryStatus.NOT_EMPTY
        assert w.peek(0) == 0xFF
    assert w.pending_interrupts == (0xD0,)
    assert w.read(CONTROL) == 0xD0  # the 6 is still pending


def test_peek_of_empty_fifos_is_ff() -> None:
    w = A16Window()
    assert w.peek(DATA) == 0xFF
    assert w.peek(FIFO2) == 0xFF


def test_reset_restores_power_on_state() -> None:
    w = A16Window()
    for b in b"BGX;":
        w.write(DATA, b)
    w.respond(b":")
    write_control(w, 0x05, 240, 0x02, 0x04)
    w.post_interrupt(0xDA)
    w.load_record(RECORD)
    w.write(FIFO2, 0)
    w.write(CONTROL, 0x05)  # a sequence left pending
    w.reset()
    assert w.command_bytes() == b"" and w.response_space() == 512
    assert w.almost_full_level == 16
    assert not w.interrupts_enabled and w.pending_interrupts == ()
    assert not w.frozen and w.record_pending == b""
    w.write(CONTROL, 0x40)  # would have been the level argument
    assert w.almost_full_level == 16
    assert w.read(CONTROL) == READ_EMPTY
