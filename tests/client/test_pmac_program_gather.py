"""Data gathering of a running motion program, end to end through a real daemon (lockstep clock):
`LIST GATHER` over Ethernet (dls-pmaclib, parsed as dls-pmaccontrol parses it) against the path a
LINEAR move commands, and beamline-style step and fly (blended raster) scans that start and end
their own gathering with `CMD"GAT"` / `CMD"END GAT"`, read back with vdevclient.pcomm's Gather.h
functions (a long LIST GATHER reply is not read with dls-pmaclib: its GETBUFFER loop fails on a
1400-byte piece ending in CR, README "Ethernet protocol") [spec pmac.md
§2.8, §3.3; Turbo UM "Linear Blended Moves", "How PMAC Executes a Motion Program"; README
"Motion programs", "Data gathering"]."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import vdevclient
from vdevclient import pcomm

from tests.client.test_pmac_gather import dls_collect, dls_parse
from tests.devices.pmac.conftest import PERIOD_NS, Pmac, card_config
from vdevd.testing import DaemonThread

DEVICE = 0
DT = PERIOD_NS / 1e9
#: motor n's commanded (D:+$08) and actual (D:+$0B) positions, as I50xx sources of 48-bit
#: integers ($8 format digit) [README "Data gathering", DLS-ctl gatherchannel.py]
COMMANDED, ACTUAL = 0x08, 0x0B
SETUP = "&1#1->1000X &1#2->1000Y #1J/ #2J/ I116=1000 I216=1000 I117=100 I217=100"
GATHER_BIT = 1 << 19  # global status word 1 (`???`): data gathering on [digest §2.1]


def source(motor: int, register: int) -> str:
    return f"$8{0x80 * motor + register:05X}"


def trapezoid(t: np.ndarray, distance: float, tm: float, ta: float) -> np.ndarray:
    """A lone LINEAR move from rest with TS0: TA of constant acceleration centred on each end of
    the TM move, so the move takes TM + TA at the speed distance/TM [UM "Linear Blended Moves"]."""
    v = distance / tm
    t = np.clip(t, 0.0, tm + ta)
    return np.where(t < ta, v * t**2 / (2 * ta),
                    np.where(t < tm, v * (t - ta / 2), distance - v * (tm + ta - t) ** 2 / (2 * ta)))


@pytest.fixture
def host() -> Iterator[Pmac]:
    cfg = card_config(device=DEVICE)  # the servo plant: actual positions follow through the PID
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        h = Pmac(rack)
        assert pcomm.OpenPmacDevice(DEVICE, endpoint=d.endpoint)
        try:
            yield h
        finally:
            pcomm.ClosePmacDevice(DEVICE)
            h.close()


def test_list_gather_of_a_linear_program_matches_the_commanded_path(host: Pmac) -> None:
    """X10 Y-5 in TM500 with TA100 TS0 from rest: every gathered commanded position is the
    trapezoid at its sample's program time (the first sample one servo cycle after `GATHER
    &1B1R`, then every I5049 cycles), to the 1/(Ixx08·32) count of the register; every actual
    position trails it by no more than the warning following error Ixx12/16 counts, and ends
    on the target."""
    send = host.dls().sendCommand
    for line in (SETUP, "OPEN PROG 1 CLEAR", "LINEAR ABS TA100 TS0 TM500", "X10 Y-5", "CLOSE"):
        assert send(line)[0] == "\x06", line
    period = 4
    sources = " ".join(f"I50{k + 1:02d}={source(m, r)}" for k, (m, r) in
                       enumerate([(1, COMMANDED), (1, ACTUAL), (2, COMMANDED), (2, ACTUAL)]))
    assert send(f"I5000=0 I5051=0 I5050=$F I5049={period} {sources}")[0] == "\x06"
    samples = 200  # of four 48-bit words; 0.354 s, into the constant speed of the 0.6 s move
    assert send(f"DEFINE GATHER {4 * samples}")[0] == "\x06"
    assert send("GATHER &1B1R")[0] == "\x06"
    host.step(period * samples + 50)
    assert not int(send("???")[0][:6], 16) & GATHER_BIT    # the buffer filled: gathering ended
    ret, ok = send("LIST GATHER")
    assert ok
    cmd1, act1, cmd2, act2 = (np.array(c, dtype=float) for c in
                              dls_parse(dls_collect(ret), [48, 48, 48, 48]))
    assert len(cmd1) == samples
    scale = int(send("I108")[0].split()[0]) * 32  # D: registers count 1/(Ixx08·32) counts
    t = (1 + period * np.arange(samples)) * DT
    x, y = trapezoid(t, 10_000.0, 0.5, 0.1), trapezoid(t, -5_000.0, 0.5, 0.1)
    assert np.abs(cmd1 / scale - x).max() < 0.05
    assert np.abs(cmd2 / scale - y).max() < 0.05
    assert cmd1[-1] / scale > 5000 > cmd1[0] / scale >= 0    # the samples span the move
    warning = int(send("I112")[0].split()[0]) / 16
    for actual, path in ((act1, x), (act2, y)):
        error = path - actual / scale
        assert np.abs(error).max() <= warning
        assert np.abs(error).max() > 0                        # the servo plant really lags
        assert np.all(np.sign(error[t > 0.05]) == np.sign(path[-1]))  # trailing, not leading
    host.step(round(0.5 / DT))
    assert send("#1P #2P")[0] == "10000\r-5000\r\x06"


# -- a beamline step scan -------------------------------------------------------------------------
COLS, ROWS = 3, 2
STEP_SCAN = """\
; a step scan of COLS x ROWS points: move, then count for DWELL ms; gathering from the program
#define COL   P1
#define ROW   P2
OPEN PROG 2 CLEAR
LINEAR ABS TA50 TS0 TM100
CMD"GAT"
ROW = 0
WHILE (ROW < P12)
  COL = 0
  WHILE (COL < P11)
    X(1 + COL * P13) Y(1 + ROW * P14)
    DWELL50
    COL = COL + 1
  ENDWHILE
  ROW = ROW + 1
ENDWHILE
CMD"END GAT"
CLOSE
"""


def test_step_scan_program_gathers_its_own_scan_with_cmd_gat(host: Pmac, tmp_path: Path) -> None:
    """A WHILE loop over P-variables stepping X and Y, CMD"GAT" before it and CMD"END GAT"
    after it: a DWELL stops the calculation until it is done, so gathering ends after the last
    point's dwell. Each point is a move from rest (TM + TA = 150 ms) and a 50 ms dwell: the
    gathered commanded positions hold on every grid point, in scan order, for the dwell, and the
    gathering spans the 6 x 200 ms of the scan [UM "How PMAC Executes a Motion Program"]."""
    dev = DEVICE
    out = ctypes.create_string_buffer(256)
    pcomm.PmacGetResponseA(dev, out, 256, SETUP)
    source_file = tmp_path / "scan.pmc"
    source_file.write_text(STEP_SCAN)
    messages: list[str] = []
    assert pcomm.PmacDownloadA(dev, lambda text, nl: messages.append(text), None, None,
                               str(source_file)) == 1, messages
    period = 10
    assert pcomm.PmacSetGather(dev, 0, "D:$000088", True)
    assert pcomm.PmacSetGather(dev, 1, "D:$000108", True)
    assert pcomm.PmacInitPlotGather(dev, 1000, period)
    # (not `P14=0.5 &1B2R`: an assignment takes an expression, `0.5 &1` would be 0.5 AND 1)
    pcomm.PmacGetResponseA(dev, out, 256, f"P11={COLS} P12={ROWS} P13=1 P14=0.5")
    pcomm.PmacGetResponseA(dev, out, 256, "&1B2R")
    assert out.value == b""
    host.step(1)
    assert int(pcomm.PmacGetResponseA(dev, out, 256, "???").text[:6], 16) & GATHER_BIT
    scan_s = COLS * ROWS * (0.1 + 0.05 + 0.05)
    host.step(round((scan_s - 0.05) / DT))
    assert int(pcomm.PmacGetResponseA(dev, out, 256, "???").text[:6], 16) & GATHER_BIT
    host.step(round(0.1 / DT))
    assert not int(pcomm.PmacGetResponseA(dev, out, 256, "???").text[:6], 16) & GATHER_BIT
    assert not int(pcomm.PmacGetResponseA(dev, out, 256, "&1??").text[:6], 16) & 1  # ended
    sources, count = ctypes.c_uint(), ctypes.c_uint()
    assert pcomm.PmacCollectGatherData(dev, ctypes.byref(sources), ctypes.byref(count))
    n = count.value
    assert sources.value == 2
    assert abs(n * period * DT - scan_s) <= 2 * period * DT
    scale = pcomm.PmacGetVariable(dev, "I", 108) * 32
    xs, ys = [], []
    assert pcomm.PmacGetGatherSamples(dev, 0, None, xs, n)
    assert pcomm.PmacGetGatherSamples(dev, 1, None, ys, n)
    path = np.column_stack([xs, ys]) / scale
    dwell_samples = int(0.05 / (period * DT))  # whole samples inside every 50 ms dwell
    held = []
    k = 0
    while k < n:
        same = k
        while same + 1 < n and np.array_equal(path[same + 1], path[k]):
            same += 1
        if same - k + 1 >= dwell_samples:
            held.append(tuple(path[k]))
        k = same + 1
    grid = [(1000.0 * (1 + col), 1000.0 * (1 + 0.5 * row)) for row in range(ROWS)
            for col in range(COLS)]
    assert held == grid
    assert tuple(path[-1]) == grid[-1]
    assert tuple(path[0]) == pytest.approx((0.0, 0.0), abs=1.0)  # gathering began with the scan


# -- a beamline fly scan ---------------------------------------------------------------------------
FLY_SCAN = """\
; a snake raster of P2 rows of P3 units, P4 apart, gathered from the program itself
OPEN PROG 3 CLEAR
LINEAR ABS TA100 TS0 F50
CMD"GAT"
P1 = 0
WHILE (P1 < P2)
  IF (P1 % 2 = 0)
    X(P3)
  ELSE
    X0
  ENDIF
  Y((P1 + 1) * P4)
  P1 = P1 + 1
ENDWHILE
DWELL0
CMD"END GAT"
CLOSE
"""


def blended(t: np.ndarray, points: list[float], times: list[float], ta: float) -> np.ndarray:
    """Moves through `points` (the start first) in `times`, blended with TA centred on each
    corner at constant acceleration (TS0), the first blend centred on t = TA/2: the velocity is
    each move's (distance/time) over its span, smoothed by a TA-wide box [UM "Linear Blended
    Moves"]; exact while no move is shorter than TA."""
    def ramp(u: np.ndarray) -> np.ndarray:  # the integral of a unit step smoothed over TA
        return np.where(u < -ta / 2, 0.0, np.where(u < ta / 2, (u + ta / 2) ** 2 / (2 * ta), u))

    corners = ta / 2 + np.concatenate([[0.0], np.cumsum(times)])
    pos = np.full_like(t, points[0])
    for k, move_t in enumerate(times):
        v = (points[k + 1] - points[k]) / move_t
        pos += v * (ramp(t - corners[k]) - ramp(t - corners[k + 1]))
    return pos


def test_fly_scan_gathers_the_blended_raster_from_cmd_gat_to_the_end(host: Pmac,
                                                                      tmp_path: Path) -> None:
    """Three rows of 10 units at F50 (0.2 s each), 6-unit steps (0.12 s), TA100 TS0: every
    gathered commanded position is on the blended path at its sample's program time. The CMD"GAT"
    met at R gathers from the first servo cycle on, as a host's `GATHER &1B1R` does (sample j
    at (1 + j·I5049) cycles); DWELL0 holds the calculation until the motion has ended, so
    CMD"END GAT" after it ends gathering with the scan, at ΣT + TA = 1.06 s."""
    dev = DEVICE
    out = ctypes.create_string_buffer(256)
    pcomm.PmacGetResponseA(dev, out, 256, SETUP)
    source_file = tmp_path / "fly.pmc"
    source_file.write_text(FLY_SCAN)
    assert pcomm.PmacDownloadA(dev, None, None, None, str(source_file)) == 1
    period = 5
    assert pcomm.PmacSetGather(dev, 0, "D:$000088", True)
    assert pcomm.PmacSetGather(dev, 1, "D:$000108", True)
    assert pcomm.PmacInitPlotGather(dev, 1000, period)
    pcomm.PmacGetResponseA(dev, out, 256, "P2=3 P3=10 P4=6")
    pcomm.PmacGetResponseA(dev, out, 256, "&1B3R")
    host.step(round(1.5 / DT))
    assert not int(pcomm.PmacGetResponseA(dev, out, 256, "???").text[:6], 16) & GATHER_BIT
    sources, count = ctypes.c_uint(), ctypes.c_uint()
    assert pcomm.PmacCollectGatherData(dev, ctypes.byref(sources), ctypes.byref(count))
    n = count.value
    scan_s = 3 * 0.2 + 3 * 0.12 + 0.1
    last = (1 + period * (n - 1)) * DT
    assert scan_s - (period + 1) * DT <= last <= scan_s + 2 * DT, (last, scan_s)
    scale = pcomm.PmacGetVariable(dev, "I", 108) * 32
    xs: list[float] = []
    ys: list[float] = []
    assert pcomm.PmacGetGatherSamples(dev, 0, None, xs, n)
    assert pcomm.PmacGetGatherSamples(dev, 1, None, ys, n)
    t = (1 + period * np.arange(n)) * DT
    times = [0.2, 0.12] * 3
    x = blended(t, [0.0, 10e3, 10e3, 0.0, 0.0, 10e3, 10e3], times, 0.1)
    y = blended(t, [0.0, 0.0, 6e3, 6e3, 12e3, 12e3, 18e3], times, 0.1)
    assert np.abs(np.array(xs) / scale - x).max() < 0.1
    assert np.abs(np.array(ys) / scale - y).max() < 0.1
    assert xs[-1] / scale == 10e3 and ys[-1] / scale > 17_990  # the last sample ends the scan
