"""Gearing, ECAM and contour mode of a DMC-13X8 through gclib's `GCommand` against a lockstep
daemon (servo plant): the manual's examples end to end [M Ch6]."""

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


def test_followers_geared_to_y_s_commanded_position(g: gclib.py) -> None:
    """[M Ch6 Example - Simple Master Slave], with the commanded position of Y as master."""
    g.GCommand("GA CY,,CY,CY;GR 5,,-.5,10;PR ,10000;SP ,100000;BGY")
    g.GMotionComplete("Y")
    g.GSleep(5)
    assert g.GCommand("RP") == "0000050000,0000010000,-0000005000,0000100000"
    g.GCommand("GR 0,,0,0;PR ,-10000;BGY")
    g.GMotionComplete("Y")
    g.GSleep(5)
    assert g.GCommand("RP") == "0000050000,0000000000,-0000005000,0000100000"


def test_gantry_follower_stays_geared_through_st(g: gclib.py) -> None:
    """[M Ch6 Example - Gantry Mode]: GA,CX; GR,1; GM,1; ST does not disengage."""
    g.GCommand("GA ,CX;GR ,1;GM ,1;JG 20000;BGX")
    g.GSleep(100)
    g.GCommand("ST")
    g.GMotionComplete("X")
    g.GSleep(5)
    x, y = g.GCommand("RP X;RP Y").split("\r\n:")
    assert int(x) == int(y) > 1000


def test_an_ecam_cycle_of_the_manual_s_table(g: gclib.py) -> None:
    """[M Ch6 Example - Electronic CAM]: master Z, slaves X and Y, interval 400."""
    table = [(0, 0), (40, 20), (120, 60), (240, 120), (280, 140), (280, 140), (280, 140),
             (240, 120), (120, 60), (40, 20), (0, 0)]
    g.GCommand("EA Z;EM 0,0,4000;EP 400,0")
    for n, (x, y) in enumerate(table):
        g.GCommand(f"ET[{n}]={x},{y}")
    g.GCommand("EB 1;EG 0,0")
    assert g.GCommand("MG _EGX,_EGY") == "0000000001.0000 0000000001.0000"
    g.GCommand("PA ,,1200;SP ,,20000;BGZ")
    g.GMotionComplete("Z")
    g.GSleep(300)  # the master's encoder settles within a count of 1200
    assert g.GCommand("RP X;RP Y") == "0000000240\r\n:0000000120"
    g.GCommand("EQ 2000,2000;PA ,,3000;BGZ")
    g.GMotionComplete("Z")
    g.GSleep(300)
    assert g.GCommand("RP X;RP Y") == "0000000280\r\n:0000000140"  # released at ET[5]
    assert g.GCommand("SC X") == "061"


def test_the_manual_s_contour_with_wc(g: gclib.py, rack: vdevclient.Rack) -> None:
    """[M Ch6 §Specifying Contour Segments]: 48 in 4 ms, 240 in 8 ms, 48 in 16 ms."""
    start = rack.sim.now_ns()
    g.GCommand("CMX;DT 2;CD 48;WC;DT 3;CD 240;WC;DT 4;CD 48;WC;DT 0;CD 0")
    # the last WC returns when the third interval starts: 4 + 8 ms of contour
    assert rack.sim.now_ns() - start >= 12_000_000
    g.GSleep(30)
    assert g.GCommand("RP X") == "0000000336"
    assert g.GCommand("MG _CM") == "0000000000.0000"
    assert g.GCommand("SC X") == "051"


def test_bad_ecam_and_contour_input_answers_question_mark_with_the_tc(g: gclib.py) -> None:
    with pytest.raises(gclib.GclibError):
        g.GCommand("ET[300]=1")
    assert g.GCommand("TC1") == "101 Improper index into ET (must be 0-256)"
    with pytest.raises(gclib.GclibError):
        g.GCommand("CD 10")
    assert g.GCommand("TC1") == "8 Command not valid when not running"
    with pytest.raises(gclib.GclibError):
        g.GCommand("EG 0")
    assert g.GCommand("TC1") == "105 EB1 command must be given first"
    assert g.GCommand("TPX") == "0000000000"  # the card serves on


def test_a_reversed_encoder_with_a_reversed_servo_closes_the_loop(g: gclib.py) -> None:
    """CE 2 (reversed main encoder) with MT -1 (reversed polarity servo) [M Ch6 §Using the CE
    Command]: the move ends at its target; MT -1 alone runs away (ER then OE stop it)."""
    g.GCommand("CE 2;MT -1;PR 1000;BGX")
    g.GMotionComplete("X")
    g.GSleep(300)
    assert g.GCommand("TP X") == "0000001000"
    g.GCommand("CE ,0;MT ,-1;ER ,2000;OE ,1;PR ,1000;BGY")
    g.GSleep(300)
    assert g.GCommand("MG _MOY") == "0000000001.0000"  # off on error: the loop ran away
    assert g.GCommand("SC Y") == "008"


def test_commutation_setup_through_gcommand(g: gclib.py) -> None:
    g.GCommand("BAX;BM 62000;BZ -2")
    assert g.GCommand("MG _BAX,_MOW,_MOX") == "0000000001.0000 0000000001.0000 0000000000.0000"
    with pytest.raises(gclib.GclibError):
        g.GCommand("BMY=1000")
    assert g.GCommand("TC1") == "110 Must be made brushless by BA command"
