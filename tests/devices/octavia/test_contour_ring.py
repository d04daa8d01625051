"""Ring-buffer contouring, 2nd order, driven through the DPR as a host would [Ch5 BTRATE,
EN_BUFBRK, START; Ch6 Contouring, Fig. 6-4; Ch7 Data Run-Out; spec octavia.md §2.5.4, §5.4].

The card has an ideal plant: ACTPOS shows the commanded position (whole counts). START runs in
sample 1 of the first interval, so point j is reached after 25·j samples (BTRATE m = 0)."""

from __future__ import annotations

import math
import struct

from vdevmaps.octavia import RING_SLOTS, Dpr, DspStat1, HostInt, slot_offset

from tests.devices.octavia.contour_host import Host, vel_word

N = 25  # BTRATE m = 0 (the default): 5 ms per point


def trace(host: Host, axes: tuple[int, ...], samples: int) -> list[tuple[int, ...]]:
    """ACTPOS of `axes` after each of the next `samples` samples."""
    out = []
    for _ in range(samples):
        host.run(1)
        out.append(tuple(host.actpos(a) for a in axes))
    return out


def ramp(points: int, step: int) -> list[tuple[int, int]]:
    """One axis at a constant velocity from rest at 0: point j at step·j, velocity step/N
    (consistent data but for the first block, which starts from rest)."""
    return [(step * j, vel_word(step / N)) for j in range(1, points + 1)]


def test_fig_6_4_ten_points_of_axes_1_and_3_fill_20_slots_read_in_increasing_axis_order() -> None:
    """Fig. 6-4: 10 points for axes 1 and 3 are 160 bytes from OUTPTR (addr y): slot 0 is axis 1
    point 1, slot 1 axis 3 point 1, ..., y+152..y+159 axis 3 point 10; INPTR ends 20 slots on.
    Each axis follows its own entries, one point per interval; axis 2 stays put."""
    host = Host()
    x1 = [100 * (i + 1) for i in range(10)]
    x3 = [-7 * (i + 1) ** 2 for i in range(10)]
    entries = []
    for p1, p3 in zip(x1, x3, strict=True):
        entries += [(p1, vel_word(4.0)), (p3, vel_word(-1.0))]
    host.put(entries)
    y = slot_offset(host.outptr())
    assert (host.outptr(), host.inptr()) == (0, 20)
    assert host.i32(y) == x1[0] and host.i32(y + 8) == x3[0] and host.i32(y + 16) == x1[1]
    assert host.i32(y + 152) == x3[9] and host.i32(y + 156) == -65536
    host.rtc("START", {"n": 0x05})
    assert host.outptr() == 2  # the first interval's two slots, read at START's sample
    seen = trace(host, (1, 2, 3), 10 * N - 1)  # samples 2 .. 250
    for i in range(10):
        assert seen[N * (i + 1) - 2] == (x1[i], 0, x3[i])
        assert seen[N * (i + 1) - 3] != (x1[i], 0, x3[i])
    assert host.outptr() == 20 and host.fw.contour.running
    host.run(1)  # the next fetch finds the ring empty, the axes moving
    assert host.hostint() & HostInt.RUN_OUT


def test_btrate_example_10_ms_interpolates_each_point_for_50_samples() -> None:
    """BTRATE m=01h: 10 ms per point [Ch5 BTRATE example]: from rest to (500, 20 counts/sample)
    the block accelerates evenly (p = 0.2·t²) and reaches 500 after 50 samples, not 25; then to
    (1000, 0). PARREAD 1Dh: 2nd order (0B9h = 00h), rate 01h."""
    host = Host()
    host.rtc("BTRATE", {"m": 0x01})
    host.put([(500, vel_word(20.0)), (1000, vel_word(0.0))])
    host.rtc("START", {"n": 0x01})
    host.run(N - 1)
    assert host.actpos(1) == 125  # 0.2·25²: at 5 ms the point would be reached here
    host.run(N)
    assert host.actpos(1) == 500 and host.outptr() == 1
    host.run(1)
    assert host.outptr() == 2 and host.actpos(1) == 520  # 500 + 20·1 − 0.2·1² = 519.8
    host.run(2 * N - 1)
    assert host.actpos(1) == 1000
    assert host.parread(0x1D)[:4] == bytes((0x00, 0x00, 0x01, 0x00))


def test_each_btrate_code_sets_its_interval() -> None:
    """m = 0..3: 5, 10, 15, 20 ms; another m leaves the rate as it was."""
    for m, samples in ((0, 25), (1, 50), (2, 75), (3, 100), (7, 100)):
        host = Host()
        if m == 7:
            host.rtc("BTRATE", {"m": 3})
        host.rtc("BTRATE", {"m": m})
        host.put([(1000, vel_word(0.0))])
        host.rtc("START", {"n": 0x02})
        host.run(samples - 2)
        assert host.actpos(2) != 1000
        host.run(1)
        assert host.actpos(2) == 1000


def test_a_contour_ending_at_rest_holds_with_no_motion_complete_and_start_runs_again() -> None:
    """An empty ring with every end velocity 0 ends the contour: the axes hold, no motion
    complete even with EN_MOTCP on [Ch5 EN_MOTCP], no run-out; START is accepted again."""
    host = Host()
    host.rtc("EN_MOTCP", {"n": 0xFF})
    host.put([(250, vel_word(20.0)), (500, vel_word(0.0))])
    host.rtc("START", {"n": 0x01})
    host.run(2 * N + 10)
    assert host.actpos(1) == 500 and not host.fw.contour.running
    assert host.hostint() & (HostInt.RUN_OUT | HostInt.STAT1) == 0
    assert host.parread(0x18)[3] == 0  # 0BBh: no axis contouring
    host.put([(0, vel_word(0.0))])
    host.rtc("START", {"n": 0x01})
    host.run(N)
    assert host.actpos(1) == 0


