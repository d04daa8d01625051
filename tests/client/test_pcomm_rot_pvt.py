"""PVT points streamed into a rotary buffer through vdevclient.pcomm while it runs, a real daemon
on the lockstep clock [Turbo SRM "PVT{data}", "OPEN ROT"; Turbo UM "PVT-Mode Moves", "Rotary
Motion Program Buffers"; PMAC UM p.213 "If the Buffer Runs Out"; README "Rotary buffers"].

The card calculates one PVT segment ahead and takes a point sent to an empty rotary buffer
"almost immediately" [UM], so a host sending each point as the segment before it starts keeps
the motion going: PVT10, X0.5:100 from rest, then X1:100 cruise segments (100 units/s, X =
100·(t − 0.005) units, 1000 counts a unit). A point sent after the segment before it has
ended finds the axes stopped on the last point (PVT adds nothing at the end of a sequence,
README "Move modes"); the segment to it starts from rest."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_ask, pcomm_device
from tests.devices.pmac.conftest import step_to as at  # after R

DEVICE = 0
DT = PERIOD_NS / 1e9
T = 0.010   # PVT10
CRUISE = 100


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str) -> str:
    return pcomm_ask(DEVICE, command)


def x() -> float:
    return float(ask("#1P"))


def test_pvt_points_fed_one_segment_ahead_keep_the_speed_and_a_late_one_stops(host: Pmac) -> None:
    """100 cruise points, each sent as the segment before it starts: X follows 100 counts/ms
    through every segment (sampled in each); the closing X0.5:0 sent 20 ms after the last cruise
    segment ended finds X held on X100.5, and the segment to it, from rest, ends on X101 at rest
    10 ms after it came."""
    ask("&1#1->1000X #1J/ &1 DEFINE ROT 200 &1 B0")
    ask("OPEN ROT")
    ask("INC PVT10")
    ask("X0.5:100")
    ask("&1R")
    now = [0]
    for k in range(1, CRUISE + 1):     # segment k (X1:100) sent as segment k − 1 starts
        at(host, (k - 1) * T, now)
        ask("X1:100")
        if k >= 2:
            at(host, (k - 1) * T + T / 2, now)   # in segment k − 1: on the line, no stop
            t = now[0] * DT
            assert x() == pytest.approx(CRUISE * 1000 * (t - 0.005), abs=1.0)
    end = (CRUISE + 1) * T                # the last cruise segment ends on X100.5
    at(host, end + 0.005, now)
    assert x() == 100500.0
    at(host, end + 0.02, now)
    assert x() == 100500.0
    ask("X0.5:0")
    at(host, end + 0.02 + T - 2 * DT, now)
    assert 100500.0 < x() < 101000.0
    at(host, end + 0.02 + T + 2 * DT, now)
    assert x() == 101000.0
    ask("CLOSE")
    ask("&1A")


def test_pvt_points_through_the_binary_rotary_ring_keep_the_speed(host: Pmac) -> None:
    """The same stream through the DPRAM binary rotary ring (I45 = 1, PmacDPRAsciiStrToRotA; the
    card takes a line from the ring at the servo cycle after it is written): 50 cruise points,
    each written as the segment before it starts, X on the line in every segment and ending on
    X51 at rest."""
    from vdevclient import pcomm

    ask("&1#1->1000X #1J/ &1 DEFINE ROT 200 &1 B0")
    assert pcomm.PmacDPRRotBufInit(DEVICE, 0) == pcomm.DprOk
    for line in ("INC PVT10", "X0.5:100"):
        assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, line, 0) == pcomm.DprOk
    host.step(1)
    ask("&1R")
    now = [0]
    for k in range(1, 51):
        at(host, (k - 1) * T, now)
        assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "X1:100", 0) == pcomm.DprOk
        if k >= 2:
            at(host, (k - 1) * T + T / 2, now)
            t = now[0] * DT
            assert x() == pytest.approx(CRUISE * 1000 * (t - 0.005), abs=1.0)
    at(host, 50 * T, now)
    assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "X0.5:0", 0) == pcomm.DprOk
    at(host, 52 * T + 2 * DT, now)
    assert x() == 51000.0
    ask("&1A")
