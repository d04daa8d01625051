"""Stepper position maintenance [M Ch6 §Stepper Position Maintenance Mode] on a stepper card:
QS = TD - TP * YA * YB / YC, the error limit of three full steps, OE, YS and the YR correction.
The stage's encoder gives 10 counts a pulse (YA 2 half steps, YB 200 steps/rev, YC 4000
counts/rev); a slipping encoder makes the error."""

from __future__ import annotations

from tests.devices.galil.follow_rig import Rig
from vdevd.devices.galil.errors import TC

SETUP = "YA 2;YB 200;YC 4000;YS 1;SP 2000;PR 1000;BGX"


def stepper(oe: int) -> Rig:
    rig = Rig("stepper")
    rig.fw.motion.core.set_encoder_scale(0, 10.0)  # 4000 counts per 400 pulses
    rig.cmd(f"OE {oe};{SETUP}")
    rig.run(100)
    return rig


def test_qs_is_zero_while_the_encoder_agrees_with_the_steps() -> None:
    rig = stepper(1)
    td, tp = rig.ints("TD X;TP X")
    assert td > 0 and tp == 10 * td
    assert rig.value("_QSX") == 0 and rig.value("_YSX") == 1


def test_an_error_over_three_full_steps_sets_ys_2_and_oe1_stops_the_axis() -> None:
    rig = stepper(1)
    rig.fw.motion.core.slip_encoder(0, 100)  # 10 pulses: over 3 full steps (6 pulses)
    rig.run(2)
    assert rig.value("_QSX") == 10 and rig.value("_YSX") == 2
    rig.run_until_stopped()
    assert rig.ints("RP X")[0] < 1000  # stopped short of the target
    assert rig.ints("SC X") == [8]


def test_with_oe0_the_axis_keeps_moving() -> None:
    rig = stepper(0)
    rig.fw.motion.core.slip_encoder(0, 100)
    rig.run(2)
    assert rig.value("_YSX") == 2
    rig.run_until_stopped()
    assert rig.ints("RP X") == [1000]


def test_yr_qs_corrects_the_error_and_ys_returns_to_1() -> None:
    rig = stepper(1)
    rig.fw.motion.core.slip_encoder(0, 100)
    rig.run(2)
    rig.run_until_stopped()
    rig.run(100)  # the KS filter lets its last pulses out
    td = rig.ints("TD X")[0]
    rig.cmd("YRX=_QSX")
    rig.run_until_stopped()
    rig.run(100)
    assert rig.ints("TD X") == [td + 10]  # ten more pulses out to the motor
    assert rig.value("_QSX") == 0 and rig.value("_YSX") == 1


def test_spm_misuse_answers_with_its_tc() -> None:
    rig = Rig("stepper")
    assert rig.refused("YA 10000") == TC.NUMBER_OUT_OF_RANGE
    assert rig.refused("YS 2") == TC.NUMBER_OUT_OF_RANGE  # 2 is a status, not a setting
    assert rig.refused("QS 5") == TC.UNRECOGNIZED_COMMAND  # read only
    rig.cmd("PR 1000;BGX")
    rig.run(2)
    assert rig.refused("YR 5") == TC.NOT_VALID_WHILE_RUNNING  # only once stopped [M Ch6]
    assert rig.cmd("YA ?;YB ?;YC ?") == "0002\n0200\n4000"
