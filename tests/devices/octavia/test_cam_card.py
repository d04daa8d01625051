"""The cam RTCs on the card, driven through the DPR as a host does [Ch5 CAM, CAM_POS, CAM_PROBE,
CAM_OFF, CAM_OFF_ACC, CAM_POINT, LOAD_CAM_TABLE; spec octavia.md §5.6], with the manual's
examples. The plant is ideal: ACTPOS is the command, so positions are exact."""

from __future__ import annotations

import struct

from vdevmaps.octavia import Dpr, DspStat1, HostInt

from tests.devices.octavia.cam_host import (
    CAM,
    CAM_OFF,
    CAM_OFF_ACC,
    CAM_POINT,
    CAM_POS,
    CAM_PROBE,
    EN_MOTCP,
    EN_PROBE,
    ESTOP_ACC,
    LOAD_CAM_TABLE,
    RESET,
    STOP,
    Host,
    cam_points,
    linear_table,
    load_cam_table,
    mask,
)

#: LOAD_CAM_TABLE's example table [Ch5 LOAD_CAM_TABLE]: ratios 2.0, 0.25, -0.2 (x128), 0
MANUAL_TABLE = [(0, 0, 0x0100), (100, 200, 0x0020), (500, 300, -26), (1000, 200, 0)]


def cam_args(master: int, slaves: dict[int, tuple[int, int]]) -> bytes:
    """CAM's bytes: n, m, then tablestart, tablesize per slave in axis order."""
    out = bytes((mask(master), mask(*slaves)))
    for axis in sorted(slaves):
        out += struct.pack("<HH", *slaves[axis])
    return out


def manual_cam(host: Host) -> None:
    """The 4-point example table at index 0; axis 2 follows axis 1 on it."""
    host.stage(cam_points(MANUAL_TABLE))
    host.rtc(LOAD_CAM_TABLE, bytes.fromhex("0000 0400"))  # index 0, numpts 4
    host.maxacc(0x4000, 1, 2)
    host.rtc(CAM, cam_args(1, {2: (0, 4)}))


def test_load_cam_table_example_is_followed_point_by_point() -> None:
    host = Host()
    manual_cam(host)
    # (master, slave, CAMCOUNT2): on the points, inside segments (ratio 0.25, then -26/128)
    # and one whole master cycle on, where the slave is one slave cycle (200) further
    for master, slave, index in ((100, 200, 1), (300, 250, 1), (500, 300, 2), (750, 249, 2),
                                 (1000, 200, 0), (1100, 400, 1), (0, 0, 0)):
        host.axmove(1, master)
        host.settle(1)
        host.tick(2)
        assert (host.actpos(1), host.actpos(2), host.camcount(2)) == (master, slave, index)


def test_load_cam_table_takes_the_data_before_3c2h_clears() -> None:
    """The host may restage as soon as 3C2h reads 00h [Ch5 LOAD_CAM_TABLE sequence]."""
    host = Host()
    manual_cam(host)
    host.stage(cam_points([(0, 0, 0), (100, -5000, 0), (500, -5000, 0), (1000, -9000, 0)]))
    host.axmove(1, 100)
    host.settle(1)
    host.tick(2)
    assert host.actpos(2) == 200


def test_load_cam_table_past_the_1600_points_or_over_67_is_ignored() -> None:
    host = Host()
    host.stage(cam_points(MANUAL_TABLE))
    host.rtc(LOAD_CAM_TABLE, struct.pack("<HH", 1598, 4))  # 1598 + 4 > 1600
    host.rtc(LOAD_CAM_TABLE, struct.pack("<HH", 0, 68))
    host.rtc(LOAD_CAM_TABLE, struct.pack("<HH", 0, 0))
    assert host.control("read_ram", address=0x2000, count=5 * 1600) == [0] * 8000
    host.rtc(LOAD_CAM_TABLE, struct.pack("<HH", 1596, 4))  # the last four points
    assert host.control("read_ram", address=0x2000 + 5 * 1597, count=5) == [100, 0, 200, 0, 32]


