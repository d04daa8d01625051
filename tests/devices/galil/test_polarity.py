"""Loop polarity: MT -1, the reversed-polarity servo, and CE 2, the reversed main encoder
[M Ch6 §Using the CE Command; spec §5.6]. Either alone turns the loop's feedback positive (the
motor runs away, as on the card with the encoder or the motor leads swapped); both together
close it again, with the DAC driving the other way."""

from __future__ import annotations

import pytest

from tests.devices.galil.follow_rig import Rig


def move(setup: str) -> Rig:
    rig = Rig("servo")
    rig.cmd(f"{setup};ER 32767;PR 1000;BGX")
    return rig


@pytest.mark.parametrize("setup", ["MT 1", "CE 8", "CE 2;MT -1", "CE 3;MT -1"])
def test_a_loop_of_negative_feedback_reaches_the_target(setup: str) -> None:
    rig = move(setup)
    rig.run(600)
    assert rig.ints("TP X;TE X") == [1000, 0]


@pytest.mark.parametrize("setup", ["MT -1", "CE 2", "CE 3"])
def test_one_reversal_alone_makes_the_motor_run_away(setup: str) -> None:
    rig = move(setup)
    rig.run(300)
    assert abs(rig.ints("TE X")[0]) > 10_000
    assert abs(float(rig.cmd("TT X"))) > 9.9  # the DAC saturated


def test_mt_minus_1_drives_the_dac_the_other_way() -> None:
    normal, reversed_ = move("MT 1"), move("CE 2;MT -1")
    normal.run(10)
    reversed_.run(10)
    tt, tt_reversed = float(normal.cmd("TT X")), float(reversed_.cmd("TT X"))
    assert tt > 0.01
    assert tt_reversed == pytest.approx(-tt, abs=1e-3)


def test_mt_minus_1_needs_no_stepper_jumper_and_reads_back() -> None:
    rig = Rig("servo")
    rig.cmd("MT -1,1")
    assert rig.value("_MTX") == -1
