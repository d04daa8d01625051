"""Vector contours: the end-of-segment velocity of `VV v,vend` and the analog velocity override
`VOA ch,full` (spec oms.md §4.3 "Vector / contouring", §5.2, §5.7, §8.14; [S App C L1360-1374,
§4.5.1]).

Times: the contour starts at the update cycle after its `VE` is sent, so after `run(maxk, t)`
the positions are those of the path at t seconds. The 4-axis card has analog inputs 0 and 1.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.devices.oms.conftest import Maxk
from vdevd.devices.oms.contour import Leg, junction_speeds, plan_legs

HZ = 1024
APP_C_3 = ("VOA0,5; VV1000,1000; VP0,0; VIO0100,,0100; VC0,5000,-180; VC0,0,-360; "
           "VIO0,,0100; VV1000,0; VP-1000,0; VE;")


def run(maxk: Maxk, seconds: float) -> None:
    """Step until the contour sent last has run `seconds` (its first cycle holds t = 0)."""
    maxk.step(round(seconds * HZ) + 1)


def xy(maxk: Maxk) -> tuple[int, int]:
    x, y = maxk.query("AA RP;").split(",")[:2]
    return int(x), int(y)


class PathClock:
    """The path time of the contour sent last (its first update cycle holds t = 0)."""

    def __init__(self, maxk: Maxk) -> None:
        self.maxk = maxk
        self.start = self.now = maxk.step(1)
        self.period = maxk.step(1) - self.now
        self.now += self.period

    def to(self, seconds: float) -> None:
        """Step to path time `seconds`."""
        self.now = self.maxk.step(round((self.start + seconds * 1e9 - self.now) / self.period))

    def speed(self, seconds: float = 0.5) -> float:
        t0, p0 = self.now, xy(self.maxk)
        self.now = self.maxk.step(round(seconds * 1e9 / self.period))
        return math.dist(p0, xy(self.maxk)) / ((self.now - t0) / 1e9)


def path_speed(maxk: Maxk, seconds: float = 0.5) -> float:
    """The X-Y path speed over the next `seconds`, counts/s (a chord: on the App C arcs it is
    shorter than the arc by under 0.01 %)."""
    t0, p0 = maxk.step(1), xy(maxk)
    t1 = maxk.step(round(seconds * HZ))
    return math.dist(p0, xy(maxk)) / ((t1 - t0) / 1e9)


# -- the planner (pure) --------------------------------------------------------------------------
def test_app_c_junctions_run_on_at_1000_and_the_last_ends_at_rest() -> None:
    """`VV1000,1000; VP0,0; VC..; VC..; VV1000,0; VP-1000,0`: the empty first segment starts
    from rest, the arcs run on at 1000, the last segment stops."""
    lengths = [0.0, math.pi * 5000, 2 * math.pi * 10_000, math.hypot(1000, 10_000)]
    speeds = junction_speeds(lengths, [1000.0] * 4, [1000.0, 1000.0, 1000.0, 0.0], 1000.0)
    assert speeds == [0.0, 1000.0, 1000.0, 0.0]


def test_a_segment_too_short_for_its_vend_ends_at_the_best_reachable_speed() -> None:
    """200 counts from rest at VA 1000 reach sqrt(2·1000·200) ≈ 632 < vend 1000."""
    speeds = junction_speeds([200.0, 3800.0], [1000.0, 1000.0], [1000.0, None], 1000.0)
    assert speeds[0] == pytest.approx(math.sqrt(2 * 1000 * 200))
    assert speeds[1] == 0.0


def test_a_short_stop_ahead_slows_the_segment_before_it() -> None:
    """A 100-count segment ending at rest (vend 0) can be entered at sqrt(2·1000·100) ≈ 447 at
    most, so the segment before ends there and the path rests exactly at the stop."""
    speeds = junction_speeds([4000.0, 100.0, 3900.0], [1000.0] * 3, [None, 0.0, None], 1000.0)
    assert speeds[0] == pytest.approx(math.sqrt(2 * 1000 * 100))
    assert speeds[1:] == [0.0, 0.0]


def test_a_junction_is_no_faster_than_the_segment_before_it() -> None:
    """A slower segment after it does not lower it: that segment slows down within itself, as
    [E-traj]'s `VA[n]a;VV[n]v` per point expects."""
    assert junction_speeds([1e5, 1e5], [2000.0, 500.0], [3000.0, None], 1e6)[0] == 2000.0
    assert junction_speeds([1e5, 1e5], [500.0, 2000.0], [3000.0, None], 1e6)[0] == 500.0


