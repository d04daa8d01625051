"""Coordinated motion of the DMC-13X8 [M Ch6 §Linear Interpolation Mode, §Vector Mode]: the path
planner on its own (vdevd/devices/galil/vector.py) and the firmware running LM/LI and VM/VP/CR
sequences sample by sample (an A16 window, no card, no daemon). Expected times come from VS, VA,
VD and the path length (a trapezoid along the path)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from tests.devices.galil.test_firmware import Rig
from vdevd.devices.galil.record import record_dtype
from vdevd.devices.galil.vector import MAX_SEGMENTS, Sequence, arc, line

DT = 0.001  # TM 1000


def path_time(length: float, vs: float, va: float, vd: float) -> float:
    """Seconds along a path of `length` from rest to rest: trapezoid, or triangle if short."""
    ramps = vs * vs / (2 * va) + vs * vs / (2 * vd)
    if length >= ramps:
        return vs / va + vs / vd + (length - ramps) / vs
    peak = math.sqrt(2 * length * va * vd / (va + vd))
    return peak / va + peak / vd


def run(seq: Sequence, vs: float, va: float, vd: float, limit: int = 100_000) -> list[float]:
    """Advance to the end; the output path distance of every sample."""
    out = []
    for _ in range(limit):
        more = seq.advance(vs, va, vd)
        out.append(seq.out)
        if not more:
            return out
    raise AssertionError("the sequence did not end")


def ended(*segments: tuple[tuple[float, ...], tuple[float, ...]], smoothing: int = 1) -> Sequence:
    seq = Sequence(len(segments[0][0]), DT)
    for a, b in segments:
        seq.add(line(a, b))
    seq.ended = True
    seq.start(smoothing)
    return seq


# -- the planner -----------------------------------------------------------------------------------
def test_fig_6_2_linear_move_trapezoid_along_the_path() -> None:
    """[M Ch6 Example - Linear Move, Fig 6.2]: LI,,40000,30000, VS 100000, VA VD 1000000: the
    path of 50000 accelerates for 0.1 s (Z 4000), slews to 0.5 s (Z 36000) and ends at 0.6 s."""
    seq = ended(((0.0, 0.0), (40000.0, 30000.0)))
    points = []
    for _ in range(700):
        more = seq.advance(100_000, 1_000_000, 1_000_000)
        points.append(seq.position())
        if not more:
            break
    assert len(points) == round(path_time(50_000, 100_000, 1e6, 1e6) / DT) == 600
    assert points[99] == pytest.approx((4000, 3000))
    assert points[499] == pytest.approx((36000, 27000))
    assert points[-1] == (40000.0, 30000.0)


def test_example_15_three_axis_trapezoid_time() -> None:
    """[M Ch2 Ex15]: LM XYZ, LI 7000,3000,6000, VS 6000, VA VD 20000: the time of the trapezoid
    over the vector length (VS² = XS² + YS² + ZS²) [M Ch6 §Additional Commands]."""
    seq = ended(((0.0, 0.0, 0.0), (7000.0, 3000.0, 6000.0)))
    out = run(seq, 6000, 20_000, 20_000)
    expected = path_time(math.sqrt(7000**2 + 3000**2 + 6000**2), 6000, 20_000, 20_000)
    assert abs(len(out) * DT - expected) <= 2 * DT
    assert seq.position() == (7000.0, 3000.0, 6000.0)


def test_a_short_path_is_a_triangle() -> None:
    seq = ended(((0.0, 0.0), (300.0, 400.0)))
    out = run(seq, 100_000, 1_000_000, 500_000)
    assert abs(len(out) * DT - path_time(500, 100_000, 1e6, 5e5)) <= 2 * DT
    assert out[-1] == 500


def test_vt_smooths_into_a_longer_move_that_ends_on_the_same_point() -> None:
    """VT: "smaller values ... imply heavier filtering"; "the smoothing process results in longer
    motion time" [M Ch6 §Motion Smoothing]: L = 1/VT samples longer, same end point."""
    plain = run(ended(((0.0, 0.0), (40000.0, 30000.0))), 100_000, 1e6, 1e6)
    smooth_seq = ended(((0.0, 0.0), (40000.0, 30000.0)), smoothing=20)
    smooth = run(smooth_seq, 100_000, 1e6, 1e6)
    assert len(smooth) == len(plain) + 19
    assert smooth_seq.position() == (40000.0, 30000.0)
    # the acceleration changes gradually: the jerk is 1/L of the trapezoid's step
    jerk_smooth = np.abs(np.diff([0.0, *smooth], 3)).max()
    jerk_plain = np.abs(np.diff([0.0, *plain], 3)).max()
    assert jerk_smooth < jerk_plain / 5


