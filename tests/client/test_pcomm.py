"""vdevclient.pcomm, the PComm32 API (spec pmac.md §3.1), against a real daemon holding one
pmac-turbo card (device 0), lockstep clock."""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import vdevclient
from vdevclient import pcomm
from vdevclient._pmac_bus import (
    Posted,
    PreprocessError,
    command_bytes,
    error_number,
    parse_slot,
    preprocess,
)
from vdevmaps.pmac import CMD_CHAR, IR_MASK, OPEN_USE, RESP_CONTROL

from tests.client.galil import card, rack_config, round_trips
from vdevd.testing import DaemonThread

DEVICE = 0
GUARD_S = 5.0  # a guard against hangs, never a wait for timing


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card("pmac-turbo", "pmac0", device=DEVICE, ethernet="tcp://127.0.0.1:*"))
    with DaemonThread(cfg) as d:
        yield d


@pytest.fixture
def dev(daemon: DaemonThread) -> Iterator[int]:
    assert pcomm.OpenPmacDevice(DEVICE, endpoint=daemon.endpoint)
    try:
        yield DEVICE
    finally:
        pcomm.ClosePmacDevice(DEVICE)


def response(dev: int, command: str) -> tuple[int, str]:
    buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)
    rc = pcomm.PmacGetResponseA(dev, buf, ctypes.sizeof(buf), command)
    assert rc.text == buf.value.decode()
    return int(rc), rc.text


# -- the pure parts -------------------------------------------------------------------------------
def test_response_slot_words_decode_lines_acks_and_bcd_errors() -> None:
    assert parse_slot(bytes(8)) is None
    assert parse_slot(b"\x0d\x00\x06\x001.940\x00") == Posted(b"1.940", 0x0D)
    assert parse_slot(b"\x06\x00\x01\x00\x00") == Posted(b"", 0x06)
    assert error_number(0x8003) == 3 and error_number(0x8119) == 119 and error_number(0x0D) is None
    assert parse_slot(b"\x03\x80\x01\x00\x00") == Posted(b"", None, 3)


def test_command_bytes_clear_the_control_slot_and_never_make_a_misaligned_word() -> None:
    assert command_bytes(b"ver") == b"\0\0ver\0"
    assert command_bytes(b"") == b"\0\0\0"  # not a 2-byte access at 0x0E9E
    assert command_bytes(b"P") == b"\0\0P\0\0"


def test_preprocess_drops_comments_and_substitutes_defines_but_keeps_motor_commands() -> None:
    src = "; header\n#define SPEED 50\n#define FAST SPEED*2\n\nI122=FAST // jog\n#1J+\nP1=SPEEDY\n"
    assert preprocess(src) == [(5, "I122=50*2", ""), (6, "#1J+", ""), (7, "P1=SPEEDY", "")]
    assert preprocess(src, macros=False)[0] == (5, "I122=FAST", "")
    with pytest.raises(PreprocessError, match="line 2: #include 'x.pmc': no file"):
        preprocess("P1=1\n#include \"x.pmc\"\n")  # no file to include from


def test_dpr_float_and_fixed_convert_two_24_bit_halves() -> None:
    assert pcomm.PmacDPRLFixed([0x000010, -1], 1.0) == -(1 << 24) + 16
    assert pcomm.PmacDPRLFixed((ctypes.c_long * 2)(5, 1), 0.5) == ((1 << 24) + 5) / 2
    # 10.0: mantissa $500000000 (0.625 * 2**35), exponent $803 [EPICS-HW doubleToPMACFloat]
    assert pcomm.PmacDPRFloat([0x000803, 0x500000], 2.0) == 20.0
    assert pcomm.PmacDPRFloat([0, 0], 1.0) == 0.0


