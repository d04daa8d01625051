"""vdevclient.mx4 on a realtime daemon (the issue: "an RTC post costs at most two round trips in
both clock modes"): the same calls as in lockstep, with simulated time following wall time.
Nothing here asserts a duration; the waits are for the card's next samples and a short move."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import pytest
from vdevclient import mx4
from vdevmaps.octavia import DspStat1

from tests.client.galil import card, rack_config, round_trips
from vdevd.testing import DaemonThread


@pytest.fixture
def h() -> Iterator[mx4.Mx4]:
    cfg = replace(rack_config(card("dspcg-octavia", "oct0", plant="ideal")), clock="realtime")
    with DaemonThread(cfg) as d, mx4.open(1, endpoint=d.endpoint) as handle:
        yield handle


def test_an_rtc_in_realtime_is_one_round_trip_and_a_report_two(
        h: mx4.Mx4, monkeypatch: pytest.MonkeyPatch) -> None:
    with round_trips(monkeypatch) as trips:
        mx4.MAXACC(h, 0x01, 0x4000)
    assert trips.count == 1
    with round_trips(monkeypatch) as trips:
        assert mx4.parread(h, 0x16)[:2] == b"\x00\x40"  # the echo comes at a 5 ms boundary
    assert trips.count == 1
    mx4.EN_MOTCP(h, 0x01)
    mx4.AXMOVE(h, 0x01, 0x4000, 2000, mx4.vel_to_raw(20))
    mx4.wait_int(h, dspstat1=DspStat1.MOTCP, axes=0x01, timeout_ms=5000)
    assert mx4.read_axes(h)[0] == 2000
    h.rack.control(h.card, "set_estop", active=True)  # motion RTCs ignored while it is active
    with round_trips(monkeypatch) as trips, pytest.raises(mx4.Mx4Error, match="b7 IGNORED"):
        mx4.AXMOVE(h, 0x01, 0x4000, 0, mx4.vel_to_raw(20))
    assert trips.count == 2