def test_end_speed_is_reached_at_the_end_of_its_segment() -> None:
    """[M Ch6 #ALT]: LI 4000,0 <4000 >1000: the speed is 1000 where the segment ends (the
    deceleration starts within it, at VD), then rises again toward 4000."""
    seq = Sequence(2, DT)
    for a, b in (((0, 0), (4000, 0)), ((4000, 0), (5000, 1000)), ((5000, 1000), (5000, 6000))):
        seq.add(line(a, b, speed=4000, end_speed=1000))
    seq.ended = True
    seq.start(1)
    speed_at_4000 = None
    peak = 0.0
    while seq.advance(25_000, 256_000, 256_000):
        if speed_at_4000 is None and seq.s >= 4000:
            speed_at_4000 = seq.v
        peak = max(peak, seq.v)
    assert speed_at_4000 == pytest.approx(1000, abs=256_000 * DT)
    assert peak == pytest.approx(4000)  # `<4000` replaced VS 25000
    assert seq.position() == (5000, 6000)


def test_vr_scales_the_speed_not_the_ramps() -> None:
    """VR .5 halves VS [M Ch6 §Changing Feedrate]."""
    seq = ended(((0.0, 0.0), (100_000.0, 0.0)))
    seq.ratio = 0.5
    out = run(seq, 50_000 * 0.5, 1e6, 1e6)
    assert abs(len(out) * DT - path_time(100_000, 25_000, 1e6, 1e6)) <= 2 * DT


def test_without_le_the_motion_stops_at_once_at_the_last_vector_and_waits() -> None:
    """"If the controller receives no additional LI segments and no LE command, the controller
    will stop motion instantly at the last vector" [M Ch6 §Specifying Linear Segments]."""
    seq = Sequence(2, DT)
    seq.add(line((0.0, 0.0), (20_000.0, 0.0)))
    seq.start(1)
    speeds = []
    for _ in range(600):
        assert seq.advance(50_000, 1e6, 1e6)  # not done: the sequence waits for segments
        speeds.append(seq.v)
    assert max(speeds) == 50_000 and speeds[-1] == 0.0 and seq.position() == (20_000, 0)
    assert speeds[speeds.index(0.0) - 1] == 50_000  # no deceleration
    seq.add(line((20_000.0, 0.0), (20_000.0, 5000.0)))
    seq.ended = True
    run(seq, 50_000, 1e6, 1e6)
    assert seq.position() == (20_000, 5000)


def test_every_arc_sample_is_on_the_radius_and_the_arc_ends_where_theta_plus_delta_is() -> None:
    seq = Sequence(2, DT)
    seq.add(arc((0.0, 0.0), 1500, 270, -180))
    seq.ended = True
    seq.start(1)
    while seq.advance(20_000, 1e6, 1e6):
        x, y = seq.position()
        assert math.hypot(x, y - 1500) == pytest.approx(1500)
    assert seq.position() == (0, 3000)


def test_the_buffer_holds_511_segments() -> None:
    seq = Sequence(2, DT)
    assert seq.free == MAX_SEGMENTS == 511
    for k in range(511):
        seq.add(line((k, 0.0), (k + 1.0, 0.0)))
    assert seq.free == 0


# -- the firmware ----------------------------------------------------------------------------------
def finish(rig: Rig, limit: int = 100_000) -> int:
    """Samples until no plane runs."""
    for k in range(1, limit):
        rig.sample()
        if not rig.fw.coord.active:
            return k
    raise AssertionError("the sequence did not end")


def rp(rig: Rig) -> list[int]:
    return [int(v) for v in rig.send(b"RP\r")[:-3].split(b",")]


def mg(rig: Rig, *operands: str) -> list[float]:
    reply = rig.send(f"MG {','.join(operands)}\r".encode())
    return [float(v) for v in re.findall(rb"-?\d+\.\d+", reply)]


def sc(rig: Rig) -> list[int]:
    return [int(v) for v in rig.send(b"SC\r")[:-3].split(b",")]


