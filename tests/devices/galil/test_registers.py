"""Manual chapter 4 "Communication": the A16 registers N+1 and N+3 driven with the manual's
procedures, through `vdevclient` Region accesses to the card's `a16` window and through the DMC
library functions built on them."""

from __future__ import annotations

import pytest
import vdevclient
import vdevmaps.galil as galil_map
from vdevclient import galil

from tests.devices.galil.conftest import (
    CLEARED,
    CONTROL,
    DATA,
    READ_EMPTY,
    WRITE_ALMOST_FULL,
    Dmc,
    host_command,
    host_receive,
    host_send,
)

# "a 512 character write FIFO buffer" [M Ch4 Introduction]; "OK to write up to 16 characters"
# [M Ch4 §Simplified Communication Procedure]; "Reading data from the READ register when the register
# is empty will result in ... FF"
FIFO_SIZE, DEFAULT_LEVEL, EMPTY = galil_map.FIFO_SIZE, galil_map.DEFAULT_ALMOST_FULL, galil_map.EMPTY_READ


def clear(a16: vdevclient.Region) -> int:
    """[M Ch4 §Clearing FIFO Buffer]: read N+3, send 01 80 01 80, read N+3; the last read."""
    a16.read8(CONTROL)
    for b in (0x01, 0x80, 0x01, 0x80):
        a16.write8(CONTROL, b)
    return a16.read8(CONTROL)


