"""The design examples of manual chapter 2 ("Design Examples", Examples 1-9), through the DMC
library against a real daemon. Durations come from the examples' parameters as the card stores
them (AC/DC rounded down to 1024 counts/s^2) and the trapezoid of [M Ch6 §Independent Axis
Positioning]."""

from __future__ import annotations

import re

import pytest

from tests.devices.galil.conftest import LATENCY_S, Dmc, move_time, stored_acc

POSITION = re.compile(r"-?\d{10}")  # 10 digits with leading zeros: "0000010000", "-0000000500"
#: |TE| of the servo plant at the end of a profile (counts); the reference (RP) is exact
FOLLOWING = 5
SETTLE_S = 0.3  # after a profile, the time the servo is given to come to rest on the target


def positions(reply: str) -> list[int]:
    fields = reply.split(",")
    assert all(POSITION.fullmatch(f) for f in fields), reply
    return [int(f) for f in fields]


# -- Example 1: system set-up ---------------------------------------------------------------------
def test_example_1_gain_forms_set_the_axes_the_manual_says(dmc: Dmc) -> None:
    """Ex. 1: KP10,10,10,10; KP*=10; KPX=10; KPA=10 all set 10; `KP, 20` sets Y only."""
    for line in ("KP10,10,10,10", "KP*=10", "KPX=10", "KPA=10", "KP, 20"):
        assert dmc.cmd(line) == ""
    assert dmc.cmd("KP ?,?,?,?") == "0010.00,0020.00,0010.00,0010.00"


def test_example_1_error_limit_and_off_on_error_then_gains(dmc: Dmc) -> None:
    """Ex. 1 second part: OE 1,1,1,1; ER*=1000; the gain forms, `KP,,10` (Z only), KPZ=10, KPD=10."""
    dmc.cmd("KP 1,2,3,4")
    for line in ("OE 1,1,1,1", "ER*=1000", "KP10,10,10,10", "KP*=10", "KPX=10", "KPA=10",
                 "KP,,10", "KPZ=10", "KPD=10"):
        assert dmc.cmd(line) == ""
    assert dmc.cmd("KP ?,?,?,?") == "0010.00,0010.00,0010.00,0010.00"
    assert dmc.values("OE ?,?,?,?") == [1, 1, 1, 1]
    assert dmc.values("ER ?,?,?,?") == [1000, 1000, 1000, 1000]


def test_example_1_letters_a_and_d_are_axes_x_and_w(dmc: Dmc) -> None:
    """"KPA=10 Alternate method for setting A (or X) axis gain", "KPD=10 ... D axis gain"."""
    dmc.cmd("KP 1,1,1,1")
    dmc.cmd("KPA=12")
    dmc.cmd("KPD=14")
    dmc.cmd("KPC=13")
    dmc.cmd("KPB=11")
    assert dmc.cmd("KP ?,?,?,?") == "0012.00,0011.00,0013.00,0014.00"


# -- Example 2: profiled move ---------------------------------------------------------------------
def test_example_2_profiled_move_takes_the_trapezoid_time_and_ends_at_10000(dmc: Dmc) -> None:
    """Ex. 2: PR 10000, SP 20000, DC 100000, AC 100000, BG X: the X motor turns 10000 counts."""
    for line in ("PR 10000", "SP 20000", "DC 100000", "AC 100000"):
        dmc.cmd(line)
    acc = stored_acc(100_000)
    assert dmc.values("AC ?") == [acc] and dmc.values("DC ?") == [acc]
    expected = move_time(10_000, 20_000, acc, acc)
    took = dmc.timed("BG X;AM X")
    assert expected <= took <= expected + LATENCY_S
    assert positions(dmc.cmd("RP X")) == [10_000]
    assert abs(positions(dmc.cmd("TP X"))[0] - 10_000) <= FOLLOWING
    dmc.step(SETTLE_S)
    assert abs(dmc.value("TP X") - 10_000) <= 1
    assert dmc.cmd("SC X") == "001"  # stopped at the commanded position (spec §4.4)


