"""PmacGetResponseA's steady state (the batch built the first time for a command, reused while the
last reply's ACK is the acknowledgement owed) and its short read of the last slot (the head, read
again whole when it holds a data line) against the general path: the same replies when a reply's
length changes, on errors and when no acknowledgement is owed [spec pmac.md §2.10]."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import pcomm
from vdevclient._pcomm_device import MEMO_SIZE, _Device, _devices

from tests.client.galil import card, rack_config, round_trips
from vdevd.testing import DaemonThread

DEVICE = 0
CARD = "pmac0"


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card("pmac-turbo", CARD, device=DEVICE, ethernet=""))) as d:
        yield d


@pytest.fixture
def dev(daemon: DaemonThread) -> Iterator[_Device]:
    assert pcomm.OpenPmacDevice(DEVICE, endpoint=daemon.endpoint)
    try:
        yield _devices[DEVICE]
    finally:
        pcomm.ClosePmacDevice(DEVICE)


def response(command: str) -> tuple[int, str]:
    buf = ctypes.create_string_buffer(pcomm.MAX_COMM_BUFFER)
    rc = pcomm.PmacGetResponseA(DEVICE, buf, ctypes.sizeof(buf), command)
    assert rc.text == buf.value.decode()
    return int(rc), rc.text


def general(dev: _Device, command: str) -> tuple[int, str]:
    """The reply through the general path: nothing learned about the command."""
    dev.memo.pop(command.encode(), None)
    return response(command)


def both(dev: _Device, command: str) -> tuple[int, str]:
    """The reply of a command that changes nothing, learned (steady state) and fresh: equal."""
    response(command)  # learns the reply's length
    response(command)  # owes the ACK's acknowledgement afterwards
    fast = response(command)
    assert dev.memo[command.encode()].ops is not None, command
    assert fast == general(dev, command), command
    return fast


def test_the_steady_state_batch_is_built_once_and_answers_as_the_general_path(
        dev: _Device, monkeypatch: pytest.MonkeyPatch) -> None:
    for command in ("#1P", "I130", "#2?PVF", "I100..104", "#1P I8192", "ver", "#1K J/"):
        both(dev, command)
    response("#1P")
    response("#1P")
    ops = dev.memo[b"#1P"].ops
    with round_trips(monkeypatch) as spy:
        assert response("#1P") == (pcomm.COMM_EOT | 2, "0\r")
    assert spy.count == 1 and spy.sent[0]["ops"] is ops
    assert [op["op"] for op in ops] == ["write", "write", "read", "write", "read"]
    assert ops[-1]["size"] == 4  # the ACK's slot: its control word and count


def test_a_reply_that_grows_and_shrinks_is_read_whole(dev: _Device) -> None:
    assert both(dev, "#3 LIST COMP") == (pcomm.COMM_EOT, "")  # no table: the ACK alone
    assert dev.memo[b"#3 LIST COMP"].slots == 1
    response("#3 DEFINE COMP 2.3,#1,#2,100,100")
    response(" ".join(str(k) for k in range(1, 12)))
    rows = "1 2 3\r4 5 6 7\r8 9 10 11\r"
    assert response("#3 LIST COMP") == (pcomm.COMM_EOT | len(rows), rows)  # the head: read again
    assert dev.memo[b"#3 LIST COMP"].slots == 4
    assert both(dev, "#3 LIST COMP") == (pcomm.COMM_EOT | len(rows), rows)
    response("#3 DELETE COMP")
    assert response("#3 LIST COMP") == (pcomm.COMM_EOT, "")
    assert dev.memo[b"#3 LIST COMP"].slots == 1 and dev.memo[b"#3 LIST COMP"].ops is None


def test_errors_and_changing_outcomes_of_one_command(dev: _Device, daemon: DaemonThread) -> None:
    assert both(dev, "I8192")[1] == "\x07ERR003\r"
    assert both(dev, "#1P I8192") == (pcomm.COMM_ERROR | 10, "0\r\x07ERR003\r")
    rack = vdevclient.connect(daemon.endpoint)
    try:
        response("#1K J/")
        rack.control(CARD, "set_phase_clock_error", active=True)
        assert response("#1K J/")[1] == "\x07ERR018\r"  # learned as ACK, now an error
        assert response("#1K J/")[1] == "\x07ERR018\r"
        rack.control(CARD, "set_phase_clock_error", active=False)
        assert response("#1K J/") == (pcomm.COMM_EOT, "")
    finally:
        rack.close()


def test_with_no_acknowledgement_owed_the_general_path_runs(dev: _Device) -> None:
    response("I130")
    assert pcomm.PmacSendLineA(DEVICE, "I131") == 4  # its lines are read by PmacGetLineA
    buf = ctypes.create_string_buffer(64)
    while not pcomm.IS_COMM_EOT(pcomm.PmacGetLineA(DEVICE, buf, 64)):
        pass
    assert not dev.pending
    assert response("I130") == (pcomm.COMM_EOT | 5, "2000\r")
    assert dev.pending == [dev.ack]
    assert response("I130") == (pcomm.COMM_EOT | 5, "2000\r")


def test_the_memo_stays_bounded(dev: _Device) -> None:
    for n in range(MEMO_SIZE + 20):
        assert response(f"P{n}") == (pcomm.COMM_EOT | 2, "0\r")
        assert len(dev.memo) <= MEMO_SIZE
    assert b"P0" not in dev.memo and f"P{MEMO_SIZE + 19}".encode() in dev.memo