def test_linear_move_example_runs_the_fig_6_2_profile_and_reports_the_sequence() -> None:
    """[M Ch6 Example - Linear Move]: SC 100 while running, 101 at the end (spec §4.4); _LE the
    vector length; _LM 511 - segments; RP at the figure's points."""
    rig = Rig()
    assert rig.send(b"LM ZW;LI,,40000,30000;LE;VS 100000;VA 1000000;VD 1000000\r") == b"::::::"
    assert mg(rig, "_LM", "_LE") == [510, 50_000]
    assert rig.send(b"BGS\r") == b":"
    for _ in range(100):
        rig.sample()
    assert rp(rig) == [0, 0, 4000, 3000]
    assert sc(rig) == [1, 1, 100, 100]
    assert rig.fw.rest_state() is None  # a running vector move: the card is not at rest
    for _ in range(400):
        rig.sample()
    assert rp(rig) == [0, 0, 36000, 27000]
    total = 500 + finish(rig)
    assert total == round(path_time(50_000, 100_000, 1e6, 1e6) / DT)
    assert rp(rig) == [0, 0, 40000, 30000]
    assert sc(rig) == [1, 1, 101, 101]
    assert mg(rig, "_CS", "_AV", "_LM", "_BGS") == [1, 50_000, 511, 0]
    for _ in range(400):
        rig.sample()
    assert rig.fw.rest_state() is not None


def test_lmove_example_operands_at_3000_and_in_the_second_segment() -> None:
    """[M Ch6 Operand Summary - Linear Interpolation]: #LMOVE, at X = 3000 _AV is 3000, _CS and
    _VPX, _VPY 0; at Y = 2000 of the second segment _AV 7000, _CS 1, _VPX 5000, _VPY 0."""
    rig = Rig()
    rig.send(b"DP 0,0;LMXY;LI 5000,0;LI 0,5000;LE;VS 4000;BGS\r")
    while rp(rig)[0] < 3000:
        rig.sample()
    x = rp(rig)[0]
    assert 3000 <= x < 3000 + 4000 * DT + 1  # the first sample at or past X = 3000
    assert mg(rig, "_AV", "_CS", "_VPX", "_VPY") == [x, 0, 0, 0]
    while rp(rig)[1] < 2000:
        rig.sample()
    y = rp(rig)[1]
    assert mg(rig, "_AV", "_CS", "_VPX", "_VPY") == [5000 + y, 1, 5000, 0]


def test_fig_6_3_vector_path_operands_and_end() -> None:
    """[M Ch6 Fig 6.3]: VM XY, VS 20000, VA VD 1000000, VP -4000,0, CR 1500,270,-180, VP 0,3000,
    CR 1500,90,-180, VE: halfway A-B _AV 2000, _CS 0, _VP = A; halfway C-D _AV 4000+1500π+2000,
    _CS 2, _VP = C (-4000,3000); back at A after the path's trapezoid time."""
    rig = Rig()
    rig.send(b"VM XY;VS 20000;VA 1000000;VD 1000000;VP -4000,0;CR 1500,270,-180;VP 0,3000;"
             b"CR 1500,90,-180;VE;BGS\r")
    length = 2 * 4000 + 2 * 1500 * math.pi
    assert mg(rig, "_VE") == [round(length)]
    while rp(rig)[0] > -2000:
        rig.sample()
    x = rp(rig)[0]
    assert mg(rig, "_AV", "_CS", "_VPX", "_VPY") == [-x, 0, 0, 0]
    c_to_d = 4000 + 1500 * math.pi  # where segment CD starts along the path
    while mg(rig, "_AV")[0] < c_to_d + 2000:
        rig.sample()
    av, cs, vpx, vpy = mg(rig, "_AV", "_CS", "_VPX", "_VPY")
    assert [cs, vpx, vpy] == [2, -4000, 3000]
    x, y = rp(rig)[:2]
    assert y == 3000 and abs(x - (-4000 + av - c_to_d)) <= 1
    finish(rig)
    assert rig.fw.ticks == pytest.approx(path_time(length, 20_000, 1e6, 1e6) / DT, abs=2)
    assert rp(rig) == [0, 0, 0, 0]


def test_example_16_circle_samples_stay_on_the_radius() -> None:
    """[M Ch2 Ex16, Fig 2-4]: the arcs of radius 2000 about (-4000,2000) and (0,2000): RP of every
    sample within a count of the radius; the path ends at the local zero (0,0)."""
    rig = Rig()
    rig.send(b"VM XY;VP -4000,0;CR 2000,270,-180;VP 0,4000;CR 2000,90,-180;VS 1000;"
             b"VA 50000;VD 50000;VE;BGS\r")
    worst = 0.0
    while rig.fw.coord.active:
        rig.sample()
        x, y = rig.fw.motion.reference()[:2]
        if x < -4000:
            worst = max(worst, abs(math.hypot(x + 4000, y - 2000) - 2000))
        elif x > 0:
            worst = max(worst, abs(math.hypot(x, y - 2000) - 2000))
    assert worst <= 1.0
    assert rp(rig) == [0, 0, 0, 0]


