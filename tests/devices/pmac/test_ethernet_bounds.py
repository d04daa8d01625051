"""The PMAC Ethernet session's bounds without sockets (vdevd/devices/pmac/ethernet.py, issue 22
§2, §11): one request per call when asked, the pending output bounded, bad requests logged by
a budget."""

from __future__ import annotations

import logging

import pytest

from tests.devices.pmac.test_ethernet import FakePort, get_response
from vdevd.devices.pmac.ethernet import (
    REPLY_ACK,
    REPLY_INVALID,
    VR_DOWNLOAD,
    VR_PMAC_FLUSH,
    VR_PMAC_SENDLINE,
    EthernetSession,
    Header,
    packet,
)


def test_a_limit_runs_one_request_and_keeps_the_rest() -> None:
    session = EthernetSession(FakePort())
    burst = get_response(b"ver") + get_response(b"cid") + get_response(b"ver")[:5]
    assert session.receive(burst, limit=1) == [b"1.940\r\x06"]
    assert session.ready
    assert session.receive(b"", limit=1) == [b"603382\r\x06"]
    assert not session.ready  # a partial request waits for its bytes
    assert session.receive(get_response(b"ver")[5:], limit=1) == [b"1.940\r\x06"]


def test_pending_output_past_its_bound_closes_the_session() -> None:
    session = EthernetSession(FakePort(), max_pending=1000)
    sendline = packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"long")  # 3001 bytes of output
    flush = packet(VR_DOWNLOAD, VR_PMAC_FLUSH)
    assert session.receive(packet(VR_DOWNLOAD, VR_PMAC_SENDLINE, data=b"ver") + flush) == [
        REPLY_ACK, REPLY_ACK]
    assert not session.closed
    assert session.receive(sendline + flush) == [REPLY_ACK]  # the FLUSH after it never runs
    assert session.closed and session.overflowed and session.pending == b""
    assert session.receive(flush) == []


def test_bad_requests_are_logged_by_a_budget(caplog: pytest.LogCaptureFixture) -> None:
    session = EthernetSession(FakePort())
    with caplog.at_level(logging.INFO):
        assert session.receive(Header(0x20, 0xB0).pack() * 5000) == [REPLY_INVALID] * 5000
        session.close_log()
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 9
    assert lines[5].endswith("(bad request 10 of the connection; logged at each tenfold)")
    assert lines[-1] == "PMAC Ethernet: 5000 bad requests on the connection, 8 of them logged"
