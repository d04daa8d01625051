"""The coordinated-motion path planner (vdevd/devices/galil/vector.py) against invariants over
seeded random sequences of lines and arcs with `<n`, `>m`, VS, VA, VD and VT (STYLE.md 5):
progress never goes back, the speed stays within VS and the `<n` given, changes by at most VA
or VD per sample, and the path ends exactly on the last segment's end point."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from vdevd.devices.galil.vector import Segment, Sequence, arc, line

PROPS = settings(derandomize=True, max_examples=100, deadline=None)
DT = 0.001
SPEED = st.floats(2000, 100_000)


@st.composite
def segments(draw: st.DrawFn) -> list[tuple[str, tuple[float, ...], float | None, float | None]]:
    out = []
    for _ in range(draw(st.integers(1, 6))):
        speed = draw(st.none() | SPEED)
        end_speed = draw(st.none() | st.just(0.0) | st.floats(1000, 50_000))
        if draw(st.booleans()):
            dx, dy = draw(st.integers(-5000, 5000)), draw(st.integers(-5000, 5000))
            if dx == dy == 0:
                dx = 1
            out.append(("line", (float(dx), float(dy)), speed, end_speed))
        else:
            r = draw(st.integers(1, 2000))
            theta = draw(st.floats(-360, 360))
            dtheta = draw(st.floats(1, 400)) * draw(st.sampled_from([-1, 1]))
            out.append(("arc", (float(r), theta, dtheta), speed, end_speed))
    return out


def build(specs: list[tuple[str, tuple[float, ...], float | None, float | None]]) -> Sequence:
    seq = Sequence(2, DT)
    for kind, args, speed, end_speed in specs:
        start = seq.last_end
        seg: Segment
        if kind == "line":
            seg = line(start, (start[0] + args[0], start[1] + args[1]), speed, end_speed)
        else:
            seg = arc((start[0], start[1]), args[0], args[1], args[2], speed, end_speed)
        seq.add(seg)
    return seq


@PROPS
@given(specs=segments(), vs=SPEED, va=st.floats(1e4, 1e7), vd=st.floats(1e4, 1e7),
       smoothing=st.integers(1, 40))
def test_the_path_progresses_within_its_speeds_and_ramps_and_ends_on_the_last_point(
        specs: list[tuple[str, tuple[float, ...], float | None, float | None]], vs: float,
        va: float, vd: float, smoothing: int) -> None:
    seq = build(specs)
    seq.ended = True
    seq.start(smoothing)
    top = max([vs, *(s for _, _, s, _ in specs if s is not None)])
    longest = seq.total / min([vs, *(s for _, _, s, _ in specs if s is not None),
                               *(m for _, _, _, m in specs if m)]) + top / va + top / vd
    s_prev, out_prev, v_prev = 0.0, 0.0, 0.0
    limit = int(longest / DT * 3) + 10 * smoothing + 100
    for _ in range(limit):
        more = seq.advance(vs, va, vd)
        assert seq.s >= s_prev and seq.out >= out_prev
        assert seq.v <= top * (1 + 1e-9)
        assert seq.v - v_prev <= va * DT * (1 + 1e-9) + 1e-6
        assert v_prev - seq.v <= vd * DT * (1 + 1e-5) + 1e-2  # (the last sample lands)
        s_prev, out_prev, v_prev = seq.s, seq.out, seq.v
        if not more:
            break
    else:
        raise AssertionError(f"no end after {limit} samples")
    assert seq.out == seq.s == seq.total
    assert seq.position() == seq.last_end
    assert seq.completed == seq.count == len(specs)


@PROPS
@given(r=st.integers(1, 100_000), theta=st.floats(-360, 360), dtheta=st.floats(-1080, 1080),
       vs=SPEED)
def test_every_sample_of_an_arc_is_on_its_radius(r: int, theta: float, dtheta: float,
                                                 vs: float) -> None:
    seg = arc((0.0, 0.0), r, theta, dtheta if abs(dtheta) > 0.1 else 90)
    seq = Sequence(2, DT)
    seq.add(seg)
    seq.ended = True
    seq.start(1)
    assert seg.center is not None
    cx, cy = seg.center
    while seq.advance(vs, 1e6, 1e6):
        x, y = seq.position()
        assert math.isclose(math.hypot(x - cx, y - cy), r, rel_tol=1e-9, abs_tol=1e-6)
    ex = cx + r * math.cos(math.radians(theta + dtheta if abs(dtheta) > 0.1 else theta + 90))
    assert math.isclose(seq.position()[0], ex, abs_tol=1e-6)