# -- opening --------------------------------------------------------------------------------------
def test_open_finds_the_configured_device_and_refuses_an_unknown_one(daemon: DaemonThread) -> None:
    assert not pcomm.OpenPmacDevice(7, endpoint=daemon.endpoint)
    assert pcomm.PmacGetResponseA(7, None, 0, "ver") == pcomm.COMM_FAIL
    assert pcomm.OpenPmacDevice(DEVICE, endpoint=daemon.endpoint)
    try:
        assert pcomm.DrvNumberOfDevices(endpoint=daemon.endpoint) == 1
        assert pcomm.PmacSelect(None, endpoint=daemon.endpoint) == DEVICE
        assert pcomm.PmacDPRAvailable(DEVICE)
    finally:
        assert pcomm.ClosePmacDevice(DEVICE)
    assert not pcomm.ClosePmacDevice(DEVICE)
    assert pcomm.PmacGetResponseA(DEVICE, None, 0, "ver") == pcomm.COMM_FAIL


# -- ASCII ------------------------------------------------------------------------------------------
def test_identity_and_variables_answer_with_comm_eot_and_the_count(dev: int) -> None:
    assert response(dev, "ver") == (pcomm.COMM_EOT | 6, "1.940\r")
    assert response(dev, "cid") == (pcomm.COMM_EOT | 7, "603382\r")
    assert response(dev, "I130") == (pcomm.COMM_EOT | 5, "2000\r")
    assert response(dev, "i130=1500 i130") == (pcomm.COMM_EOT | 5, "1500\r")
    assert response(dev, "#1J/") == (pcomm.COMM_EOT, "")
    assert pcomm.PmacGetVariable(dev, "I", 130, -1) == 1500
    assert pcomm.PmacGetVariableDouble(dev, "I", 130, -1.0) == 1500.0
    assert pcomm.PmacGetVariable(dev, "I", 99999, -7) == -7
    assert pcomm.PmacGetRomVersionA(dev, None, 0) == "1.940"
    assert pcomm.PmacGetRomDateA(dev, None, 0) == "06/26/2003"
    assert pcomm.PmacGetPmacType(dev) == pcomm.PMAC_TYPES["TURBO2"]


def test_multi_line_reply_keeps_a_cr_after_every_line(dev: int) -> None:
    rc, text = response(dev, "I100..104")
    lines = text.split("\r")
    assert rc == pcomm.COMM_EOT | len(text) and len(lines) == 6 and lines[-1] == ""
    assert response(dev, "I100..104") == (rc, text)  # read ahead in one batch the second time


@pytest.mark.parametrize("command", ["I99999", "garbage"])
def test_an_error_is_comm_error_with_bell_errnnn_and_the_card_answers_next(dev: int, command: str) -> None:
    assert response(dev, command) == (pcomm.COMM_ERROR | 8, "\x07ERR003\r")
    assert response(dev, "ver") == (pcomm.COMM_EOT | 6, "1.940\r")


def test_output_buffers_may_be_a_bytearray_a_list_or_short(dev: int) -> None:
    raw = bytearray(8)
    assert pcomm.PmacGetResponseA(dev, raw, 8, "cid") == pcomm.COMM_EOT | 7
    assert raw == b"603382\r\0"
    out: list[str] = []
    assert pcomm.PmacGetResponseA(dev, out, 4, "cid") == pcomm.COMM_EOT | 3
    assert out == ["603"]
    assert pcomm.PmacGetResponseA(dev, ctypes.byref(ctypes.create_string_buffer(3)), 3, "ver").text == "1."


def test_a_one_line_reply_is_one_round_trip_with_its_ack_deferred(dev: int, monkeypatch: pytest.MonkeyPatch
                                                                   ) -> None:
    response(dev, "#1P")  # the first time reads two slots, as for any new command
    with round_trips(monkeypatch) as spy:
        for _ in range(3):
            assert response(dev, "#1P") == (pcomm.COMM_EOT | 2, "0\r")
        assert spy.count == 3
        ops = spy.sent[-1]["ops"]
    assert len(ops) == 5 and ops[0]["offset"] == CMD_CHAR  # the last ACK acknowledged in its write
    assert ops[0]["data"][RESP_CONTROL - CMD_CHAR:] == b"\0\0"


def test_control_characters_answer_their_text(dev: int) -> None:
    rc = pcomm.PmacGetControlResponseA(dev, None, 256, "\x10")  # ^P: 8 motors' positions
    assert rc == pcomm.COMM_EOT | 16 and rc.text == "0 0 0 0 0 0 0 0\r"
    status = pcomm.PmacGetControlResponseA(dev, None, 256, 2)  # ^B: 8 motors' status words
    assert pcomm.IS_COMM_EOT(status) and len(status.text.split()) == 8
    assert all(len(word) == 12 for word in status.text.split())


