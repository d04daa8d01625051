"""Coordinated motion through gclib's `GCommand` against a lockstep daemon with one DMC-13X8
[M Ch6 §Linear Interpolation Mode, §Vector Mode]: the manual's examples end where it says, at
the time VS, VA and VD give for the path's length; ST, AB and a limit switch during a vector
move; the 511-segment buffer; bad input answered with `?` and the card's TC code."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import gclib

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread

TM_S = 0.001
LATENCY_S = 3 * TM_S  # BGS starts at the next sample; AMS answers at the sample it holds


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        yield d


@pytest.fixture
def rack(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as r:
        yield r


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[gclib.py]:
    conn = gclib.py()
    conn.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


def path_time(length: float, vs: float, va: float, vd: float) -> float:
    """Seconds of the trapezoid (triangle when short) along a path from rest to rest."""
    ramps = vs * vs / (2 * va) + vs * vs / (2 * vd)
    if length >= ramps:
        return vs / va + vs / vd + (length - ramps) / vs
    peak = math.sqrt(2 * length * va * vd / (va + vd))
    return peak / va + peak / vd


def numbers(reply: str) -> list[float]:
    return [float(v) for v in reply.replace(" ", ",").split(",") if v]


def timed(g: gclib.py, rack: vdevclient.Rack, line: str) -> float:
    start = rack.sim.now_ns()
    g.GCommand(line)
    return (rack.sim.now_ns() - start) / 1e9


def tc(g: gclib.py, line: str) -> int:
    with pytest.raises(gclib.GclibError, match="question mark"):
        g.GCommand(line)
    return int(g.GCommand("TC1").split()[0])


def test_linear_move_example_fig_6_2(g: gclib.py, rack: vdevclient.Rack) -> None:
    """[M Ch6 Example - Linear Move]: LM ZW, LI,,40000,30000, VS 100000, VA VD 1000000: at
    0.1 s Z 4000 and W 3000 (TP following), SC 100; BGS;AMS takes 0.6 s; RP 40000,30000, SC 101."""
    g.GCommand("LM ZW;LI,,40000,30000;LE;VS 100000;VA 1000000;VD 1000000")
    assert numbers(g.GCommand("MG _LM,_LE")) == [510, 50_000]
    start = rack.sim.now_ns()
    g.GCommand("BGS")
    rack.sim.step(seconds=0.1)
    z, w = numbers(g.GCommand("RP ZW"))
    assert abs(z - 4000) <= 80_000 * TM_S and abs(w - 3000) <= 60_000 * TM_S  # within a sample
    assert z * 3 == pytest.approx(w * 4, abs=4)  # on the line
    tz, tw = numbers(g.GCommand("TP ZW"))
    # the motors follow the path, a following error of about AC / 24000 (README "Motion")
    assert abs(tz - z) < 800_000 / 24_000 * 1.5 and abs(tw - w) < 600_000 / 24_000 * 1.5
    assert numbers(g.GCommand("SC")) == [1, 1, 100, 100]
    record = g.GRecord(gclib.G_DR)
    assert record["axis_c_stop_code"] == 100
    assert record["s_plane_move_status"] & 0x8000
    g.GCommand("AMS")
    elapsed = (rack.sim.now_ns() - start) / 1e9
    assert abs(elapsed - path_time(50_000, 100_000, 1e6, 1e6)) <= LATENCY_S
    assert g.GCommand("RP") == "0000000000,0000000000,0000040000,0000030000"
    assert numbers(g.GCommand("SC")) == [1, 1, 101, 101]
    assert numbers(g.GCommand("MG _CS,_AV,_LM,_BGS")) == [1, 50_000, 511, 0]
    rack.sim.step(seconds=0.3)
    assert [abs(v) for v in numbers(g.GCommand("TE ZW"))] == pytest.approx([0, 0], abs=1)


def test_example_15_linear_interpolation_time(g: gclib.py, rack: vdevclient.Rack) -> None:
    """[M Ch2 Ex15]: LM XYZ, LI 7000,3000,6000, VS 6000, VA VD 20000."""
    g.GCommand("LM XYZ;LI 7000,3000,6000;LE;VS 6000;VA 20000;VD 20000")
    length = math.sqrt(7000**2 + 3000**2 + 6000**2)
    elapsed = timed(g, rack, "BGS;AMS")
    assert abs(elapsed - path_time(length, 6000, 20_000, 20_000)) <= LATENCY_S
    assert g.GCommand("RP") == "0000007000,0000003000,0000006000,0000000000"


def test_example_16_circular_interpolation(g: gclib.py, rack: vdevclient.Rack) -> None:
    """[M Ch2 Ex16, Fig 2-4]: the path through (-4000,0), (-4000,4000), (0,4000) back to the
    local zero; on the arcs RP is within a count of the radius 2000."""
    g.GCommand("VM XY;VP -4000,0;CR 2000,270,-180;VP 0,4000;CR 2000,90,-180;VS 1000;"
               "VA 50000;VD 50000;VE")
    length = 2 * 4000 + 2 * 2000 * math.pi
    start = rack.sim.now_ns()
    g.GCommand("BGS")
    checked = 0
    for _ in range(40):
        rack.sim.step(seconds=0.5)
        x, y = numbers(g.GCommand("RP XY"))
        if x < -4000:
            assert abs(math.hypot(x + 4000, y - 2000) - 2000) <= 1
            checked += 1
        elif x > 0:
            assert abs(math.hypot(x, y - 2000) - 2000) <= 1
            checked += 1
    assert checked >= 10
    g.GCommand("AMS")
    elapsed = (rack.sim.now_ns() - start) / 1e9
    assert abs(elapsed - path_time(length, 1000, 50_000, 50_000)) <= LATENCY_S
    assert g.GCommand("RP XY") == "0000000000,0000000000"


def test_st_s_decelerates_along_the_path(g: gclib.py, rack: vdevclient.Rack) -> None:
    g.GCommand("LM XY;LI 80000,60000;LE;VS 50000;VA 500000;VD 250000;BGS")
    rack.sim.step(seconds=0.2)
    g.GCommand("ST S")
    assert numbers(g.GCommand("SC XY")) == [4, 4]
    start = numbers(g.GCommand("MG _AV"))[0]
    elapsed = timed(g, rack, "AMS")
    assert elapsed <= 50_000 / 250_000 + LATENCY_S
    travelled = numbers(g.GCommand("MG _AV"))[0] - start
    assert travelled <= 50_000**2 / (2 * 250_000) + 1
    x, y = numbers(g.GCommand("RP XY"))
    assert abs(x * 0.6 - y * 0.8) <= 1  # still on the line
    assert numbers(g.GCommand("SC XY")) == [4, 4]


def test_ab_stops_the_vector_at_once(g: gclib.py, rack: vdevclient.Rack) -> None:
    g.GCommand("LM XY;LI 80000,60000;LE;VS 50000;VA 500000;VD 250000;BGS")
    rack.sim.step(seconds=0.2)
    g.GCommand("AB")
    here = numbers(g.GCommand("RP XY"))
    rack.sim.step(seconds=0.1)
    assert numbers(g.GCommand("RP XY")) == here
    assert numbers(g.GCommand("SC XY")) == [7, 7]
    assert numbers(g.GCommand("MG _BGS,_LM")) == [0, 511]


def test_a_limit_switch_during_the_move(g: gclib.py, rack: vdevclient.Rack) -> None:
    g.GCommand("LM XY;LI 100000,50000;LE;VS 50000;VA 500000;VD 250000;BGS")
    rack.sim.step(seconds=0.2)
    rack.control("galil0", "set_limit", axis="X", side="positive")
    elapsed = timed(g, rack, "AMS")
    assert elapsed <= 50_000 / 250_000 + LATENCY_S
    assert numbers(g.GCommand("SC XY")) == [2, 2]
    g.GCommand("LI 100,0;LE")
    assert tc(g, "BGS") == 22


def test_the_buffer_holds_511_segments(g: gclib.py) -> None:
    g.GCommand("LM XY")
    for _ in range(511):
        g.GCommand("LI 10,-10")
    assert numbers(g.GCommand("MG _LM")) == [0]
    assert tc(g, "LI 10,-10") == 32
    g.GCommand("LE")
    g.GCommand("VS 100000;BGS;AMS")
    assert g.GCommand("RP XY") == "0000005110,-0000005110"


@pytest.mark.parametrize(("line", "code"), [
    ("LI 100,100", 4),  # no LM
    ("LM XY;LI 100,100,100", 4),  # Z is not in LM
    ("VM XY;CR 0,0,90", 30),  # radius 0
    ("LM XY;VP 10,10", 33),
    ("VM XY;LI 10,10", 33),
    ("BGS", 24),
])
def test_bad_input(g: gclib.py, line: str, code: int) -> None:
    assert tc(g, line) == code
    assert g.GCommand("RP") == "0000000000,0000000000,0000000000,0000000000"
    assert g.GCommand("MG _BGS") == "0000000000.0000"
