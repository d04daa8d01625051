"""Data gathering through a real daemon (lockstep clock): dls-pmaclib's `sendCommand` the way
dls-pmaccontrol's gather form drives it [spec pmac.md §3.3; DLS-ctl gather.py, gatherchannel.py],
and vdevclient.pcomm's gather functions [PComm32 Gather.h; README "Data gathering"]."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator

import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import Pmac, pcomm_device

DEVICE = 0
#: motor n's block and the registers dls-pmaccontrol gathers [DLS-ctl gatherchannel.py]
MOTOR_BASE = [0x80 * n for n in range(1, 33)]
DESIRED, ACTUAL = 0x08, 0x0B
LONG = 0x8  # format digit: 48-bit


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def dls_collect(ret: str) -> list[str]:
    """dls-pmaccontrol's collectData: the reply without its last character, split, each word's
    [6:] then [:6]."""
    words = []
    for long_val in ret[:-1].split():
        words += [long_val.strip()[6:], long_val.strip()[:6]]
    return words


def dls_parse(words: list[str], widths: list[int]) -> list[list[int]]:
    """dls-pmaccontrol's parseData and strToRaw for 24/48-bit channels: a 48-bit value is the
    second word then the first; a sample with an odd number of words is followed by one more
    word, skipped."""
    odd = sum(w // 24 for w in widths) % 2
    out: list[list[int]] = [[] for _ in widths]
    channel, pending = 0, None
    for word in words:
        if channel >= len(widths):
            channel = 0
            if odd:
                continue
        if widths[channel] == 24:
            out[channel].append(int(word, 16))
            channel += 1
        elif pending is None:
            pending = word
        else:
            v = int(word + pending, 16)
            out[channel].append(v - (1 << 48) if v >> 47 else v)
            pending, channel = None, channel + 1
    return out


def test_dls_pmaccontrol_gather_sequence_reads_the_positions_of_two_moving_motors(
        host: Pmac) -> None:
    """i5051=0 i5050=$3, i5049, i5001/i5002 = motors 1 and 2 actual position ($8 + address),
    `define gather 47 + words/2 * samples`, `gather`, jogs, `list gather` parsed as dls-pmaccontrol
    parses it: 100 samples, each the motors' D:$xx8B registers at that cycle."""
    pmac = host.dls()
    send = pmac.sendCommand
    assert send("i5051=0 i5050=$3")[1]
    assert send("i5049=2")[0] == "\x06"
    for index, axis in enumerate((1, 2)):
        addr = f"${LONG:X}{MOTOR_BASE[axis - 1] + ACTUAL:05X}"  # "$%X%05X" [DLS-ctl]
        assert send(f"i50{index + 1:02d}={addr}")[0] == "\x06"
    assert send("i5001")[0] == "$80008B\r\x06"
    samples, words = 100, 4
    assert send(f"define gather {int(47 + (words / 2) * samples)}")[0] == "\x06"  # "%d"
    assert send("i122=50 i119=5 i120=1 i121=0 i222=50 i219=5 i220=1 i221=0 #1j+ #2j-")[0] == "\x06"
    assert send("gather")[0] == "\x06"
    assert int(send("???")[0][:6], 16) & 1 << 19  # data gathering on [digest §2.1]
    host.step(2 * samples - 1)  # samples at cycles 1, 3 ... 199
    assert send("endgather")[0] == "\x06"
    ret, ok = send("list gather")
    assert ok and ret.endswith("\r\x06") and len(ret) > 1400  # more than one Ethernet packet
    m1, m2 = dls_parse(dls_collect(ret), [48, 48])
    assert len(m1) == len(m2) == samples
    # the last sample is the motors' registers now (the card stopped gathering with endgather)
    d1, d2 = (int(send(f"rd:${a:X}")[0].split()[0]) for a in (0x8B, 0x10B))
    assert (m1[-1], m2[-1]) == (d1, d2)
    assert m1 == sorted(m1) and m2 == sorted(m2, reverse=True) and m1[-1] > 0 > m2[-1]


