"""Every card type records a move on its scope (issue 23 §1), through a real daemon with the
lockstep clock, each move commanded and checked with the card's own client: what the recorder
holds at the end is what the card's position and status commands report then. (The generic
servo card: tests/test_scope.py, against its registers.)"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from ctypes import byref, c_double, c_int32

import numpy as np
import pytest
import vdevclient
from vdevclient import aps, gclib, maxk, mx4, pcomm
from vdevmaps.galil import AxisStatus

from tests.client.galil import card, rack_config
from vdevd.testing import DaemonThread

PMAC_DEVICE = 3


@pytest.fixture(scope="module")
def daemon() -> Iterator[DaemonThread]:
    cfg = rack_config(card("galil-dmc13x8", "galil0"), card("oms-maxk", "maxk0", board=1),
                      card("dspcg-octavia", "octavia0", plant="ideal"),
                      card("pmac-turbo", "pmac0", device=PMAC_DEVICE, plant="ideal", ethernet=""),
                      card("adlink-amp20xc", "amp0"))
    with DaemonThread(cfg) as d:
        yield d


@pytest.fixture
def rack(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    with vdevclient.connect(daemon.endpoint, daemon.events, timeout=30) as r:
        yield r


def test_galil_profiled_move(daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    """Chapter 2 example 2: PR 10000 at SP 20000, AC = DC 100000: 0.7 s; TP and RP after it."""
    g = gclib.py()
    g.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    try:
        trace = rack.card("galil0").scope(["X"], ["position", "command", "velocity", "error"],
                                          seconds=0.01)  # at rest: 10 samples of 0
        assert (trace["X.position"] == 0).all() and len(trace) == 10
        g.GCommand("SB 2")  # output 2 on: bit 1 of the output bank
        g.GCommand("SH X;PR 10000;SP 20000;DC 100000;AC 100000;BG X")
        trace = rack.card("galil0").scope(["x"], ["position", "command", "velocity", "error",
                                                  "status", "outputs"], seconds=0.9)
        assert len(trace) == 900 and (np.diff(trace.time_ns) == 1_000_000).all()
        assert trace["X.position"][-1] == int(g.GCommand("TP X")) == 10_000
        assert trace["X.command"][-1] == int(g.GCommand("RP X")) == 10_000
        assert trace["X.velocity"].max() == pytest.approx(20_000, rel=0.05)
        assert np.abs(trace["X.error"]).max() > 0  # the servo lags while it accelerates
        assert int(g.GCommand("TE X")) == trace["X.error"][-1]
        assert trace["X.outputs"][-1] == int(float(g.GCommand("MG _OP"))) == 2
        moving, done = trace["X.status"][100], trace["X.status"][-1]
        assert moving & AxisStatus.MOVING and not done & AxisStatus.MOVING  # the data record's
    finally:
        g.GClose()


def test_maxk_relative_move(daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    with maxk.open(1, endpoint=daemon.endpoint, name="maxk0") as m:
        scope = rack.card("maxk0").scope_recorder()
        scope.arm(["X", "Y"], ["position", "command", "velocity"], seconds=0.5)
        m.send_string("AX MR1000 GO")
        rack.sim.step(seconds=0.5)
        trace = scope.read()
        assert trace.state == "done" and len(trace) == 512  # 0.5 s of 976,562.5 ns ticks
        assert trace["X.command"][-1] == int(m.send_and_get_string("AX RP")) == 1000
        assert trace["X.position"][-1] == int(m.send_and_get_string("AX RE")) == 1000
        assert trace["X.velocity"].max() > 0 and (trace["Y.position"] == 0).all()


def test_octavia_axmove(daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    with mx4.open(1, endpoint=daemon.endpoint, name="octavia0") as h:
        scope = rack.card("octavia0").scope_recorder()
        scope.arm(["1", "2"], ["position", "command"], seconds=0.5)
        mx4.EN_MOTCP(h, 0x03)
        mx4.AXMOVE(h, 0x03, 0x2000, [5000, -3000], mx4.vel_to_raw(8))
        rack.sim.step(seconds=0.5)
        trace = scope.read()
        assert len(trace) == 2500 and (np.diff(trace.time_ns) == 200_000).all()
        actual = mx4.read_axes(h)
        assert trace["1.position"][-1] == actual[0] == 5000
        assert trace["2.position"][-1] == actual[1] == -3000
        assert (np.diff(trace["1.command"]) >= 0).all()


def pmac_ask(command: str) -> str:
    out = ctypes.create_string_buffer(256)
    pcomm.PmacGetResponseA(PMAC_DEVICE, out, 256, command)
    return out.value.decode("latin-1").strip("\r\x06")


def test_pmac_jog_to_a_position(daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    """#1J=1000: the position `#1P` reports, the two status words `#1?` reports."""
    assert pcomm.OpenPmacDevice(PMAC_DEVICE, endpoint=daemon.endpoint)
    try:
        scope = rack.card("pmac0").scope_recorder()
        scope.arm(["1"], ["position", "command", "status"], seconds=0.5)
        pmac_ask("#1J/")
        pmac_ask("#1J=1000")
        rack.sim.step(seconds=0.5)
        trace = scope.read()
        assert len(trace) == 1129  # 0.5 s of I10 cycles (442,708.37 ns)
        assert trace["1.position"][-1] == float(pmac_ask("#1P")) == 1000
        assert trace["1.status"][-1] == int(pmac_ask("#1?"), 16)
        moving = trace["1.status"][len(trace) // 10]
        assert moving != trace["1.status"][-1]  # in position only at the end
    finally:
        pcomm.ClosePmacDevice(PMAC_DEVICE)


def test_adlink_ptp(daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    """APS_ptp_all to 2000: APS_get_position_f, APS_get_command_f, APS_motion_status."""
    bits = c_int32()
    assert aps.APS_initial(byref(bits), 0, endpoint=daemon.endpoint) == aps.ERR_NoError
    try:
        assert aps.APS_set_servo_on(0, 1) == 0
        scope = rack.card("amp0").scope_recorder()
        scope.arm(["0"], ["position", "command", "command_velocity", "status"], seconds=0.5)
        assert aps.APS_ptp_all(0, 0, 2000.0, 0.0, 10000.0, 0.0, 100000.0, 100000.0, 0.0,
                               None) == 0
        rack.sim.step(seconds=0.5)
        trace = scope.read()
        pos, cmd = c_double(), c_double()
        aps.APS_get_position_f(0, byref(pos))
        aps.APS_get_command_f(0, byref(cmd))
        assert trace["0.position"][-1] == pos.value == 2000
        assert trace["0.command"][-1] == cmd.value == 2000
        assert trace["0.command_velocity"].max() == pytest.approx(10_000)
        assert trace["0.status"][-1] == aps.APS_motion_status(0)
    finally:
        aps.APS_close()