def test_data_run_out_holds_the_axes_at_the_last_point() -> None:
    """The ring empties while the axis moves: 1FFEh b5 at the fetch that finds it empty, the
    axis holds at the last point (velocity 0) and the contour ends [Ch7 Data Run-Out]."""
    host = Host()
    host.rtc("EN_MOTCP", {"n": 0xFF})
    host.put(ramp(20, 250))
    host.rtc("START", {"n": 0x01})
    host.run(20 * N - 1)
    assert host.actpos(1) == 5000 and host.hostint() & HostInt.RUN_OUT == 0
    host.run(1)
    assert host.hostint() & HostInt.RUN_OUT
    assert host.stat1() & DspStat1.MOTCP == 0
    host.run(100)
    assert host.actpos(1) == 5000
    assert host.fw.core.axes.cmd_vel[0] == 0.0
    assert host.parread(0x18)[3] == 0


def test_the_card_reads_all_83_slots_of_a_full_ring_and_takes_inptr_equal_outptr_as_empty() -> None:
    """Full is one slot empty: 83 slots are read; INPTR == OUTPTR is an empty ring (84 slots
    written with INPTR back at OUTPTR start nothing)."""
    host = Host()
    host.put([(10 * j, vel_word(0.4)) for j in range(1, 83)] + [(830, vel_word(0.0))])
    assert host.inptr() == 83
    host.rtc("START", {"n": 0x01})
    host.run(83 * N)
    assert host.outptr() == 83 and host.actpos(1) == 830 and not host.fw.contour.running
    for s in range(RING_SLOTS):  # a careless host fills all 84: INPTR wraps onto OUTPTR
        host.write(slot_offset(s), struct.pack("<ii", 5000, 0))
    host.write(Dpr.INPTR, bytes((host.outptr(),)))
    host.rtc("START", {"n": 0x01})
    host.run(2 * N)
    assert host.actpos(1) == 830 and host.outptr() == 83 and not host.fw.contour.running


def test_buffer_breakpoint_fires_once_per_fall_below_the_threshold() -> None:
    """EN_BUFBRK 1Eh (30 slots) [Ch5 EN_BUFBRK example]: 40 slots of one axis; the read that
    leaves 29 posts 1FFEh b0, the next reads do not; a refill above 30 re-arms it, the next fall
    posts again; DISABL_INT b0 turns it off."""
    host = Host()
    host.put(ramp(40, 10))
    host.rtc("EN_BUFBRK", {"buffbrk": 0x1E})
    host.rtc("START", {"n": 0x01})  # the first read leaves 39
    host.run(9 * N)  # ... the 10th leaves 30
    assert host.hostint() & HostInt.BUFBRK == 0
    host.run(N)  # the 11th leaves 29
    assert host.hostint() & HostInt.BUFBRK
    assert (host.inptr() - host.outptr()) % RING_SLOTS == 29
    host.acknowledge()
    host.run(5 * N)
    assert host.hostint() & HostInt.BUFBRK == 0
    host.put([(10 * j, vel_word(0.4)) for j in range(41, 51)])  # 24 + 10 = 34 slots
    host.run(4 * N)  # reads at 34, 33, 32, 31 leave 30
    assert host.hostint() & HostInt.BUFBRK == 0
    host.run(N)  # 30 -> 29
    assert host.hostint() & HostInt.BUFBRK
    host.acknowledge()
    host.rtc("DISABL_INT", {"n": 0x01}, [{"mask": 0x01}])
    host.put([(10 * j, vel_word(0.4)) for j in range(51, 61)])
    host.run(15 * N)
    assert host.hostint() & HostInt.BUFBRK == 0


def test_a_streamed_contour_wraps_the_ring_refilled_at_inptr_on_each_buffer_breakpoint() -> None:
    """The Fig. 6-5 loop: 300 points of axes 1 and 2 (600 slots, 7 times round the ring), the
    first 41 loaded before START, the rest written at INPTR whenever the buffer breakpoint
    (30 slots) fires; the axes pass through every point at its interval's end, never run out,
    and end at rest (no interrupt but the breakpoints)."""
    host = Host()
    total = 300
    a, b = 40_000, 15_000

    def point(j: int) -> list[tuple[int, int]]:
        th = math.pi * j / total
        x, vx = a * (1 - math.cos(th)) / 2, a * math.pi / (2 * total) * math.sin(th) / N
        y, vy = b * math.sin(th) ** 2, b * math.pi / total * math.sin(2 * th) / N
        return [(round(x), vel_word(vx)), (round(y), vel_word(vy))]

    sent = 41
    host.acknowledge()  # the power-up "reset finished"
    host.put([e for j in range(1, sent + 1) for e in point(j)])
    host.rtc("EN_BUFBRK", {"buffbrk": 0x1E})
    host.rtc("START", {"n": 0x03})
    breaks = 0
    seen = []
    for _ in range(total * N + N):
        host.run(1)
        seen.append((host.actpos(1), host.actpos(2)))
        if host.hostint():
            assert host.hostint() == HostInt.BUFBRK
            host.acknowledge()
            breaks += 1
            room = min(host.free_slots() // 2, total - sent)
            host.put([e for j in range(sent + 1, sent + room + 1) for e in point(j)])
            sent += room
    assert sent == total and breaks >= 10
    assert host.outptr() == 2 * total % RING_SLOTS and not host.fw.contour.running
    for j in range(1, total + 1):
        want = tuple(pos for pos, _ in point(j))
        assert seen[N * j - 2] == want, j
    assert seen[-1] == (40_000, 0)
