"""The virtual axis N as an axis of its own [M Ch6 §Virtual Axis] on the firmware alone: "no
encoder and no DAC. However, it can be commanded by the commands: AC, DC, JG, SP, PR, PA, BG, IT,
GA, VM, VP, CR, ST, DP, RP"; the manual's ECAM Master Example (EAN, EMN=4000, `PAN=2000 BGN`
moves XY to the table's points), N as a gear master, N on a VM path, and what N does not take."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.galil.follow_rig import Rig
from tests.devices.galil.program_rig import Rig as ProgramRig
from vdevd.devices.galil.errors import TC


def bgn_samples(rig: Rig, limit: int = 20_000) -> int:
    """Samples until N's profile is complete (`_BGN` 0)."""
    for k in range(1, limit):
        rig.fw.step()
        if not rig.fw.virtual.moving:
            return k
    raise AssertionError("N still moves")


# -- N's own profile -------------------------------------------------------------------------------
def test_prn_bgn_moves_n_on_its_own_trapezoid_and_drives_no_axis() -> None:
    """PRN, SPN, ACN, DCN, BGN: a trapezoid of d/v + v/a; RP N and TP N (no encoder: TP is the
    commanded position) read the distance; the real axes stay."""
    rig = Rig()
    rig.cmd("PRN=10000;SPN=10000;ACN=102400;DCN=102400;BGN")
    assert rig.value("_BGN") == 1
    n = bgn_samples(rig)
    assert n == pytest.approx((10000 / 10000 + 10000 / 102400) * 1000, abs=2)
    assert rig.ints("RP N") == [10000] and rig.ints("TP N") == [10000]
    assert rig.ints("RP XYZW") == [0, 0, 0, 0] and rig.ints("TP XN") == [0, 10000]
    assert rig.value("_RPN") == rig.value("_TPN") == 10000 and rig.value("_BGN") == 0
    rig.cmd("BG N")  # PR again from there
    bgn_samples(rig)
    assert rig.ints("RP N") == [20000]


def test_pan_moves_to_the_position_and_pan_reads_the_destination_while_moving() -> None:
    rig = Rig()
    rig.cmd("PAN=-3000;SPN=50000;BGN")
    rig.run(10)
    assert rig.value("_PAN") == -3000 and rig.ints("PAN=?") == [-3000]
    assert 0 > rig.value("_RPN") > -3000
    bgn_samples(rig)
    assert rig.ints("RP N") == [-3000]


def test_jgn_jogs_changes_on_the_fly_and_stn_stops_with_dcn() -> None:
    """JG mode of N [M Ch6 §Independent Jogging]: the speed, a new JGN on the fly, ST N at DCN."""
    rig = Rig()
    rig.cmd("JGN=5000;ACN=1024000;DCN=1024000;BGN")
    rig.run(1000)
    at = rig.value("_RPN")
    assert at == pytest.approx(5000 - 5000**2 / (2 * 1024000), abs=2)
    rig.cmd("JGN=-5000")  # reverses through zero on the fly
    rig.run(1000)
    assert rig.value("_RPN") < at
    rig.cmd("DCN=51200;ST N")
    n = bgn_samples(rig)
    assert n == pytest.approx(5000 / 51200 * 1000, abs=2)
    assert rig.value("_BGN") == 0


def test_st_alone_stops_n_too() -> None:
    rig = Rig()
    rig.cmd("JGN=5000;JG 5000;BG XN")
    rig.run(100)
    rig.cmd("ST")
    rig.run(200)
    assert not rig.fw.virtual.moving and rig.value("_BGX") == 0


