"""A rotary buffer fed in time through vdevclient.pcomm blends through the corner, a real daemon
on the lockstep clock: lines as text (`OPEN ROT`) with Isx13 segmentation, and through the DPRAM
binary rotary ring (PmacDPRRotBuf*) with Isx13 and the special lookahead [Turbo SRM "OPEN ROT",
I16, I17, Isx13, Isx20, "DEFINE LOOKAHEAD"; Turbo UM "Rotary Motion Program Buffers", "Special
Lookahead"; README "Rotary buffers"].

X10 at F20 (0.5 s) with TA50 from rest, then Y10 sent while X10 runs: the blend out of X10 runs
0.50-0.55 s. Blended, Y has started before X reaches its end (5 ms past the corner, at 0.53 s, Y
is 0.4 counts/ms² × 30² / 2 = 180 counts on) and the sequence ends at 1.05 s; a move stopped on
its end would hold Y at 0 until 0.55 s and end at 1.10 s."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import Pmac, pcomm_ask, pcomm_device
from tests.devices.pmac.conftest import step_to as at  # after R

DEVICE = 0
LOOKAHEAD_BIT = 1 << 23   # `??` word 2 [digest §2.6]


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str) -> str:
    return pcomm_ask(DEVICE, command)


def xy() -> tuple[float, float]:
    return float(ask("#1P")), float(ask("#2P"))


def check_blended(host: Pmac, now: list[int]) -> None:
    at(host, 0.53, now)
    x, y = xy()
    assert 9900 < x < 10000 and y == pytest.approx(180, abs=3)
    at(host, 1.04, now)
    assert xy()[1] < 10000
    at(host, 1.06, now)
    assert xy() == (10000.0, 10000.0)


def test_text_rotary_buffer_with_segmentation_blends_a_line_sent_in_time(host: Pmac) -> None:
    """Isx13 = 10: Y10 sent at 0.45 s (X10 taken at R, the buffer empty since) blends."""
    ask("&1#1->1000X #2->1000Y #1J/ #2J/ I5113=10 &1 DEFINE ROT 200 &1 B0")
    ask("OPEN ROT")
    ask("INC LINEAR TA50 TS0 F20")
    ask("X10")
    ask("&1R")
    now = [0]
    at(host, 0.45, now)
    assert ask("&1PR") == "0"
    ask("Y10")
    check_blended(host, now)
    ask("CLOSE")
    ask("&1A")


def test_binary_rotary_ring_with_segmentation_and_lookahead_blends(host: Pmac) -> None:
    """The DPRAM binary rotary ring (I45 = 1) feeding C.S. 1's rotary buffer, Isx13 = 10 and a
    lookahead of Isx20 = 10 segments (the lookahead buffer filling from the rotary buffer, so
    the line is needed 0.1 s earlier): Y10 through the ring at 0.35 s blends, the lookahead bit
    set while it runs; X-10 sent once all is done starts from rest and ends on X0 0.55 s
    later."""
    ask("&1#1->1000X #2->1000Y #1J/ #2J/ I5113=10 I5120=10 I117=1 I217=1")
    ask("&1 DEFINE ROT 200")
    ask("&1 DEFINE LOOKAHEAD 500,10")
    ask("&1 B0")
    assert pcomm.PmacDPRRotBufInit(DEVICE, 0) == pcomm.DprOk   # C.S. 1's ring, I45 = 1
    for line in ("INC LINEAR TA50 TS0 F20", "X10"):
        assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, line, 0) == pcomm.DprOk
    host.step(1)                           # the card takes them into the rotary buffer
    assert ask("&1PR") == "2"
    ask("&1R")
    now = [0]
    at(host, 0.35, now)
    assert int(ask("&1??")[6:12], 16) & LOOKAHEAD_BIT
    assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "Y10", 0) == pcomm.DprOk
    check_blended(host, now)
    at(host, 1.2, now)
    assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "X-10", 0) == pcomm.DprOk
    at(host, 1.2 + 0.55 - 0.01, now)
    assert 9 < xy()[0] < 100              # still decelerating from rest-to-rest X-10
    at(host, 1.2 + 0.55 + 0.01, now)
    assert xy() == (0.0, 10000.0)
    ask("&1A")