def hold_interpreter(rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """Send `WT 1000` ("Wait 1000 milliseconds before reading the next instruction", Example 10
    buffer mode) and let one sample pass: the card has taken it and reads nothing more for 1 s."""
    host_send(a16, b"WT 1000\r")
    rack.sim.step(ticks=1)


def fill_until_almost_full(a16: vdevclient.Region) -> int:
    """Write one byte at a time to N+1, reading bit 4 before each, while the card takes nothing
    (held by WT, no clock step); the number of bytes written while bit 4 read 0."""
    written = 0
    while not a16.read8(CONTROL) & WRITE_ALMOST_FULL:
        a16.write8(DATA, ord(" "))
        written += 1
        assert written <= FIFO_SIZE, "bit 4 never read 1"
    return written


# -- the simplified procedure ---------------------------------------------------------------------
def test_at_power_on_there_is_no_data_to_read_and_writing_is_ok(a16: vdevclient.Region) -> None:
    status = a16.read8(CONTROL)
    assert status & READ_EMPTY  # bit 5 = 1: no data to be read
    assert not status & WRITE_ALMOST_FULL  # bit 4 = 0: OK to write up to 16 characters
    assert a16.read8(DATA) == EMPTY


def test_read_procedure_gets_the_reply_until_bit_5_then_an_empty_read_gives_ff(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """[M Ch4 §Read Procedure] and §Controller Response to DATA: data, CR LF, ':'."""
    host_send(a16, b"TPX\r")
    assert a16.wait_value(CONTROL, 0, mask=READ_EMPTY, size=1, timeout_s=1.0) is not None
    assert host_receive(a16) == b"0000000000\r\n:"
    assert a16.read8(CONTROL) & READ_EMPTY
    assert a16.read8(DATA) == EMPTY
    assert a16.read8(DATA) == EMPTY  # an empty read pops nothing


def test_each_valid_command_answers_a_colon(a16: vdevclient.Region) -> None:
    """"the DMC-13X8 returns a colon (:) if the instruction was valid or a question mark (?)"."""
    assert host_command(a16, b"SP 5000;AC 102400\r", replies=2) == b"::"
    assert host_command(a16, b"AC ?\r") == b"0102400\r\n:"  # data, CR LF, ':' (AC 7.0, spec §4.1)


def test_invalid_command_answers_a_question_mark(a16: vdevclient.Region) -> None:
    """[M Ch5 §Controller Response to DATA]: `bg` in lower case returns '?'; TC1 tells why."""
    assert host_command(a16, b"bg\r") == b"?"
    assert host_command(a16, b"TC1\r") == b"1 Unrecognized command\r\n:"


# -- write procedure and the almost-full level ----------------------------------------------------
def test_bit_4_reads_1_once_fewer_than_16_bytes_are_free(rack: vdevclient.Rack,
                                                         a16: vdevclient.Region) -> None:
    """[M Ch4 §Write Procedure]: bit 4 = 0 allows 16 more characters; it goes 1 when the
    512-byte FIFO has fewer than 16 free."""
    hold_interpreter(rack, a16)
    written = fill_until_almost_full(a16)
    assert written == FIFO_SIZE - DEFAULT_LEVEL + 1
    assert a16.read8(CONTROL) & WRITE_ALMOST_FULL


def test_almost_full_level_256_after_writing_5_then_240(rack: vdevclient.Rack,
                                                        a16: vdevclient.Region) -> None:
    """[M Ch4 §Changing Almost Full Flags]: "to extend the Almost Full level to 256 bytes, write a
    5 to address N+3. Then write a 240 to address N+3"."""
    hold_interpreter(rack, a16)
    a16.write8(CONTROL, 5)
    a16.write8(CONTROL, 240)
    assert fill_until_almost_full(a16) == FIFO_SIZE - 256 + 1


@pytest.mark.parametrize("level", [16, 32, 128, 256])
def test_almost_full_level_m_is_set_by_5_then_m_minus_16(rack: vdevclient.Rack, a16: vdevclient.Region,
                                                         level: int) -> None:
    hold_interpreter(rack, a16)
    a16.write8(CONTROL, 5)
    a16.write8(CONTROL, level - 16)
    assert fill_until_almost_full(a16) == FIFO_SIZE - level + 1


def test_bit_4_returns_to_0_when_the_card_has_taken_the_commands(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """The FIFO lets the host send ahead of processing [M Ch4 Introduction]: filled with complete
    commands while WT holds the card, it drains when the card goes on and bit 4 reads 0 again."""
    hold_interpreter(rack, a16)
    line = b"SP 1000;"
    sent = 0
    while not a16.read8(CONTROL) & WRITE_ALMOST_FULL:
        host_send(a16, line)
        sent += 1
    assert a16.wait_value(CONTROL, 0, mask=WRITE_ALMOST_FULL, size=1, timeout_s=2.0) is not None
    got = b""
    while got.count(b":") < sent + 1:
        assert a16.wait_value(CONTROL, 0, mask=READ_EMPTY, size=1, timeout_s=1.0) is not None
        got += host_receive(a16)
    assert got == b":" * (sent + 1)  # WT's and each SP's


# -- clearing the FIFOs ---------------------------------------------------------------------------
def test_clear_sequence_empties_both_fifos_and_sets_bit_7(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """[M Ch4 §Clearing FIFO Buffer]: read N+3, 01 80 01 80, read N+3 (bit 7 will be 1): "All
    data, including data from the DMC-13X8, will then be cleared"."""
    host_send(a16, b"TPX\r")
    rack.sim.step(ticks=1)
    assert not a16.read8(CONTROL) & READ_EMPTY  # a reply waits in the READ FIFO
    host_send(a16, b"MG 12")  # and an unterminated command in the WRITE FIFO
    status = clear(a16)
    assert status & CLEARED
    assert status & READ_EMPTY
    assert a16.read8(DATA) == EMPTY
    # the half command is gone: the next line is a command of its own
    assert host_command(a16, b"TPX\r") == b"0000000000\r\n:"


def test_clear_then_rs_resets_the_controller(a16: vdevclient.Region) -> None:
    """"to Reset the controller, clear the FIFO, then send the RS command" [M Ch4]."""
    assert host_command(a16, b"DP 1234\r") == b":"
    clear(a16)
    assert host_command(a16, b"RS\r") == b":"
    assert host_command(a16, b"TPX\r") == b"0000000000\r\n:"


# -- the same through the DMC library -------------------------------------------------------------
def test_dmc_command_longer_than_the_fifo_honours_bit_4(dmc: Dmc) -> None:
    """A 600-character line (more than the 512-byte FIFO) goes through the write procedure:
    every command is answered."""
    line = "KPX=7;" * 100
    assert len(line) > FIFO_SIZE
    assert dmc.cmd(line) == ":" * 99
    assert dmc.cmd("KP ?") == "0007.00"


def test_dmc_clear_empties_both_fifos(dmc: Dmc, a16: vdevclient.Region) -> None:
    host_send(a16, b"TPX\r")
    dmc.step(0.001)
    host_send(a16, b"MG 12")
    assert galil.DMCClear(dmc.handle) == galil.DMCNOERROR
    assert a16.read8(CONTROL) & (CLEARED | READ_EMPTY) == CLEARED | READ_EMPTY
    assert dmc.cmd("TPX") == "0000000000"


def test_dmc_reset_restores_positions_to_zero(dmc: Dmc) -> None:
    dmc.cmd("DP 1234,5678")
    assert galil.DMCReset(dmc.handle) == galil.DMCNOERROR
    assert dmc.cmd("TP XY") == "0000000000,0000000000"