def test_parameters_of_n_are_kept_apart_and_answer_in_the_axes_formats() -> None:
    """`ACN=?` in AC's 7.0, `SPN=?` in SP's 8.0, `PRN=?` a position; `PR N=` as `PRN=`; the
    operands `_ACN _DCN _SPN _JGN _PRN _ITN`; X's values stay the power-on ones."""
    rig = Rig()
    rig.cmd("ACN=512000;DCN=300000;SPN=1234;JGN=-777;ITN=0.5;PR N=250")
    assert rig.cmd("ACN=?") == "0512000" and rig.cmd("SPN=?") == "00001234"
    assert rig.cmd("PRN=?") == "0000000250"
    assert [rig.value(f"_{p}N") for p in ("AC", "DC", "SP", "JG", "PR", "IT")] == [
        512000, 299008, 1234, -776, 250, 0.5]  # AC/DC round down to 1024, SP/JG to 2
    rig.cmd("JGX=-777")
    assert rig.value("_JGX") == rig.value("_JGN")  # rounded as an axis's
    assert rig.ints("AC ?;SP ?") == [256000, 25000]
    assert rig.refused("ACN=99999999") == TC.NUMBER_OUT_OF_RANGE


def test_it_smooths_n_s_move_as_an_s_curve() -> None:
    """IT [M Ch6 §Motion Smoothing]: the move lasts longer, ends at the same point."""
    plain, smooth = Rig(), Rig()
    plain.cmd("PRN=5000;SPN=20000;BGN")
    smooth.cmd("PRN=5000;SPN=20000;ITN=0.1;BGN")
    assert bgn_samples(smooth) > bgn_samples(plain)
    assert smooth.ints("RP N") == plain.ints("RP N") == [5000]


def test_bg_xn_begins_both_and_bg_n_while_n_moves_is_tc_21() -> None:
    rig = Rig()
    rig.cmd("PR 1000;PRN=2000;BG XN")
    assert rig.value("_BGX") == 1 and rig.value("_BGN") == 1
    assert rig.refused("BGN") == TC.BEGIN_WHILE_RUNNING
    rig.run_until_stopped()
    bgn_samples(rig)
    assert rig.ints("RP XN") == [1000, 2000]


def test_dpn_defines_n_and_is_refused_while_it_moves() -> None:
    rig = Rig()
    rig.cmd("DPN=500")
    assert rig.ints("RP N") == [500] and rig.value("_DPN") == 500 and rig.cmd("DPN=?") == "0000000500"
    rig.cmd("PRN=100;BGN")
    assert rig.refused("DPN=0") == TC.NOT_VALID_WHILE_RUNNING
    bgn_samples(rig)
    assert rig.ints("RP N") == [600]


def test_amn_and_mcn_hold_the_interpreter_until_n_is_complete() -> None:
    rig = Rig()
    assert rig.send("PRN=1000;BGN;AMN;MG _RPN") == b"::"
    rig.run(20)
    assert rig.receive() == b""
    bgn_samples(rig)
    rig.fw.step()
    assert rig.receive() == b": 0000001000.0000\r\n:"
    assert rig.send("PRN=-1000;BGN;MC N;MG _RPN") == b"::"
    bgn_samples(rig)
    rig.fw.step()
    assert rig.receive() == b": 0000000000.0000\r\n:"


def test_amn_in_a_program_waits_for_n() -> None:
    rig = ProgramRig()
    assert rig.download("#A\rPRN=300\rBGN\rAMN\rV1=_RPN\rEN\r") == b":"
    rig.send(b"XQ #A\r")
    rig.samples(5)
    assert "V1" not in rig.fw.variables
    rig.samples(1000)
    assert rig.fw.variables["V1"] == 300


def test_ab_and_the_abort_input_stop_n_at_once_and_rs_resets_it() -> None:
    rig = Rig()
    rig.cmd("JGN=8000;BGN")
    rig.run(100)
    rig.cmd("AB")
    assert not rig.fw.virtual.moving
    at = rig.value("_RPN")
    rig.run(50)
    assert rig.value("_RPN") == at
    rig.cmd("BGN")
    rig.run(10)
    rig.fw.set_abort(True)
    assert not rig.fw.virtual.moving
    rig.fw.set_abort(False)
    rig.cmd("ACN=102400;DPN=77")
    rig.cmd("RS")
    assert rig.ints("RP N") == [0] and rig.value("_ACN") == 256000


def test_a_moving_n_keeps_the_card_from_resting() -> None:
    """Decision 0008: N's profile is work every sample; at rest it costs nothing."""
    rig = Rig()
    assert rig.fw.rest_state() is not None
    rig.cmd("PRN=2000;BGN")
    assert rig.fw.rest_state() is None
    bgn_samples(rig)
    assert rig.fw.rest_state() is not None