def test_send_line_then_get_line_reads_the_posted_lines(dev: int) -> None:
    assert pcomm.PmacSendLineA(dev, "I130 I131") == 9
    assert pcomm.PmacReadReady(dev)
    buf = ctypes.create_string_buffer(64)
    assert pcomm.PmacGetLineA(dev, buf, 64) == 4 and buf.value == b"2000"
    assert pcomm.PmacGetLineA(dev, buf, 64) == len(buf.value) and buf.value
    assert pcomm.PmacGetLineA(dev, buf, 64) == pcomm.COMM_EOT
    assert not pcomm.PmacReadReady(dev)
    assert pcomm.PmacSendCharA(dev, "\x10") == 1
    assert pcomm.PmacGetLineA(dev, buf, 64).text == "0 0 0 0 0 0 0 0"


# -- DPRAM ------------------------------------------------------------------------------------------
def test_dpram_memory_round_trips_bytes_and_floats(dev: int) -> None:
    data = bytes(range(1, 11))
    assert pcomm.PmacDPRSetMem(dev, OPEN_USE, len(data), data) == data
    out = (ctypes.c_ubyte * 10)()
    assert pcomm.PmacDPRGetMem(dev, OPEN_USE, 10, out) == data and bytes(out) == data
    assert pcomm.PmacDPRSetMem(dev, OPEN_USE + 1, 2, [0xAB, 0xCD]) is not None  # misaligned word
    assert pcomm.PmacDPRGetMem(dev, OPEN_USE, 4, None) == b"\x01\xab\xcd\x04"
    pcomm.PmacDPRSetFloat(dev, OPEN_USE + 16, 2.5)
    assert pcomm.PmacDPRGetFloat(dev, OPEN_USE + 16) == 2.5
    assert pcomm.PmacDPRGetMem(dev, 0x3FFF, 2, None) is None


def test_realtime_buffer_shows_a_jog_moving_motor_1(dev: int, rack: vdevclient.Rack) -> None:
    assert pcomm.PmacDPRRealTimeEx(dev, 0xFF, 1, 1)
    assert pcomm.PmacDPRPosition(dev, 1, 1.0) == 0.0
    assert response(dev, "#1J+")[0] == pcomm.COMM_EOT
    rack.sim.step(seconds=0.2)
    first = pcomm.PmacDPRPosition(dev, 1, 1.0)
    rack.sim.step(seconds=0.2)
    second = pcomm.PmacDPRPosition(dev, 1, 1.0)
    assert 0 < first < second
    reported = float(response(dev, "#1P")[1])
    assert abs(reported - second) < 20  # one servo cycle later at the jog speed
    assert response(dev, "#1J/")[0] == pcomm.COMM_EOT
    rack.sim.step(seconds=0.5)
    stopped = pcomm.PmacDPRPosition(dev, 1, 1.0)
    assert stopped > second and pcomm.PmacDPRPosition(dev, 1, 0.5) == pytest.approx(stopped / 2, abs=0.5)
    assert pcomm.PmacDPRRealTimeEx(dev, 0xFF, 1, 0)


def test_background_buffer_gives_the_global_status_words(dev: int) -> None:
    assert pcomm.PmacDPRBackgroundEx(dev, 1, 1, 16)
    gs = (ctypes.c_ulong * 2)()
    words = pcomm.PmacDPRGetGlobalStatus(dev, gs)
    assert words == (gs[0], gs[1])
    assert pcomm.PmacDPRBackgroundEx(dev, 0, 1, 16)


# -- download -----------------------------------------------------------------------------------------
def test_download_stops_at_the_first_error_and_reports_its_line(dev: int, tmp_path: Path) -> None:
    path = tmp_path / "motion.pmc"
    path.write_text("#define ONE 11\nP1=ONE ; first\nP2=1 garbage\nP3=33\n")
    messages: list[str] = []
    percent: list[int] = []
    ok = pcomm.PmacDownloadA(dev, lambda text, newline: messages.append(text), None, percent.append,
                             str(path), True, False, False, True)
    assert ok == 0
    assert messages == [f"{path}:3: P2=1 garbage: ERR003"]
    assert response(dev, "P1 P3") == (pcomm.COMM_EOT | 5, "11\r0\r")  # line 4 never ran
    path.write_text("P3=33\nP3\nP4=P3+1\n")
    assert pcomm.PmacDownloadA(dev, None, None, percent.append, str(path), True, False, False, True) == 1
    assert response(dev, "P4")[1] == "34\r" and percent[-1] == 100


