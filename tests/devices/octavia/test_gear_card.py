"""The electronic gearing RTCs on the card, driven through the DPR as a host does [Ch5 GEAR,
GEAR_POS, GEAR_PROBE, GEAR_OFF, GEAR_OFF_ACC, REL_AXMOVE_SLAVE; spec octavia.md §5.7], with the
manual's examples. The ratio is x128 per the text, or x4096 as the examples have it with the
card option `gear_ratio_bits = 12` (spec Q-5)."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.octavia import DspStat1, HostInt

from tests.devices.octavia.cam_host import (
    EN_MOTCP,
    EN_PROBE,
    ESTOP_ACC,
    GEAR,
    GEAR_OFF,
    GEAR_OFF_ACC,
    GEAR_POS,
    GEAR_PROBE,
    POS_PRESET,
    REL_AXMOVE_SLAVE,
    Host,
    mask,
)


def gear_args(leader: int, ratios: dict[int, int]) -> bytes:
    out = bytes((mask(leader), mask(*ratios)))
    for axis in sorted(ratios):
        out += struct.pack("<h", ratios[axis])
    return out


def test_gear_example_is_a_ratio_of_64_under_the_texts_x128_format() -> None:
    """[Ch5 GEAR example] n=01h, m=10h, r=2000h: 2000h/128 = 64 (the text's 1.8.7 format)."""
    host = Host()
    host.maxacc(0x4000, 1, 5)
    host.rtc(GEAR, bytes.fromhex("01 10 0020"))
    host.axmove(1, 10, vel=0x1000)
    host.settle(1, 5)
    assert host.actpos(5) == 640


def test_gear_example_is_a_ratio_of_2_with_gear_ratio_bits_12() -> None:
    """The example's intent, "a gear ratio of 2", with the x4096 option."""
    host = Host(gear_ratio_bits=12)
    host.maxacc(0x4000, 1, 5)
    host.rtc(GEAR, bytes.fromhex("01 10 0020"))
    host.axmove(1, 1000)
    host.settle(1, 5)
    assert host.actpos(5) == 2000
    host.axmove(1, -250)
    host.settle(1, 5)
    assert host.actpos(5) == -500


def test_gear_option_refuses_other_widths() -> None:
    with pytest.raises(ValueError, match="gear_ratio_bits"):
        Host(gear_ratio_bits=8)


def test_gear_pos_example_engages_at_the_leaders_tp() -> None:
    """[Ch5 GEAR_POS example] n=02h, m=40h, r7=2000h (2.0 with x4096), tp7=1000."""
    host = Host(gear_ratio_bits=12)
    host.maxacc(0x4000, 2, 7)
    host.rtc(GEAR_POS, bytes.fromhex("02 40 0020 E8030000"))
    host.axmove(2, 900)
    host.settle(2, 7)
    assert host.actpos(7) == 0
    host.axmove(2, 1500)
    host.settle(2, 7)
    assert host.actpos(7) == 1000
    host.axmove(2, 200)  # back below tp: engaged, the follower follows back
    host.settle(2, 7)
    assert host.actpos(7) == -1600


def test_gear_pos_from_above_engages_when_the_leader_comes_down_to_tp() -> None:
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.axmove(1, 3000, vel=0x80000)
    host.settle(1)
    host.rtc(GEAR_POS, bytes((mask(1), mask(2))) + struct.pack("<hi", 0x80, 2000))  # 1.0 at 2000
    host.axmove(1, 2500)
    host.settle(1, 2)
    assert host.actpos(2) == 0
    host.axmove(1, 1500)
    host.settle(1, 2)
    assert host.actpos(2) == -500


def test_gear_probe_example_with_q_20h_is_ignored() -> None:
    """[Ch5 GEAR_PROBE example] q=20h is not an *EXT code (a manual error, spec Q-30): the
    command is ignored, EN_PROBE stays enabled and its edge interrupts."""
    host = Host(gear_ratio_bits=12)
    host.maxacc(0x4000, 4, 5)
    host.rtc(EN_PROBE, b"\x08")
    host.rtc(GEAR_PROBE, bytes.fromhex("08 10 20 0028"))
    host.control("set_probe", input=4, active=True)
    host.axmove(4, 400)
    host.settle(4, 5)
    assert host.actpos(5) == 0
    status = host.status()
    assert status["dspstat1"] & DspStat1.PROBE and status["src6"] == 0x08


def test_gear_probe_on_ext4_engages_at_the_edge_without_an_interrupt() -> None:
    """The example corrected (q=08h): 2800h = 2.5 with x4096; EN_PROBE disabled, no
    interrupt at the edge [Ch5 GEAR_PROBE Note 1]."""
    host = Host(gear_ratio_bits=12)
    host.maxacc(0x4000, 4, 5)
    host.rtc(EN_PROBE, b"\x08")
    host.rtc(GEAR_PROBE, bytes.fromhex("08 10 08 0028"))
    host.axmove(4, 400)
    host.settle(4, 5)
    assert host.actpos(5) == 0
    assert host.parread(0x17)[3] >> 4 == 0  # EN_PROBE disabled (PARREAD 17h, 0BBh high)
    host.control("set_probe", input=4, active=True)
    host.axmove(4, 800)
    host.settle(4, 5)
    assert host.actpos(5) == 1000
    status = host.status()
    assert status["dspstat1"] == 0 and status["hostint"] & HostInt.STAT1 == 0


def test_gear_off_example_disengages_only_axis_5() -> None:
    """[Ch5 GEAR_OFF example] leader 1, followers 4 and 5; n=10h disengages axis 5."""
    host = Host()
    host.maxacc(0x4000, 1, 4, 5)
    host.rtc(GEAR, gear_args(1, {4: 0x80, 5: 0x100}))
    host.axmove(1, 100)
    host.settle(1, 4, 5)
    host.rtc(GEAR_OFF, b"\x10")
    host.axmove(1, 300)
    host.settle(1, 4, 5)
    assert (host.actpos(4), host.actpos(5)) == (300, 200)


def test_gear_off_acc_example_halts_axis_4_at_maxacc() -> None:
    """[Ch5 GEAR_OFF_ACC example] leader 1, followers 3 and 4; n=08h stops axis 4 at MAXACC
    with motion complete; axis 3 goes on following."""
    host = Host()
    host.maxacc(0x2000, 1, 3, 4)
    host.rtc(EN_MOTCP, bytes((mask(3, 4),)))
    host.rtc(GEAR, gear_args(1, {3: 0x80, 4: 0x80}))
    host.velmode(1, 0x20000)
    host.tick(300)
    host.rtc(GEAR_OFF_ACC, b"\x08")
    speeds = []
    for _ in range(30):
        host.tick()
        speeds.append(host.axis(4)["cmd_vel"] * 200e-6)
    assert speeds[-1] == 0 and speeds[0] > 1.2
    assert max(abs(a - b) for a, b in zip(speeds, speeds[1:], strict=False)) <= 0.25 + 1e-9
    assert abs(host.axis(3)["cmd_vel"] * 200e-6 - 2) < 1e-9
    status = host.status()
    assert status["dspstat1"] & DspStat1.MOTCP and status["src5"] == mask(4)


def rel_slave(axis: int, acc: int, rel_pos: int, rel_vel: int) -> bytes:
    return bytes((mask(axis),)) + struct.pack("<Hii", acc, rel_pos, rel_vel)


def test_rel_axmove_slave_superimposes_a_trapezoid_on_a_geared_slave() -> None:
    """[Ch5 REL_AXMOVE_SLAVE] +1000 counts at 0.25 counts/sample^2 and 4 counts/sample onto a
    follower at ratio 2; it stays geared; motion complete at the end of the move."""
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(EN_MOTCP, bytes((mask(2),)))
    host.rtc(GEAR, gear_args(1, {2: 0x100}))
    host.axmove(1, 100)
    host.settle(1, 2)
    assert host.actpos(2) == 200
    host.ack()
    host.rtc(REL_AXMOVE_SLAVE, rel_slave(2, 0x2000, 1000, 0x40000))
    speeds = []
    for _ in range(400):
        host.tick()
        speeds.append(host.axis(2)["cmd_vel"] * 200e-6)
    assert max(speeds) == pytest.approx(4.0)
    assert max(abs(a - b) for a, b in zip(speeds, speeds[1:], strict=False)) <= 0.25 + 1e-9
    assert host.actpos(2) == 1200
    status = host.status()
    assert status["dspstat1"] & DspStat1.MOTCP and status["src5"] == mask(2)
    host.axmove(1, 150)
    host.settle(1, 2)
    assert host.actpos(2) == 1300


def test_rel_axmove_slave_during_a_leader_move_adds_up() -> None:
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(GEAR, gear_args(1, {2: -0x80}))
    host.axmove(1, 2000, vel=0x10000)
    host.tick(100)
    host.rtc(REL_AXMOVE_SLAVE, rel_slave(2, 0x1000, -300, 0x20000))
    host.settle(1, 2)
    assert host.actpos(2) == -2000 - 300


def test_rel_axmove_slave_on_an_axis_not_geared_is_ignored() -> None:
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(REL_AXMOVE_SLAVE, rel_slave(2, 0x2000, 1000, 0x40000))
    host.tick(500)
    assert host.actpos(2) == 0


def test_pos_preset_of_the_leader_keeps_the_follower_where_it_is() -> None:
    """A redefinition of position is no travel ("without losing position integrity")."""
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(GEAR, gear_args(1, {2: 0x100}))
    host.axmove(1, 100)
    host.settle(1, 2)
    host.rtc(POS_PRESET, bytes((mask(1),)) + struct.pack("<i", 50000))
    host.tick(10)
    assert (host.actpos(1), host.actpos(2)) == (50000, 200)
    host.axmove(1, 50100)
    host.settle(1, 2)
    assert host.actpos(2) == 400


def test_estop_keeps_followers_engaged_behind_their_halting_leader() -> None:
    """[Ch5 GEAR_PROBE Note 2] *ESTOP halts the leader; the followers stay engaged."""
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(ESTOP_ACC, bytes((mask(1, 2),)) + struct.pack("<HH", 0x0800, 0x7FFF))
    host.rtc(GEAR, gear_args(1, {2: 0x180}))  # 3.0
    host.velmode(1, 0x10000)
    host.tick(200)
    host.control("set_estop", active=True)
    host.settle(1, 2)
    assert host.actpos(2) == 3 * host.actpos(1)
    host.control("set_estop", active=False)
    host.axmove(1, host.actpos(1) + 10)
    host.settle(1, 2)
    assert host.actpos(2) == 3 * host.actpos(1)


def test_an_engaged_follower_of_a_still_leader_lets_the_card_rest() -> None:
    """Idle costs nothing (decision 0008): a geared pair at rest is skipped in closed form."""
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(GEAR, gear_args(1, {2: 0x100}))
    host.axmove(1, 100)
    host.settle(1, 2)
    skipped = host.card.quiet_skipped
    host.tick(5000)
    assert host.card.quiet_skipped - skipped > 4000
    host.axmove(1, 200)
    host.settle(1, 2)
    assert host.actpos(2) == 400


def test_a_follower_at_rest_stands_on_its_count_exactly() -> None:
    """With an ideal plant ACTPOS is the command: after every leader move the follower reads
    exactly ratio x travel (the tracked path's last piece is rounded in time, its hold is
    not)."""
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(GEAR, gear_args(1, {2: 0x80}))
    for target in (7, 250, 251, -33, 1000, 999, 4, 5000, 4990, 12345, 0, -777):
        host.axmove(1, target, vel=0x28000, acc=0x3000)
        host.settle(1, 2)
        assert host.actpos(2) == host.actpos(1) == target


def test_gear_off_acc_of_a_follower_at_rest_reports_motion_complete_at_once() -> None:
    """A follower of a still leader is already at rest: it is halted at once, and motion
    complete still reports it [Ch5 GEAR_OFF_ACC, EN_MOTCP]."""
    host = Host()
    host.maxacc(0x2000, 1, 3)
    host.rtc(EN_MOTCP, bytes((mask(3),)))
    host.rtc(GEAR, gear_args(1, {3: 0x80}))
    host.axmove(1, 100)
    host.settle(1, 3)
    host.ack()
    host.rtc(GEAR_OFF_ACC, bytes((mask(3),)))
    host.tick(2)
    status = host.status()
    assert status["dspstat1"] & DspStat1.MOTCP and status["src5"] == mask(3)
    host.axmove(1, 300)
    host.settle(1, 3)
    assert host.actpos(3) == 100


def test_estop_leaves_an_armed_follower_armed() -> None:
    host = Host()
    host.maxacc(0x4000, 1, 2)
    host.rtc(GEAR_POS, bytes((mask(1), mask(2))) + struct.pack("<hi", 0x80, 100))
    host.control("set_estop", active=True)
    host.tick(10)
    host.control("set_estop", active=False)
    host.axmove(1, 300)
    host.settle(1, 2)
    assert host.actpos(2) == 200