def test_cam_example_runs_two_slaves_on_their_own_tables() -> None:
    """[Ch5 CAM example] n=01h, m=06h: axis 2 on 10 points from index 0, axis 3 on 25 points
    from index 100 (tables here: slope 0.5 and -1)."""
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 50))
    load_cam_table(host, 100, linear_table(25, 40, -40))
    host.maxacc(0x4000, 1, 2, 3)
    host.rtc(CAM, bytes.fromhex("01 06 0000 0A00 6400 1900"))
    host.axmove(1, 450)
    host.settle(1)
    host.tick(2)
    assert (host.actpos(2), host.camcount(2)) == (225, 4)
    assert (host.actpos(3), host.camcount(3)) == (-450, 100 + 11)


def test_cam_pos_example_engages_each_slave_where_the_master_reaches_masterpos() -> None:
    """[Ch5 CAM_POS example] n=08h, m=06h: axis 2 at 1000 (10 points from 0), axis 3 at 4096
    with the arguments as printed (start 0019h, size 0064h: 100 points from 25)."""
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 100))  # ratio 1, cycle 900
    load_cam_table(host, 25, linear_table(100, 10, 20))  # ratio 2, cycle 990
    host.maxacc(0x4000, 2, 3, 4)
    host.rtc(CAM_POS, bytes.fromhex("08 06 E8030000 0000 0A00 00100000 1900 6400"))
    host.axmove(4, 900, vel=0x80000)
    host.settle(4)
    assert (host.actpos(2), host.actpos(3)) == (0, 0)
    host.axmove(4, 1500, vel=0x80000)
    host.settle(4, 2, 3)
    assert (host.actpos(2), host.actpos(3)) == (500, 0)
    host.axmove(4, 5000, vel=0x80000)
    host.settle(4, 2, 3)
    assert host.actpos(2) == 4000  # 4000 counts of master travel at ratio 1
    assert host.actpos(3) == 2 * (5000 - 4096)


def test_cam_probe_example_engages_on_ext2_without_an_interrupt_and_disables_en_probe() -> None:
    """[Ch5 CAM_PROBE example] n=02h, m=41h, q=02h: axis 1 on 100 points from 0, axis 7 on 250
    points from 220 (four downloads); "will disable any previously enabled EN_PROBE", and the
    edge "does not generate an interrupt"."""
    host = Host()
    load_cam_table(host, 0, linear_table(100, 10, 10))
    load_cam_table(host, 220, linear_table(250, 10, -30))
    host.maxacc(0x4000, 1, 2, 7)
    host.rtc(EN_PROBE, b"\x02")
    assert host.parread(0x17)[3] >> 4 == 0xF  # the probe enabled (0BBh high nibble)
    host.rtc(CAM_PROBE, bytes.fromhex("02 41 02 0000 6400 DC00 FA00"))
    assert host.parread(0x17)[3] >> 4 == 0  # EN_PROBE disabled by CAM_PROBE
    host.axmove(2, 300)
    host.settle(2)
    assert (host.actpos(1), host.actpos(7)) == (0, 0)  # armed, not engaged
    host.ack()
    host.control("set_probe", input=2, active=True)
    host.axmove(2, 500)
    host.settle(2)
    host.tick(2)
    assert (host.actpos(1), host.actpos(7)) == (200, -600)
    assert host.camcount(7) == 220 + 20
    status = host.status()
    assert status["dspstat1"] & DspStat1.PROBE == 0 and status["src6"] == 0
    assert host.dpr.read(Dpr.PRB, 16) == bytes(16)  # nothing latched


def test_cam_probe_waits_for_its_own_input() -> None:
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 100))
    host.maxacc(0x4000, 1, 2)
    host.rtc(CAM_PROBE, bytes.fromhex("01 02 08 0000 0A00"))  # *EXT4
    host.control("set_probe", input=2, active=True)
    host.axmove(1, 300)
    host.settle(1)
    assert host.actpos(2) == 0
    host.control("set_probe", input=4, active=True)
    host.axmove(1, 500)
    host.settle(1)
    host.tick(2)
    assert host.actpos(2) == 200


def test_cam_off_example_disengages_slaves_3_and_4_at_once() -> None:
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 100))
    host.maxacc(0x4000, 1, 3, 4)
    host.rtc(CAM, cam_args(1, {3: (0, 10), 4: (0, 10)}))
    host.axmove(1, 200)
    host.settle(1)
    host.rtc(CAM_OFF, b"\x0c")  # [Ch5 CAM_OFF example]
    host.axmove(1, 700)
    host.settle(1)
    assert (host.actpos(3), host.actpos(4)) == (200, 200)


