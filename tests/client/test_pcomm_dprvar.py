"""PComm's DPRAM variable buffer functions through a real daemon (lockstep clock): I55, the read
buffer's users, reads from fresh updates, the write buffer [Turbo UM p.407-410; EPICS tpmac
drvPmac.c; PComm32 dprbkg.h; README "Variable buffers"]."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator

import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import Pmac
from tests.devices.pmac.test_acceptance import pmac_pcomm
from vdevd.devices.pmac.numbers import pmac_float_words

DEVICE = 0
P = pcomm.VBG_L  # an L register: P1 is L:$6001


@pytest.fixture
def card() -> Iterator[Pmac]:
    with pmac_pcomm() as host:
        yield host


def ask(line: str) -> str:
    rc = pcomm.PmacGetResponseA(DEVICE, None, 0, line)
    assert pcomm.IS_COMM_EOT(rc), (line, rc.text)
    return str(rc.text)


def test_read_buffer_users_read_registers_from_fresh_updates(card: Pmac) -> None:
    """Two users; each read clears the data-ready bit and waits for the card's next update, so
    the servo counter advances between reads and a P-variable set on-line shows at once."""
    dev = DEVICE
    assert pcomm.PmacDPRBackGroundVar(dev, True)
    assert ask("I55") == "1\r"
    h = pcomm.PmacDPRVarBufInit(dev, 3, [P | 0x6001, pcomm.VBG_X | 0x0000, P | 0x6002])
    h2 = pcomm.PmacDPRVarBufInit(dev, 1, (ctypes.c_long * 1)(P | 0x6003))
    assert (h, h2) == (0, 1)
    assert pcomm.PmacDPRGetVBGTotalEntries(dev) == 4 and pcomm.PmacDPRGetVBGNumEntries(dev, h) == 3
    ask("P1=-2.75 P2=1000000 P3=0.5")
    two = (ctypes.c_long * 2)()
    assert pcomm.PmacDPRVarBufRead(dev, h, 0, two)
    assert pcomm.PmacDPRFloat(two, 1.0) == -2.75
    counts = []
    for _ in range(2):
        one = [0]
        assert pcomm.PmacDPRVarBufRead(dev, h, 1, one)
        counts.append(one[0])
    assert 0 < counts[0] < counts[1]
    assert pcomm.PmacDPRGetVBGServoTimer(dev) == counts[1] & 0xFFFF
    words: list[int] = []
    assert pcomm.PmacDPRVarBufReadEx(dev, h, words) and len(words) == 5
    assert pcomm.PmacDPRFloat(words[3:5], 1.0) == 1000000.0
    assert pcomm.PmacDPRVarBufReadEx(dev, h2, two) and pcomm.PmacDPRFloat(two, 1.0) == 0.5
    assert pcomm.PmacDPRVarBufRemove(dev, h)
    assert not pcomm.PmacDPRVarBufRead(dev, h, 0, two)
    ask("P3=-8")
    assert pcomm.PmacDPRVarBufRead(dev, h2, 0, two) and pcomm.PmacDPRFloat(two, 1.0) == -8.0
    assert not pcomm.PmacDPRVarBufRead(dev, h2, 1, two)  # h2 has one entry
    assert pcomm.PmacDPRVarBufInit(dev, 128, [P | 0x6001] * 128) == -1  # 129 in all


def test_write_buffer_sets_registers_without_a_command(card: Pmac) -> None:
    """PmacDPRWriteBuffer: P5 (L:, its two halves) and X:$000123 written by the card's next
    background pass; with I55 = 0 nothing is taken (0) and nothing changes."""
    dev = DEVICE
    x, y = pmac_float_words(3.25)
    rows = (pcomm.VBGWFormat * 2)(pcomm.VBGWFormat(P | 0x6005, y, x),
                                  pcomm.VBGWFormat(pcomm.VBG_X | 0x0123, 0x123456, 0))
    assert pcomm.PmacDPRWriteBuffer(dev, 2, rows) == 0  # I55 = 0
    assert ask("P5") == "0\r"
    assert pcomm.PmacDPRBackGroundVar(dev, True)
    assert pcomm.PmacDPRWriteBuffer(dev, 2, rows) == 2
    assert ask("P5") == "3.25\r"
    one = [0]
    h = pcomm.PmacDPRVarBufInit(dev, 1, [pcomm.VBG_X | 0x0123])
    assert pcomm.PmacDPRVarBufRead(dev, h, 0, one) and one[0] == 0x123456
    assert pcomm.PmacDPRWriteBuffer(dev, 33, rows) == 0  # at most 32