@pytest.mark.parametrize("line", ["HMN", "MON", "SHN", "KPN=1", "KPN=?", "TE N", "GRN=2",
                                  "FE N", "TD N", "SC N", "PR ,,,,100"])
def test_commands_n_does_not_take_are_tc_4_and_the_card_serves_on(line: str) -> None:
    """N has no encoder, no DAC: the commands of a motor or an encoder naming it are `?`, TC 4
    "Operand error", and nothing changes."""
    rig = Rig()
    assert rig.refused(line) == TC.OPERAND_ERROR
    assert rig.value("1+1") == 2 and rig.ints("RP N") == [0]
    assert "KPN" not in rig.fw.variables


def test_jgn_during_a_pr_move_is_tc_13_and_an_unknown_operand_of_n_tc_57() -> None:
    rig = Rig()
    rig.cmd("PRN=100000;BGN")
    assert rig.refused("JGN=100") == TC.JG_ONLY_IN_JOG_MODE
    assert rig.refused("MG _TEN") == TC.BAD_FUNCTION
    assert rig.value("_BGN") == 1


def test_other_names_ending_in_n_are_still_variables() -> None:
    rig = Rig()
    rig.cmd("RUN=5;MIN=2")
    assert rig.value("RUN+MIN") == 7


# -- N as the ECAM master [M Ch6 §Virtual Axis, ECAM Master Example] --------------------------------
#: a table over the cycle of 4000: interval 400, X and Y
TABLE = [(0, 0), (400, -200), (1000, -500), (1800, -900), (2600, -1300), (3000, -1500),
         (3200, -1600), (3000, -1500), (2000, -1000), (800, -400), (0, 0)]


def cam_on_n() -> Rig:
    rig = Rig()
    rig.cmd("EAN;EMN=4000;EM 0,0;EP 400,0")
    for i, (x, y) in enumerate(TABLE):
        rig.cmd(f"ET[{i}]={x},{y}")
    rig.cmd("EB1;EG 0,0")
    return rig


def table_at(p: float) -> tuple[float, float]:
    grid = np.arange(len(TABLE)) * 400.0
    return (float(np.interp(p, grid, [x for x, _ in TABLE])),
            float(np.interp(p, grid, [y for _, y in TABLE])))


def test_ecam_master_example_pan_2000_bgn_moves_xy_along_the_table() -> None:
    """"EAN ... EMN=4000. Next, the table is constructed ... PAN = 2000 BGN will cause the XY
    axes to move to the corresponding points on the motion cycle": at every sample X and Y are
    the table interpolated at N's position (N is computed first in the sample)."""
    rig = cam_on_n()
    assert rig.cmd("EA ?") == "N" and rig.cmd("EMN=?") == "0000004000"
    assert rig.value("_EMN") == 4000
    rig.cmd("PAN=2000;SPN=20000;BGN")
    seen = 0
    while rig.fw.virtual.moving:
        rig.fw.step()
        n = rig.fw.virtual.position()
        x, y = table_at(n)
        assert rig.fw.motion.core.axes.cmd_pos[:2].tolist() == pytest.approx([x, y], abs=1e-6)
        seen += 1
    assert seen == pytest.approx((2000 / 20000 + 20000 / 256000) * 1000, abs=2)
    rig.fw.step()
    assert rig.ints("RP XYN") == [*TABLE[5], 2000]
    assert rig.ints("SC XY") == [60, 60]
    rig.cmd("PAN=1000;BGN")  # back along the cam
    bgn_samples(rig)
    rig.fw.step()
    assert rig.ints("RP XY") == [round(v) for v in table_at(1000)]


