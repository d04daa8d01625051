"""The backdoor's `push(axis, counts)` on every card type of the default rack (issue 23 §3; each
card's README "Backdoor"): the mechanics moved by hand, seen through the vendor's own position
read in lockstep. A servo-off axis stays where pushed and its encoder reads it; a servo-on axis
shows the push as a following error its loop takes back (an ideal drive at once); a stepper's
step count stays while its encoder moves; a bad value is `bad_param` naming `counts` and changes
nothing."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator

import numpy as np
import pytest
import vdevclient
from vdevclient import aps, maxk, mx4
from vdevclient.errors import RemoteError

from tests.client.galil import card, rack_config
from tests.client.test_snapshot_cards import (
    AXIS,
    COMMAND,
    POSITION,
    aps_session,
    default_rack,
    galil_session,
    pmac_ask,
    pmac_session,
)
from tests.devices.galil.conftest import card_config
from vdevd.testing import DaemonThread

SERVO_OFF = 7  # the generic card's COMMAND code (vdevd/devices/generic/README.md)


@pytest.fixture(scope="module")
def daemon() -> Iterator[DaemonThread]:
    with default_rack() as d:
        yield d


@pytest.fixture
def rack(daemon: DaemonThread) -> Iterator[vdevclient.Rack]:
    """A client of the default rack at power-on (reset for each test)."""
    daemon.reset()
    with vdevclient.connect(daemon.endpoint, shm=False) as r:
        yield r


def test_galil_servo_off_axis_stays_where_pushed_and_tp_reads_it(
        daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    with galil_session(daemon) as g:
        g.GCommand("MO X")  # motor off [M Ch2]
        rack.sim.step(seconds=0.01)
        rack.control("galil0", "push", axis="X", counts=1234)
        rack.control("galil0", "push", axis="x", counts=-34)
        rack.sim.step(seconds=0.01)
        assert float(g.GCommand("TP X")) == 1200
        assert float(g.GCommand("TE X")) == 0  # the command follows an open loop
        rack.sim.step(seconds=0.5)
        assert float(g.GCommand("TP X")) == 1200 and float(g.GCommand("TP Y")) == 0


def test_galil_servo_on_axis_shows_a_following_error_that_decays(
        daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    with galil_session(daemon) as g:
        rack.control("galil0", "push", axis="Y", counts=500)
        assert float(g.GCommand("TE Y")) == -500 and float(g.GCommand("RP Y")) == 0
        rack.sim.step(seconds=0.005)
        assert -500 < float(g.GCommand("TE Y")) < -10
        rack.sim.step(seconds=0.5)
        assert abs(float(g.GCommand("TE Y"))) <= 1 and float(g.GCommand("RP Y")) == 0


def test_galil_stepper_keeps_its_step_count_while_tp_reads_the_stage() -> None:
    """A stepper card (README "Stepper cards"): TD, the step count, and RP stay; TP, the main
    encoder, reads where the stage was pushed, so TE shows the steps lost."""
    with (DaemonThread(card_config(plant="stepper")) as d,
          vdevclient.connect(d.endpoint, shm=False) as rack, galil_session(d) as g):
        g.GCommand("SH Z")
        g.GCommand("PR ,,1000;SP ,,20000;BG Z")
        rack.sim.step(seconds=0.5)
        assert [float(g.GCommand(f"{q} Z")) for q in ("TP", "TD", "RP")] == [1000] * 3
        rack.control("galil0", "push", axis="Z", counts=-40)
        rack.sim.step(seconds=0.5)
        assert [float(g.GCommand(f"{q} Z")) for q in ("TP", "TD", "RP", "TE")] == [
            960, 1000, 1000, 40]


def test_galil_push_onto_a_limit_switch_trips_it() -> None:
    """The stage's switches are where the stage is: a push past the forward limit (the axis
    world's `limits`) makes it active at once, a push back releases it (TS bit 3: forward limit
    inactive when 1 [M Ch3 TS])."""
    with (DaemonThread(card_config(axis=[{"limits": [-1000, 1000]}])) as d,
          vdevclient.connect(d.endpoint, shm=False) as rack, galil_session(d) as g):
        g.GCommand("MO X")
        assert int(float(g.GCommand("TS X"))) & 0x08
        rack.control("galil0", "push", axis="X", counts=1500)
        rack.sim.step(seconds=0.01)
        assert not int(float(g.GCommand("TS X"))) & 0x08 and float(g.GCommand("TP X")) == 1500
        rack.control("galil0", "push", axis="X", counts=-1500)
        rack.sim.step(seconds=0.01)
        assert int(float(g.GCommand("TS X"))) & 0x08 and float(g.GCommand("TP X")) == 0


def test_pmac_killed_motor_stays_where_pushed(daemon: DaemonThread,
                                              rack: vdevclient.Rack) -> None:
    with pmac_session(daemon):
        pmac_ask("#1K")  # kill: the loop opens
        rack.sim.step(seconds=0.01)
        rack.control("pmac0", "push", axis=1, counts=-777)
        rack.sim.step(seconds=0.01)
        assert int(pmac_ask("#1P")) == -777
        rack.sim.step(seconds=0.5)
        assert int(pmac_ask("#1P")) == -777 and int(pmac_ask("#1F")) == 0


def test_pmac_closed_loop_motor_takes_the_push_back(daemon: DaemonThread,
                                                    rack: vdevclient.Rack) -> None:
    with pmac_session(daemon):
        pmac_ask("#2J/")  # closed loop, holding
        rack.sim.step(seconds=0.01)
        rack.control("pmac0", "push", axis=2, counts=500)
        rack.sim.step(seconds=0.001)
        assert int(pmac_ask("#2F")) < -100
        rack.sim.step(seconds=0.5)
        assert abs(int(pmac_ask("#2F"))) <= 1 and abs(int(pmac_ask("#2P"))) <= 1


def reads(m: maxk.MaxK, query: str) -> list[int]:
    return [int(v) for v in m.send_and_get_string(f"AA {query}").split(",")]


def test_maxk_servo_loop_open_stepper_and_closed(daemon: DaemonThread,
                                                 rack: vdevclient.Rack) -> None:
    """X (servo) with CL0 stays; Y (servo, loop closed) comes back; U (a stepper, PSO): its RP
    (the steps) stays and RE (the encoder the card counts) moves."""
    with maxk.open(1, endpoint=daemon.endpoint, name="maxk0") as m:
        m.send_string("AX CL0")
        rack.sim.step(seconds=0.01)
        for axis in ("X", "Y", "U"):
            rack.control("maxk0", "push", axis=axis, counts=300)
        rack.sim.step(seconds=0.002)
        rp, re = reads(m, "RP"), reads(m, "RE")
        assert (rp[0], re[0]) == (300, 300)
        assert 0 < re[1] < 300 and rp[1] == 0
        assert (rp[4], re[4]) == (0, 300)
        rack.sim.step(seconds=0.5)
        rp, re = reads(m, "RP"), reads(m, "RE")
        assert (rp[0], re[0], rp[1], re[1], rp[4], re[4]) == (300, 300, 0, 0, 0, 300)


def test_octavia_open_loop_axis_stays_and_a_closed_one_comes_back(
        daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    with mx4.open(0, endpoint=daemon.endpoint, name="octavia0") as h:
        mx4.DDAC(h, 0x01, [0])  # axis 1: the loop open, 0 V out
        mx4.CTRL(h, 0x02, ki=100, kp=4000, kf=3000, kd=2500)  # axis 2: the manual's gains
        mx4.KILIMIT(h, 0x02, 0)
        rack.sim.step(seconds=0.01)
        rack.control("octavia0", "push", axis=1, counts=100)
        rack.control("octavia0", "push", axis=2, counts=500)
        rack.sim.step(seconds=0.01)
        pos, err = mx4.read_axes(h, mx4.Window.ACTPOS), mx4.read_axes(h, mx4.Window.ERROR)
        assert pos[0] == 100 and err[0] == 0
        assert 0 < pos[1] < 500 and err[1] == -pos[1]
        rack.sim.step(seconds=2.0)
        pos, err = mx4.read_axes(h, mx4.Window.ACTPOS), mx4.read_axes(h, mx4.Window.ERROR)
        assert pos[0] == 100 and abs(pos[1]) <= 2 and abs(err[1]) <= 2


def aps_position(axis: int) -> float:
    pos = ctypes.c_double()
    assert aps.APS_get_position_f(axis, ctypes.byref(pos)) == aps.ERR_NoError
    return pos.value


def test_adlink_servo_off_axis_stays_and_an_ideal_drive_follows_its_command(
        daemon: DaemonThread, rack: vdevclient.Rack) -> None:
    with aps_session(daemon):
        assert aps.APS_set_servo_on(1, 1) == 0  # axis 0 stays off (power-on)
        rack.sim.step(seconds=0.01)
        rack.control("adlink0", "push", axis=0, counts=2500)
        rack.control("adlink0", "push", axis=1, counts=2500)
        rack.sim.step(seconds=0.002)
        assert aps_position(0) == 2500
        assert aps_position(1) == 0  # the ideal drive (feedback = command) at its next cycle
        rack.sim.step(seconds=0.5)
        assert aps_position(0) == 2500


def aps_error(axis: int) -> float:
    err = ctypes.c_double()
    assert aps.APS_get_error_position_f(axis, ctypes.byref(err)) == aps.ERR_NoError
    return err.value


def test_adlink_servo_drive_and_a_maxk_stepper_with_encoder_see_the_push() -> None:
    """A `servo` drive on the AMP takes the push back with its position error; a MAXk stepper
    with encoder (PSE) keeps its steps (RP) while RE moves, and past ES that is a slip
    (EA char 3 'S') [S §4.7]."""
    cfg = rack_config(card("adlink-amp20xc", "adlink0", drive="servo"),
                      card("oms-maxk", "maxk0", axes=2,
                           axis_types=["servo", "stepper_encoder"]))
    with DaemonThread(cfg) as d, vdevclient.connect(d.endpoint, shm=False) as rack:
        with aps_session(d):
            assert aps.APS_set_servo_on(1, 1) == 0
            rack.sim.step(seconds=0.01)
            rack.control("adlink0", "push", axis=1, counts=500)
            rack.sim.step(seconds=0.002)
            assert 0 < aps_position(1) < 500 and aps_error(1) == -aps_position(1)
            rack.sim.step(seconds=0.5)
            assert aps_position(1) == 0 and aps_error(1) == 0
        with maxk.open(1, endpoint=d.endpoint, name="maxk0") as m:
            m.send_string("AY ES10")
            rack.control("maxk0", "push", axis="Y", counts=50)
            rack.sim.step(seconds=0.01)
            assert (reads(m, "RP")[1], reads(m, "RE")[1]) == (0, 50)
            assert m.send_and_get_string("AY EA")[2] == "S"


def signed(value: int) -> int:
    return value - (1 << 32) if value & 0x8000_0000 else value


def test_generic_servo_off_axis_stays_and_a_servo_on_axis_comes_back(
        rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    bar.write32(COMMAND + AXIS, SERVO_OFF)  # axis 1 off; axis 0 on (power-on)
    rack.sim.step(seconds=0.01)
    rack.control("servo0", "push", axis=0, counts=300)
    rack.control("servo0", "push", axis=1, counts=-300)
    rack.sim.step(seconds=0.002)
    assert 0 < signed(bar.read32(POSITION)) < 300 and signed(bar.read32(POSITION + AXIS)) == -300
    rack.sim.step(seconds=0.5)
    assert abs(signed(bar.read32(POSITION))) <= 1 and signed(bar.read32(POSITION + AXIS)) == -300


CARDS = {"servo0": 0, "galil0": "X", "maxk0": "X", "pmac0": 1, "octavia0": 1, "adlink0": 0}


@pytest.mark.parametrize("card", list(CARDS))
@pytest.mark.parametrize(("counts", "message"), [
    ("100", "counts: expected a number, got '100'"),
    (True, "counts: expected a number, got True"),
    (None, "counts: expected a number, got None"),
    (float("nan"), "counts nan outside -2147483648..2147483648"),
    (float("-inf"), "counts -inf outside -2147483648..2147483648"),
    (2**31 + 1, "counts 2147483649 outside -2147483648..2147483648"),
])
def test_a_bad_count_is_bad_param_naming_it_and_changes_nothing(
        rack: vdevclient.Rack, card: str, counts: object, message: str) -> None:
    with pytest.raises(RemoteError, match="bad_param") as err:
        rack.control(card, "push", axis=CARDS[card], counts=counts)
    assert str(err.value).endswith(f"push: {message}")
    rack.request("scope", card=card, action="arm", axes=[CARDS[card]], signals=["position"],
                 samples=4)
    rack.sim.step(seconds=0.01)
    read = rack.request("scope", card=card, action="read")
    (column,) = read["columns"].values()
    assert read["count"] == 4 and not np.frombuffer(column, "<f8").any()  # the axis stayed at 0


def test_a_push_of_an_axis_the_card_has_not_is_bad_param(rack: vdevclient.Rack) -> None:
    with pytest.raises(RemoteError, match="no axis 'Q'"):
        rack.control("galil0", "push", axis="Q", counts=1)
    with pytest.raises(RemoteError, match="counts"):
        rack.control("galil0", "push", axis="X")
