"""Sinusoidal commutation setup [M Ch2 Step 5, Step 7b; spec §5.8] on a DMC-1348: BA and the
second DACs, BM, BI, BB, BC, BZ, BS and TC 110 for an axis not made brushless."""

from __future__ import annotations

import pytest

from tests.devices.galil.follow_rig import Rig
from vdevd.devices.galil.errors import TC


def test_bax_takes_the_w_dac_and_leaves_a_1338() -> None:
    """"BAX ... the 'W' axis to be the second sinusoidal signal ... re-configured to a
    DMC-1338" [M Ch2 Step 1]."""
    rig = Rig("servo")
    rig.cmd("BAX")
    com = rig.fw.follow.commutation
    assert com.second_dac.tolist()[0] == 3 and com.standard_axes == 3
    assert rig.value("_BAX") == 1 and rig.value("_MOW") == 1  # W's DAC is X's phase B


def test_baxz_pairs_x_with_y_and_z_with_w() -> None:
    """[M Ch2 Step 5 Example]: X phase 2 = Y, Z phase 2 = W; the card becomes a DMC-1328."""
    rig = Rig("servo")
    rig.cmd("BAXZ")
    com = rig.fw.follow.commutation
    assert com.second_dac.tolist() == [1, -1, 3, -1]
    assert com.standard_axes == 2


@pytest.mark.parametrize("axes", ["W", "XYZ"])
def test_the_highest_axis_never_commutates_and_dacs_must_suffice(axes: str) -> None:
    assert Rig("servo").refused(f"BA{axes}") == TC.NUMBER_OUT_OF_RANGE


def test_bm_bi_bb_need_a_brushless_axis() -> None:
    rig = Rig("servo")
    assert rig.refused("BM 62000") == TC.NOT_BRUSHLESS  # 110
    rig.cmd("BAXZ;BM 62000,,1333.333;BI ,,6;BB 30")
    assert rig.value("_BMZ") == pytest.approx(1333.333, abs=1e-3)
    assert rig.cmd("BI ,,?") == "006"
    assert rig.refused("BI 7") == TC.NUMBER_OUT_OF_RANGE  # three inputs from IN7: none left
    assert rig.refused("BZY=-2") == TC.ONLY_ABCD_VALID  # Y drives X's phase B: not available
    assert rig.refused("BSY=2,700") == TC.NOT_BRUSHLESS
    rig.cmd("BSX=2,700;BCX")


def test_bz_sets_the_zero_phase_here_and_ends_in_mo_or_sh() -> None:
    """BZ v: v > 0 ends motor off, v < 0 servo here [M Ch2 Step 7b F]; _BZ the counts to it."""
    rig = Rig("servo")
    rig.cmd("BAX;BM 4000;PR 1000;BGX")
    rig.run_until_stopped()
    rig.run(200)
    rig.cmd("BZ 2")
    assert rig.value("_MOX") == 1 and rig.value("_BZX") == 0
    rig.cmd("BZ -2")
    assert rig.value("_MOX") == 0
    rig.cmd("PR 1000;BGX")
    rig.run_until_stopped()
    rig.run(200)
    assert rig.value("_BZX") == pytest.approx(-1000, abs=2)  # back 1000 counts to a zero


def test_a_quarter_magnetic_cycle_from_zero_puts_phase_a_at_u_and_phase_b_at_minus_half() -> None:
    """Phase A = u sin(theta), phase B = u sin(theta + 120 deg) (spec §5.8): at theta = 90 deg,
    A = u and B = u sin(210 deg) = -u/2."""
    rig = Rig("servo")
    rig.cmd("BAX;BM 4000;BZ -1;PR 1000;BGX")
    rig.run_until_stopped()
    rig.run(300)
    rig.cmd("OF 1")  # one volt out, so that there is a u to commutate
    rig.run(1)
    a, b = rig.fw.follow.commutation.phases()[:, 0]
    u = float(rig.fw.motion.torque()[0])
    assert abs(u) > 0.5
    assert a == pytest.approx(u, rel=1e-3)
    assert b == pytest.approx(-u / 2, rel=1e-2)


def test_after_bax_the_card_is_a_1338_and_w_is_no_longer_available() -> None:
    """[M Ch2 Step 1]: "if the command BAX is given to a DMC-1348 controller, the controller will
    be re-configured to a DMC-1338 controller ... The 'W' axis is no longer available since the
    output DAC is being used for sinusoidal commutation": W named is TC 90 as on a 1338, the
    reports and "every axis" commands cover X, Y, Z."""
    rig = Rig("servo")
    assert rig.cmd("\x12\x16").startswith("DMC1348")  # ^R^V
    rig.cmd("BAX")
    assert rig.cmd("\x12\x16").startswith("DMC1338")
    for line in ("PRW=100", "PR 1,2,3,4", "BGW", "TPW", "KP ,,,5", "SHW"):
        assert rig.refused(line) == TC.ONLY_ABCD_VALID, line
    assert len(rig.ints("TP")) == 3
    rig.cmd("KP*=12")
    assert rig.cmd("KP ?,?,?") == "0012.00,0012.00,0012.00"
    rig.cmd("SH;PR 100,200,300;BG")
    rig.run(2000)
    assert rig.ints("RP") == [100, 200, 300]


def test_baxz_leaves_x_and_z_and_frees_y_and_w() -> None:
    """BAXZ: X's phase B is Y's DAC and Z's is W's [M Ch2 Step 5]: Y and W are refused."""
    rig = Rig("servo")
    rig.cmd("BAXZ")
    assert rig.cmd("\x12\x16").startswith("DMC1328")
    assert rig.refused("PRY=5") == TC.ONLY_ABCD_VALID
    assert rig.refused("BG W") == TC.ONLY_ABCD_VALID
    assert len(rig.ints("TP")) == 2