def test_tangent_knife_example() -> None:
    """[M Ch6 §Tangent Motion]: VM XYZ, TN 2000/360,-500, CR 3000,0,180: _TN is 0 (the knife
    toward +Y); the cut from (3000,0) ends at (-3000,0) with Z at -500 + 270 x 2000/360 = 1000,
    Z following the direction of the path."""
    rig = Rig()
    assert rig.send(b"VM XYZ;TN 2000/360,-500;CR 3000,0,180;VE;MG _TN\r").endswith(
        b" 0000000000.0000\r\n:")
    rig.send(b"PA 3000,0,_TN;BG XYZ\r")
    for _ in range(1000):
        rig.sample()
    assert rp(rig)[:3] == [3000, 0, 0]
    rig.send(b"BGS\r")
    while rig.fw.coord.active:
        rig.sample()
        x, y, z = rig.fw.motion.core.axes.cmd_pos[:3]
        heading = math.degrees(math.atan2(y, x)) % 360 + 90
        assert z == pytest.approx(-500 + heading * 2000 / 360, abs=0.5)
    assert rp(rig)[:3] == [-3000, 0, 1000]


def test_sinusoid_example_with_the_virtual_axis_n() -> None:
    """[M Ch6 §Sinusoidal Motion Example]: VMXN, VA VD 68000000, VS 125664, CR 1000,-90,3600:
    X swings ±1000 at 20 Hz for 10 cycles (0.5 s) and ends at 0; N drives no axis."""
    rig = Rig()
    rig.send(b"VMXN;VA 68000000;VD 68000000;VS 125664;CR 1000,-90,3600;VE;BGS\r")
    xs = []
    while rig.fw.coord.active:
        rig.sample()
        xs.append(rig.fw.motion.core.axes.cmd_pos[0])
    assert len(xs) == pytest.approx(path_time(1000 * 2 * math.pi * 10, 125664, 68e6, 68e6) / DT,
                                    abs=2)
    assert max(xs) == pytest.approx(1000, abs=5) and min(xs) == pytest.approx(-1000, abs=5)
    crossings = np.flatnonzero(np.diff(np.sign(np.array(xs[5:-5]))) > 0)
    assert np.diff(crossings) == pytest.approx(50, abs=1)  # 20 Hz at 1 ms
    assert rp(rig) == [0, 0, 0, 0] and sc(rig) == [101, 1, 1, 1]


def test_st_decelerates_the_path_at_vd_with_stop_code_4() -> None:
    rig = Rig()
    rig.send(b"LM XY;LI 80000,60000;LE;VS 50000;VA 500000;VD 250000;BGS\r")
    for _ in range(200):
        rig.sample()
    at = mg(rig, "_AV")[0]  # 2500 accelerating + 5000 slewing
    assert at == 7500
    assert rig.send(b"ST S\r") == b":"
    assert sc(rig)[:2] == [4, 4]  # decelerating or stopped by ST
    n = finish(rig)
    assert n == pytest.approx(50_000 / 250_000 / DT, abs=1)
    assert mg(rig, "_AV", "_LM")[0] == at + 50_000**2 / (2 * 250_000)
    assert rp(rig)[:2] == [round((at + 5000) * 0.8), round((at + 5000) * 0.6)]
    assert sc(rig)[:2] == [4, 4]


def test_st_alone_stops_the_sequence_too() -> None:
    rig = Rig()
    rig.send(b"LM X;LI 100000;LE;VS 20000;VA 1000000;VD 1000000;BGS\r")
    for _ in range(100):
        rig.sample()
    rig.send(b"ST\r")
    assert finish(rig) == pytest.approx(20, abs=1)
    assert sc(rig)[0] == 4


def test_ab_stops_at_once_with_stop_code_7() -> None:
    rig = Rig()
    rig.send(b"LM XY;LI 80000,60000;LE;VS 50000;VA 500000;VD 250000;BGS\r")
    for _ in range(200):
        rig.sample()
    here = rp(rig)
    assert rig.send(b"AB;MG _BGS\r") == b": 0000000000.0000\r\n:"
    rig.sample()
    assert not rig.fw.coord.active
    assert sc(rig)[:2] == [7, 7]
    moved = np.abs(np.array(rp(rig)[:2]) - here[:2]).max()
    assert moved <= 50_000 * DT  # at most the sample under way
    assert mg(rig, "_LM") == [511]


