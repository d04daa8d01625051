"""Cam and gearing followers [Ch5 CAM family, GEAR family, LOAD_CAM_TABLE, CAM_POINT;
spec octavia.md §5.6, §5.7]."""

from __future__ import annotations

from bisect import bisect_right
from fractions import Fraction

import numpy as np
import pytest

from vdevd.devices.octavia.cam import (
    CamFollowers,
    Follow,
    Gears,
    cam_point_ratio,
    check_table_span,
    place_cam_point,
    table_problem,
    table_ratios,
)
from vdevd.devices.octavia.ram import BoardRam

N = 8
MASTER = [0, 100, 500, 1000]          # the LOAD_CAM_TABLE example [Ch5 LOAD_CAM_TABLE]
SLAVE = [0, 200, 300, 200]
ENCODED = [0x0100, 0x0020, 0xFFE6 - 0x10000, 0]


def example_ram(start: int = 0) -> BoardRam:
    ram = BoardRam()
    ram.store_cam_points(start, MASTER, SLAVE, ENCODED)
    return ram


def linear(mu: int) -> Fraction:
    """The example table's slave position at master phase mu, exact piecewise-linear."""
    j = bisect_right(MASTER, mu) - 1
    return SLAVE[j] + Fraction(SLAVE[j + 1] - SLAVE[j], MASTER[j + 1] - MASTER[j]) * (mu - MASTER[j])


def step(cam: CamFollowers, master_axis: int, master: int, commands: np.ndarray) -> tuple[int, int]:
    """One sample with the master at `master`; returns (target, CAMCOUNT) of axis 1."""
    positions = np.zeros(N, np.int64)
    positions[master_axis] = master
    targets, camcount = cam.targets(positions, commands)
    return int(targets[1]), int(camcount[1])


# --- ratios: LOAD_CAM_TABLE's formula and CAM_POINT's computation ---

def test_example_ratios_encode_as_the_manual_table() -> None:
    assert table_ratios(MASTER, SLAVE).tolist() == ENCODED
    assert [cam_point_ratio(100, 200), cam_point_ratio(400, 100), cam_point_ratio(500, -100)] \
        == [0x0100, 0x0020, -26]


def test_out_of_range_ratios_saturate() -> None:
    assert cam_point_ratio(1, 300) == 0x7FFF
    assert cam_point_ratio(1000, 255_999) == 0x7FFF       # the manual's upper limit
    assert cam_point_ratio(1000, -256_000) == -0x8000     # and lower limit
    assert cam_point_ratio(1, -257) == -0x8000
    assert cam_point_ratio(0, 5) == 0                     # no master step: no ratio


def test_cam_point_builds_the_example_table_point_by_point() -> None:
    ram = BoardRam()
    for index, (m, s) in enumerate(zip(MASTER, SLAVE, strict=True)):
        assert place_cam_point(ram, 500, 4, index, m, s)
    master, slave, ratio = ram.cam_points(500, 4)
    assert (master.tolist(), slave.tolist(), ratio.tolist()) == (MASTER, SLAVE, ENCODED)


def test_cam_point_manual_example_recomputes_the_neighbouring_ratios() -> None:
    ram = BoardRam()   # a 10-point table at 500; replace the 3rd point with (1000, 3000) [Ch5 CAM_POINT]
    ram.store_cam_points(500, [500 * i for i in range(10)], [1000 * i for i in range(10)], [256] * 9 + [0])
    assert place_cam_point(ram, 0x01F4, 0x000A, 0x0002, 0x000003E8, 0x00000BB8)
    _, slave, ratio = ram.cam_points(500, 10)
    assert slave[2] == 3000
    assert ratio.tolist() == [256, 512, 0] + [256] * 6 + [0]


def test_cam_point_reports_a_ratio_out_of_range_and_stores_it_saturated() -> None:
    ram = example_ram(0)
    assert not place_cam_point(ram, 0, 4, 1, 100, 40_000)      # 400 from point 0
    assert ram.cam_points(0, 1)[2][0] == 0x7FFF
    ram = example_ram(0)
    assert not place_cam_point(ram, 0, 4, 2, 99_000, 300)       # slope 100/98900 < 1/128
    assert ram.cam_points(1, 1)[2][0] == 0                      # rounded
    ram = example_ram(0)
    assert place_cam_point(ram, 0, 4, 2, 100, 300)              # master does not increase:
    assert ram.cam_points(1, 1)[2][0] == 0                      # ratio 0, left to table_problem


