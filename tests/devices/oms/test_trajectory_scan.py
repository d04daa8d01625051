"""The EPICS MAXv trajectory scan driving the card's vector tasks [E-traj: epics-motor/motorOms
omsApp/src/MAX_trajectoryScan.st], then the pieces it needs one by one: `VID[n]0|1`, `VP`/`VC`
with the A/R flag, `VA` per segment, `VH[n]0` "don't start until I tell you to start", `VG[n]`
(spec oms.md §4.3 "Vector / contouring", §8.14).

[E-traj] loads one vector task per axis (task n = axis j + 1) that moves only that axis, and
starts them together with one `VG` string. The strings here are built as it formats them
(`load_strings`, `execute_strings`, `abort_strings`), one write each, on an 8-axis card (its MAX_AXES
is 8, so every VP, SI and KS has 8 fields). The trajectory: points every 0.125 s (128 update
cycles), constant acceleration, cruise, deceleration, in whole counts, so the positions the
card should pass through are exact. Tolerance: 1 count: the card publishes whole counts
(rounded), and its 976 562 ns period runs path time 64 ns per point behind the nominal one.

Times: the contours start in the update cycle after the `VG` string (that cycle holds path
time 0), so after `m` steps the path time is m - 1 cycles.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from vdevmaps.oms import MaxkDoorbell

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd.devices.oms.commands import OPERANDS
from vdevd.devices.oms.contour import junction_speeds, plan_legs
from vdevd.devices.oms.firmware import Firmware
from vdevd.devices.oms.syntax import Lexer

HZ = 1024
PERIOD = 976_562e-9  # s, 1/1024 rounded to whole ns (the card's update period)
DT = 0.125  # s between trajectory points
CYCLES = 128  # update cycles between points
MAX_AXES = 8  # [E-traj] (trajectoryScan.h)
AXIS_NAMES = "XYZTUVRS"  # [E-traj L113]
IN_BIT = 3  # a factory input (IO0-7)
DONE_XY = MaxkDoorbell.DONE_X | MaxkDoorbell.DONE_Y


@dataclass(frozen=True)
class Trajectory:
    """One axis's trajectory from rest at 0: constant acceleration `accels[i]` (counts/s²)
    for DT seconds before point i, as [E-traj]'s buildTrajectory hands it to the loader
    (positions, velocities and accelerations per point)."""

    accels: tuple[float, ...]

    def points(self) -> list[tuple[float, float, float]]:
        """(position, velocity, acceleration) at each point."""
        p = v = 0.0
        out = []
        for a in self.accels:
            p, v = p + v * DT + a * DT * DT / 2, v + a * DT
            out.append((p, v, a))
        return out

    def at(self, t: float) -> float:
        """The intended position at time t (s after the start)."""
        k = min(int(t // DT), len(self.accels))
        p, v = (0.0, 0.0) if k == 0 else self.points()[k - 1][:2]
        if k == len(self.accels):
            return p
        tau = t - k * DT
        return p + v * tau + self.accels[k] * tau * tau / 2

    @property
    def end(self) -> float:
        return self.points()[-1][0]


#: X: 3 points up at 16,000 counts/s² to 6000 counts/s, 3 at 6000, 2 down (at 16,000, then
#: 32,000: each point has its own VA); ends at 4250
X_TRAJ = Trajectory((16_000.0,) * 3 + (0.0,) * 3 + (-16_000.0, -32_000.0))
#: Y: the same shape backwards at twice the acceleration (to -12,000 counts/s); ends at -7500
Y_TRAJ = Trajectory((-32_000.0,) * 3 + (0.0,) * 2 + (32_000.0,) * 3)
SCAN = {0: X_TRAJ, 1: Y_TRAJ}
DURATION = DT * len(X_TRAJ.accels)  # 1 s


# -- the strings [E-traj] writes ----------------------------------------------------------------
def selected(axes: dict[int, Trajectory]) -> str:
    """`1` for each moved axis in MAX_AXES comma-separated fields (`1,1,,,,,,`)."""
    return ",".join("1" if j in axes else "" for j in range(MAX_AXES))


def load_strings(axes: dict[int, Trajectory], in_bit: int | None = None) -> list[str]:
    """The writes of loadTrajectory [E-traj L1184-1440] without output pulses: AM, the input
    bit made an input, SI on the moved axes, the update-rate query, then per axis j (task
    j + 1) VIO, VID1, VH0, `A<axis>; SW<bit>` when an input starts the scan, one
    `VA;VV;VP A` write per point (the last `VV v_start,v_end`), VE."""
    out = ["AM;"]
    if in_bit is not None:
        out.append(f"IO{in_bit},0;")
    out += [f"AM; SI{selected(axes)};", "AX; #UR?;"]
    for j, traj in sorted(axes.items()):
        n = j + 1
        out += [f"AM; VIO[{n}]0,0,0;", f"AM; VID[{n}]1;", f"AM; VH[{n}]0;"]
        if in_bit is not None:
            out.append(f"A{AXIS_NAMES[j]}; SW{in_bit};")
        points = traj.points()
        for i, (p, v, a) in enumerate(points):
            accel = min(max(abs(round(a)), 1), 8_000_000)
            v_start = min(max(abs(round(points[i - 1][1] if i else v)), 1), 4_194_303)
            v_end = min(abs(round(v)), 4_194_303)
            vv = f"VV[{n}]{v_end};" if i < len(points) - 1 else f"VV[{n}]{v_start},{v_end};"
            fields = "," * j + str(round(p)) + "," * (MAX_AXES - 1 - j)
            out.append(f"AM; VA[{n}]{accel};{vv}VP[{n}]A{fields};")
        out.append(f"AM; VE[{n}];")
    return out


def execute_strings(axes: dict[int, Trajectory]) -> list[str]:
    """No override, then "GO!" for every task in one write [E-traj L572-585]."""
    tasks = [j + 1 for j in sorted(axes)]
    return ["AM;" + "".join(f"VO[{n}]=100;" for n in tasks),
            "AM;" + "".join(f"VG[{n}];" for n in tasks)]


def abort_strings(axes: dict[int, Trajectory]) -> list[str]:
    """Halt each task, then kill the axes and flush their queues [E-traj L812-824]."""
    return [f"AM; VH[{j + 1}]1;" for j in sorted(axes)] + [f"KS{selected(axes)};"]


def write(card: Maxk, strings: list[str]) -> None:
    """One write per string, as the sequencer does; a query's reply is read; none may be a
    command error."""
    for text in strings:
        if "?" in text:
            assert card.query(text) == "1024", text
        else:
            card.send(text)
        assert not card.command_error(), text


# -- the card -------------------------------------------------------------------------------------
@pytest.fixture
def card() -> Iterator[Maxk]:
    """A MAXk-8000 (the trajectory scan's eight axes) in a daemon of its own."""
    with maxk_card(axes=8) as c:
        yield c


def positions(card: Maxk) -> tuple[int, int]:
    """X and Y motor positions (0x000, 0x004)."""
    return card.word(0), card.word(4)


def run_path(card: Maxk, cycles: int, every: int = 8) -> list[tuple[float, tuple[int, int]]]:
    """Step `cycles` update cycles from a VG just sent; (path time, (x, y)) every `every`."""
    out = []
    stepped = 0
    while stepped < cycles:
        n = min(every, cycles - stepped)
        card.step(n)
        stepped += n
        out.append(((stepped - 1) * PERIOD, positions(card)))
    return out


def worst(samples: list[tuple[float, tuple[int, int]]], axis: int, shift: int = 0) -> float:
    """The largest distance of `axis` from its trajectory, started `shift` cycles late."""
    traj = SCAN[axis]
    return max(abs(p[axis] - traj.at(max(0.0, t - shift * PERIOD))) for t, p in samples)


def assert_follows(samples: list[tuple[float, tuple[int, int]]]) -> None:
    """Both axes within 1 count of their trajectories, started in the same update cycle (the
    one after VG): a start one cycle early or late is several counts off."""
    for axis in (0, 1):
        assert worst(samples, axis) <= 1
        assert worst(samples, axis, -1) > 2 and worst(samples, axis, 1) > 2


def test_the_trajectory_scan_runs_both_tasks_together_from_vg(card: Maxk) -> None:
    """Nothing is a command error; loaded (VE on every queue) nothing moves, until VG; then X
    and Y follow their trajectories from the same update cycle; VID sets their done flags
    (doorbell bits, QI 'D') as the contours end at 1 s, not before."""
    write(card, load_strings(SCAN))
    card.step(HZ // 2)
    assert positions(card) == (0, 0)
    assert card.query("QI;")[1::5][:2] == "NN"
    write(card, execute_strings(SCAN))
    assert_follows(run_path(card, round(DURATION / PERIOD) - 1))  # to 3 cycles before the end
    assert card.odbr() & (MaxkDoorbell.DONE_X | MaxkDoorbell.DONE_Y) == 0
    assert card.query("QI;")[1::5][:2] == "NN"
    card.step(4)
    assert card.odbr() & DONE_XY == DONE_XY
    assert card.query("QI;")[1::5][:2] == "DD"
    assert positions(card) == (X_TRAJ.end, Y_TRAJ.end)


def test_the_points_are_reached_at_their_times(card: Maxk) -> None:
    """At each point time (128 cycles apart) the axes are on the point, within 1 count."""
    write(card, load_strings(SCAN) + execute_strings(SCAN))
    card.step(1)  # path time 0
    for (x, _, _), (y, _, _) in zip(X_TRAJ.points(), Y_TRAJ.points(), strict=True):
        card.step(CYCLES)
        assert positions(card) == pytest.approx((x, y), abs=1)


def test_the_abort_halts_kills_and_flushes_and_a_new_scan_runs(card: Maxk) -> None:
    """[E-traj L812-824]: `VH[n]1` for each task, then `KS1,1,...`: the axes stop where they
    are, their queues are empty, no done flag comes and a VG moves nothing; the next scan
    (back at the start) runs as the first did."""
    write(card, load_strings(SCAN) + execute_strings(SCAN))
    card.step(round(0.5 / PERIOD))  # cruising
    write(card, abort_strings(SCAN))
    here = positions(card)
    assert 1500 < here[0] < 2000 and -4500 < here[1] < -3000
    card.step(HZ)
    assert positions(card) == here
    assert card.query("AM; RQC;").split(",")[:2] == ["2559", "2559"]
    assert card.odbr() & (MaxkDoorbell.DONE_X | MaxkDoorbell.DONE_Y) == 0
    write(card, execute_strings(SCAN))
    card.step(HZ // 2)
    assert positions(card) == here
    write(card, ["AA; VL20000,20000; MA0,0; GO;"])
    card.step(HZ)
    assert positions(card) == (0, 0)
    write(card, load_strings(SCAN) + execute_strings(SCAN))
    assert_follows(run_path(card, 1 + round(DURATION / PERIOD), every=16))
    card.step(4)
    assert card.odbr() & DONE_XY == DONE_XY


def test_a_four_axis_card_takes_the_eight_fields_of_every_vp_si_and_ks(maxk: Maxk) -> None:
    """[E-traj] writes MAX_AXES (8) fields whatever the card has: empty fields past a MAXk-4000's
    axes are not an error, so the scan and its abort run there as on eight axes; a value for an
    axis the card does not have still is."""
    write(maxk, load_strings(SCAN) + execute_strings(SCAN))
    assert_follows(run_path(maxk, round(DURATION / PERIOD) - 1))
    maxk.step(4)
    assert positions(maxk) == (X_TRAJ.end, Y_TRAJ.end)
    write(maxk, load_strings(SCAN) + execute_strings(SCAN) + abort_strings(SCAN))
    for bad in ("AM; KS1,1,,,1,,,;", "AM; VP[1]A1,,,,5;", "AM; LMH,,,,H;", "AM; SI,,,,,1;"):
        maxk.send(bad)
        assert maxk.command_error(), bad


def test_an_input_bit_holds_the_start_after_vg_until_it_goes_high(card: Maxk) -> None:
    """[E-traj L1303-1310]: with `A<axis>; SW<bit>` before the points, VG does not start the
    contours while the input is low; both start in the cycle after it goes high."""
    card.control("set_input", bit=IN_BIT, level=0)
    write(card, load_strings(SCAN, in_bit=IN_BIT) + execute_strings(SCAN))
    card.step(HZ // 2)
    assert positions(card) == (0, 0)
    card.control("set_input", bit=IN_BIT, level=1)
    assert_follows(run_path(card, 1 + round(DURATION / PERIOD)))
    card.step(4)
    assert positions(card) == (X_TRAJ.end, Y_TRAJ.end)
    assert card.odbr() & DONE_XY == DONE_XY


def test_vh1_halts_on_the_path_and_vg_resumes_it_to_its_end(card: Maxk) -> None:
    """VH[1]1 at the cruise: X slows down at the contour's VA (16,000 counts/s², the first
    point's) and rests (6000²/(2·16,000) ≈ 1125 counts on); VG[1] resumes it to its end and
    its done flag. Task 2 runs on untouched."""
    write(card, load_strings(SCAN) + execute_strings(SCAN))
    card.step(round(0.4 / PERIOD))
    write(card, ["AM; VH[1]1;"])
    x0 = positions(card)[0]
    card.step(8)
    assert positions(card)[0] - x0 == pytest.approx(6000 * 8 * PERIOD, abs=3)  # not a jump
    card.step(HZ)
    rest = positions(card)[0]
    assert x0 + 900 < rest < X_TRAJ.end
    card.step(HZ // 4)
    assert positions(card)[0] == rest
    assert positions(card)[1] == Y_TRAJ.end
    assert card.odbr() & (MaxkDoorbell.DONE_X | MaxkDoorbell.DONE_Y) == MaxkDoorbell.DONE_Y
    write(card, ["AM;VG[1];"])
    card.step(HZ)
    assert positions(card)[0] == X_TRAJ.end
    assert card.odbr() & MaxkDoorbell.DONE_X


# -- the pieces, on a 4-axis card ------------------------------------------------------------------
def run_to_end(maxk: Maxk, text: str, seconds: float = 1.0) -> int:
    """Send a contour, run it, return the doorbell's done bits (X..T)."""
    maxk.send(text)
    assert not maxk.command_error()
    maxk.step(round(seconds * HZ))
    return maxk.odbr() & 0x0F


@pytest.mark.parametrize(("vid", "done"), [
    ("VID[1]1;", MaxkDoorbell.DONE_X), ("VID[1];", MaxkDoorbell.DONE_X), ("VID[1]0;", 0), ("", 0)])
def test_vid_before_the_points_sets_the_done_flags_at_the_end_or_not(
        maxk: Maxk, vid: str, done: int) -> None:
    """`VID[n]1` (or bare) in the definition: done flag and doorbell bit at the contour's end
    [E-traj L1296]; `VID[n]0` or none: no done flag."""
    line = "VV[1]1000; VA[1]1000000; VP[1]A500;"
    assert run_to_end(maxk, f"AM; VIO[1]0,0,0; {vid} {line}", 0.2) == 0  # no VE, no run
    assert run_to_end(maxk, "AM; VE[1];") == done
    assert maxk.query("AX QA;")[1] == ("D" if done else "N")


def test_vid_after_ve_applies_to_the_contour_just_defined(maxk: Maxk) -> None:
    assert run_to_end(maxk, "AM; VV[2]1000; VA[2]1000000; VP[2],500; VE[2]; VID[2];") == 2


@pytest.mark.parametrize("bad", ["VID[1]2", "VID[1]1,1", "VID[1]-1"])
def test_a_bad_vid_is_a_command_error(maxk: Maxk, bad: str) -> None:
    maxk.send(f"AM; {bad};")
    assert maxk.command_error()


def test_the_lexer_takes_the_a_and_r_flags_of_vp_and_vc() -> None:
    lexer = Lexer(OPERANDS)
    got = lexer.feed(b"VP[1]A1000,,,;vp[2]r-5,3;VC[3]R1,2,90;VP5,6;VID[4]1;")
    assert [(c.mnemonic, c.index, c.operand, c.error) for c in got] == [
        ("VP", 1, "A1000,,,", ""), ("VP", 2, "R-5,3", ""), ("VC", 3, "R1,2,90", ""),
        ("VP", None, "5,6", ""), ("VID", 4, "1", "")]


def firmware(travel_limits: list[tuple[float, float] | None] | None = None) -> Firmware:
    """A 4-axis firmware without bus or daemon (every axis ideal), with the card option
    `travel_limits` if given."""
    return Firmware(4, ["M"] * 4, round(PERIOD * 1e9), update_hz=HZ, ideal=True,
                    ring=lambda bits: None, version="1.50", serial=1, save=lambda image: None,
                    saved=None, travel_limits=travel_limits)


def test_vp_a_is_absolute_and_vp_r_from_the_end_of_the_segment_before() -> None:
    """An empty field keeps the axis where it is; no flag is absolute."""
    fw = firmware()
    fw.feed(b"AA; VP100,50; VPR100,; VPR,-50.7; VPA,7; VP3,; VE;")
    assert fw.errors == 0
    ends = [seg.end[:2] for seg in fw.defined_contours[1].segments]
    assert ends == [(100, 50), (200, 50), (200, 0), (200, 7), (3, 7)]


def test_vc_r_takes_the_centre_from_where_the_arc_starts() -> None:
    fw = firmware()
    fw.feed(b"AA; VP1000,0; VCR0,500,180; VCA1000,1500,-180; VE;")
    assert fw.errors == 0
    arc, back = fw.defined_contours[1].segments[1:]
    assert arc.end[:2] == pytest.approx((1000, 1000))
    assert back.end[:2] == pytest.approx((1000, 2000))


def test_a_ve_the_queue_has_no_room_for_keeps_the_definition() -> None:
    """README "Errors": a full queue changes nothing. X's queue, held by an SW, has 7 units
    left; a 7-segment contour's VE needs 8: refused, the points stay defined, and once the
    queue has room the same VE queues the whole contour."""
    fw = firmware()
    fw.gpio_in &= ~(1 << 3)
    fw.feed(b"AX SW3;" + b"VL1000;" * 1275)
    assert fw.queues[0].free == 7 and fw.errors == 0
    points = b"".join(f"VP{100 * i},0;".encode() for i in range(1, 8))
    fw.feed(b"AA; VV1000; VA100000; " + points + b" VE;")
    assert fw.errors == 1 and len(fw.contours[1].segments) == 7
    fw.gpio_in |= 1 << 3
    cycles(fw, 10)  # the SW passes, the VLs run
    fw.feed(b"VE;")
    cycles(fw, 1500)
    assert fw.errors == 1 and fw.motor_position()[0] == 700


def test_vio_sets_the_outputs_once_as_its_segment_begins() -> None:
    """README "Points": VIO sets its outputs at the start of the next segment; an output the
    host changes while the segment runs keeps the host's level."""
    fw = firmware()
    fw.feed(b"AA; VV1000; VA1000000; VIO100,0,100; VP1000,0; VE;")
    cycles(fw, 100)
    assert fw.gpio_out >> 8 & 1
    fw.feed(b"AX BL8;")
    cycles(fw, 100)
    assert not fw.gpio_out >> 8 & 1 and fw.running_contours


@pytest.mark.parametrize("points", [b"VPR500,0; VIO200,0,200; VP1000,0;",
                                    b"VP1000,0; VIO200,0,200; VP1000,0;"])
def test_vio_before_a_segment_of_no_length_at_the_end_is_set_there(points: bytes) -> None:
    """The last segment has no length (its point repeated, or reached already by an MR the
    contour was queued behind): its VIO is set when the path ends there."""
    fw = firmware()
    fw.feed(b"AX MR500; GO; AA; VV1000; VA100000; " + points + b" VE;")
    cycles(fw, 2000)
    assert fw.gpio_out >> 9 & 1 and fw.motor_position()[0] == 1000 and not fw.live_contours


@pytest.mark.parametrize("bad", ["VPA", "VPR", "VP[1]A1,2,3,4,5", "VCR1,2", "VPR1.5.5"])
def test_a_bad_vp_or_vc_is_a_command_error(bad: str) -> None:
    fw = firmware()
    fw.feed(f"AA; {bad};".encode())
    assert fw.errors == 1


def test_vv0_a_point_at_rest_keeps_the_velocity_and_ends_there() -> None:
    """[E-traj L1355] sends a point where the velocity is 0 as `VV[n]0`."""
    fw = firmware()
    fw.feed(b"AA; VA1000; VV800; VP500,0; VV0; VP1000,0; VV800; VP1500,0; VE;")
    assert fw.errors == 0
    c = fw.defined_contours[1]
    assert [(s.velocity, s.end_velocity) for s in c.segments] == [
        (800, None), (800, 0.0), (800, None)]
    assert [leg.exit for leg in c.legs] == [800.0, 0.0, 0.0]


def test_va_between_points_sets_the_acceleration_of_the_segments_after_it(maxk: Maxk) -> None:
    """VA1000 before the first point: it ramps 1 s to 1000 (500 counts); VA100000 before the
    second: that one stops in 10 ms, at 1 + 0.5 + 1.995 + 0.01 ≈ 3.505 s."""
    maxk.send("AA; VA1000; VV1000; VP1000,0; VA100000; VV1000,0; VP3000,0; VE;")
    maxk.step(1 + HZ)  # path time 1 s
    assert maxk.word(0) == pytest.approx(500, abs=1)
    maxk.step(round(2.49 * HZ))  # 3.49 s: 5 ms of cruise and the 5-count stop ahead
    assert maxk.word(0) == pytest.approx(2990, abs=1)
    maxk.step(round(0.02 * HZ))
    assert maxk.word(0) == 3000


def test_junctions_use_each_segments_own_acceleration() -> None:
    """Up at 1000 over 200 counts reaches sqrt(2·1000·200) ≈ 632; the second segment, at
    1e6, stops within itself, so it does not lower that junction; a third at 10 must be
    entered slowly enough to stop in its 50 counts: sqrt(2·10·50) ≈ 31.6."""
    speeds = junction_speeds([200.0, 3800.0, 100.0, 50.0], [1000.0] * 4,
                             [1000.0, 1000.0, None, None], [1000.0, 1e6, 1e6, 10.0])
    assert speeds[0] == pytest.approx(math.sqrt(2 * 1000 * 200))
    assert speeds[2] == pytest.approx(math.sqrt(2 * 10 * 50))
    assert speeds[3] == 0.0


def test_a_slower_segment_slows_down_within_itself_at_its_own_va() -> None:
    """[E-traj]: `VA a; VV v` after a faster point ramps down from that speed at the start of
    the segment, so constant-deceleration points take their time exactly; a longer one then
    cruises at v."""
    legs = plan_legs([1000.0, 375.0, 125.0], [4000.0, 2000.0, 2000.0], [None, None, 0.0],
                     [1e9, 16_000.0, 16_000.0])
    assert legs[1].entry == pytest.approx(4000) and legs[1].exit == pytest.approx(2000)
    assert legs[1].duration == pytest.approx(0.125)
    assert legs[1].s_at(0.0625) == pytest.approx(4000 * 0.0625 - 8000 * 0.0625 ** 2)
    assert legs[2].duration == pytest.approx(0.125)
    longer = plan_legs([1000.0, 1000.0], [4000.0, 2000.0], [None, None], [1e9, 16_000.0])[1]
    assert longer.v_at(0.2) == pytest.approx(2000)  # down at its start, then cruising
    assert longer.s_at(0.2) == pytest.approx(375 + 2000 * 0.075)


@settings(derandomize=True, max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1e5), st.floats(1, 1e5), st.none() | st.floats(0, 1e5),
                          st.floats(1, 8e6)), min_size=1, max_size=8))
def test_legs_with_their_own_va_keep_their_bounds_and_cover_their_length(
        segments: list[tuple[float, float, float | None, float]]) -> None:
    """Per-segment VA: every leg changes speed within what its own acceleration allows over
    its length, leaves at most at its velocity and vend, enters where the one before left,
    and covers its length exactly, monotonically, never faster than its velocity or its
    entry speed; the path starts and ends at rest."""
    lengths, velocities, ends, accels = (list(x) for x in zip(*segments, strict=True))
    legs = plan_legs(lengths, velocities, ends, accels)
    assert legs[0].entry == 0.0 and legs[-1].exit == 0.0
    entry = 0.0
    for leg, length, v, end, a in zip(legs, lengths, velocities, ends, accels, strict=True):
        tol = 1e-9 * max(v, leg.entry, 1.0)
        assert leg.accel == a and leg.entry == entry
        assert leg.exit <= v + tol and (end is None or leg.exit <= end + tol)
        assert abs(leg.exit ** 2 - leg.entry ** 2) <= 2 * a * length * (1 + 1e-9) + tol
        steps = 64
        dt = leg.duration / steps
        s = [leg.s_at(k * dt) for k in range(steps + 1)]
        assert s[-1] == pytest.approx(length, rel=1e-9, abs=1e-6)
        assert all(q >= p - 1e-9 * length - 1e-12 for p, q in zip(s, s[1:], strict=False))
        assert max((q - p for p, q in zip(s, s[1:], strict=False)), default=0.0) <= max(
            v, leg.entry) * dt * (1 + 1e-9) + 1e-9
        entry = leg.exit


# -- VH0 and VG on the firmware ------------------------------------------------------------------
def cycles(fw: Firmware, n: int) -> None:
    """n update cycles, the clock with them."""
    for _ in range(n):
        fw.now_ns += round(PERIOD * 1e9)
        fw.cycle()


def contour(task: int) -> bytes:
    return f"VV[{task}]1000; VA[{task}]1000000; VP[{task}]R100; VE[{task}];".encode()


def test_without_vh0_a_contour_starts_at_its_ve() -> None:
    """The App C example has no VH: the contour runs once its VE reaches the queue head."""
    fw = firmware()
    fw.feed(b"AM; " + contour(1))
    cycles(fw, 1)
    assert 1 in fw.running_contours


def test_vh0_holds_the_start_until_vg_even_when_vg_comes_first() -> None:
    fw = firmware()
    fw.feed(b"AM; VH[1]0; " + contour(1))
    cycles(fw, 10)
    assert 1 in fw.waiting_contours and not fw.running_contours
    fw.feed(b"VG[1];")
    assert 1 in fw.running_contours
    fw = firmware()
    fw.feed(b"AM; VH[1]0; AX WT50; AM; " + contour(1) + b" VG[1];")  # VG before the queue's VE
    cycles(fw, 40)
    assert not fw.running_contours
    cycles(fw, 20)
    assert 1 in fw.running_contours


def test_vh0_is_consumed_by_the_vg_that_starts_the_contour() -> None:
    """One-shot: the task's next contour starts at its VE again."""
    fw = firmware()
    fw.feed(b"AM; VH[1]0; " + contour(1) + b" VG[1];")
    cycles(fw, 200)
    assert not fw.running_contours and float(fw.motor_position()[0]) == 100
    fw.feed(contour(1))
    cycles(fw, 1)
    assert 1 in fw.running_contours


def test_vh0_belongs_to_its_task() -> None:
    fw = firmware()
    fw.feed(b"AM; VH[2]0; " + contour(1))
    cycles(fw, 1)
    assert 1 in fw.running_contours


def test_a_flush_ends_a_waiting_contour_and_its_vh0_and_vh1() -> None:
    """KS before VG: the contour never starts, and the task's next one starts at its VE,
    neither waiting for VG nor halted."""
    fw = firmware()
    fw.feed(b"AM; VH[1]0; " + contour(1) + b" VH[1]1; KS1;")
    cycles(fw, 1)
    assert not fw.waiting_contours and not fw.running_contours
    assert float(fw.motor_position()[0]) == 0
    fw.feed(contour(1))
    cycles(fw, 200)
    assert float(fw.motor_position()[0]) == 100


@pytest.mark.parametrize("stop", [b"AX ST;", b"AM; SI1;", b"AM; KS1;"])
def test_a_stop_or_kill_on_an_axis_ends_the_contour_running_on_it(stop: bytes) -> None:
    """ST, SI and KS flush the axis's queue: the contour ends, without done flags (ST and SI
    after ramping down on the path, here within a cycle at VA 10⁶: test_contour_stops.py)."""
    fw = firmware()
    fw.feed(b"AA; VID; VV1000; VA1000000; VP100000,50000; VE;")
    cycles(fw, 100)
    fw.feed(stop)
    cycles(fw, 1)
    here = fw.motor_position()[:2].tolist()
    cycles(fw, 100)
    assert not fw.running_contours and fw.motor_position()[:2].tolist() == here
    assert not fw.done.any()