@settings(derandomize=True, max_examples=200, deadline=None)
@given(segments=st.lists(st.tuples(st.floats(0, 1e5), st.floats(1, 1e5),
                                   st.none() | st.floats(0, 1e5)), min_size=1, max_size=8),
       accel=st.floats(1, 8e6))
def test_planned_legs_keep_their_bounds_and_cover_their_length(
        segments: list[tuple[float, float, float | None]], accel: float) -> None:
    """Every leg: exit within its velocity, its vend and the acceleration's reach, entry the
    exit before; progress monotonic, never faster than its velocity or its entry speed,
    ending exactly at its length; the path starts and ends at rest; a vend of 0 is rest."""
    lengths, velocities, ends = (list(x) for x in zip(*segments, strict=True))
    legs = plan_legs(lengths, velocities, ends, accel)
    assert legs[0].entry == 0.0 and legs[-1].exit == 0.0
    for leg, v, end, nxt in zip(legs, velocities, ends, legs[1:] + [None], strict=True):
        tol = 1e-9 * max(v, 1.0)
        assert leg.exit <= v + tol and leg.peak <= v + tol
        assert end is None or leg.exit <= end + tol
        assert end != 0.0 or leg.exit == 0.0
        assert abs(leg.exit ** 2 - leg.entry ** 2) <= 2 * accel * leg.length * (1 + 1e-9) + tol
        if nxt is not None:
            assert nxt.entry == leg.exit
        check_progress(leg, max(v, leg.entry))


def check_progress(leg: Leg, v: float) -> None:
    steps = 64
    dt = leg.duration / steps
    s = [leg.s_at(k * dt) for k in range(steps + 1)]
    assert s[0] == 0.0
    assert s[-1] == pytest.approx(leg.length, rel=1e-9, abs=1e-6)
    assert all(b >= a - 1e-9 * leg.length - 1e-12 for a, b in zip(s, s[1:], strict=False))
    if dt > 0:
        assert max(b - a for a, b in zip(s, s[1:], strict=False)) <= v * dt * (1 + 1e-9) + 1e-9


# -- VV v,vend on the card -----------------------------------------------------------------------
@pytest.mark.parametrize(("vv", "x_at_3s"), [
    ("VV1000,0", 2000.0),  # seg 1 (2000 counts): 1 s up, 1 s cruise, 1 s down to rest
    ("VV1000,500", 2257.8),  # down to 500 at 2.625 s, then 0.375 s of 500 -> 1000
    ("VV1000,1000", 2500.0),  # runs on: 1 s up (500), then 2 s at 1000
    ("VV1000", 2500.0),  # no vend: runs on (as before vend was modelled)
])
def test_vv_vend_sets_the_speed_at_the_end_of_the_segments_after_it(
        maxk: Maxk, vv: str, x_at_3s: float) -> None:
    """[spec §4.3 VV `v,vend`]: a segment defined after `VV v,vend` ends at vend; 0 rests."""
    maxk.send(f"AA; VA1000; {vv}; VP2000,0; VV1000; VP4000,0; VE;")
    run(maxk, 3.0)
    assert xy(maxk)[0] == pytest.approx(x_at_3s, abs=2)
    maxk.step(5 * HZ)
    assert xy(maxk) == (4000, 0)


def test_vv_vend_0_rests_at_the_segment_end_before_the_next_starts(maxk: Maxk) -> None:
    maxk.send("AA; VA1000; VV1000,0; VP2000,0; VV1000; VP4000,0; VE;")
    run(maxk, 2.99)
    assert xy(maxk)[0] == pytest.approx(2000 - 1000 * 0.01 ** 2 / 2, abs=1)
    maxk.step(round(0.02 * HZ))  # 3.01 s: the next segment has started from rest
    assert xy(maxk)[0] == pytest.approx(2000 + 1000 * 0.01 ** 2 / 2, abs=1)


