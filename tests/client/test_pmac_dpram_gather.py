"""DPRAM data gathering through a real daemon (lockstep clock): PComm's gather functions with
GATMODE GAT_DPR_NOWRAP (I5000 = 2), the samples read from the DPRAM buffer at 0x1140 up to the
next-item offset at 0x113E [Turbo UM p.422; PComm32 Gather.h GATMODE; README "Data gathering"]."""

from __future__ import annotations

import ctypes
import struct
from collections.abc import Iterator

import pytest
from vdevclient import pcomm
from vdevmaps.pmac import GAT_SIZE

from tests.devices.pmac.conftest import Pmac
from tests.devices.pmac.test_acceptance import pmac_pcomm

DEVICE = 0


@pytest.fixture
def card() -> Iterator[Pmac]:
    with pmac_pcomm() as host:
        yield host


def test_pcomm_gathers_into_the_dpram_and_uploads_from_it(card: Pmac) -> None:
    """Motor 1 desired position (D:, two words) and P1 (L:, two words) every 3 servo cycles, 50
    samples: DEFINE GATHER 200 (32-bit words, no pad); after 150 cycles the offset reached the
    size and gathering stopped (I5000 = 2); PmacCollectGatherData reads the DPRAM."""
    dev = DEVICE
    assert pcomm.PmacSetGatherMode(dev, pcomm.GAT_DPR_NOWRAP)
    assert pcomm.PmacGetGatherMode(dev) == pcomm.GAT_DPR_NOWRAP
    assert pcomm.PmacSetGather(dev, 0, "D:$000088", True)
    assert pcomm.PmacSetGather(dev, 1, "L:$6001", True)
    assert pcomm.PmacInitPlotGather(dev, 50, 3)
    assert struct.unpack("<HH", pcomm.PmacDPRGetMem(dev, GAT_SIZE, 4)) == (200, 0)
    out = ctypes.create_string_buffer(64)
    pcomm.PmacGetResponseA(dev, out, 64, "P1=2.5 I122=50 I119=5 I120=1 I121=0 #1J+")
    assert pcomm.PmacStartGather(dev) == 1
    card.step(60)
    assert pcomm.PmacGetResponseA(dev, out, 64, "P1=-7") & pcomm.COMM_EOT
    card.step(90)
    assert struct.unpack("<HH", pcomm.PmacDPRGetMem(dev, GAT_SIZE, 4)) == (200, 200)
    assert not int(pcomm.PmacGetResponseA(dev, out, 64, "???").text[:6], 16) & 1 << 19
    sources, samples = ctypes.c_uint(), ctypes.c_uint()
    assert pcomm.PmacCollectGatherData(dev, ctypes.byref(sources), ctypes.byref(samples))
    assert (sources.value, samples.value) == (2, 50)
    pos: list[float] = []
    assert pcomm.PmacGetGatherSamples(dev, 0, None, pos, 50)
    assert pos == sorted(pos) and pos[-1] > 0
    p1: list[float] = []
    assert pcomm.PmacGetGatherSamples(dev, 1, None, p1, 50)
    assert p1[:20] == [2.5] * 20 and p1[-1] == -7.0
    assert pcomm.PmacGetResponseA(dev, out, 64, "LIST GATHER").text == ""  # in the DPRAM