def test_a_limit_switch_stops_the_vector_at_vd() -> None:
    """A limit switch during the move: a decelerated stop [M Ch3 §Limit Switch Input], SC 2; BGS
    toward the tripped switch is then TC 22."""
    rig = Rig()
    rig.send(b"LM XY;LI 100000,50000;LE;VS 50000;VA 500000;VD 250000;BGS\r")
    for _ in range(200):
        rig.sample()
    rig.fw.set_limits(np.array([True, False, False, False]), np.zeros(4, bool))
    n = finish(rig)
    assert n == pytest.approx(50_000 / 250_000 / DT, abs=2)
    assert sc(rig)[:2] == [2, 2]
    assert rig.send(b"LI 10,0;LE;BGS;TC\r") == b"::?022\r\n:"
    assert rig.send(b"CS;LI -10,0;LE;BGS\r") == b"::::"  # away from it
    finish(rig)
    assert sc(rig)[:2] == [101, 101]


def test_the_512th_segment_is_refused_with_tc_32() -> None:
    """511 segments fill the buffer: _LM 0; the next LI is TC 32 [M Ch6; spec §4.3]."""
    rig = Rig()
    rig.send(b"LM XY\r")
    for k in range(511):
        assert rig.send(b"LI 10,10\r") == b":", k
    assert mg(rig, "_LM") == [0]
    assert rig.send(b"LM?\r") == b"000\r\n:"
    assert rig.send(b"LI 10,10;TC\r") == b"?032\r\n:"
    assert rig.send(b"LE;BGS\r") == b"::"
    for _ in range(30):
        rig.sample()
    assert mg(rig, "_LM")[0] > 0  # segments done leave the buffer while it runs
    assert rig.send(b"LI 10,10;TC\r") == b"?007\r\n:"  # the sequence has ended (LE)


@pytest.mark.parametrize(("line", "code"), [
    (b"LI 100,100", 4),  # no LM given
    (b"LM XY;LI 100,100,100", 4),  # a field for Z, not in LM
    (b"LM XY;LI 0,0", 30),  # a segment of no length
    (b"VM XY;CR 0,0,90", 30),  # radius 0
    (b"VM XY;CR 1000,0,0", 30),  # no angle to travel
    (b"VM XY;CR -1000,0,90", 6),
    (b"VM XY;CR 1000,0", 50),
    (b"LM XY;VP 100,100", 33),  # VP or CR mixed with LI
    (b"VM XY;LI 100,100", 33),
    (b"LM XY;BGS", 24),  # no sequence
    (b"VM X", 50),
    (b"VM XX", 4),
    (b"LM XYQ", 4),
    (b"VS 13000000", 6),
    (b"VA 100", 6),
    (b"VR 11", 6),
    (b"CA Q", 4),
])
def test_bad_input_answers_question_mark_and_the_tc_code(line: bytes, code: int) -> None:
    rig = Rig()
    replies = rig.send(line + b";TC\r")
    assert replies.endswith(b"?" + f"{code:03d}".encode() + b"\r\n:")
    assert not rig.fw.coord.active
    assert rp(rig) == [0, 0, 0, 0]


def test_commands_refused_while_a_sequence_runs() -> None:
    rig = Rig()
    rig.send(b"LM XY;LI 80000,60000;LE;BGS\r")
    rig.sample()
    assert rig.send(b"BGS;TC\r") == b"?021\r\n:"
    assert rig.send(b"BG X;TC\r") == b"?021\r\n:"
    assert rig.send(b"LM XZ;TC\r") == b"?007\r\n:"
    assert rig.send(b"CS;TC\r") == b"?007\r\n:"
    assert rig.fw.coord.active


def test_am_s_waits_for_the_sequence() -> None:
    rig = Rig()
    assert rig.send(b"LM X;LI 1000;LE;VS 10000;VA 1000000;VD 1000000;BGS;AM S;MG 1\r") == b":" * 7
    samples = 0
    while not rig.receive():
        rig.sample()
        samples += 1
    assert rig.receive() == b""
    assert samples == pytest.approx(path_time(1000, 10_000, 1e6, 1e6) / DT, abs=2)
    assert rp(rig)[0] == 1000