def test_a_short_segment_passes_at_the_best_reachable_speed(maxk: Maxk) -> None:
    """200 counts cannot reach vend 1000 at VA 1000: the path leaves them at ≈632 counts/s and
    goes on accelerating, as one ramp from rest (0.5·1000·1² = 500 counts after 1 s)."""
    maxk.send("AA; VA1000; VV1000,1000; VP200,0; VV1000; VP4000,0; VE;")
    run(maxk, 1.0)
    assert xy(maxk)[0] == pytest.approx(500, abs=2)


def test_a_short_stop_ahead_is_reached_at_rest(maxk: Maxk) -> None:
    """VP4100 with vend 0 after 4000 counts at 1000: the first segment slows to ≈447, the
    second ends at rest at 5.1 s (1 + 3.1 + 0.553 + 0.447 s), exactly on 4100."""
    maxk.send("AA; VA1000; VV1000; VP4000,0; VV1000,0; VP4100,0; VV1000; VP8000,0; VE;")
    run(maxk, 5.0)
    assert xy(maxk)[0] == pytest.approx(4100 - 1000 * 0.1 ** 2 / 2, abs=1)
    maxk.step(round(0.1 * HZ))
    assert xy(maxk)[0] == pytest.approx(4100, abs=1)


@pytest.mark.parametrize("bad", ["VV1000,-1", "VV1000,4194304", "VV1000,0,0", "VV,0"])
def test_a_bad_vv_is_a_command_error(maxk: Maxk, bad: str) -> None:
    maxk.send(f"AA; {bad};")
    assert maxk.command_error()
    assert maxk.query("WY;").startswith("MAXk")  # the card keeps working


# -- VOA ch,full on the card ---------------------------------------------------------------------
def start_line(maxk: Maxk, prefix: str) -> None:
    """A 100,000-count X line at VV 1000, VA 1e6 (ramps of a few ms), after `prefix`."""
    maxk.send(f"AA; {prefix}; VV1000; VA1000000; VP100000,0; VE;")
    run(maxk, 0.1)


@pytest.mark.parametrize(("volts", "voa", "speed"), [
    (5.0, "VOA0,5", 1000.0),  # App C: 100 % at 5 V
    (10.0, "VOA0,5", 2000.0),  # 200 %
    (2.5, "VOA0", 500.0),  # full scale defaults to 5 V
    (-3.0, "VOA0,5", 0.0),  # negative volts: 0 %
    (10.0, "VOA1,2", 2000.0),  # 500 % clamped to 200 %
    (4.0, "VOA1,8", 500.0),
])
def test_voa_sets_the_override_from_the_analog_input(
        maxk: Maxk, volts: float, voa: str, speed: float) -> None:
    """[S App C]: "an analog input may be used to vary the vector velocity from 0-200 %"."""
    channel = int(voa[3])
    maxk.control("set_analog", channel=channel, volts=volts)
    start_line(maxk, voa)
    assert path_speed(maxk) == pytest.approx(speed, rel=0.01, abs=1)


def test_voa_follows_the_input_while_the_contour_runs(maxk: Maxk) -> None:
    maxk.control("set_analog", channel=0, volts=0.0)
    start_line(maxk, "VOA0,5")
    assert path_speed(maxk) == 0.0  # 0 V: the contour waits at its start
    assert xy(maxk) == (0, 0)
    maxk.control("set_analog", channel=0, volts=5.0)
    maxk.step(2)
    assert path_speed(maxk) == pytest.approx(1000, rel=0.01)
    maxk.control("set_analog", channel=0, volts=7.5)
    maxk.step(2)
    assert path_speed(maxk) == pytest.approx(1500, rel=0.01)