def test_download_includes_files_and_keeps_the_branches_taken(dev: int, tmp_path: Path) -> None:
    """PComm's preprocessor: `#include "file"` (from the downloading file's folder) shares the
    #define table; `#ifdef`/`#ifndef`/`#else`/`#endif` keep the branches taken; an error in an
    included file names that file and its line."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "defs.pmc").write_text("#define GEO\n#define SCALE 4\n")
    (tmp_path / "bad.pmc").write_text("P8=1\nP9=1 garbage\n")
    path = tmp_path / "main.pmc"
    path.write_text('#include "sub/defs.pmc"\n#ifdef GEO\nP1=SCALE*2\n#ifndef SCALE\nP2=99\n'
                    '#else\nP2=SCALE\n#endif\n#else\nP1=-1\n#endif\n#undef SCALE\n'
                    '#ifdef SCALE\nP3=99\n#endif\n')
    assert pcomm.PmacDownloadA(dev, None, None, None, str(path), True, False, False, True) == 1
    assert response(dev, "P1 P2 P3")[1] == "8\r4\r0\r"
    path.write_text('P7=7\n#include "bad.pmc"\nP10=1\n')
    messages: list[str] = []
    assert pcomm.PmacDownloadA(dev, lambda t, n: messages.append(t), None, None, str(path),
                               True, False, False, True) == 0
    assert messages[0] == "bad.pmc:2: P9=1 garbage: ERR003"
    assert response(dev, "P7 P8 P10")[1] == "7\r1\r0\r"


def test_download_refuses_what_it_cannot_preprocess_and_sends_nothing(dev: int, tmp_path: Path
                                                                       ) -> None:
    """A missing include, a file including itself, an unclosed #ifdef, `#if`: the error through
    msgproc, 0, and not one line sent."""
    path = tmp_path / "inc.pmc"
    cases = {'P1=1\n#include "other.pmc"\n': "other.pmc",
             'P1=1\n#include "inc.pmc"\n': "includes itself",
             "P1=1\n#ifdef X\nP2=2\n": "#ifdef without #endif",
             "P1=1\n#endif\n": "#endif without #ifdef",
             "P1=1\n#if 1\nP2=2\n#endif\n": "#if is not supported"}
    messages: list[str] = []
    for text, expected in cases.items():
        path.write_text(text)
        messages.clear()
        assert pcomm.PmacDownloadA(dev, lambda t, n: messages.append(t), None, None, str(path),
                                   True, False, False, True) == 0
        assert expected in messages[0], (text, messages)
        assert response(dev, "P1")[1] == "0\r"  # nothing sent


# -- interrupts ---------------------------------------------------------------------------------------
def test_ascii_ready_interrupt_calls_back_when_enabled(dev: int, rack: vdevclient.Rack) -> None:
    got: list[tuple[int, int]] = []
    fired = threading.Event()

    def callback(msg: int, buffer: Any) -> None:
        got.append((msg, buffer.contents.dwInterruptType))
        fired.set()

    assert pcomm.PmacINTRFuncCallInit(dev, callback, 42, pcomm.HostIrq.ASCII_READY)
    host = rack.card("pmac0").region("host")
    assert host.read8(IR_MASK) == pcomm.HostIrq.ASCII_READY
    assert response(dev, "ver")[0] == pcomm.COMM_EOT | 6
    assert fired.wait(GUARD_S)
    assert got[0] == (42, 4)
    fired.clear()
    assert response(dev, "cid")[0] == pcomm.COMM_EOT | 7  # acknowledged, so it fires again
    assert fired.wait(GUARD_S)
    assert pcomm.PmacINTRTerminate(dev)
    assert host.read8(IR_MASK) == 0