def test_bad_gather_input_answers_the_card_errors_over_ethernet(host: Pmac) -> None:
    send = host.dls().sendCommand
    assert send("delete gather i5001=$C06001 i5050=1")[0] == "\x06"
    assert send("gather")[0] == "\x07ERR003\r"          # no DEFINE GATHER
    assert send("i5002=$8FFFFF")[0] == "\x07ERR003\r"   # no such address
    assert send("define gather 10 gather")[0] == "\x06"
    assert send("define gather 20")[0] == "\x07ERR007\r"  # buffer in use
    assert send("#1 define comp 12.10,#4,1280,1200")[0] == "\x07ERR007\r"
    assert send("endgather i5002")[0] == "$0\r\x06"     # nothing else changed


def test_pcomm_gather_functions_upload_scaled_as_the_registers(host: Pmac) -> None:
    """PmacSetGather/PmacInitGather/PmacStartGather/PmacStopGather/PmacCollectGatherData/
    PmacGetGatherSamples: motor 1 desired position (D:) and P1 (L:) every 3 servo cycles."""
    dev = DEVICE
    assert pcomm.PmacSetGather(dev, 0, "D:$000088", True)
    assert pcomm.PmacSetGather(dev, 1, "L:$6001", True)
    assert pcomm.PmacGetGatherEnable(dev, 1) and not pcomm.PmacGetGatherEnable(dev, 2)
    buf = ctypes.create_string_buffer(32)
    assert pcomm.PmacGetGather(dev, 0, buf, 32) and buf.value == b"D:$000088"
    assert pcomm.PmacSetGatherPeriod(dev, 3) == 3
    servo_ms = pcomm.PmacGetVariable(dev, "I", 10) / 8388608.0
    assert pcomm.PmacGetGatherSampleTime(dev) == pytest.approx(3 * servo_ms)
    assert pcomm.PmacInitPlotGather(dev, 50, 3)
    assert pcomm.PmacGetGatherMode(dev) == pcomm.GAT_RAM_NOWRAP
    out = ctypes.create_string_buffer(64)
    pcomm.PmacGetResponseA(dev, out, 64, "P1=2.5 I122=50 I119=5 I120=1 I121=0 #1J+")
    assert pcomm.PmacStartGather(dev) == 1
    host.step(60)
    assert pcomm.PmacGetResponseA(dev, out, 64, "P1=-7") & pcomm.COMM_EOT
    host.step(90)  # 150 cycles: the 50-sample buffer is full and gathering stopped itself
    assert not int(pcomm.PmacGetResponseA(dev, out, 64, "???").text[:6], 16) & 1 << 19
    assert pcomm.PmacStopGather(dev) == 1
    sources, samples = ctypes.c_uint(), ctypes.c_uint()
    assert pcomm.PmacCollectGatherData(dev, ctypes.byref(sources), ctypes.byref(samples))
    assert (sources.value, samples.value) == (2, 50)
    assert pcomm.PmacGetNumGatherSamples(dev) == 50
    pos = (ctypes.c_double * 50)()
    n = ctypes.c_uint()
    assert pcomm.PmacGetGatherSamples(dev, 0, ctypes.byref(n), pos, 50) and n.value == 50
    assert list(pos) == sorted(pos) and pos[-1] > 0
    p1: list[float] = []
    assert pcomm.PmacGetGatherSamples(dev, 1, None, p1, 50)
    assert p1[:20] == [2.5] * 20 and p1[-1] == -7.0
    assert not pcomm.PmacGetGatherSamples(dev, 2, None, [], 50)  # not gathered
    point = ctypes.c_double()
    assert pcomm.PmacGetGatherPoint(dev, 0, 49, ctypes.byref(point)) and point.value == pos[49]
    pcomm.PmacClearGather(dev)
    assert pcomm.PmacGetNumGatherSources(dev) == 0
    assert pcomm.PmacStartGather(dev) == 0  # no buffer, no source: ERR003
