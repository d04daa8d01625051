"""CUBIC_INT and CUBIC_SCALE: cubic-spline contouring from the internal table [Ch5 CUBIC_INT,
CUBIC_RATE, CUBIC_SCALE; Ch6 Table 6-10 ICUBCOUNT; spec octavia.md §4.3, §5.4, Q-17].

The table is written straight into the card's RAM (`fw.ram`), standing in for LOAD_CUBIC_TABLE,
which is another module's RTC. CUBIC_INT takes 25 samples to interpret; the motion starts at
the next one, so point j (from 1) of the run is reached after 25 + j·m samples."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from vdevmaps.octavia import BY_NAME, Dpr, DspStat1, pack

from tests.devices.octavia.contour_host import Host

WAIT = 25  # "approximately 5 ms to interpret"


def load_table(host: Host, index: int, values: list[int]) -> None:
    host.fw.ram.store_cubic_points(index, values)


def icubcount(host: Host) -> int:
    return int(struct.unpack("<H", host.read(Dpr.ICUBCOUNT, 2))[0])


def cubic_int(host: Host, m: int, si: int, n: int, ax: int) -> None:
    host.rtc("CUBIC_INT", {"m": m, "si": si, "n": n, "ax": ax})


def circle(points: int, radius: int = 2500) -> list[tuple[int, int]]:
    return [(round(radius * math.cos(2 * math.pi * k / points)),
             round(radius * math.sin(2 * math.pi * k / points))) for k in range(points)]


def test_cubic_int_example_300_entries_from_100_eight_times_on_axes_1_and_4() -> None:
    """CUBIC_INT m=012Ch, si=0064h, n=0008h, ax=09h [Ch5 CUBIC_INT example]: 300 entries from
    index 100, interleaved (axis 1 at 100, 102, ...; axis 4 at 101, 103, ...): 150 points per
    axis, 8 passes. Each point is reached at its interval's end, ICUBCOUNT shows the point's
    table index, axes 2 and 3 stay, and motion complete (005h = 09h) follows the last point,
    reached at rest."""
    assert pack(BY_NAME["CUBIC_INT"], {"m": 0x012C, "si": 0x0064, "n": 0x0008, "ax": 0x09}) \
        == bytes.fromhex("2c01640008" "0009")
    host = Host()
    a1 = [round(3000 * math.sin(2 * math.pi * j / 150)) for j in range(150)]
    a4 = [round(1500 * (1 - math.cos(2 * math.pi * j / 150))) for j in range(150)]
    load_table(host, 100, [v for pair in zip(a1, a4, strict=True) for v in pair])
    host.rtc("CUBIC_RATE", {"m": 25})
    host.rtc("EN_MOTCP", {"n": 0x09})
    host.acknowledge()
    cubic_int(host, 0x012C, 0x0064, 0x0008, 0x09)
    s0 = host.card.ticks  # the sample CUBIC_INT ran in
    host.run(WAIT)
    assert (host.actpos(1), host.actpos(4)) == (0, 0)  # interpreting
    assert host.parread(0x18)[3] == 0x09
    host.run(s0 + WAIT - 1 + 25 - host.card.ticks)  # to the end of the first interval
    for k in range(8 * 150):
        j = k % 150
        assert (host.actpos(1), host.actpos(4)) == (a1[j], a4[j]), k
        assert icubcount(host) == 100 + 2 * j
        assert host.stat1() == 0
        host.run(25)
    assert host.stat1() == DspStat1.MOTCP and host.u8(Dpr.INTAXIS_MOTCP) == 0x09
    assert (host.actpos(1), host.actpos(4)) == (a1[149], a4[149])
    assert host.fw.core.axes.cmd_vel[[0, 3]].tolist() == [0.0, 0.0]
    assert (host.actpos(2), host.actpos(3)) == (0, 0)
    assert host.parread(0x18)[3] == 0


@pytest.mark.parametrize(("points", "rate"), [(16, 400), (32, 200), (64, 100), (128, 50)])
def test_cubic_rate_example_circles_take_1_28_s_each(points: int, rate: int) -> None:
    """CUBIC_RATE example: 16 points at 80 ms, 32 at 40, 64 at 20 and 128 at 10 ms all take
    1.28 s (6400 samples) per circle [Ch5 CUBIC_RATE]: a looping run (periodic spline) passes
    p1 = (2500, 0) every 6400 samples and each point in between on time, within a few counts of
    the circle (the radius-2500 points are rounded to counts)."""
    host = Host()
    pts = circle(points)
    load_table(host, 0, [v for p in pts for v in p])
    host.rtc("CUBIC_RATE", {"m": rate})
    cubic_int(host, 2 * points, 0, 2, 0x03)
    host.run(WAIT + rate - 1)  # p1 at the end of the first interval
    assert (host.actpos(1), host.actpos(2)) == pts[0]
    at_p1 = host.card.ticks
    worst = 0.0
    for k in range(1, points + 1):
        for _ in range(rate // 25):
            host.run(25)
            worst = max(worst, abs(math.hypot(host.actpos(1), host.actpos(2)) - 2500))
        assert (host.actpos(1), host.actpos(2)) == pts[k % points]
    assert host.card.ticks - at_p1 == 6400  # 1.28 s
    assert worst < 3


def test_cubic_scale_example_halves_axis_2s_table_points() -> None:
    """CUBIC_SCALE n=02h, pos_mult2=2000h (0.5), pos_shift2=0 [Ch5 CUBIC_SCALE example]; axis 3
    with C000h (−1.0) and a shift of 100: the table's 1000..4000 become 500..2000 and −900..
    −3900."""
    host = Host()
    load_table(host, 0, [1000, 1000, 2000, 2000, 3000, 3000, 4000, 4000])
    host.rtc("CUBIC_SCALE", {"n": 0x06}, [{"pos_mult": 0x2000, "pos_shift": 0},
                                          {"pos_mult": -0x4000, "pos_shift": 100}])
    host.rtc("CUBIC_RATE", {"m": 50})
    cubic_int(host, 8, 0, 1, 0x06)
    host.run(WAIT + 50 - 1)
    for k in range(4):
        assert (host.actpos(2), host.actpos(3)) == (500 * (k + 1), 100 - 1000 * (k + 1))
        host.run(50)


def test_one_pass_follows_the_natural_spline_and_ends_at_rest() -> None:
    """n = 1: velocities at the points from the natural C² spline (zero curvature at the ends:
    v_{i−1} + 4v_i + v_{i+1} = 3(P_{i+1} − P_{i−1})/N, 2v_0 + v_1 = 3(P_1 − P_0)/N, ...), solved
    here independently; Hermite between points; the last point reached at rest."""
    host = Host()
    pts = np.array([0.0, 4000.0, 2000.0, 9000.0, 6000.0])
    load_table(host, 10, [int(p) for p in pts])
    rate = 100
    host.rtc("CUBIC_RATE", {"m": rate})
    cubic_int(host, 5, 10, 1, 0x10)
    a = np.diag([2.0, 4, 4, 4, 2]) + np.diag([1.0] * 4, 1) + np.diag([1.0] * 4, -1)
    rhs = 3 * np.concatenate([[pts[1] - pts[0]], pts[2:] - pts[:-2], [pts[-1] - pts[-2]]]) / rate
    v = np.linalg.solve(a, rhs)
    v[-1] = 0.0
    host.run(WAIT + rate - 1)
    for i in range(4):
        for t in range(1, rate + 1):
            host.run(1)
            s = t / rate
            want = ((2 * s**3 - 3 * s**2 + 1) * pts[i] + (s**3 - 2 * s**2 + s) * rate * v[i]
                    + (3 * s**2 - 2 * s**3) * pts[i + 1] + (s**3 - s**2) * rate * v[i + 1])
            assert abs(host.actpos(5) - want) <= 0.5 + 1e-9, (i, t)
    host.run(2)
    assert host.actpos(5) == 6000 and host.fw.core.axes.cmd_vel[4] == 0.0


def test_the_run_starts_after_the_interpretation_time_within_one_long_batch() -> None:
    """The 25 samples of interpretation are work: a card that would rest through them never
    starts; one batch of 1000 samples runs the whole first interval."""
    host = Host()
    load_table(host, 0, [800])
    host.rtc("CUBIC_RATE", {"m": 100})
    host.write(Dpr.ARGMNTS, pack(BY_NAME["CUBIC_INT"], {"m": 1, "si": 0, "n": 1, "ax": 1}))
    host.write(Dpr.RTC, bytes((BY_NAME["CUBIC_INT"].code,)))
    host.card.tick(1000)
    assert host.actpos(1) == 800


def test_icubcount_waits_while_the_host_holds_its_access_byte() -> None:
    """ICUBCOUNT (482h) is under the 480h/481h access bytes: while the host holds 481h the card
    does not write it; released, the next sample does."""
    host = Host()
    load_table(host, 200, list(range(0, 5000, 1000)))
    host.rtc("CUBIC_RATE", {"m": 25})
    cubic_int(host, 5, 200, 1, 0x01)
    host.run(WAIT + 25)
    assert icubcount(host) == 201
    host.write(Dpr.HOSTACC_COUNT, b"\x01")
    host.run(50)
    assert icubcount(host) == 201
    host.write(Dpr.HOSTACC_COUNT, b"\x00")
    host.run(1)
    assert icubcount(host) == 203


def test_axmove_and_start_for_a_cubic_int_axis_are_conflicting_commands() -> None:
    """CUBIC_INT is contouring (Ch7 "Conflicting Commands"): AXMOVE on its axis, or START
    naming it, is refused with 000h b6; the run goes on."""
    host = Host()
    load_table(host, 0, [100 * j for j in range(1, 21)])
    host.rtc("CUBIC_RATE", {"m": 25})
    cubic_int(host, 20, 0, 1, 0x01)
    host.acknowledge()
    host.rtc("AXMOVE", {"n": 0x01}, [{"acc": 0x100, "pos": -5000, "vel": 0x80000}])
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x01
    host.acknowledge()
    host.put([(10, 0)])
    host.rtc("START", {"n": 0x01})
    assert host.stat1() == DspStat1.CONFLICT and host.outptr() == 0
    host.run(WAIT + 20 * 25)
    assert host.actpos(1) == 2000


def test_cubic_int_naming_an_axis_in_axmove_or_ring_contouring_is_conflicting_commands() -> None:
    host = Host()
    load_table(host, 0, [100 * j for j in range(1, 21)])
    host.put([(10 * j, 0) for j in range(1, 21)])
    host.rtc("START", {"n": 0x04})
    host.rtc("AXMOVE", {"n": 0x08}, [{"acc": 0x100, "pos": 5000, "vel": 0x80000}])
    host.acknowledge()
    cubic_int(host, 20, 0, 1, 0x0D)
    assert host.stat1() == DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 0x0C
    host.run(WAIT + 50)
    assert host.actpos(1) == 0


def test_a_second_cubic_int_while_one_runs_is_ignored() -> None:
    host = Host()
    load_table(host, 0, [100 * j for j in range(1, 21)])
    host.rtc("CUBIC_RATE", {"m": 25})
    cubic_int(host, 10, 0, 1, 0x01)
    host.acknowledge()
    cubic_int(host, 10, 10, 1, 0x02)
    assert host.hostint() == 0
    host.run(WAIT + 10 * 25)
    assert (host.actpos(1), host.actpos(2)) == (1000, 0)


def test_stop_takes_one_axis_out_of_the_run_and_the_other_runs_on() -> None:
    """STOP axis 1 (40 counts/sample, MAXACC 1/2: 80 samples, 1600 counts): it halts and holds;
    axis 2 runs to its last point."""
    host = Host()
    load_table(host, 0, [v for j in range(1, 21) for v in (1000 * j, -100 * j)])
    host.rtc("MAXACC", {"n": 0x01}, [{"acc": 0x4000}])
    host.rtc("CUBIC_RATE", {"m": 25})
    cubic_int(host, 40, 0, 1, 0x03)
    host.run(WAIT + 5 * 25)
    host.rtc("STOP", {"n": 0x01})
    stopped_at = host.actpos(1)
    host.run(15 * 25)
    assert host.actpos(2) == -2000
    assert 1000 < host.actpos(1) - stopped_at < 2000
    assert host.parread(0x18)[:4] == bytes(4)


@pytest.mark.parametrize(("m", "si"), [(2001, 0), (10, 4090), (0, 0)])
def test_cubic_int_the_table_cannot_give_is_ignored(m: int, si: int) -> None:
    """m at most 2000, si + m within the 4096 entries, at least one entry per axis."""
    host = Host()
    cubic_int(host, m, si, 1, 0x01)
    assert host.parread(0x18)[3] == 0
    host.run(100)
    assert host.actpos(1) == 0 and not host.fw.cubic.running
