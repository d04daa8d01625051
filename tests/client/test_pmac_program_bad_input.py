"""Bad input around motion programs, end to end through a real daemon (lockstep clock), from three
ports at once (vdevclient.pcomm on the DPRAM, two dls-pmaclib Ethernet connections): a program
line the card rejects, running a program that does not exist, a buffer left open, opening a
buffer while a program runs, a PLC that loops for ever. Each gets the card's error code and
nothing else changes: the program running in C.S. 2 keeps its timing to the servo cycle [issue
21; spec pmac.md §2.8, §2.9; SRM OPEN PROGRAM, R; UM "Linear Blended Moves"; README "Motion
programs", "PLCs"]."""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from vdevclient import pcomm

from tests.client.test_pmac_program_gather import trapezoid
from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_device

DEVICE = 0
DT = PERIOD_NS / 1e9
ACK = "\x06"
WATCHDOG = 1 << 15  # global status word 1 (`???`) [README "PLCs"]
REJECTED = """\
OPEN PROG 1 CLEAR
LINEAR ABS TA100 TS0 TM300
X2 Y1
FROB 3
Y2
CLOSE
"""


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def dpram(command: str) -> str:
    """One command through the DPRAM ASCII handshake (vdevclient.pcomm)."""
    out = ctypes.create_string_buffer(256)
    pcomm.PmacGetResponseA(DEVICE, out, 256, command)
    return out.value.decode("latin-1")


def running(send: Callable[[str], tuple[str, bool]], cs: int) -> bool:
    """`&n??` word 1 bit 0: the C.S. runs a program [SRM ??]."""
    return bool(int(send(f"&{cs}??")[0][:6], 16) & 1)


def test_bad_input_gets_the_cards_errors_and_the_other_cs_keeps_its_timing(
        host: Pmac, tmp_path: Path) -> None:
    """C.S. 2 runs X8 in TM2000 TA100 from rest (2.1 s, motor 3 at 1000 counts a unit) while
    the other ports: run a program that does not exist (ERR015), open a buffer (ERR001 while a
    program runs), start a PLC that loops for ever (one pass each background scan, every I8 + 1
    cycles; the watchdog stays clear) and run in C.S. 1 the program whose download stopped at a
    line refused with ERR003 and left its buffer open (R refused with ERR015, other ports' OPEN
    with ERR007 until the host closed it). Motor 3 is on the trapezoid at every check, and C.S.
    2 ends on its cycle."""
    eth, other = host.dls().sendCommand, host.dls().sendCommand
    assert eth("&1#1->1000X &1#2->1000Y &2#3->1000X #1J/ #2J/ #3J/")[0] == ACK
    assert eth("I116=1000 I216=1000 I316=1000 I117=100 I217=100 I317=100")[0] == ACK
    for line in ("OPEN PROG 2 CLEAR", "LINEAR INC TA100 TS0 TM2000", "X8", "CLOSE",
                 "OPEN PLC 5 CLEAR", "WHILE (1=1)", "P50=P50+1", "ENDWHILE", "CLOSE"):
        assert eth(line)[0] == ACK, line
    # a program line the card rejects: ERR003 at entry, the line not stored; PmacDownloadA stops
    # there and leaves the buffer open on the DPRAM port
    source = tmp_path / "rejected.pmc"
    source.write_text(REJECTED)
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda text, nl: messages.append(text), None, None,
                               str(source)) == 0
    assert len(messages) == 1 and messages[0].endswith("4: FROB 3: ERR003"), messages
    assert other("LIST PROG 1")[0] == "LINEAR ABS TA100 TS0 TM300\rX2 Y1\r" + ACK
    # the buffer left open: no program may run, no other port may open a buffer
    assert eth("&2B2R")[0] == "\x07ERR015\r"
    assert other("OPEN PLC 6")[0] == "\x07ERR007\r"
    host.step(10)
    assert not running(eth, 2) and eth("#3P")[0] == "0\r" + ACK
    assert dpram("Y2") == "" and dpram("CLOSE") == ""    # the host finishes its download by hand
    assert other("LIST PROG 1")[0] == "LINEAR ABS TA100 TS0 TM300\rX2 Y1\rY2\r" + ACK

    assert eth("&2B2R")[0] == ACK
    cycles = 0

    def advance_to(seconds: float) -> None:
        nonlocal cycles
        target = round(seconds / DT)
        host.step(target - cycles)
        cycles = target

    def on_path() -> None:
        """`P` reports the encoder's whole counts: within one of the commanded path."""
        assert float(eth("#3P")[0].split()[0]) == pytest.approx(
            float(trapezoid(cycles * DT, 8000.0, 2.0, 0.1)), abs=1.0), cycles

    advance_to(0.3)
    on_path()
    assert dpram("&1B77R") == "\x07ERR015\r"            # no such program
    assert other("OPEN PROG 3")[0] == "\x07ERR001\r"    # a program runs
    assert other("LIST PROG 77")[0] == "\x07ERR003\r"
    on_path()                                           # none of it took a cycle or moved it
    assert eth("P50=0 ENABLE PLC 5")[0] == ACK
    i8 = int(eth("I8")[0].split()[0])
    advance_to(0.6)
    on_path()
    scans = float(eth("P50")[0].split()[0])
    assert dpram("&1B1R") == ""                          # the program that lost a line runs
    end_1 = cycles * DT + 0.3 + 0.3 + 0.1                # X2 Y1, Y2 blended: 2 TM + TA
    advance_to(0.9)
    on_path()
    passes = float(eth("P50")[0].split()[0]) - scans     # one pass of its loop a scan
    assert passes == pytest.approx((round(0.9 / DT) - round(0.6 / DT)) / (i8 + 1), abs=1)
    assert not int(eth("???")[0][:6], 16) & WATCHDOG
    assert running(eth, 1) and running(eth, 2)
    advance_to(end_1 - 2 * DT)
    on_path()
    assert running(eth, 1)
    advance_to(end_1 + 2 * DT)
    on_path()
    assert not running(eth, 1)
    assert eth("#1P #2P")[0] == "2000\r2000\r" + ACK
    advance_to(2.1 - 2 * DT)
    on_path()
    assert running(eth, 2)
    advance_to(2.1 + 2 * DT)
    assert not running(eth, 2)
    assert eth("#3P")[0] == "8000\r" + ACK
    assert not int(eth("???")[0][:6], 16) & WATCHDOG
    assert float(eth("P50")[0].split()[0]) > scans       # the PLC still loops, one pass a scan
    # decision 0008: the endless PLC keeps the card out of rest; disabled, the card rests again
    quiet = host.rack.stats()["cards"]["pmac0"]["quiet_ticks"]
    host.step(300)
    assert host.rack.stats()["cards"]["pmac0"]["quiet_ticks"] == quiet
    assert eth("DISABLE PLC 5")[0] == ACK
    host.step(300)
    assert host.rack.stats()["cards"]["pmac0"]["quiet_ticks"] > quiet