@pytest.mark.parametrize("back", ["VO", "VOA", "VO50"])
def test_vo_or_a_bare_voa_goes_back_to_the_fixed_override(maxk: Maxk, back: str) -> None:
    """`VO[n]=pct` or a bare `VOA`/`VO` ends the analog override: the fixed one (150 % from
    the earlier VO, or the new VO50) applies again."""
    maxk.control("set_analog", channel=0, volts=0.0)
    start_line(maxk, "VO150; VOA0,5")
    assert path_speed(maxk) == 0.0
    maxk.send(f"{back};")
    assert not maxk.command_error()
    maxk.step(2)
    assert path_speed(maxk) == pytest.approx(500 if back == "VO50" else 1500, rel=0.01)


def test_vh1_halts_a_contour_under_analog_override_and_vg_resumes(maxk: Maxk) -> None:
    maxk.control("set_analog", channel=0, volts=5.0)
    start_line(maxk, "VOA0,5")
    maxk.send("VH1;")
    maxk.step(2)
    assert path_speed(maxk) == 0.0
    maxk.send("VG;")
    maxk.step(2)
    assert path_speed(maxk) == pytest.approx(1000, rel=0.01)


def test_voa_belongs_to_its_task(maxk: Maxk) -> None:
    """`VOA[2]` leaves task 1 (the default) at its fixed override."""
    maxk.control("set_analog", channel=0, volts=0.0)
    start_line(maxk, "VOA[2]0,5")
    assert path_speed(maxk) == pytest.approx(1000, rel=0.01)


@pytest.mark.parametrize("bad", ["VOA2", "VOA-1", "VOA0.5", "VOA0,0", "VOA0,-5", "VOA0,11",
                                 "VOA,5", "VOA0,5,1"])
def test_a_bad_voa_is_a_command_error_and_changes_nothing(maxk: Maxk, bad: str) -> None:
    """The 4-axis card has inputs 0 and 1 [S Table 6-2]; the full scale is 0 < volts ≤ 10."""
    maxk.control("set_analog", channel=0, volts=0.0)
    maxk.send(f"AA; {bad};")
    assert maxk.command_error()
    start_line(maxk, "")
    assert path_speed(maxk) == pytest.approx(1000, rel=0.01)


# -- App C example 3 -----------------------------------------------------------------------------
@pytest.mark.slow
def test_app_c_example_3_cuts_the_hole_at_1000_and_stops_at_the_end(maxk: Maxk) -> None:
    """[S App C L1370]: `VOA0,5` with 5 V on input 0 is 100 %. A `VA1000` first makes a stop
    at a junction take a second, so it would show. The half circle (π·5000 ≈ 15,708 counts,
    reached at 1 s of ramp + 15.208 s) and the full circle run on at 1000 across their
    junction, output IO8 on; at 10 V (200 %) the rest runs at 2000; the last segment ends at
    rest on (-1000, 0) with the output off."""
    maxk.control("set_analog", channel=0, volts=5.0)
    maxk.send(f"AA; VA1000; {APP_C_3} VID;")
    clock = PathClock(maxk)
    clock.to(5.0)
    assert clock.speed() == pytest.approx(1000, rel=0.01)
    assert maxk.control("get_outputs")["gpio"] & 0x0100
    junction = 1.0 + (math.pi * 5000 - 500) / 1000
    clock.to(junction - 0.5)
    assert clock.speed(1.0) == pytest.approx(1000, rel=0.01)
    # 500 counts clockwise round (0, 0) from the top (0, 10000): no time lost at the junction
    assert xy(maxk) == pytest.approx((10_000 * math.sin(0.05), 10_000 * math.cos(0.05)), abs=3)
    maxk.control("set_analog", channel=0, volts=10.0)
    maxk.step(2)
    assert clock.speed() == pytest.approx(2000, rel=0.01)
    assert maxk.control("get_outputs")["gpio"] & 0x0100
    assert maxk.odbr() & 0b11 == 0  # VID not yet
    maxk.step(40 * HZ)  # the rest: ≈ 73,000 counts at 2000
    assert xy(maxk) == (-1000, 0)
    assert maxk.odbr() & 0b11 == 0b11  # VID: done X and Y
    assert not maxk.control("get_outputs")["gpio"] & 0x0100
    maxk.step(HZ)
    assert xy(maxk) == (-1000, 0)