# -- Example 3: multiple axes ---------------------------------------------------------------------
def test_example_3_four_axes_move_independently_with_their_own_profiles(dmc: Dmc) -> None:
    """Ex. 3: PR 500,1000,600,-400; SP 10000,12000,20000,10000; AC 100000,10000,100000,100000;
    DC 80000,40000,30000,50000; BG XZ; BG YW."""
    distance = [500, 1000, 600, -400]
    speed = [10_000, 12_000, 20_000, 10_000]
    acc = [100_000, 10_000, 100_000, 100_000]
    dec = [80_000, 40_000, 30_000, 50_000]
    dmc.cmd("PR 500,1000,600,-400")
    dmc.cmd("SP 10000,12000,20000,10000")
    dmc.cmd("AC 100000,10000,100000,100000")
    dmc.cmd("DC 80000,40000,30000,50000")
    assert dmc.values("AC ?,?,?,?") == [stored_acc(a) for a in acc]
    assert dmc.values("DC ?,?,?,?") == [stored_acc(d) for d in dec]
    expected = {axis: move_time(distance[k], speed[k], stored_acc(acc[k]), stored_acc(dec[k]))
                for k, axis in enumerate("XYZW")}
    start = dmc.now_s()
    dmc.cmd("BG XZ;BG YW")
    for axis in sorted(expected, key=expected.__getitem__):
        dmc.cmd(f"AM {axis}")
        took = dmc.now_s() - start
        assert expected[axis] <= took <= expected[axis] + LATENCY_S, axis
    assert positions(dmc.cmd("RP")) == distance
    dmc.step(SETTLE_S)
    assert all(abs(p - d) <= 1 for p, d in zip(positions(dmc.cmd("TP")), distance, strict=True))


# -- Example 4: independent moves -----------------------------------------------------------------
def test_example_4_y_and_z_parameters_given_field_by_field(dmc: Dmc) -> None:
    """Ex. 4: PR ,300,-600; SP ,2000; DC ,80000; AC, 100000; SP ,,40000; AC ,,100000;
    DC ,,150000; BG Z; BG Y. X and W keep their values and do not move."""
    dmc.cmd("SP 5000,5000,5000,5000")
    for line in ("PR ,300,-600", "SP ,2000", "DC ,80000", "AC, 100000", "SP ,,40000", "AC ,,100000",
                 "DC ,,150000"):
        dmc.cmd(line)
    assert dmc.values("SP ?,?,?,?") == [5000, 2000, 40_000, 5000]
    y = move_time(300, 2000, stored_acc(100_000), stored_acc(80_000))
    z = move_time(600, 40_000, stored_acc(100_000), stored_acc(150_000))
    start = dmc.now_s()
    dmc.cmd("BG Z;BG Y")
    for axis, expected in sorted((("Y", y), ("Z", z)), key=lambda item: item[1]):
        dmc.cmd(f"AM {axis}")
        assert expected <= dmc.now_s() - start <= expected + LATENCY_S, axis
    assert positions(dmc.cmd("RP")) == [0, 300, -600, 0]


# -- Example 5: position interrogation ------------------------------------------------------------
def test_example_5_tp_and_te_for_all_axes_and_each_axis(dmc: Dmc) -> None:
    """Ex. 5: TP tells all four axes, TP X ... TP W one each; TE = commanded - actual."""
    target = [1000, -2000, 3000, -4000]
    dmc.cmd("PR 1000,-2000,3000,-4000;BG;AM")
    dmc.step(SETTLE_S)
    every = positions(dmc.cmd("TP"))
    assert every == [positions(dmc.cmd(f"TP {axis}"))[0] for axis in "XYZW"]
    assert all(abs(p - t) <= 1 for p, t in zip(every, target, strict=True))
    errors = positions(dmc.cmd("TE"))
    assert errors == [positions(dmc.cmd(f"TE {axis}"))[0] for axis in "XYZW"]
    assert errors == [r - p for r, p in zip(positions(dmc.cmd("RP")), every, strict=True)]


def test_example_5_tp_xy_reply_format(dmc: Dmc) -> None:
    """Ch. 5 "Interrogation Commands": TP X -> 0000000000; TP XY -> 0000000000,0000000000."""
    assert dmc.cmd("TP X") == "0000000000"
    assert dmc.cmd("TP XY") == "0000000000,0000000000"


