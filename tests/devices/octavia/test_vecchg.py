"""VECCHG: the contouring axis set changes at a ring slot; three may wait, a fourth overflows
[Ch5 VECCHG; Ch6 Contouring; Ch7 Table 7-1; spec octavia.md §3.2, §5.4]."""

from __future__ import annotations

from vdevmaps.octavia import Dpr, DspStat1, HostInt

from tests.devices.octavia.contour_host import Host, vel_word

N = 25


def test_vecchg_example_axes_1_2_3_from_slot_23() -> None:
    """VECCHG n=07h, m=17h [Ch5 VECCHG example]: "begin 2nd order contouring in axes 1, 2, and 3
    after the 23rd segment move command": START n=01h, slots 0..22 are axis 1's, from slot 23
    on each point is three slots (axes 1, 2, 3 in that order)."""
    host = Host()
    entries = [(100 * j, vel_word(4.0)) for j in range(1, 24)]
    for i in range(1, 11):
        entries += [(100 * (23 + i), vel_word(4.0)), (50 * i, vel_word(2.0)),
                    (-30 * i, vel_word(-1.2))]
    host.put(entries)
    assert host.inptr() == 53
    host.rtc("START", {"n": 0x01})
    host.rtc("VECCHG", {"n": 0x07, "m": 0x17})
    host.run(23 * N - 2)
    assert [host.actpos(a) for a in (1, 2, 3)] == [2300, 0, 0]
    assert host.outptr() == 23
    for i in range(1, 11):
        host.run(N)
        assert [host.actpos(a) for a in (1, 2, 3)] == [100 * (23 + i), 50 * i, -30 * i]
        assert host.outptr() == 23 + 3 * i


def test_vecchg_dropping_an_axis_holds_it_and_the_rest_read_one_slot_a_point() -> None:
    """Axes 1 and 2, then from slot 10 axis 2 alone: axis 1 holds its last point, axis 2 reads
    every slot."""
    host = Host()
    entries = []
    for j in range(1, 6):
        entries += [(100 * j, vel_word(4.0)), (-10 * j, vel_word(-0.4))]
    entries += [(-10 * j, vel_word(-0.4)) for j in range(6, 16)]
    host.put(entries)
    host.rtc("START", {"n": 0x03})
    host.rtc("VECCHG", {"n": 0x02, "m": 10})
    host.run(15 * N - 2)
    assert (host.actpos(1), host.actpos(2)) == (500, -150)
    assert host.outptr() == 20


def test_a_fourth_pending_vecchg_overflows_and_is_discarded() -> None:
    """Triple-buffered: three VECCHGs wait; a fourth posts 1FFEh b3 ("vector change buffer
    overflow") and is discarded (its axis 2 never takes the slots); once one was used another
    fits."""
    host = Host()
    host.put([(10 * j, vel_word(0.4)) for j in range(1, 51)])
    host.rtc("START", {"n": 0x01})
    host.acknowledge()
    for m in (10, 20, 30):
        host.rtc("VECCHG", {"n": 0x01, "m": m})
    assert host.hostint() == 0
    host.rtc("VECCHG", {"n": 0x02, "m": 40})
    assert host.hostint() == HostInt.VECCHG_OVERFLOW
    host.acknowledge()
    host.run(12 * N)  # slot 10's change is used: room for one more
    host.rtc("VECCHG", {"n": 0x01, "m": 44})
    assert host.hostint() == 0
    host.run(40 * N)
    assert (host.actpos(1), host.actpos(2)) == (500, 0)
    assert host.outptr() == 50


def test_an_axis_joining_while_it_runs_an_axmove_is_conflicting_commands_its_slots_unused() -> None:
    """VECCHG to axes 1 and 2 while axis 2 runs an AXMOVE: at the change, "conflicting commands"
    (007h = 02h); axis 2's move goes on, its slots are read and unused, axis 1 contours on."""
    host = Host()
    entries = [(100 * j, vel_word(4.0)) for j in range(1, 5)]
    for j in range(5, 11):
        entries += [(100 * j, vel_word(4.0)), (-77, vel_word(0.0))]
    host.put(entries)
    host.rtc("START", {"n": 0x01})
    host.rtc("AXMOVE", {"n": 0x02}, [{"acc": 0x100, "pos": 1_000_000, "vel": 0x20000}])
    host.rtc("VECCHG", {"n": 0x03, "m": 4})
    host.acknowledge()
    host.run(4 * N - 3)
    assert host.stat1() == 0
    host.run(1)
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x02
    host.run(6 * N - 1)
    assert host.actpos(1) == 1000 and host.outptr() == 16
    assert host.actpos(2) > 0
