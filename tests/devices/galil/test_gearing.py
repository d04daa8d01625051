"""Electronic gearing and gantry mode [M Ch6 §Electronic Gearing] on the firmware alone."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.devices.galil.follow_rig import Rig
from vdevd.devices.galil.errors import TC


def test_followers_move_ratio_times_the_master_s_distance_manual_example() -> None:
    """[M Ch6 Example - Simple Master Slave]: GA Y,,Y,Y; GR 5,,-.5,10; Y moves 10000."""
    rig = Rig()
    rig.cmd("GA Y,,Y,Y;GR 5,,-.5,10;PR ,10000;SP ,100000;BGY")
    rig.run_until_stopped()
    assert rig.ints("RP") == [50000, 10000, -5000, 100000]


def test_followers_move_with_the_master_during_the_move_not_after_it() -> None:
    rig = Rig()
    rig.cmd("GA Y;GR -2;PR ,4000;SP ,100000;BGY")
    rig.run(30)
    x, y = rig.ints("RP X;RP Y")
    assert 0 < y < 4000
    assert abs(x + 2 * y) <= 2 * 25  # one sample behind at most (25 counts a sample here)


def test_gr_0_disengages_and_the_follower_stays_where_it_is() -> None:
    rig = Rig()
    rig.cmd("GA Y;GR 2;PR ,1000;BGY")
    rig.run_until_stopped()
    rig.cmd("GR 0;PR ,1000;BGY")
    rig.run_until_stopped()
    assert rig.ints("RP X;RP Y") == [2000, 2000]


def test_gr_changes_on_the_fly_without_a_jump() -> None:
    rig = Rig()
    rig.cmd("GA Y;GR 1;PR ,1000;BGY")
    rig.run_until_stopped()
    rig.cmd("GR 2")
    assert rig.ints("RP X") == [1000]
    rig.cmd("PR ,1000;BGY")
    rig.run_until_stopped()
    assert rig.ints("RP X") == [3000]


def test_a_follower_s_own_move_is_superimposed_on_the_gearing() -> None:
    """[M Ch6 Example - Synchronize two conveyor belts]: GA,X; GR,2; PR,300 ... BGY."""
    rig = Rig()
    rig.cmd("GA ,X;GR ,2;PR 1000,300;SP 5000,5000;BG XY")
    rig.run_until_stopped()
    assert rig.ints("RP X;RP Y") == [1000, 2300]


def test_ga_cx_follows_the_commanded_position_and_dx_the_auxiliary_encoder() -> None:
    rig = Rig("servo")
    rig.cmd("GA ,CX;GR ,1;PR 2000;BGX")
    rig.run_until_stopped()
    assert rig.ints("RP Y") == [2000]  # the commanded position, whatever the encoder read
    rig = Rig("servo")
    rig.cmd("GA ,,DX;GR ,,3;DE 500")
    rig.run(2)
    assert rig.ints("RP Z") == [1500]


def test_st_disengages_in_standard_mode_but_not_in_gantry_mode() -> None:
    """"A limit switch or ST command disable gearing in the standard mode but not in the gantry
    mode" [M Ch6]: ST (all axes) while X jogs."""
    ends = []
    for gm in (0, 1):
        rig = Rig()
        rig.cmd(f"GA ,CX;GR ,1;GM ,{gm};JG 5000;BGX")
        rig.run(200)
        rig.cmd("ST")
        y_at_st = rig.ints("RP Y")[0]
        rig.run_until_stopped()
        x, y = rig.ints("RP X;RP Y")
        ends.append((x, y, y_at_st))
    (x0, y0, st0), (x1, y1, st1) = ends
    assert y0 == st0 < x0  # standard: Y stopped following at ST, X decelerated on
    assert y1 == x1 > st1  # gantry: Y followed X to its stop
    rig = Rig()
    rig.cmd("GM ,1")
    assert rig.value("_GMY") == 1


def test_a_limit_switch_ahead_disengages_a_standard_follower_only() -> None:
    for gm, follows in ((0, False), (1, True)):
        rig = Rig()
        rig.cmd(f"GA ,CX;GR ,1;GM ,{gm};JG 5000;BGX")
        rig.run(100)
        forward = np.array([False, True, False, False])
        rig.fw.set_limits(forward, np.zeros(4, dtype=bool))
        y0 = rig.ints("RP Y")[0]
        rig.run(50)
        assert (rig.ints("RP Y")[0] > y0 + 100) is follows


def test_an_engaged_follower_keeps_the_card_from_resting() -> None:
    rig = Rig()
    rig.run(5)
    assert rig.fw.rest_state() is not None
    rig.cmd("GA Y;GR 1")
    rig.run(1)
    assert rig.fw.rest_state() is None
    rig.cmd("GR 0")
    rig.run(2)
    assert rig.fw.rest_state() is not None


def test_bad_gearing_commands_answer_with_their_tc() -> None:
    rig = Rig()
    assert rig.refused("GR 128") == TC.NUMBER_OUT_OF_RANGE
    assert rig.refused("GA X") == TC.GEAR_MASTER_AND_FOLLOWER  # X its own master
    assert rig.refused("GA ,DS") == TC.OPERAND_ERROR  # a plane has no auxiliary encoder
    assert rig.refused("GA ,Q") == TC.OPERAND_ERROR
    assert rig.refused("GM 2") == TC.NUMBER_OUT_OF_RANGE
    assert rig.cmd("GR 127.99994;GR ?") == "127.9999"


@settings(derandomize=True, max_examples=25, deadline=None)
@given(ratios=st.lists(st.integers(-1_279_999, 1_279_999), min_size=3, max_size=3),
       moves=st.lists(st.integers(-5000, 5000), min_size=1, max_size=3))
def test_followers_end_at_ratio_times_the_master_s_travel(ratios: list[int], moves: list[int]
                                                          ) -> None:
    """Any ratios (resolution 0.0001) and any master moves, forth and back: each follower ends at
    GR x the master's net travel, rounded to a count."""
    rig = Rig()
    gr = [r / 10_000 for r in ratios]
    rig.cmd("GA ,X,X,X;GR ," + ",".join(f"{g:.4f}" for g in gr))
    for d in moves:
        rig.cmd(f"PR {d};SP 200000;BGX")
        rig.run_until_stopped()
    travel = sum(moves)
    assert rig.ints("RP") == [travel] + [round(g * travel) for g in gr]


def test_ip_on_a_geared_follower_is_a_relative_move_on_top() -> None:
    """"this IP command is equivalent to PR,10 BGY" [M Ch6 Example - Gantry Mode]."""
    rig = Rig()
    rig.cmd("GA ,CX;GR ,1;GM ,1;PR 3000;BGX")
    rig.run(20)
    rig.cmd("IP ,10")
    rig.run_until_stopped()
    assert rig.ints("RP X;RP Y") == [3000, 3010]
