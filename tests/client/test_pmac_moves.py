"""PVT, CIRCLE and rotary-buffer programs through a real daemon (lockstep clock) with
vdevclient.pcomm: a PVT scan whose points come from P-variables with CMD"GAT"/CMD"END GAT"
gathering around it, a CIRCLE move, a rotary buffer fed while it runs [Turbo SRM "PVT",
"CIRCLE1", "OPEN ROT", "PR"; README "Motion programs"]."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_device

DEVICE = 0
DT = PERIOD_NS / 1e9

PVT_SCAN = """\
#define POINT  P1
#define POINTS P2
OPEN PROG 20 CLEAR
ABS
PVT(P3)
CMD"GAT"
POINT = 0
WHILE (POINT < POINTS)
  X(P(100 + POINT)):(P(300 + POINT))
  POINT = POINT + 1
ENDWHILE
DWELL 0
CMD"END GAT"
CLOSE
"""


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str, size: int = 256) -> str:
    out = ctypes.create_string_buffer(size)
    pcomm.PmacGetResponseA(DEVICE, out, size, command)
    return out.value.decode("latin-1").strip("\r\x06")


def position(motor: int) -> float:
    return float(ask(f"#{motor}P"))


def running() -> bool:
    return bool(int(ask("&1??")[:6], 16) & 1)


def download(tmp_path: Path, text: str) -> None:
    source = tmp_path / "prog.pmc"
    source.write_text(text)
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda t, nl: messages.append(t), None, None,
                               str(source)) == 1, messages


def test_pvt_scan_from_p_variables_with_gathering(host: Pmac, tmp_path: Path) -> None:
    """20 points 50 ms apart: the axis passes point k at (k+1)·50 ms; the gathered commanded
    positions (every 10 servo cycles) end on the last point."""
    ask("&1#1->1000X #1J/")
    n, t_ms = 20, 50
    pts = np.round(np.linspace(0, 4, n) ** 2, 4)
    vel = np.round(np.gradient(pts, t_ms / 1000), 4)
    vel[0] = vel[-1] = 0.0   # from rest (the program starts at 0) back to rest
    for k in range(n):
        ask(f"P{100 + k}={pts[k]} P{300 + k}={vel[k]}")
    ask(f"P2={n} P3={t_ms}")
    ask("I5001=$800088 I5050=1 I5049=10 DEFINE GATHER 2000")
    download(tmp_path, PVT_SCAN)
    ask("&1B20R")
    t = 0.0
    for k in (4, 9, 14):
        ticks = round(((k + 1) * t_ms / 1000 - t) / DT)
        host.step(ticks)
        t += ticks * DT
        assert position(1) / 1000 == pytest.approx(pts[k], abs=abs(vel[k]) * DT + 1e-3)
    host.step(round((n * t_ms / 1000 - t) / DT) + 20)
    assert not running()
    assert position(1) == pytest.approx(pts[-1] * 1000)
    lines = ask("LIST GATHER", 65536).split("\r")
    assert len(lines) == pytest.approx(n * t_ms / 1000 / DT / 10, abs=3)
    words = [int(line.split()[0], 16) for line in lines]
    words = [w - (1 << 48) if w >= 1 << 47 else w for w in words]
    # 1/(Ixx08·32) count; the last sample is at most one gather period (10 cycles) before the end
    assert words[-1] / 3072 == pytest.approx(pts[-1] * 1000, abs=20)
    assert all(b >= a for a, b in zip(words, words[1:], strict=False))  # a rising scan


def test_circle_move_through_the_daemon(host: Pmac, tmp_path: Path) -> None:
    """A clockwise half circle of radius 5 around (5,0): (5,5) at its middle, (10,0) at the end."""
    ask("&1#1->1000X &1#2->1000Y #1J/#2J/ I5113=10")
    download(tmp_path, "OPEN PROG 21 CLEAR\nCIRCLE1 TA100 TS0 F10\nX10 Y0 I5 J0\nCLOSE\n")
    ask("&1B21R")
    half = (np.pi * 5 / 10 + 0.1) / 2
    host.step(round(half / DT))
    assert (position(1), position(2)) == pytest.approx((5000, 5000), abs=10)
    host.step(round(half / DT) + 20)
    assert not running()
    assert (position(1), position(2)) == (10000.0, 0.0)


def test_rotary_buffer_fed_while_it_runs(host: Pmac) -> None:
    """Lines sent to the open rotary buffer while it runs are executed in order; PR reports the
    lines waiting."""
    ask("&1#1->1000X #1J/ &1 DEFINE ROT 200 &1 B0")
    ask("OPEN ROT")
    ask("INC LINEAR TA50 TS0 F2")
    ask("X1")
    ask("&1R")
    host.step(5)
    for _ in range(4):
        ask("X1")
    assert ask("&1PR") == "4"
    host.step(round(1.0 / DT))
    assert 1000 < position(1) < 5000 and running()
    host.step(round(3.0 / DT))
    assert position(1) == 5000.0 and ask("&1PR") == "0"
    ask("X-2.5")
    host.step(round(2.0 / DT))
    assert position(1) == 2500.0
    ask("CLOSE")
    ask("&1A")
    assert ask("&1 DELETE ROT") == ""


def test_two_motor_kinematic_cs_through_the_daemon(host: Pmac, tmp_path: Path) -> None:
    """The UM's shoulder-elbow robot downloaded with PmacDownloadA: the tip moves from the forward
    position of the motors (30°, 60°) to X500 Y200 and the motors end where the inverse program
    puts them [UM "Kinematic Calculations"]."""
    from tests.devices.pmac.test_kinematics import FORWARD, INVERSE

    text = "\n".join(["&1 #1->I #2->I", "&1 Q91=400 Q92=300 Q93=1000 I5150=1 I5113=10",
                      "&1 OPEN FORWARD CLEAR", *FORWARD, "CLOSE",
                      "&1 OPEN INVERSE CLEAR", *INVERSE, "CLOSE",
                      "OPEN PROG 22 CLEAR", "LINEAR ABS TA100 TS0 F100", "X500 Y200", "CLOSE"])
    download(tmp_path, text + "\n")
    ask("#1J/ #2J/ #1J=30000 #2J=60000")
    host.step(round(3.0 / DT))
    ask("&1B22R")
    host.step(round(4.0 / DT))
    assert not running()
    a, b = np.radians(position(1) / 1000), np.radians(position(2) / 1000)
    x = 400 * np.cos(a) + 300 * np.cos(a + b)
    y = 400 * np.sin(a) + 300 * np.sin(a + b)
    assert (x, y) == pytest.approx((500, 200), abs=0.01)


def test_binary_rotary_ring_feeds_the_running_rotary_buffer(host: Pmac) -> None:
    """The DPRAM binary rotary ring (I45) hands its lines to the C.S.'s rotary buffer, which runs
    them as if they had come as text: the motor ends at the sum of the incremental moves
    [PMAC1 DPRAM UM p.30; README "Binary rotary buffer"]."""
    ask("&1#1->1000X #1J/ &1 DEFINE ROT 200 &1 B0")
    assert pcomm.PmacDPRRotBufInit(DEVICE, 0) == pcomm.DprOk  # C.S. 1, I45 = 1
    for line in ("INC LINEAR TA50 TS0 F2", "X1", "X1", "X0.5"):
        assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, line, 0) == pcomm.DprOk
    host.step(1)                       # the card takes them into the rotary buffer
    assert ask("&1PR") == "4"
    ask("&1R")
    host.step(round(0.5 / DT))
    assert running() and 500 < position(1) < 1500   # 2 units/s: about 1 unit after 0.5 s
    assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "X-1", 0) == pcomm.DprOk  # fed while it runs
    host.step(round(3.0 / DT))
    assert position(1) == 1500.0 and ask("&1PR") == "0"
    assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "BAD", 0) == pcomm.DprOk
    host.step(1)
    assert pcomm.PmacDPRAsciiStrToRotA(DEVICE, "X1", 0) == pcomm.DprCmdErr  # the card's ERR003
    ask("&1A")
