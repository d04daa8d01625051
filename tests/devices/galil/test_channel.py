"""A command channel beside the command FIFO (vdevd/devices/galil/channel.py, the Ethernet
connections' stream): the card's one interpreter, each channel with its own held trippoint
(spec §5.7). Firmware only: no card, no socket."""

from __future__ import annotations

from tests.devices.galil.test_firmware import Rig
from vdevd.devices.galil.channel import MAX_COMMAND, CommandChannel
from vdevd.devices.galil.errors import TC


def test_the_channel_answers_with_the_bytes_the_fifo_gives() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    for line in (b"TPX\r", b"MG _BGX\r", b"KP 10;KP ?\r", b"DP 1000;TP\r", b"XYZ\r", b"TC1\r"):
        assert ch.receive(line) == rig.send(line)


def test_both_channels_share_the_interpreter_s_state() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(b"speed=12;DP 500\r") == b"::"
    fifo = rig.send(b"MG speed;TPX\r")
    assert fifo == rig.send(b"MG 12;TPX\r") and fifo.endswith(b"0000000500\r\n:")
    assert ch.receive(b"XYZ\r") == b"?"
    assert rig.send(b"TC1\r") == b"1 Unrecognized command\r\n:"  # one error code per card


def test_commands_arrive_in_pieces_and_run_when_their_terminator_does() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(b"DP 7") == b""
    assert ch.receive(b"7;TP") == b":"
    assert ch.receive(b"X\r") == b"0000000077\r\n:"


def test_a_trippoint_holds_its_own_channel_only() -> None:
    """AM on the channel: the FIFO keeps being served; the channel's next command waits for the
    move's end [spec §5.7]."""
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(b"PR 2000;BGX;AMX;MG 7\r") == b"::"
    assert ch.held
    assert rig.send(b"MG _BGX\r") == rig.send(b"MG 1\r")  # not held by the channel's AM
    replies = b""
    for _ in range(5000):
        rig.sample()
        replies += ch.serve()
        if replies:
            break
    assert replies == b":" + rig.send(b"MG 7\r")
    assert not ch.held
    assert rig.send(b"RPX\r") == b"0000002000\r\n:"


def test_a_trippoint_on_the_fifo_does_not_hold_the_channel() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert rig.send(b"PR 2000;BGX;AMX\r") == b"::"
    assert rig.send(b"MG 1\r") == b""  # the FIFO channel waits for the move's end
    assert ch.receive(b"MG _BGX;MG 1\r") == b" 0000000001.0000\r\n:" * 2


def test_an_overlong_command_is_refused_with_tc5_and_the_next_one_runs() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(b"MG " + b"1" * MAX_COMMAND) == b"?"
    assert ch.receive(b"1" * 1000) == b""  # the rest of it is dropped
    assert ch.receive(b"2\rTPX\r") == b"0000000000\r\n:"
    assert rig.fw.error_code == TC.INPUT_BUFFER_FULL
    assert ch.receive(b"TC1\r") == b"5 Input buffer full\r\n:"


def test_a_command_as_long_as_the_fifo_holds_runs() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    line = b"MG " + b" " * (MAX_COMMAND - 4) + b"1"
    assert len(line) == MAX_COMMAND
    assert ch.receive(line + b"\r") == rig.send(b"MG 1\r")


def test_a_binary_command_runs_as_on_the_fifo() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(bytes.fromhex("A7 02 00 05 03 E8 FE 0C")) == b":"  # PR 1000,,-500 [M Ch5]
    assert ch.receive(b"PR ?,,?\r") == rig.send(b"PR ?,,?\r")
    assert b"1000" in rig.send(b"PR ?,,?\r")
    bad = bytes.fromhex("A7 03 00 01 00 00 01")  # 3 bytes per field: TC 97
    assert ch.receive(bad) == rig.send(bad) == b"?"


def test_closing_drops_a_command_cut_mid_line_and_the_held_trippoint() -> None:
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(b"PR 2000;BGX;AMX;DP 5") == b"::"
    ch.close()
    assert not ch.held
    assert ch.receive(b"\r") == b":"  # a bare terminator: nothing of the cut command is left
    assert rig.send(b"MG _DPX\r") == rig.send(b"MG 0\r")


def test_qd_takes_its_data_from_the_channel_in_pieces() -> None:
    """QD's numbers follow it on the connection (as on the FIFO) and are not run as commands."""
    rig = Rig()
    ch = CommandChannel(rig.fw)
    assert ch.receive(b"DM A[4]\r") == b":"
    assert ch.receive(b"QD A[],0,3\r1,2") == b""
    assert ch.receive(b",3,4\\") == b":"
    assert ch.receive(b"QU A[],0,3,1\r") == rig.send(b"QU A[],0,3,1\r")
    assert rig.send(b"MG A[3]\r") == b" 0000000004.0000\r\n:"
    assert ch.receive(b"QD B[],0,1\r5,6\\TPX\r").startswith(b"?")  # no array B: refused