def test_at_the_end_of_n_s_cycle_n_s_position_is_redefined() -> None:
    """[M Ch6 Step 2] with N as the master: N jogs through 4000 and reads modulo its cycle; the
    slaves go on along the table, N's followers see no jump."""
    rig = cam_on_n()
    rig.cmd("GA ,,CN;GR ,,1")  # Z follows N's commanded position
    rig.cmd("JGN=20000;BGN")
    rig.run(300)
    before = rig.value("_RPZ")
    rig.run(100)  # N passes 4000 here
    rig.cmd("ST N")
    bgn_samples(rig)
    rig.fw.step()
    n = rig.value("_RPN")
    assert 0 <= n < 4000
    assert rig.ints("RP XY") == [round(v) for v in table_at(n)]
    assert rig.value("_RPZ") > before + 2000  # Z went on through the redefinition


# -- N as a gear master ----------------------------------------------------------------------------
def test_ga_n_gears_a_follower_to_n_s_commanded_position() -> None:
    """GA N [M Ch6 §Virtual Axis: GA]: X at GR 2 moves twice N's distance, in step with it."""
    rig = Rig()
    rig.cmd("GA N;GR 2;PRN=1000;SPN=10000;BGN")
    while rig.fw.virtual.moving:
        rig.fw.step()
        n = rig.fw.virtual.position()
        assert rig.fw.motion.core.axes.cmd_pos[0] == pytest.approx(2 * n, abs=1e-6)
    rig.fw.step()
    assert rig.ints("RP XN") == [2000, 1000]
    assert rig.refused("GA DN") == TC.OPERAND_ERROR  # N has no auxiliary encoder


# -- N on a vector path (VM) -----------------------------------------------------------------------
def test_a_vm_plane_with_n_drives_n_s_position_along_the_path() -> None:
    """VMXN: N's position is one value; the path drives it from where N stands at BGS
    (README "Virtual axis N")."""
    rig = Rig()
    rig.cmd("DPN=100;VMXN;VP 3000,4000;VE;VS 50000;BGS")
    rig.run(20)
    x, n = rig.fw.motion.core.axes.cmd_pos[0], rig.fw.virtual.position()
    assert (n - 100) / x == pytest.approx(4000 / 3000, rel=1e-6)
    assert rig.refused("BGN") == TC.BEGIN_WHILE_RUNNING  # N is in the running plane
    assert rig.refused("DPN=0") == TC.NOT_VALID_WHILE_RUNNING
    while rig.fw.coord.active:
        rig.fw.step()
    assert rig.ints("RP XN") == [3000, 4100] and rig.value("_BGN") == 0


def test_bgs_with_n_moving_on_its_own_is_tc_21_and_st_n_stops_the_plane() -> None:
    rig = Rig()
    rig.cmd("VMXN;VP 30000,40000;VE;JGN=1000;BGN")
    assert rig.refused("BGS") == TC.BEGIN_WHILE_RUNNING
    assert rig.refused("BG SN") == TC.BEGIN_WHILE_RUNNING
    rig.cmd("ST N")
    bgn_samples(rig)
    rig.cmd("BGS")
    rig.run(100)
    rig.cmd("ST N")  # the plane that drives N decelerates along its path
    assert rig.ints("SC X") == [4]
    while rig.fw.coord.active:
        rig.fw.step()
    x, n0 = rig.value("_RPX"), rig.value("_RPN")
    assert 0 < x < 30000 and rig.value("_BGN") == 0
    assert n0 == pytest.approx(rig.fw.virtual.reference())


def test_a_path_driving_n_the_ecam_master_goes_on_through_n_s_redefinitions() -> None:
    """N on a VM path and the master of a cam at once: at the end of each of N's cycles its
    position is redefined and the path goes on from there (no jump back)."""
    rig = Rig()
    rig.cmd("EAN;EMN=1000;EM 0,1000;EP 100,0")
    for i in range(11):
        rig.cmd(f"ET[{i}]=,{i * 100}")  # Y is N's position within the cycle, 1000 a cycle
    rig.cmd("EB1;EG ,0;VMXN;VP 3000,2500;VE;VS 20000;BGS")
    while rig.fw.coord.active:
        rig.fw.step()
        n = rig.fw.virtual.position()
        assert 0 <= n < 1000
    rig.fw.step()
    assert rig.ints("RP XYN") == [3000, 500, 500]
    physical = rig.fw.motion.core.physical()
    assert physical[:2].tolist() == [3000, 2500]  # Y went on through two cycles, no jumps
