"""The rotary buffer request through a real daemon (lockstep clock): lines through the DPRAM binary
rotary ring into C.S. 1's rotary buffer raise IR1 (BREQ) while fewer than I17 lines wait, none
once I17 wait, and IR1 again when the running program has taken them down to fewer than I16;
global status word 2 bit 20 while the binary rotary buffer is open [Turbo SRM I16, I17; digest
§2.11 proposed interrupt controller; README "Rotary buffers"]."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest
from vdevclient import pcomm
from vdevmaps.pmac import IR_STATUS, HostIrq

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_ask, pcomm_device

DEVICE = 0
DT = PERIOD_NS / 1e9
GUARD_S = 5.0  # a guard against hangs, never a wait for timing
BREQ = int(HostIrq.BUFFER_REQUEST)


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str) -> str:
    return pcomm_ask(DEVICE, command)


def status_word2() -> int:
    return int(ask("???")[6:12], 16)


def send(host: Pmac, *lines: str) -> None:
    for line in lines:
        assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, line, 0) == pcomm.DprOk
    host.step(1)  # the card takes them into the rotary buffer in its next servo cycle


def test_binary_rotary_buffer_open_is_global_status_word2_bit20(host: Pmac) -> None:
    assert status_word2() & (1 << 20) == 0
    assert pcomm.PmacDPRRotBufInit(DEVICE, 0) == pcomm.DprOk    # the ring, I45 = 1
    assert status_word2() & (1 << 20)
    assert pcomm.PmacDPRRotBuf(DEVICE, False) == pcomm.DprOk    # I45 = 0
    assert status_word2() & (1 << 20) == 0
    assert pcomm.PmacDPRRotBuf(DEVICE, True) == pcomm.DprOk
    assert status_word2() & (1 << 20)
    assert pcomm.PmacDPRRotBufRemove(DEVICE, 0) == pcomm.DprOk     # no ring
    assert status_word2() & (1 << 20) == 0


def test_breq_interrupt_when_the_rotary_buffer_has_room_again(host: Pmac) -> None:
    """SRM I17: each line sent while fewer than I17 wait takes BREQ high again (IR1); at I17 it
    stays low; the program catching up to fewer than I16 lines takes it high: IR1, delivered by
    PmacINTRFuncCallInit's callback as interrupt number 1."""
    irq = host.card.region("host")
    ask("I16=2")
    ask("I17=4")
    ask("&1#1->1000X #1J/ &1 DEFINE ROT 200 &1 B0")
    assert pcomm.PmacDPRRotBufInit(DEVICE, 0) == pcomm.DprOk
    irq.write(IR_STATUS, bytes([0xFF]))
    send(host, "INC LINEAR TA20 TS0 F10")
    assert irq.read8(IR_STATUS) & BREQ            # 1 line waits: room
    irq.write(IR_STATUS, bytes([BREQ]))
    send(host, "X0.1", "X0.1", "X0.1")
    assert ask("&1PR") == "4"
    assert int(ask("&1??")[6:12], 16) & (1 << 16)  # rotary buffer full [SRM ?? word 2 bit 16]
    irq.write(IR_STATUS, bytes([BREQ]))           # the edges of the 2nd and 3rd lines, cleared
    send(host, "X0.1")                             # a 5th line: BREQ stays low
    host.step(10)
    assert irq.read8(IR_STATUS) & BREQ == 0

    got: list[tuple[int, int]] = []
    fired = threading.Event()

    def callback(msg: int, buffer: Any) -> None:
        got.append((msg, buffer.contents.dwInterruptType))
        fired.set()

    assert pcomm.PmacINTRFuncCallInit(DEVICE, callback, 42, BREQ)
    ask("&1R")
    while int(ask("&1PR")) >= 2:
        assert not fired.is_set()
        host.step(1)
    assert fired.wait(GUARD_S)
    assert got == [(42, 1)]
    assert not int(ask("&1??")[6:12], 16) & (1 << 16)
    host.step(round(1.0 / DT))
    assert ask("#1P") == "400"   # four moves of 0.1 unit, 1000 counts a unit
    assert pcomm.PmacINTRTerminate(DEVICE)
    ask("&1A")