def test_cam_point_on_the_last_point_keeps_its_ratio_zero() -> None:
    ram = example_ram(0)
    assert place_cam_point(ram, 0, 4, 3, 2000, 400)
    assert ram.cam_points(0, 4)[2].tolist() == [0x100, 0x20, 9, 0]   # 100/1500·128 = 8.53


def test_cam_point_rejects_an_index_or_table_outside_the_memory() -> None:
    ram = BoardRam()
    with pytest.raises(ValueError):
        place_cam_point(ram, 0, 4, 4, 1, 1)
    with pytest.raises(ValueError):
        place_cam_point(ram, 1600, 3, 0, 0, 0)        # "0 ≤ tablestart ≤ 1600"
    with pytest.raises(ValueError):
        check_table_span(0, 2)
    check_table_span(1597, 3)
    assert not ram.words.any()


def test_table_problem_names_a_bad_first_point_or_a_decreasing_master() -> None:
    assert table_problem(MASTER, SLAVE) is None
    assert "first point" in str(table_problem([1, 100, 500], [0, 1, 2]))
    assert "increase" in str(table_problem([0, 100, 100], [0, 1, 2]))


# --- the follower law ---

def test_example_table_over_one_master_cycle() -> None:
    cam = CamFollowers(N, example_ram(40))
    cam.engage(1, 0, 40, 4, master_position=7000, slave_position=-300)
    commands = np.full(N, -300, np.int64)
    for mu in range(1000):
        target, camcount = step(cam, 0, 7000 + mu, commands)
        assert abs(target - (-300 + linear(mu))) <= 2, mu      # ratio quantisation: 500·0.003125
        assert camcount == 40 + bisect_right(MASTER, mu) - 1
        if mu in MASTER:
            assert target == -300 + SLAVE[MASTER.index(mu)]    # exact on every point


def test_cycle_wrap_forward_adds_the_slave_cycle() -> None:
    cam = CamFollowers(N, example_ram(0))
    cam.engage(1, 0, 0, 4, 0, 0)
    commands = np.zeros(N, np.int64)
    got = [step(cam, 0, m, commands) for m in range(0, 2601, 50)]
    assert got[20] == (200, 0)          # master 1000: one cycle, slave +200, back to point 0
    assert got[22] == (200 + 200, 1)    # master 1100 = 1000 + 100
    assert got[50] == (400 + 300, 2)    # master 2500 = 2·1000 + 500
    assert got[52] == (400 + 280, 2)    # master 2600 = 2·1000 + 600: 300 − 0.203125·100


def test_cycle_wrap_backward_subtracts_the_slave_cycle() -> None:
    cam = CamFollowers(N, example_ram(0))
    cam.engage(1, 0, 0, 4, 0, 1000)
    commands = np.full(N, 1000, np.int64)
    target, camcount = step(cam, 0, -1, commands)
    assert abs(target - (1000 - 200 + linear(999))) <= 2 and camcount == 2
    assert step(cam, 0, -500, commands) == (1000 - 200 + 300, 2)
    assert step(cam, 0, -900, commands) == (1000 - 200 + 200, 1)
    assert step(cam, 0, -2000, commands) == (1000 - 400, 0)
    assert step(cam, 0, 0, commands) == (1000, 0)          # back where it started: no drift


def reference(displacement: int) -> int:
    """The example cam law from the absolute master displacement (not incrementally)."""
    cycles, mu = divmod(displacement, 1000)
    j = bisect_right(MASTER, mu) - 1
    return cycles * 200 + SLAVE[j] + int(np.floor((mu - MASTER[j]) * ENCODED[j] / 128 + 0.5))


def test_random_master_walk_follows_the_law_of_the_absolute_displacement() -> None:
    rng = np.random.default_rng(5)
    cam = CamFollowers(N, example_ram(0))
    cam.engage(1, 3, 0, 4, 123, 0)
    commands = np.zeros(N, np.int64)
    master = 123
    for _ in range(3000):
        master += int(rng.choice([rng.integers(-3, 4), rng.integers(-2500, 2500)], p=[0.9, 0.1]))
        target, camcount = step(cam, 3, master, commands)
        assert target == reference(master - 123)
        assert camcount == bisect_right(MASTER, (master - 123) % 1000) - 1