def test_the_data_record_shows_the_plane_and_the_coordinated_axes() -> None:
    """Record revision 4: the S plane's segment count, move status (bit 15 in progress) and
    distance; axis status bit 8 "coordinated motion" [M Ch4; spec §2.5]."""
    rig = Rig()
    rig.send(b"LM XY;LI 3000,4000;LI 1000,0;LE;VS 50000;BGS\r")
    for _ in range(150):
        rig.sample()
    rec = np.frombuffer(rig.fw.data_record(), record_dtype(4))[0]
    assert rec["s_plane_move_status"] & 0x8000
    assert rec["s_plane_segment_count"] == mg(rig, "_CS")[0]
    assert rec["s_distance"] == mg(rig, "_AV")[0]
    assert list(rec["axis"]["status"] & 0x100) == [0x100, 0x100, 0, 0]
    assert list(rec["axis"]["stop_code"]) == [100, 100, 1, 1]


def test_vector_parameters_report_per_plane() -> None:
    rig = Rig()
    assert rig.send(b"VS 20000,30000;VS ?,?;VR .5;VR ?;VT 0.5;VT ?\r") == (
        b":00020000,00030000\r\n::00.5000\r\n::0.5000\r\n:")
    assert rig.send(b"CA T;CA ?;LM XY;LI 5,5;CA S;LM?;CA T;LM?\r") == (
        b":1\r\n::::511\r\n::510\r\n:")


def test_mo_of_one_axis_ends_the_sequence_and_the_others_stop_where_they_are() -> None:
    rig = Rig()
    rig.send(b"LM XY;LI 80000,60000;LE;VS 50000;VA 500000;VD 250000;BGS\r")
    for _ in range(100):
        rig.sample()
    rig.send(b"MO X\r")
    rig.sample()
    assert not rig.fw.coord.active
    y = rp(rig)[1]
    for _ in range(100):
        rig.sample()
    assert rp(rig)[1] == y  # Y does not run on at the path's speed
    assert sc(rig)[:2] == [7, 7]


def test_the_abort_input_ends_the_sequence_with_stop_code_6() -> None:
    rig = Rig()
    rig.send(b"LM XY;LI 80000,60000;LE;VS 50000;VA 500000;VD 250000;BGS\r")
    for _ in range(100):
        rig.sample()
    rig.fw.set_abort(True)
    here = rp(rig)
    for _ in range(10):
        rig.sample()
    assert not rig.fw.coord.active
    assert rp(rig) == here and sc(rig)[:2] == [6, 6]


def test_mc_s_waits_for_the_sequence_and_the_axes_in_position() -> None:
    rig = Rig()
    assert rig.send(b"LM XY;LI 3000,4000;LE;VS 10000;VA 1000000;VD 1000000;BGS;MC S\r") == (
        b":" * 7)
    samples = 0
    while not rig.receive():
        rig.sample()
        samples += 1
    assert samples >= path_time(5000, 10_000, 1e6, 1e6) / DT - 2
    assert rp(rig)[:2] == [3000, 4000]
    assert rig.send(b"TP XY\r") == b"0000003000,0000004000\r\n:"


def test_motion_complete_interrupts_fire_when_the_sequence_ends() -> None:
    """EI bits 0-3 and 8 [M Ch4]: the X and Y ends and all axes complete."""
    rig = Rig()
    rig.send(b"EI 259;LM XY;LI 3000,4000;LE;VS 10000;BGS\r")
    assert rig.bus.pending_interrupts == ()
    finish(rig)  # the sample the path ends in ends the axes' profiles
    assert rig.bus.pending_interrupts == (0xD0, 0xD1, 0xD8)


@pytest.mark.parametrize("skip_quiet", [True, False])
def test_a_vector_move_in_runs_of_samples_ends_as_one_by_one(skip_quiet: bool) -> None:
    """A card running sample runs (card.py `run`) and one stepping every sample end alike
    through vector moves, ST S and AB (decision 0008: not at rest while a plane runs)."""
    from tests.devices.galil.test_sample_runs import Twin

    twin = Twin(skip_quiet, "servo")
    twin.send("EI 511;DR 3;VM XYZ;TN 10,0;VS 50000;VA 1000000;VD 1000000;CR 5000,0,270;"
              "VP 0,0;VE;CA T;LM W;LI,,,8000;LE;CA S;BG ST")
    for n in [1, 2, 5, 7, 11, 13, 17, 19, 23, 64, 200] * 10:
        twin.tick(n)
        twin.same(read=False)
    twin.send("LM XY;LI 30000,40000;LE;BGS")
    twin.tick(100)
    twin.send("ST S")
    for n in [3, 64, 7, 200]:
        twin.tick(n)
        twin.same(read=True)
    twin.send("LI 3000,4000;LE;BGS")
    twin.tick(20)
    twin.send("AB")
    twin.tick(50)
    twin.same(read=True)
    for card in twin.cards:
        assert not card.firmware.coord.active
        assert card.firmware.motion.stop_code[:4].tolist() == [7, 7, 101, 101]


