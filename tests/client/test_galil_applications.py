"""Whole DMC applications through gclib against a lockstep daemon: programs that use vector and
linear motion, record mode, arrays, trippoints and gearing together, as a user's application
does (issue 20: "a DMC program with vector moves" runs end to end) [M Ch6]."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest
from vdevclient import gclib

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread


@pytest.fixture
def g() -> Iterator[gclib.py]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        conn = gclib.py()
        conn.GOpen(f"galil0 --endpoint {d.endpoint}")
        yield conn
        conn.GClose()


def _distance_to_path(x: float, y: float) -> float:
    """From (x, y) to the path VP 4000,0; CR 2000,270,180; VP 0,4000 from (0, 0)."""
    first = abs(y) if 0 <= x <= 4000 else math.hypot(x - min(max(x, 0), 4000), y)
    arc = abs(math.hypot(x - 4000, y - 2000) - 2000) if x >= 4000 else math.inf
    last = abs(y - 4000) if 0 <= x <= 4000 else math.inf
    return min(first, arc, last)


def test_a_program_runs_a_vector_path_and_records_it(g: gclib.py) -> None:
    """Vector mode with an arc [M Ch6 §Vector Mode: Linear and Circular Interpolation Motion],
    recorded by record mode [M Ch6 §Teach]: every recorded commanded point is on the path, the
    move ends at the last VP, and the program's message says it waited for it (AM S)."""
    g.GProgramDownload("\r".join([
        "#VEC", "DM PX[100],PY[100]", "RA PX[],PY[]", "RD _RPX,_RPY",
        "VM XY", "VS 20000", "VP 4000,0", "CR 2000,270,180", "VP 0,4000", "VE",
        "RC 3", "BG S", "AM S", "MG \"DONE\", _CS", "EN"]), "")
    g.GCommand("XQ #VEC")
    g.GSleep(3000)
    word, segments = g.GMessage().split()
    assert (word, float(segments)) == ("DONE", 3.0)  # the three segments passed
    assert g.GCommand("RP") == "0000000000,0000004000,0000000000,0000000000"
    assert float(g.GCommand("MG _BGS")) == 0.0
    xs = g.GArrayUpload("PX", 0, 99, 1)
    ys = g.GArrayUpload("PY", 0, 99, 1)
    assert max(_distance_to_path(x, y) for x, y in zip(xs, ys, strict=True)) <= 1.0
    assert max(xs) >= 5900  # the arc's far side (x = 6000) was passed and recorded
    assert float(g.GCommand("MG _SCX")) == 101.0  # stopped after finishing the vector sequence


def test_a_program_feeds_linear_segments_from_arrays_and_waits_on_av(g: gclib.py) -> None:
    """Linear interpolation fed from arrays in a loop [M Ch6 §Linear Interpolation Mode, the
    #LMOVE example's AV]: the program's AV passes after the given path distance, and the axes
    end at the sum of the segments; Y geared to X (GA/GR) follows at half the ratio."""
    g.GProgramDownload("\r".join([
        "#LIN", "DM DX[4],DZ[4]", "DX[0]=1000;DX[1]=2000;DX[2]=0;DX[3]=-500",
        "DZ[0]=0;DZ[1]=1000;DZ[2]=3000;DZ[3]=0",
        "GA ,X;GR ,0.5", "LM XZ", "i=0", "#SEG", "LI DX[i],,DZ[i]", "i=i+1", "JP #SEG,i<4", "LE",
        "VS 10000", "BG S", "AV 1000", "MG \"PASSED\", _AV", "AM S", "MG \"END\"", "EN"]), "")
    g.GCommand("XQ #LIN")
    g.GSleep(2000)
    passed, end = g.GMessage().strip().split("\r\n")
    assert passed.split()[0] == "PASSED" and float(passed.split()[1]) >= 1000
    assert end == "END"
    assert g.GCommand("RPX") == "0000002500"
    assert g.GCommand("RPZ") == "0000004000"
    assert abs(float(g.GCommand("TPY")) - 1250) <= 1  # half of X's 2500 through the gearing