# -- Example 6: absolute position -----------------------------------------------------------------
def test_example_6_define_position_then_absolute_moves_and_back_to_zero(dmc: Dmc) -> None:
    """Ex. 6: DP 0,2000; PA 7000,4000; BG X; BG Y; then PA 0,0; BG XY."""
    dmc.cmd("DP 0,2000")
    assert positions(dmc.cmd("RP XY")) == [0, 2000]
    assert positions(dmc.cmd("TP XY")) == [0, 2000]
    dmc.cmd("PA 7000,4000")
    dmc.cmd("BG X")
    dmc.cmd("BG Y")
    dmc.cmd("AM XY")
    assert positions(dmc.cmd("RP XY")) == [7000, 4000]
    dmc.cmd("PA 0,0")
    dmc.cmd("BG XY")
    dmc.cmd("AM XY")
    assert positions(dmc.cmd("RP XY")) == [0, 0]
    dmc.step(SETTLE_S)
    assert all(abs(p) <= 1 for p in positions(dmc.cmd("TP XY")))


# -- Example 7: velocity control ------------------------------------------------------------------
def test_example_7_jog_speeds_reversal_and_stop(dmc: Dmc) -> None:
    """Ex. 7: JG 10000,-20000; AC 100000, 40000; DC 50000,50000; BG XY; after a few seconds
    JG -40000 (X reverses), TV X; JG ,20000 (Y reverses), TV Y; ST."""
    dmc.cmd("JG 10000,-20000")
    dmc.cmd("AC 100000, 40000")
    dmc.cmd("DC 50000,50000")
    dmc.cmd("BG XY")
    dmc.step(2.0)
    x, y = dmc.values("TV XY")
    assert x == pytest.approx(10_000, rel=0.02) and y == pytest.approx(-20_000, rel=0.02)
    dmc.cmd("JG -40000")
    dmc.step(2.0)
    assert dmc.value("TV X") == pytest.approx(-40_000, rel=0.02)
    dmc.cmd("JG ,20000")
    dmc.step(2.0)
    assert dmc.value("TV Y") == pytest.approx(20_000, rel=0.02)
    # ST decelerates each axis with its DC [M Ch6 §Independent Jogging]
    took = dmc.timed("ST;AM X")
    expected = 40_000 / stored_acc(50_000)
    assert expected <= took <= expected + LATENCY_S
    dmc.cmd("AM Y")
    assert dmc.values("SC XY") == [4, 4]  # stopped by ST (spec §4.4)


# -- Example 8: torque limit ----------------------------------------------------------------------
def test_example_8_a_low_torque_limit_does_not_overcome_friction(dmc: Dmc) -> None:
    """Ex. 8: TL 0.2; JG 10000; BG X: "the X motor will probably not move since the output signal
    will not be sufficient to overcome the friction" (0.5 V of friction here); TT <= TL.
    "Increase the torque level gradually": TL 1.0, then TL 9.98, and it jogs."""
    dmc.control("set_friction", axis="X", volts=0.5)
    dmc.cmd("TL 0.2")
    dmc.cmd("JG 10000")
    dmc.cmd("BG X")
    dmc.step(0.5)
    assert abs(dmc.value("TP X")) <= 1
    assert abs(dmc.value("TT X")) <= 0.2
    assert abs(dmc.value("TV X")) <= 1
    dmc.cmd("TL 1.0")
    dmc.step(0.2)
    assert dmc.value("TP X") > 100  # above the friction: it moves
    assert abs(dmc.value("TT X")) <= 1.0
    dmc.cmd("TL 9.98")
    dmc.step(2.0)
    assert dmc.value("TV X") == pytest.approx(10_000, rel=0.03)


def test_example_8_torque_limit_maximum_is_9_998_volts(dmc: Dmc) -> None:
    """Ex. 8: "The maximum level of 9.998 volts provides the full output torque"."""
    dmc.cmd("TL 1.0")
    dmc.cmd("TL 9.998")
    assert dmc.value("TL ?") == pytest.approx(9.998, abs=1e-4)


