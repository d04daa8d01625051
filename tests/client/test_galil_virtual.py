"""The virtual axis N of a DMC-13X8 through gclib's `GCommand` against a lockstep daemon (servo
plant) [M Ch6 §Virtual Axis]: N's own move, a follower geared to it, the manual's ECAM Master
Example, and the commands N does not take."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import gclib

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0"))) as d:
        yield d


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[gclib.py]:
    conn = gclib.py()
    conn.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


def test_prn_bgn_and_amn_wait_for_n_s_own_move(g: gclib.py, rack: vdevclient.Rack) -> None:
    """PRN=1000 BGN: a trapezoid at SPN/ACN/DCN; AMN holds the reply until it is complete."""
    start = rack.sim.now_ns()
    g.GCommand("PRN=1000;SPN=10000;BGN;AMN")
    took = (rack.sim.now_ns() - start) / 1e9
    assert took == pytest.approx(1000 / 10000 + 10000 / 256000, abs=0.005)
    assert g.GCommand("MG _RPN,_BGN") == "0000001000.0000 0000000000.0000"
    assert g.GCommand("RP N") == "0000001000" and g.GCommand("TP XN") == "0000000000,0000001000"
    g.GCommand("PAN=-500;BGN")
    g.GMotionComplete("N")  # polls _BGN as gclib does
    assert g.GCommand("RP N") == "-0000000500"


def test_a_follower_geared_to_n_at_gr_2(g: gclib.py) -> None:
    """GA N: X follows N's commanded position at GR 2 [M Ch6 §Virtual Axis: GA]."""
    g.GCommand("GA N;GR 2;PRN=1000;SPN=20000;BGN")
    g.GMotionComplete("N")
    g.GSleep(5)
    assert g.GCommand("RP XN") == "0000002000,0000001000"


def test_the_manual_s_ecam_master_example(g: gclib.py) -> None:
    """EAN, EMN=4000, the table, then "PAN = 2000 BGN will cause the XY axes to move to the
    corresponding points on the motion cycle"."""
    table = [(0, 0), (40, 20), (120, 60), (240, 120), (280, 140), (280, 140), (280, 140),
             (240, 120), (120, 60), (40, 20), (0, 0)]
    g.GCommand("EAN;EMN=4000;EM 0,0;EP 400,0")
    for n, (x, y) in enumerate(table):
        g.GCommand(f"ET[{n}]={x},{y}")
    g.GCommand("EB1;EG 0,0")
    g.GCommand("PAN=1000;BGN;AMN")
    g.GSleep(5)
    assert g.GCommand("RP X;RP Y") == "0000000180\r\n:0000000090"  # between ET[2] and ET[3]
    g.GCommand("PAN=2000;BGN;AMN")
    g.GSleep(5)
    assert g.GCommand("RP X;RP Y") == "0000000280\r\n:0000000140"  # ET[5]


@pytest.mark.parametrize("line", ["HMN", "MON", "KPN=1"])
def test_commands_n_does_not_take_raise_and_the_card_serves_on(g: gclib.py, line: str) -> None:
    with pytest.raises(gclib.GclibError):
        g.GCommand(line)
    assert g.GCommand("TC1") == "4 Operand error"
    g.GCommand("PRN=10;BGN;AMN")
    assert g.GCommand("MG _RPN") == "0000000010.0000"