def test_master_rolling_over_int32_keeps_the_cam_phase() -> None:
    cam = CamFollowers(N, example_ram(0))
    top = 2**31 - 1
    cam.engage(1, 0, 0, 4, top - 40, 0)
    commands = np.zeros(N, np.int64)
    assert step(cam, 0, top, commands)[0] == 80                # 40 counts at ratio 2
    assert step(cam, 0, -2**31 + 59, commands) == (200, 1)     # 100 counts in: point 1


def test_slaves_follow_their_own_tables_and_masters_in_one_call() -> None:
    ram = example_ram(0)
    ram.store_cam_points(100, [0, 1000, 2000], [0, -1000, 0], [-128, 128, 0])
    cam = CamFollowers(N, ram)
    cam.engage(1, 0, 0, 4, 0, 10)
    cam.engage(2, 0, 100, 3, 0, 20)      # the CAM example: same master, another table
    cam.engage(5, 6, 100, 3, 500, 30)    # another master
    positions = np.array([1500, 0, 0, 0, 0, 0, 800, 0])
    targets, camcount = cam.targets(positions, np.arange(N) * 1000)
    assert targets.tolist() == [0, 10 + 200 + 300, 20 - 500, 3000, 4000, 30 - 300, 6000, 7000]
    assert camcount.tolist()[:3] == [0, 2, 101] and camcount[5] == 100


def test_cam_pos_engages_when_the_master_reaches_masterpos() -> None:
    cam = CamFollowers(N, example_ram(0))
    cam.engage_at(1, 3, 0, 4, masterpos=1000, master_position=0)   # the CAM_POS example, axis 2
    assert cam.mode[1] == Follow.AT_POSITION and cam.active and not cam.engaged[1]
    commands = np.full(N, 77, np.int64)
    for master in range(0, 1000, 7):
        assert step(cam, 3, master, commands)[0] == 77
    assert step(cam, 3, 1001, commands) == (77 + 2, 0)   # engaged at 1000, followed 1 count
    assert cam.engaged[1]


def test_cam_pos_engages_from_above_too() -> None:
    cam = CamFollowers(N, example_ram(0))
    cam.engage_at(1, 0, 0, 4, masterpos=4096, master_position=5000)
    commands = np.zeros(N, np.int64)
    assert step(cam, 0, 4100, commands)[0] == 0 and not cam.engaged[1]
    assert step(cam, 0, 4095, commands)[0] == -200 + 199     # phase 999 of the cycle before
    assert cam.engaged[1]


def test_cam_probe_engages_on_its_ext_input_at_the_latched_master_position() -> None:
    cam = CamFollowers(N, example_ram(0))
    cam.engage_on_probe(0, 1, 0, 4, ext=0x02)     # the CAM_PROBE example: master 2, slaves 1, 7
    cam.engage_on_probe(6, 1, 0, 4, ext=0x02)
    cam.engage_on_probe(4, 1, 0, 4, ext=0x04)
    latched = np.array([0, 5000, 0, 0, 0, 0, 0, 0])
    commands = np.arange(N, dtype=np.int64) * 10
    assert not cam.probe(0x01, latched, commands).any()
    assert cam.probe(0x02, latched, commands).tolist() == [True] + [False] * 5 + [True, False]
    targets, _ = cam.targets(np.array([0, 5050, 0, 0, 0, 0, 0, 0]), commands)
    assert targets.tolist() == [100, 10, 20, 30, 40, 50, 160, 70]
    assert cam.mode[4] == Follow.ON_PROBE


def test_cam_off_holds_the_command_and_keeps_camcount() -> None:
    cam = CamFollowers(N, example_ram(0))
    cam.engage(1, 0, 0, 4, 0, 0)
    commands = np.zeros(N, np.int64)
    step(cam, 0, 600, commands)
    cam.disengage(1)
    assert not cam.active
    commands[1] = 280
    assert step(cam, 0, 50, commands) == (280, 2)


def test_an_edited_point_is_followed_after_refresh() -> None:
    ram = example_ram(0)
    cam = CamFollowers(N, ram)
    cam.engage(1, 0, 0, 4, 0, 0)
    commands = np.zeros(N, np.int64)
    assert step(cam, 0, 100, commands)[0] == 200
    place_cam_point(ram, 0, 4, 1, 100, 100)
    assert step(cam, 0, 100, commands)[0] == 200     # the follower's copy is not re-read
    cam.refresh()
    assert step(cam, 0, 100, commands)[0] == 100