def test_cam_off_acc_example_halts_slaves_4_and_8_at_maxacc_then_motion_complete() -> None:
    """[Ch5 CAM_OFF_ACC example] n=88h: the slaves come to a stop at MAXACC (0.125 here) while
    the master runs on; motion complete reports both."""
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 100))
    host.maxacc(0x1000, 1, 4, 8)
    host.rtc(EN_MOTCP, b"\x88")
    host.rtc(CAM, cam_args(1, {4: (0, 10), 8: (0, 10)}))
    host.velmode(1, 0x30000)  # 3 counts/sample
    host.tick(400)
    host.ack()
    host.rtc(CAM_OFF_ACC, b"\x88")
    vel, steps = [], 0
    while host.axis(4)["cmd_vel"] != 0 and steps < 200:
        host.tick()
        vel.append(host.axis(4)["cmd_vel"] * 200e-6)
        steps += 1
    assert 20 <= steps < 200  # 3 counts/sample at 0.125 per sample: 24 samples
    assert max(abs(a - b) for a, b in zip(vel, vel[1:], strict=False)) <= 0.125 + 1e-9
    host.tick(2)
    assert host.axis(8)["cmd_vel"] == 0 and host.axis(1)["cmd_vel"] != 0
    status = host.status()
    assert status["dspstat1"] & DspStat1.MOTCP and status["src5"] == 0x88
    assert status["hostint"] & HostInt.STAT1


def test_cam_point_example_replaces_the_third_point_and_the_card_computes_the_ratios() -> None:
    """[Ch5 CAM_POINT example] a 10-point table at 500; its third point becomes (1000, 3000).
    The table here is built point by point with CAM_POINT too (no ratios given)."""
    host = Host()
    for j in range(10):
        host.rtc(CAM_POINT, struct.pack("<HHHii", 500, 10, j, 500 * j, 500 * j))
    host.rtc(CAM_POINT, bytes.fromhex("F401 0A00 0200 E8030000 B80B0000"))
    host.maxacc(0x4000, 1, 2)
    host.rtc(CAM, cam_args(1, {2: (500, 10)}))
    # slopes now 1, (3000-500)/500 = 5, (1500-3000)/500 = -3, then 1
    for master, slave in ((500, 500), (750, 1750), (1000, 3000), (1250, 2250), (2000, 2000)):
        host.axmove(1, master, vel=0x8000)
        host.settle(1)
        host.tick(2)
        assert host.actpos(2) == slave, master


def test_engaging_behind_a_moving_master_accelerates_at_most_at_maxacc_then_locks() -> None:
    """MAXACC bounds the engagement transient (spec §5.6); then the slave is exactly on the
    cam: its position is the master's travel since engagement (ratio 1)."""
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 100))
    host.maxacc(0x0800, 1, 2)  # 0.0625 counts/sample^2
    host.velmode(1, 0x40000)  # 4 counts/sample
    host.tick(300)
    host.rtc(CAM, cam_args(1, {2: (0, 10)}))
    m0 = host.axis(1)["encoder"] - 4  # the master's position when CAM ran (one sample back)
    vel = []
    for _ in range(600):
        host.tick()
        vel.append(host.axis(2)["cmd_vel"] * 200e-6)
    acc = [b - a for a, b in zip(vel, vel[1:], strict=False)]
    assert max(abs(a) for a in acc) <= 0.0625 + 1e-9
    assert max(vel) > 4.5  # it caught up: faster than the master for a while
    # locked: the master's travel since CAM, one sample behind it
    assert abs(host.axis(2)["cmd_pos"] - (host.axis(1)["encoder"] - 4 - m0)) <= 1
    assert abs(vel[-1] - 4) < 1e-9


def test_estop_halts_the_master_and_the_slaves_follow_it_engaged() -> None:
    """[Ch5 CAM Note] *ESTOP halts the master and subsequently the slaves, which stay
    engaged."""
    host = Host()
    load_cam_table(host, 0, linear_table(10, 100, 200))  # ratio 2
    host.maxacc(0x8000, 1, 2)
    host.rtc(ESTOP_ACC, bytes((mask(1),)) + struct.pack("<H", 0x1000))
    host.rtc(CAM, cam_args(1, {2: (0, 10)}))
    host.velmode(1, 0x20000)
    host.tick(200)
    host.control("set_estop", active=True)
    host.settle(1)
    host.tick(3)
    master = host.actpos(1)
    assert host.actpos(2) == 2 * master
    assert host.u8(Dpr.HOSTINT1) & HostInt.ESTOP
    host.control("set_estop", active=False)
    host.axmove(1, master + 150)
    host.settle(1)
    host.tick(2)
    assert host.actpos(2) == 2 * (master + 150)


