"""What a contour shows and leaves on its axes (card README "Contours"): the commanded velocity
is the path's while it runs (RV), a move after it counts from where it ended, position
maintenance holds its end and not the target before it, and another axis's move ending does
not round the path's axes (spec oms.md §4.3 "Vector / contouring", §5.4, §5.6).
"""

from __future__ import annotations

import math

import pytest

from tests.devices.oms.test_trajectory_scan import cycles, firmware

HZ = 1024


def test_rv_reports_the_path_velocity_of_each_axis_while_a_contour_runs() -> None:
    """At the cruise of VV2000 along (3, -1): RV is 2000·(3, -1)/√10 counts/s."""
    fw = firmware()
    fw.feed(b"AA; VV2000; VA20000; VP3000,-1000; VE;")
    cycles(fw, 1000)
    fw.replies.clear()
    fw.feed(b"AA; RV;")
    x, y, *_ = (int(v) for v in fw.replies[-1].decode().strip().split(","))
    assert x == pytest.approx(2000 * 3 / math.sqrt(10), abs=2)
    assert y == pytest.approx(-2000 / math.sqrt(10), abs=2)
    cycles(fw, 2000)
    fw.feed(b"AA; RV;")
    assert fw.replies[-1].decode().strip() == "0,0,0,0"


@pytest.mark.parametrize("before", [b"", b"AX; MA500; GO; "])
def test_mr_after_a_contour_counts_from_where_it_ended(before: bytes) -> None:
    """Not from the target of a move before the contour (which would take X back)."""
    fw = firmware()
    fw.feed(before + b"AA; VV5000; VA50000; VP1000,2000; VE; AX; MR100; GO; AY; MR-100; GO;")
    cycles(fw, 3000)
    assert fw.motor_position()[:2].tolist() == [1100, 1900]


def test_position_maintenance_holds_the_contours_end_not_the_move_before_it() -> None:
    """A stepper with encoder in position maintenance (CL1): during the contour it never steps
    back towards the MA target of before; after it, it stays at the end, in its deadband."""
    fw = firmware()
    fw.feed(b"AX; PSE; CL1; HV2000; HD0; MA500; GO;")
    cycles(fw, 2000)
    fw.feed(b"AA; VV1000; VA100000; VP3000,1000; VE;")
    xs = []
    for _ in range(4000):
        cycles(fw, 1)
        xs.append(float(fw.motion.core.axes.cmd_pos[0]))
    assert all(b >= a - 1e-9 for a, b in zip(xs, xs[1:], strict=False))
    assert max(b - a for a, b in zip(xs, xs[1:], strict=False)) <= 1000 / HZ + 1e-6
    cycles(fw, 3000)
    assert fw.motor_position()[:2].tolist() == [3000, 1000]
    assert fw.in_deadband(0)


def test_another_axis_ending_a_move_leaves_a_contour_moving_off_a_limit_alone() -> None:
    """Y stands on its active negative limit switch and the contour takes it up, away from it
    (README "Limits": it runs); Z's moves ending meanwhile do not round the path's axes to
    whole counts, which would put the next point below Y's and read as a move into the
    switch."""
    fw = firmware()
    fw.motion.limit_neg_level[1] = bool(fw.params.limit_high[1])
    fw.motion.apply_limits()
    fw.feed(b"AA; VV1000; VA100000; VP10000,100; VE; VID;")
    cycles(fw, 300)
    for _ in range(5):
        fw.feed(b"AZ; MR50; GO;")
        cycles(fw, 150)
    cycles(fw, 12 * HZ)
    assert fw.motor_position()[:2].tolist() == [10000, 100]
    assert fw.done[:2].all() and not fw.live_contours


def test_qa_shows_the_direction_each_axis_last_moved_on_the_path() -> None:
    """Y goes up to 1000 and back to 0 (start and end equal): its last motion was down, QA
    `M`; X only went up, `P` [§4.3 QA: the direction of the last motion]."""
    fw = firmware()
    fw.feed(b"AA; VV4000; VA40000; VP1000,1000; VP2000,0; VE;")
    cycles(fw, 3 * HZ)
    fw.feed(b"AA; QA;")
    x, y, *_ = fw.replies[-1].decode().strip().split(",")
    assert (x[0], y[0]) == ("P", "M")


def test_an_axis_whose_loop_opens_mid_contour_shows_no_path_velocity_and_keeps_no_target() -> None:
    """CL0 on X while the contour runs: X's command follows X (it stays put, RV 0), Y runs on
    the path; the end leaves X no target (MR counts from where X is)."""
    fw = firmware()
    fw.feed(b"AA; VV2236; VA100000; VP20000,10000; VE;")
    cycles(fw, 100)
    fw.feed(b"AX; CL0;")
    for _ in range(5):
        cycles(fw, 500)
        fw.feed(b"AA; RV;")
        assert fw.replies[-1].decode().split(",")[0] == "0"
    cycles(fw, 10 * HZ)
    assert fw.motor_position()[1] == 10000 and not fw.live_contours
    assert not fw.motion.core.target_valid[0]
