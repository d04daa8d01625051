"""The electronic cam [M Ch6 §Electronic Cam] on the firmware alone: the manual's example table
(master Z, slaves X and Y), engagement and disengagement, and the TC codes of misuse."""

from __future__ import annotations

import pytest

from tests.devices.galil.follow_rig import Rig
from vdevd.devices.galil.errors import TC

#: [M Ch6 Example - Electronic CAM]: ET[0..10] for X and Y, master interval 400
TABLE = [(0, 0), (40, 20), (120, 60), (240, 120), (280, 140), (280, 140), (280, 140),
         (240, 120), (120, 60), (40, 20), (0, 0)]


def cam_rig() -> Rig:
    rig = Rig()
    rig.cmd("EA Z;EM 0,0,4000;EP 400,0")
    for n, (x, y) in enumerate(TABLE):
        rig.cmd(f"ET[{n}]={x},{y}")
    rig.cmd("EB 1")
    return rig


def master_to(rig: Rig, position: int) -> None:
    rig.cmd(f"PA ,,{position};SP ,,40000;BGZ")
    rig.run_until_stopped()


@pytest.mark.parametrize("point", range(11))
def test_engaged_slaves_sit_at_the_table_points(point: int) -> None:
    rig = cam_rig()
    rig.cmd("EG 0,0")  # the master stands at 0: engaged now
    master_to(rig, 400 * point)
    assert rig.ints("RP X;RP Y") == list(TABLE[point])


def test_between_points_the_table_is_interpolated_and_the_cycle_repeats() -> None:
    rig = cam_rig()
    rig.cmd("EG 0,0")
    master_to(rig, 1000)  # halfway between ET[2] and ET[3]
    assert rig.ints("RP X;RP Y") == [180, 90]
    master_to(rig, 4000 + 400)  # into the second cycle: the master redefined modulo 4000
    assert rig.ints("RP X;RP Y;RP Z") == [40, 20, 400]
    assert rig.ints("SC X;SC Y") == [60, 60]  # SC 60: running ECAM (spec §4.4)


def test_eg_inside_the_cycle_waits_for_the_master_to_pass_it() -> None:
    rig = cam_rig()
    rig.cmd("EG ,1200")  # Y at ET[3] = 120 when the master passes 1200
    master_to(rig, 800)
    assert rig.ints("RP Y") == [0] and rig.value("_EGY") == 0
    master_to(rig, 1600)
    assert rig.ints("RP Y") == [140] and rig.value("_EGY") == 1


def test_eq_disengages_where_the_master_passes_its_position() -> None:
    rig = cam_rig()
    rig.cmd("EG 0,0;EQ 2000,2000")
    assert rig.value("_EQX") == 1
    master_to(rig, 3200)  # passes 2000: released there, at ET[5]
    assert rig.ints("RP X;RP Y") == [280, 140]
    assert rig.ints("SC X;SC Y") == [61, 61]
    master_to(rig, 400)
    assert rig.ints("RP X;RP Y") == [280, 140]


def test_at_the_end_of_a_cycle_master_and_slave_positions_are_redefined() -> None:
    """[M Ch6 Step 2]: master cycle 6000, slave change 1500, table 0, 3000, 2250, 1500; "at the
    end of a cycle when the master is 6000 and the slave is 1500, the positions of both x and y
    are redefined as zero"; the motion goes on (a follower geared to the master sees no jump)."""
    rig = Rig()
    rig.cmd("EAX;EM 6000,1500;EP 2000,0;ET[0]=,0;ET[1]=,3000;ET[2]=,2250;ET[3]=,1500;EB1;EG ,0")
    rig.cmd("GA ,,,CX;GR ,,,1")
    rig.cmd("PA 8000;SP 50000;BGX")
    rig.run_until_stopped()
    assert rig.ints("RP X;RP Y;RP W") == [2000, 3000, 8000]
    physical = rig.fw.motion.core.physical()
    assert physical[:2].tolist() == [8000, 1500 + 3000]  # the stage went on through the cycle


def test_eb0_releases_the_slaves_and_an_engaged_cam_keeps_the_card_busy() -> None:
    rig = cam_rig()
    rig.cmd("EG 0,0")
    rig.run(2)
    assert rig.fw.rest_state() is None
    rig.cmd("EB 0")
    rig.run(3)
    assert rig.fw.rest_state() is not None
    assert rig.value("_EB") == 0


def test_ecam_misuse_answers_with_its_tc() -> None:
    rig = Rig()
    assert rig.refused("ET[257]=1,2") == TC.ECAM_INDEX  # 101: index 0-256
    assert rig.refused("EC 300") == TC.ECAM_INDEX
    assert rig.refused("EB 1") == TC.NO_ECAM_MASTER  # 102: no EA
    assert rig.refused("EG 0") == TC.EB1_FIRST  # 105
    rig.cmd("EA Z;EM ,,4000;EP 10,0")
    assert rig.refused("EB 1") == TC.ECAM_MODULUS_TOO_LARGE  # 103: 4000 > 256 * 10
    rig = cam_rig()
    rig.cmd("EG 0,0")
    assert rig.refused("EA X") == TC.NOT_VALID_RUNNING_ECAM  # 100
    assert rig.refused("EG ,,0") == TC.NOT_VALID_PERFORMING_ECAM  # the master as its own slave
    rig.cmd("GA ,,,Z")
    assert rig.refused("GR 1") == TC.NOT_VALID_PERFORMING_ECAM  # X is a cam slave
    assert rig.refused("CMY") == TC.NOT_VALID_PERFORMING_ECAM
    assert rig.refused("EM ,,9000000") == TC.NUMBER_OUT_OF_RANGE


def test_et_queries_a_point_and_ec_keeps_the_index() -> None:
    rig = Rig()
    rig.cmd("ET[4]=7,8;EC 5")
    assert rig.cmd("ET[4]=?,?") == "0000000007,0000000008"
    assert rig.value("_EC") == 5
    assert rig.refused("ET[1.5]=1") == TC.ECAM_INDEX