def test_camcount_waits_while_the_host_holds_481h() -> None:
    host = Host()
    manual_cam(host)
    host.dpr.write(Dpr.HOSTACC_COUNT, b"\x01")
    host.axmove(1, 300)
    host.settle(1)
    assert host.dpr.read(Dpr.CAMCOUNT + 2, 2) == b"\x00\x00"
    host.dpr.write(Dpr.HOSTACC_COUNT, b"\x00")
    host.tick()
    assert host.camcount(2) == 1


def test_reset_keeps_the_cam_table_and_disengages_the_slaves() -> None:
    """[Ch7] RESET does not clear the cam tables."""
    host = Host()
    manual_cam(host)
    host.rtc(RESET, b"\xaa\xaa")
    host.axmove(1, 100)
    host.settle(1)
    assert host.actpos(2) == 0  # disengaged by the reset
    host.maxacc(0x4000, 1, 2)
    host.rtc(CAM, cam_args(1, {2: (0, 4)}))
    host.axmove(1, 300)
    host.settle(1)
    host.tick(2)
    assert host.actpos(2) == 225  # 200 of master travel: 2.0 on 100 counts, 0.25 on the next 100


def test_stop_on_a_slave_disengages_it() -> None:
    """spec Q-21: STOP (or DDAC) on an engaged slave ends its following."""
    host = Host()
    manual_cam(host)
    host.axmove(1, 50)
    host.settle(1)
    host.rtc(STOP, bytes((mask(2),)))
    host.axmove(1, 100)
    host.settle(1)
    assert host.actpos(2) == 100


def test_cam_without_a_single_master_is_ignored() -> None:
    host = Host()
    host.stage(cam_points(MANUAL_TABLE))
    host.rtc(LOAD_CAM_TABLE, bytes.fromhex("0000 0400"))
    host.maxacc(0x4000, 1, 2, 3)
    host.rtc(CAM, bytes((mask(1, 3), mask(2))) + struct.pack("<HH", 0, 4))
    host.rtc(CAM, cam_args(2, {2: (0, 4)}))  # its own master
    host.rtc(CAM, cam_args(1, {2: (1598, 4)}))  # past the 1600 points
    host.axmove(1, 100)
    host.axmove(3, 100)
    host.settle(1)
    assert host.actpos(2) == 0


def test_quiet_ticks_in_closed_form_change_nothing_the_host_sees() -> None:
    """Decision 0008: the same host session with the card skipping its quiet ticks and with it
    ticking every sample leaves the same DPR and positions; the skipping one skipped."""

    def session(skip: bool) -> tuple[list[bytes], int]:
        host = Host()
        host.card.skip_quiet = skip
        seen = []
        load_cam_table(host, 0, linear_table(10, 100, 300))
        host.maxacc(0x4000, 1, 2, 3)
        host.rtc(CAM_POS, bytes((mask(1), mask(2))) + struct.pack("<iHH", 500, 0, 10))
        host.rtc(0x9C, bytes((mask(1), mask(3))) + struct.pack("<h", -0x40))  # GEAR -0.5
        for target, pause in ((300, 900), (800, 3000), (800, 50), (-100, 4000)):
            host.axmove(1, target)
            host.tick(pause)
            host.rtc(0xAD, bytes.fromhex("01 07") + struct.pack("<q", target)[:6])
            host.rtc(0xB2, bytes.fromhex("01 07"))
            host.tick(777)
            seen.append(bytes(host.dpr.buf) + b"".join(
                struct.pack("<dd", host.axis(a)["cmd_pos"], host.axis(a)["cmd_vel"])
                for a in (1, 2, 3)))
        return seen, host.card.quiet_skipped

    ticked, none = session(False)
    skipped, count = session(True)
    assert none == 0 and count > 5000
    assert skipped == ticked