# -- Example 9: interrogation ---------------------------------------------------------------------
def test_example_9_kp_interrogation_forms(dmc: Dmc) -> None:
    """Ex. 9: KP ? (X), KP ,,? (Z), KP ?,?,?,? (all); KP and KD answer in 4.2 format."""
    dmc.cmd("KP 1,2,3,4")
    assert dmc.cmd("KP ?") == "0001.00"
    assert dmc.cmd("KP ,,?") == "0003.00"
    assert dmc.cmd("KP ?,?,?,?") == "0001.00,0002.00,0003.00,0004.00"
    dmc.cmd("KD ,100")
    assert dmc.cmd("KD ,?") == "0100.00"


def test_example_9_fractional_gains_read_back(dmc: Dmc) -> None:
    """Ex. 9 "Many other parameters such as KI, KD, FA, can also be interrogated": the 4.2 (KP,
    KD) and 4.4 (KI) formats carry the fraction that was set."""
    dmc.cmd("KP 3.5")
    dmc.cmd("KD 100.5")
    dmc.cmd("KI 0.25")
    assert dmc.cmd("KP ?") == "0003.50"
    assert dmc.cmd("KD ?") == "0100.50"
    assert dmc.cmd("KI ?") == "0000.2500"


def test_it_smoothing_parameter_keeps_values_between_0_and_1(dmc: Dmc) -> None:
    """[M Ch6 §Motion Smoothing]: "The smoothing parameters ... are numbers between 0 and 1"."""
    dmc.cmd("IT 0.5")
    assert dmc.value("IT ?") == 0.5


# -- Example 10: buffer mode ----------------------------------------------------------------------
def test_example_10_wt_holds_the_following_instructions(dmc: Dmc) -> None:
    """Ex. 10: PR 600000; SP 10000; WT 10000 ("Wait 10000 milliseconds before reading the next
    instruction"); BG X: the motion begins 10 s after the line."""
    took = dmc.timed("PR 600000;SP 10000;WT 10000;BG X")
    assert 10.0 <= took <= 10.0 + LATENCY_S
    assert dmc.value("MG _BGX") == 1
    dmc.step(0.01)
    assert 0 < dmc.value("RP X") < 10_000 * (0.01 + LATENCY_S)  # it has just begun
    dmc.cmd("ST X;AM X")


# -- chapter 5 "Command Syntax - ASCII" examples --------------------------------------------------
def test_chapter_5_field_forms(dmc: Dmc) -> None:
    """PR 1000 (X), PR ,2000 (Y), PR ,,3000 (Z), PR ,,,4000 (W); PR 2000, 4000,6000, 8000;
    PR ,8000,,9000 (Y and W only); PR ?,?, ?,? and PR ,? request values; PRX=1000; ACY=200000."""
    for line in ("PR 1000", "PR ,2000", "PR ,,3000", "PR ,,,4000"):
        dmc.cmd(line)
    assert positions(dmc.cmd("PR ?,?, ?,?")) == [1000, 2000, 3000, 4000]
    dmc.cmd("PR 2000, 4000,6000, 8000")
    dmc.cmd("PR ,8000,,9000")
    assert positions(dmc.cmd("PR ?,?, ?,?")) == [2000, 8000, 6000, 9000]
    assert positions(dmc.cmd("PR ,?")) == [8000]
    dmc.cmd("PRX=1000")
    dmc.cmd("ACY=200000")
    assert positions(dmc.cmd("PR ?")) == [1000]
    assert dmc.values("AC ,?") == [stored_acc(200_000)]


def test_chapter_5_action_commands_take_axis_letters(dmc: Dmc) -> None:
    """"BG Begin all axes"; "ST XY stops motion on both the X and Y axes"."""
    dmc.cmd("JG 1000,1000,1000,1000")
    dmc.cmd("BG")
    dmc.step(0.05)
    dmc.cmd("ST XY")
    dmc.cmd("AM XY")
    assert dmc.values("SC") == [4, 4, 0, 0]
    assert dmc.values("MG _BGZ") == [1]
    dmc.cmd("ST;AM")