def test_lmove_example_slows_for_the_corner_with_av_and_vs() -> None:
    """[M Ch6 #LMOVE]: VS 4000; BGS; AV 4000; VS 1000; AV 5000; VS 4000: VS takes effect at
    once, so the path slows (at VD) after 4000 to 1000 counts/s round the corner at 5000 and
    speeds up again; the move ends at (5000, 5000)."""
    rig = Rig()
    assert rig.send(b"DP 0,0;LMXY;LI 5000,0;LI 0,5000;LE;VS 4000;BGS;AV 4000;VS 1000;AV 5000;"
                    b"VS 4000\r") == b":" * 7
    replies = 0  # AV 4000, VS 1000, AV 5000, VS 4000
    av_at: dict[int, float] = {}
    speeds: list[float] = []
    while rig.fw.coord.active and len(speeds) < 20_000:
        rig.sample()
        seq = rig.fw.coord.planes["S"].seq
        replies += rig.receive().count(b":")
        av_at.setdefault(replies, seq.out)
        speeds.append(seq.v)
    assert replies == 4
    assert av_at[2] == pytest.approx(4000, abs=4000 * DT)  # AV 4000 released; VS 1000 at once
    assert av_at[4] == pytest.approx(5000, abs=1000 * DT)  # AV 5000 released at the corner
    corner = int(4000 / 4000 / DT)  # samples to the first AV, then 1 s at <= 1000 counts/s
    assert max(speeds[corner + 100: corner + 900]) <= 1000
    assert max(speeds) == 4000
    assert rp(rig)[:2] == [5000, 5000]


def test_av_answers_at_once_when_no_sequence_runs() -> None:
    rig = Rig()
    assert rig.send(b"AV 1000;AV ,2000\r") == b"::"
    assert rig.send(b"AV;TC\r") == b"?050\r\n:"


def test_st_after_a_sequence_stops_an_axis_of_that_plane_moving_on_its_own() -> None:
    rig = Rig()
    rig.send(b"LM XY;LI 300,400;LE;VS 100000;BGS\r")
    finish(rig)
    rig.send(b"JG 10000;BG X\r")
    for _ in range(50):
        rig.sample()
    rig.send(b"ST\r")
    for _ in range(200):
        rig.sample()
    assert not rig.fw.motion.moving(0)
    assert sc(rig)[0] == 4


def test_a_segment_speed_is_vs_from_that_segment_on() -> None:
    """`<n` "is equivalent to commanding VSn at the start of the given segment" [M Ch6]."""
    rig = Rig()
    rig.send(b"LM X;VS 5000;LI 1000;LI 1000 <2000;LI 1000;LE;BGS\r")
    speeds = []
    while rig.fw.coord.active:
        rig.sample()
        speeds.append(rig.fw.coord.planes["S"].seq.v)
    assert max(speeds[:150]) == 5000
    assert max(speeds[400:]) == 2000  # the third segment keeps the second's speed
    assert rig.send(b"VS ?\r") == b"00002000\r\n:"


def test_on_a_stepper_card_the_step_count_follows_the_path() -> None:
    """TD (the step count after KS) of a stepper card follows the path's reference (RP) and
    MC S waits for the last steps [M Ch6 §Stepper Motor Operation, §Motion Complete Trippoint]."""
    from vdevd.devices.galil.bus import A16Window
    from vdevd.devices.galil.firmware import Firmware

    rig = Rig()
    rig.bus = A16Window()
    rig.fw = Firmware(4, 1_000_000, "stepper", 1000, rig.bus, raise_irq=lambda c: None,
                      clear_irq=lambda: None, clock=lambda: rig.now_ns)
    rig.send(b"VM XY;VS 20000;VA 1000000;VD 1000000;CR 1000,180,-90;VE;BGS\r")
    for _ in range(50):
        rig.sample()
    td = [int(v) for v in rig.send(b"TD XY\r")[:-3].split(b",")]
    ref = rp(rig)[:2]
    assert 0 < td[0] < 2000 and abs(td[0] - ref[0]) < 20_000 * 6 * DT  # a few samples behind
    assert rig.send(b"MC S\r") == b""
    while not rig.receive():
        rig.sample()
    assert rig.send(b"TD XY;RP XY\r") == b"0000001000,0000001000\r\n:0000001000,0000001000\r\n:"