def test_engage_rejects_bad_tables_and_self_following() -> None:
    cam = CamFollowers(N, BoardRam())
    with pytest.raises(ValueError):
        cam.engage(1, 0, 1599, 3, 0, 0)
    with pytest.raises(ValueError):
        cam.engage(1, 1, 0, 3, 0, 0)
    with pytest.raises(ValueError):
        cam.engage_on_probe(1, 0, 0, 3, ext=0x20)    # the GEAR_PROBE example's EXT4 (Q-30 item 4)
    assert not cam.active


def test_a_table_without_a_master_cycle_does_not_divide_by_zero() -> None:
    cam = CamFollowers(N, BoardRam())
    cam.engage(1, 0, 0, 3, 0, 5)
    for master in (0, 10, -10):
        assert step(cam, 0, master, np.zeros(N, np.int64))[0] == 5


# --- gearing ---

def gear_step(gears: Gears, positions: dict[int, int], commands: np.ndarray) -> np.ndarray:
    pos = np.zeros(N, np.int64)
    for axis, value in positions.items():
        pos[axis] = value
    return gears.targets(pos, commands)


def test_gear_follows_at_the_1_8_7_ratio_rounding_to_nearest() -> None:
    gears = Gears(N)
    gears.engage(4, 0, 0x0100, leader_position=1000, follower_position=-50)   # 2.0
    gears.engage(5, 0, 0x0020, leader_position=1000, follower_position=0)     # 0.25
    gears.engage(6, 0, -0x0180, leader_position=1000, follower_position=0)    # −3.0
    commands = np.zeros(N, np.int64)
    assert gear_step(gears, {0: 1003}, commands)[4:7].tolist() == [-50 + 6, 1, -9]   # 0.75 → 1
    assert gear_step(gears, {0: 997}, commands)[4:7].tolist() == [-50 - 6, -1, 9]    # −0.75 → −1
    assert gear_step(gears, {0: 1002}, commands)[5] == 1                            # 0.5 → 1


def test_gear_manual_examples_under_twelve_fraction_bits() -> None:
    gears = Gears(N, frac_bits=12)        # the examples' encoding (Q-5)
    gears.engage(4, 0, 0x2000, 0, 0)      # GEAR: axis 5 to axis 1, ratio 2
    gears.engage_on_probe(3, 2, 0x2800, ext=0x08)   # GEAR_PROBE shape: ratio 2.5 on EXT4
    commands = np.zeros(N, np.int64)
    gears.probe(0x08, np.array([0, 0, 400, 0, 0, 0, 0, 0]), commands)
    out = gear_step(gears, {0: 1000, 2: 600}, commands)
    assert out[4] == 2000 and out[3] == 500


def test_gear_pos_engages_when_the_leader_reaches_tp() -> None:
    gears = Gears(N, frac_bits=12)
    gears.engage_at(6, 1, 0x2000, tp=0x3E8, leader_position=0)   # the GEAR_POS example
    commands = np.full(N, 5, np.int64)
    assert gear_step(gears, {1: 999}, commands)[6] == 5
    assert gear_step(gears, {1: 1010}, commands)[6] == 5 + 20
    assert gear_step(gears, {1: 900}, commands)[6] == 5 - 200


def test_gear_survives_a_leader_rollover_and_gear_off_holds() -> None:
    gears = Gears(N)
    gears.engage(1, 0, 0x0100, 2**31 - 10, 2**31 - 10)
    commands = np.zeros(N, np.int64)
    assert gear_step(gears, {0: -2**31 + 9}, commands)[1] == -2**31 + 28   # 19 counts ×2, wrapped
    gears.disengage(1)
    assert gear_step(gears, {0: 0}, commands)[1] == 0 and not gears.active


def test_gear_rejects_bad_ratios_and_formats() -> None:
    with pytest.raises(ValueError):
        Gears(N, frac_bits=16)
    gears = Gears(N)
    with pytest.raises(ValueError):
        gears.engage(1, 0, 0x8000, 0, 0)
    with pytest.raises(ValueError):
        gears.engage(1, 8, 0x100, 0, 0)
    assert not gears.active
