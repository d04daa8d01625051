"""START, STOP and the conflicts of contouring with the other motion commands [Ch5 START,
STOP; Ch6 Contouring; Ch7 Table 7-1 "Conflicting Commands"; spec octavia.md §3.2, §4.3]."""

from __future__ import annotations

from vdevmaps.octavia import Dpr, DspStat1, HostInt

from tests.devices.octavia.contour_host import Host, vel_word

N = 25
MAXACC = 0x0800  # 1.15: 1/16 count/sample²


def ramp(points: int, step: int, first: int = 1) -> list[tuple[int, int]]:
    return [(step * j, vel_word(step / N)) for j in range(first, first + points)]


def two_axes(points: int, first: int = 1) -> list[tuple[int, int]]:
    """Axes 1 and 2 at 10 and −4 counts/sample."""
    out = []
    for (p1, v1), (p2, v2) in zip(ramp(points, 250, first), ramp(points, -100, first), strict=True):
        out += [(p1, v1), (p2, v2)]
    return out


def axmove(host: Host, n: int, pos: int) -> None:
    host.rtc("AXMOVE", {"n": n}, [{"acc": 0x0100, "pos": pos, "vel": 0x00080000}])


def test_start_names_an_axis_in_axmove_motion_conflicting_commands_and_nothing_starts() -> None:
    """START n=06h [Ch5 START example] while axis 2 runs an AXMOVE: 000h b6, 007h = 02h, the
    START discarded whole (axis 3 stays, OUTPTR too); the AXMOVE goes on."""
    host = Host()
    host.put([(1000, 0), (2000, 0)] * 3)
    axmove(host, 0x02, 100_000)
    host.acknowledge()
    host.rtc("START", {"n": 0x06})
    assert host.hostint() == HostInt.STAT1 and host.stat1() == DspStat1.CONFLICT
    assert host.u8(Dpr.INTAXIS_CONFLICT) == 0x02
    host.run(3 * N)
    assert host.outptr() == 0 and host.actpos(3) == 0 and host.actpos(2) > 0
    assert not host.fw.contour.running


def test_start_names_a_velmode_axis_conflicting_commands() -> None:
    host = Host()
    host.rtc("MAXACC", {"n": 0x01}, [{"acc": MAXACC}])
    host.rtc("VELMODE", {"n": 0x01}, [{"vel": 0x00040000}])
    host.acknowledge()
    host.put(ramp(3, 100))
    host.rtc("START", {"n": 0x01})
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x01
    assert not host.fw.contour.running and host.outptr() == 0


def test_start_for_an_axis_halting_under_stop_is_rtc_ignored() -> None:
    """An axis halting under STOP: START is ignored with "RTC Command Ignored" (000h b7, 008h)
    [Ch5 STOP]."""
    host = Host()
    host.rtc("MAXACC", {"n": 0x01}, [{"acc": 0x0040}])
    axmove(host, 0x01, 1_000_000)
    host.run(200)
    host.rtc("STOP", {"n": 0x01})
    host.acknowledge()
    host.put(ramp(3, 100))
    host.rtc("START", {"n": 0x01})
    assert host.stat1() == DspStat1.IGNORED and host.u8(Dpr.INTAXIS_IGNORED) == 0x01
    assert not host.fw.contour.running


def test_start_while_contouring_is_ignored() -> None:
    """"START will be ignored if contouring is in progress" [Ch5 START Note]: no report, the
    axes in contour stay those of the first START."""
    host = Host()
    host.put(ramp(10, 100))
    host.rtc("START", {"n": 0x01})
    host.acknowledge()
    host.rtc("START", {"n": 0x02})
    assert host.hostint() == 0
    assert host.parread(0x18)[3] == 0x01
    host.run(10 * N)
    assert host.actpos(1) == 1000 and host.actpos(2) == 0


def test_axmove_and_velmode_for_a_contouring_axis_are_conflicting_commands() -> None:
    """Ch6: "VELMODE or AXMOVE for an axis while that axis is involved in contouring motion ...
    'conflicting commands detected' ... and the second command will be ignored"."""
    host = Host()
    host.rtc("MAXACC", {"n": 0x01}, [{"acc": MAXACC}])
    host.put(ramp(12, 100))
    host.rtc("START", {"n": 0x01})
    host.acknowledge()
    axmove(host, 0x01, -50_000)
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x01
    host.acknowledge()
    host.rtc("VELMODE", {"n": 0x01}, [{"vel": -0x00100000}])
    assert host.stat1() == DspStat1.CONFLICT
    host.run(12 * N)
    assert host.actpos(1) == 1200


def test_parread_18h_reports_the_contouring_axes_of_both_banks() -> None:
    """PARREAD 18h: 0BBh low nibble = axes 1-4 in contouring operation, 8BBh = axes 5-8."""
    host = Host()
    host.put([(100 * j, 0) for j in range(1, 11) for _ in (1, 6)])
    host.rtc("START", {"n": 0x21})
    data = host.parread(0x18)
    assert (data[3], data[11]) == (0x01, 0x02)
    assert data[:3] == bytes(3)


