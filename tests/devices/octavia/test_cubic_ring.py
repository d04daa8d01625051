"""Cubic-spline ring contouring: CUBIC_RATE selects it, Hermite between the ring's points, the
axis coding in the velocity word's upper nibble [Ch1 Cubic Spline Contouring; Ch5 CUBIC_RATE;
Ch6 Contouring; spec octavia.md §4.4, §5.4, Q-16]."""

from __future__ import annotations

import math

from vdevmaps.octavia import HostInt

from tests.devices.octavia.contour_host import Host, vel_word

RADIUS = 2500


def hermite_at(p0: float, v0: float, p1: float, v1: float, n: int, t: int) -> float:
    """The cubic Hermite position t samples into an n-sample interval (written out here, not
    taken from the card's spline module)."""
    s = t / n
    return ((2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * n * v0
            + (3 * s**2 - 2 * s**3) * p1 + (s**3 - s**2) * n * v1)


def test_the_last_rate_command_selects_the_ring_mode_and_parread_1dh_shows_it() -> None:
    """CUBIC_RATE then START: cubic, one point every m samples; BTRATE after it: 2nd order
    again (spec §4.4). PARREAD 1Dh: 0B9h FFh and the 16-bit rate m for cubic."""
    host = Host()
    host.rtc("CUBIC_RATE", {"m": 40})
    assert host.parread(0x1D)[1:4] == bytes((0xFF, 40, 0))
    host.rtc("CUBIC_RATE", {"m": 400})
    assert host.parread(0x1D)[1:4] == bytes((0xFF, 0x90, 0x01))
    host.put([(1000, vel_word(0.0))])
    host.rtc("START", {"n": 0x01})
    host.run(199)
    assert host.actpos(1) == 500  # half way at half the interval (2nd order: there at 25)
    host.run(200)
    assert host.actpos(1) == 1000
    host.rtc("BTRATE", {"m": 0})
    assert host.parread(0x1D)[1:4] == bytes((0x00, 0x00, 0x00))
    host.put([(0, vel_word(0.0))])
    host.rtc("START", {"n": 0x01})
    host.run(24)
    assert host.actpos(1) == 0


def test_cubic_rate_outside_5_to_511_is_ignored() -> None:
    host = Host()
    host.rtc("CUBIC_RATE", {"m": 40})
    for m in (4, 512):
        host.rtc("CUBIC_RATE", {"m": m})
    assert host.parread(0x1D)[1:4] == bytes((0xFF, 40, 0))


def test_cubic_ring_interpolates_hermite_segments_between_the_points() -> None:
    """From rest at 0 to (800, 6 counts/sample) then (900, 0) at m = 100: every sample on the
    Hermite cubic of the two end states, rounded to counts (not on the 2nd-order block)."""
    host = Host()
    host.rtc("CUBIC_RATE", {"m": 100})
    host.put([(800, vel_word(6.0)), (900, vel_word(0.0))])
    host.rtc("START", {"n": 0x04})
    seen = [host.actpos(3)]
    for _ in range(199):
        host.run(1)
        seen.append(host.actpos(3))
    want = [round(hermite_at(0, 0, 800, 6, 100, t)) for t in range(1, 101)]
    want += [round(hermite_at(800, 6, 900, 0, 100, t)) for t in range(1, 101)]
    assert all(abs(a - b) <= 1 for a, b in zip(seen, want, strict=True))
    assert seen[99] == 800 and seen[199] == 900
    block = [800 + t + 6 * t * (100 - t) / 200 for t in range(1, 101)]  # 2nd order: elsewhere
    assert max(abs(a - b) for a, b in zip(want[100:], block, strict=True)) > 10


def test_cubic_rate_example_16_point_circle_at_80_ms_takes_1_28_s() -> None:
    """CUBIC_RATE m = 400 (80 ms), the 16-point circle of radius 2500 [Ch5 CUBIC_RATE example:
    p1 = (2500, 0), p2 = (2310, 957), ..., p16 = (2310, −957)] streamed through the ring with
    its tangent velocities: the axes pass each point at its interval's end, once round in 16
    intervals = 6400 samples = 1.28 s, within a count or two of the circle in between."""
    host = Host()
    points = [(round(RADIUS * math.cos(2 * math.pi * k / 16)),
               round(RADIUS * math.sin(2 * math.pi * k / 16))) for k in range(16)]
    assert points[0] == (2500, 0) and points[1] == (2310, 957) and points[15] == (2310, -957)
    speed = 2 * math.pi * RADIUS / 6400  # counts/sample
    entries = []
    for k in (*range(16), 0):
        th = 2 * math.pi * k / 16
        entries += [(points[k][0], vel_word(-speed * math.sin(th))),
                    (points[k][1], vel_word(speed * math.cos(th)))]
    host.put(entries)
    host.rtc("CUBIC_RATE", {"m": 400})
    host.rtc("START", {"n": 0x03})
    path = []
    for _ in range(17 * 400 - 1):
        host.run(1)
        path.append((host.actpos(1), host.actpos(2)))
    assert path[400 - 2] == points[0] == path[400 + 6400 - 2]
    for k in range(16):
        assert path[400 * (k + 1) - 2] == points[k]
    radius = [math.hypot(x, y) for x, y in path[400:400 + 6400]]
    assert max(abs(r - RADIUS) for r in radius) < 3
    assert host.hostint() & HostInt.RUN_OUT == 0
    host.run(1)  # the last point moves on: the ring ran out
    assert host.hostint() & HostInt.RUN_OUT


def coded(vel: float, mask: int) -> int:
    """A velocity word with an axis mask in bits 28..31 (bits 25..27 sign extension)."""
    word = vel_word(vel) & 0x1FFFFFF
    if word & 0x1000000:
        word |= 0x0E000000
    return word | mask << 28


def test_the_velocity_upper_nibble_recodes_the_contouring_axes() -> None:
    """Q-16: a first slot whose bits 28..31 are not the sign extension of bit 24 codes the axes
    (1..4) from that point on: axis 1 alone, then axes 1 and 2 (0011b); a negative velocity's
    1111b is its sign, no coding."""
    host = Host()
    host.rtc("CUBIC_RATE", {"m": 20})
    entries = [(100, vel_word(5.0)), (200, vel_word(-5.0) | 0xF0000000)]  # sign, no coding
    entries += [(300, coded(5.0, 0x3)), (-50, vel_word(-2.5))]
    entries += [(400, vel_word(5.0)), (-100, vel_word(0.0))]
    host.put(entries)
    host.rtc("START", {"n": 0x01})
    host.run(2 * 20 - 1)
    assert (host.actpos(1), host.actpos(2)) == (200, 0)
    host.run(20)
    assert (host.actpos(1), host.actpos(2)) == (300, -50)
    host.run(20)
    assert (host.actpos(1), host.actpos(2)) == (400, -100)
    assert host.outptr() == 6