def test_bg_of_a_sequence_and_an_axis_is_checked_whole() -> None:
    """BG XS with X in the S plane is refused (TC 21) and starts nothing; BG ZS starts both."""
    rig = Rig()
    rig.send(b"LM XY;LI 1000,1000;LE;PR ,,500\r")
    assert rig.send(b"BG XS;TC\r") == b"?021\r\n:"
    rig.sample()
    assert not rig.fw.coord.active and not rig.fw.motion.moving(0)
    assert rig.send(b"BG ZS\r") == b":"
    finish(rig)
    for _ in range(100):
        rig.sample()
    assert rp(rig) == [1000, 1000, 500, 0]


def test_es_scales_the_higher_resolution_axis_of_a_circle() -> None:
    """[M Ch6 §Compensating for Differences in Encoder Resolution]: ES 1,2 (Y has two counts for
    X's one): the path is in X's counts and Y moves twice its coordinate, so a CR of radius 1000
    is, in counts, the ellipse x^2/1000^2 + (y/2)^2/1000^2 = 1 and ends where the circle does."""
    rig = Rig()
    assert rig.send(b"ES ?\r") == b"00001,00001\r\n:"
    rig.send(b"VM XY;ES 1,2;CR 1000,180,360;VS 5000;VA 100000;VD 100000;VE;BGS\r")
    worst = 0.0
    while rig.fw.coord.active:
        rig.sample()
        x, y = rig.fw.motion.reference()[:2]
        worst = max(worst, abs(math.hypot(x - 1000, y / 2) - 1000))
    assert worst <= 1.0
    assert rp(rig) == [0, 0, 0, 0]
    assert rig.send(b"ES ?\r") == b"00001,00002\r\n:"
    rig.send(b"VP 1000,1000;VE;BGS\r")
    while rig.fw.coord.active:
        rig.sample()
        x, y = rig.fw.motion.reference()[:2]
        assert abs(y - 2 * x) <= 1.0
    assert rp(rig) == [1000, 2000, 0, 0]
    assert rig.send(b"ES 0,1\r") == b"?"
    assert rig.send(b"ES 1,70000\r") == b"?"


def test_ga_s_gears_an_axis_to_the_distance_along_the_path() -> None:
    """[M Ch6 §Electronic Gearing]: "n = S or T for gearing to coordinated motion": Z geared to
    plane S at GR 0.5 moves half the path's length; a second sequence goes on from there (the
    follower follows the increments, a new sequence's distance from 0 moves it no way back)."""
    rig = Rig()
    rig.send(b"GA ,,S;GR ,,0.5;VM XY;VP 3000,4000;VE;VS 20000;BGS\r")
    while rig.fw.coord.active:
        rig.sample()
        x, y, z = rig.fw.motion.reference()[:3]
        assert abs(z - 0.5 * math.hypot(x, y)) <= 1.0
    rig.sample()
    assert rp(rig)[:3] == [3000, 4000, 2500]
    rig.send(b"VP 3000,0;VE;BGS\r")
    for _ in range(2000):
        rig.sample()
    assert rp(rig)[:3] == [6000, 4000, 4000]
    assert rig.send(b"GA ,,DS\r") == b"?"  # no auxiliary encoder of a plane


def test_a_soft_limit_stops_the_path_at_vd_as_a_switch_does() -> None:
    """FL [spec §4.5]: X's commanded position passing FL 2000 while the path carries it on
    stops the whole path at VD (SC 2 on the plane's axes), the axes still on the line."""
    rig = Rig()
    rig.send(b"FL 2000;VM XY;VP 10000,5000;VE;VS 10000;VA 100000;VD 100000;BGS\r")
    while rig.fw.coord.active:
        rig.sample()
        x, y = rig.fw.motion.reference()[:2]
        assert abs(2 * y - x) <= 2.0
    x, y = rp(rig)[:2]
    # from 10000 counts/s at VD 100000: 500 counts past the point where X passed 2000
    assert 2000 < x <= 2000 + 500 + 50
    assert mg(rig, "_SCX", "_SCY") == [2.0, 2.0]
    rig.send(b"FL 2147483647;VP 10000,5000;VE;BGS\r")  # no soft limit: the path runs to its end
    while rig.fw.coord.active:
        rig.sample()
    assert rp(rig)[:2] == [x + 10000, y + 5000]