def test_stop_decelerates_contouring_axes_at_maxacc_leaves_the_ring_and_reports_completion() -> None:
    """STOP n=03h while axes 1 and 2 contour at 10 and −4 counts/sample: they decelerate at
    MAXACC (1/16 count/sample²: 160 and 64 samples), motion complete follows ("upon completion
    of stop trajectory Mx4 Octavia generates motion complete interrupt", Ch5 STOP); the ring is
    left as it is: OUTPTR stays until the host clears it (INPTR := OUTPTR) and STARTs again."""
    host = Host()
    host.rtc("MAXACC", {"n": 0x03}, [{"acc": MAXACC}, {"acc": MAXACC}])
    host.rtc("EN_MOTCP", {"n": 0x03})
    host.put(two_axes(30))
    host.rtc("START", {"n": 0x03})
    host.run(10 * N - 1)
    assert (host.actpos(1), host.actpos(2)) == (2500, -1000)
    host.acknowledge()
    host.rtc("STOP", {"n": 0x03})
    out = host.outptr()
    speeds = []
    for _ in range(200):
        before = host.actpos(1)
        host.run(1)
        speeds.append(host.actpos(1) - before)
    assert speeds[0] in (9, 10) and speeds[-1] == 0
    assert all(b <= a + 1 for a, b in zip(speeds, speeds[1:], strict=False))
    assert abs(host.actpos(1) - (2500 + 10 + 800)) <= 12  # v²/2a = 800 counts
    assert abs(host.actpos(2) - (-1000 - 4 - 128)) <= 6
    assert host.stat1() == DspStat1.MOTCP and host.u8(Dpr.INTAXIS_MOTCP) == 0x03
    assert host.outptr() == out == 20 and host.inptr() == 60  # 20 slots read, 40 left
    host.write(Dpr.INPTR, bytes((out,)))  # the host clears the ring
    host.put([(0, vel_word(0.0)), (0, vel_word(0.0))])
    host.rtc("START", {"n": 0x03})
    host.run(N)
    assert (host.actpos(1), host.actpos(2)) == (0, 0)


def test_stopping_one_contouring_axis_lets_the_other_contour_on_with_the_layout_kept() -> None:
    """STOP of axis 1 of axes 1 and 2: axis 1 halts at MAXACC, axis 2 goes on through its points
    (its slots still every second one: the stopped axis's slots are read and unused)."""
    host = Host()
    host.rtc("MAXACC", {"n": 0x01}, [{"acc": MAXACC}])
    host.put(two_axes(30))
    host.rtc("START", {"n": 0x03})
    host.run(10 * N - 1)
    host.rtc("STOP", {"n": 0x01})
    host.run(10 * N - 1)
    assert host.actpos(2) == -2000 and host.outptr() == 40
    assert abs(host.actpos(1) - 3310) <= 12
    assert host.parread(0x18)[:4] == bytes((0, 0, 0, 0x02))


def test_estop_halts_the_contouring_axes_at_estop_acc_and_ends_the_contour() -> None:
    """*ESTOP going active: 1FFEh b2, every axis halts at its ESTOP_ACC [Ch7 Table 7-1]; the
    contour ends where it was (OUTPTR stays), and START is "RTC ignored" while *ESTOP holds."""
    host = Host()
    host.rtc("ESTOP_ACC", {"n": 0x03}, [{"acc": 0x4000}, {"acc": 0x4000}])
    host.put(two_axes(30))
    host.rtc("START", {"n": 0x03})
    host.run(5 * N)
    host.acknowledge()
    host.card.control("set_estop", {"active": True})
    host.run(1)
    assert host.hostint() & HostInt.ESTOP
    out = host.outptr()
    host.run(100)  # 10 counts/sample at 1/2: 20 samples
    settled = (host.actpos(1), host.actpos(2))
    host.run(50)
    assert (host.actpos(1), host.actpos(2)) == settled and host.outptr() == out
    assert 1250 < settled[0] < 1250 + 10 + 10 * 10 + 10
    host.acknowledge()
    host.rtc("START", {"n": 0x03})
    assert host.stat1() == DspStat1.IGNORED and host.u8(Dpr.INTAXIS_IGNORED) == 0x03


def test_gear_naming_a_contouring_axis_as_its_slave_is_conflicting_commands() -> None:
    """A slave that contours makes GEAR conflict: the command is discarded with "conflicting
    commands" (000h b6, 007h), as Ch7 Table 7-1 rules for contouring against RTC motion (README
    assumption); the contour goes on to its end."""
    host = Host()
    host.put(ramp(12, 100))
    host.rtc("START", {"n": 0x01})
    host.acknowledge()
    host.rtc("GEAR", {"n": 0x02, "m": 0x01}, [{"r": 0x0100}])  # leader 2, slave 1 (contouring)
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x01
    host.run(12 * N)
    assert host.actpos(1) == 1200


def test_cam_naming_a_contouring_axis_as_its_slave_is_conflicting_commands() -> None:
    """The same for CAM [Ch5 CAM; Ch7 Table 7-1]."""
    host = Host()
    host.put(ramp(12, 100))
    host.rtc("START", {"n": 0x01})
    host.acknowledge()
    host.rtc("CAM", {"n": 0x02, "m": 0x01}, [{"tablestart": 0, "tablesize": 10}])
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x01
    host.run(12 * N)
    assert host.actpos(1) == 1200
