"""Where a contour starts: from where its axes are when its `VE` reaches the head of their queues,
not where they were when it was defined (card README "Contours", Start). `VP` positions stay
absolute and `VP R` distances and `VC R` centres count from there, so a contour queued behind a
move, defined in the same write as an `ST`, or run again by `LS`/`LE` never jumps (spec oms.md
§4.3 "Vector / contouring", App C).

The contours run at VV 4000 counts/s and VA 20 000 counts/s²: at most ~3.9 counts of path per
update cycle at 1024 Hz, so a step of more than 5 counts in one cycle is a jump.
"""

from __future__ import annotations

import math

import pytest

from tests.devices.oms.conftest import Maxk

HZ = 1024
MOST_PER_CYCLE = 5.0  # 4000 counts/s at 1024 Hz is 3.9 counts of path a cycle
SPEED = "AA; VV4000; VA20000;"


def xy(card: Maxk) -> tuple[int, int]:
    return card.word(0), card.word(4)


def run(card: Maxk, cycles: int) -> list[tuple[int, int]]:
    """X and Y after each of `cycles` update cycles, starting with where they are now."""
    out = [xy(card)]
    for _ in range(cycles):
        card.step(1)
        out.append(xy(card))
    return out


def largest_step(trace: list[tuple[int, int]]) -> float:
    return max(math.dist(p, q) for p, q in zip(trace, trace[1:], strict=False))


def test_a_contour_queued_behind_a_move_runs_from_the_move_s_end(maxk: Maxk) -> None:
    """`AX MR1000 GO` then a contour to (3000, 1000) in the same write: X's queue holds the
    contour's VE until the move ends at 1000, and the path runs from (1000, 0), never back to
    where X was when the points were sent."""
    maxk.send(f"AX; VL5000; AC50000; MR1000; GO; {SPEED} VP3000,1000; VE;")
    assert not maxk.command_error()
    trace = run(maxk, 2 * HZ)
    assert trace[-1] == (3000, 1000)
    assert [x for x, _ in trace] == sorted(x for x, _ in trace)  # X never goes back
    path = trace[trace.index((1000, 0)):]
    assert largest_step(path) <= MOST_PER_CYCLE
    assert all(abs((x - 1000) - 2 * y) <= 2 for x, y in path)  # on the line from (1000, 0)


def test_a_contour_defined_with_an_st_runs_from_where_the_ramp_rests(maxk: Maxk) -> None:
    """The contour after `ST` waits on the stopped axis's queue until the first contour rests
    (README "Stops"), then starts from that rest point: no step larger than its speed allows."""
    maxk.send(f"{SPEED} VP40000,20000; VE;")
    maxk.step(HZ // 2)
    maxk.send(f"AX ST; {SPEED} VP0,5000; VE;")
    assert not maxk.command_error()
    trace = run(maxk, 3 * HZ)
    assert largest_step(trace) <= MOST_PER_CYCLE
    assert trace[-1] == (0, 5000)


def test_relative_points_in_a_loop_go_on_from_each_pass_s_end(maxk: Maxk) -> None:
    """`LS3,3; VPR1000,500; VE; LE`: each pass moves 1000, 500 from where the last one ended."""
    maxk.send(f"{SPEED} LS3,3; VPR1000,500; VE; LE;")
    assert not maxk.command_error()
    trace = run(maxk, 3 * HZ)
    assert trace[-1] == (3000, 1500)
    assert largest_step(trace) <= MOST_PER_CYCLE


def test_an_absolute_path_run_again_starts_from_where_the_last_pass_ended(maxk: Maxk) -> None:
    """`LS2,2; VP1000,0; VP1000,1000; VE; LE`: the second pass's first segment runs from
    (1000, 1000) back to (1000, 0) on X = 1000, with no jump to where the first pass started."""
    maxk.send(f"{SPEED} LS2,2; VP1000,0; VP1000,1000; VE; LE;")
    trace = run(maxk, 3 * HZ)
    assert largest_step(trace) <= MOST_PER_CYCLE
    assert trace[-1] == (1000, 1000)
    back = [i for i, (p, q) in enumerate(zip(trace, trace[1:], strict=False)) if q[1] < p[1]]
    assert back  # the second pass went down to (1000, 0) again
    assert all(trace[i][0] == 1000 for i in back)


@pytest.mark.parametrize("centre", ["VCR1000,0,180", "VC2000,0,180"])
def test_an_arc_after_a_move_turns_round_the_centre_from_where_it_starts(
        maxk: Maxk, centre: str) -> None:
    """After `MR1000` on X: `VC R1000,0,180` turns round (2000, 0), 1000 from where the arc
    starts, and so does `VC2000,0,180` (an absolute centre): the half circle ends at (3000, 0)
    with every point 1000 from the centre."""
    maxk.send(f"AX; VL5000; AC50000; MR1000; GO; {SPEED} {centre}; VE;")
    assert not maxk.command_error()
    trace = run(maxk, 2 * HZ)
    assert trace[-1] == (3000, 0)
    moving = [p for p in trace if p[0] > 1000]
    assert moving and all(abs(math.dist(p, (2000, 0)) - 1000) <= 2 for p in moving)
    assert largest_step(trace[trace.index((1000, 0)):]) <= MOST_PER_CYCLE


def test_a_field_equal_to_where_the_axis_was_still_makes_it_a_contour_axis(maxk: Maxk) -> None:
    """`AX MR500 GO` then `VP0,1000`: when the points are sent X is still at 0, but its field
    names it, so the contour waits for X's move and takes X back to 0 from 500 on the line."""
    maxk.send(f"AX; VL5000; AC50000; MR500; GO; {SPEED} VP0,1000; VE;")
    assert not maxk.command_error()
    trace = run(maxk, 2 * HZ)
    assert trace[-1] == (0, 1000)
    path = trace[trace.index((500, 0)):]
    assert largest_step(path) <= MOST_PER_CYCLE
    assert all(abs(2 * (500 - x) - y) <= 2 for x, y in path)  # on the line from (500, 0)


def test_a_contour_sent_with_the_st_of_a_move_starts_where_its_ramp_rests(maxk: Maxk) -> None:
    """X runs MR100000 at 20 000 counts/s; `AX ST` with a contour up Y in the same write: X
    slows to rest at AC (20 000² / (2 · 50 000) = 4000 counts on), and only then does the
    contour start, from there (it starts from rest, README "From where the axes are")."""
    maxk.send("AX; VL20000; AC50000; MR100000; GO;")
    maxk.step(HZ)
    at_stop = xy(maxk)[0]
    maxk.send(f"AX ST; {SPEED} VPR0,100; VE;")
    assert not maxk.command_error()
    trace = run(maxk, HZ)
    xs = [x for x, _ in trace]
    assert all(0 <= b - a <= 20 for a, b in zip(xs, xs[1:], strict=False))  # slows, never jumps
    rest = at_stop + 4000
    assert abs(xs[-1] - rest) <= 25
    assert all(y == 0 for x, y in trace if x < xs[-1])  # Y waits for X to rest
    assert trace[-1] == (xs[-1], 100)


def test_a_contour_on_a_jogging_axis_waits_and_does_not_stop_the_jog(maxk: Maxk) -> None:
    """JG does not hold the queue, so the contour's VE reaches X's queue head while X jogs: it
    waits for X to rest rather than stop the jog dead, X jogging on at 5000 counts/s; the `ST`
    that ends the jog flushes it (README "From where the axes are")."""
    maxk.send(f"AX; AC50000; JG5000; {SPEED} VPR100,100; VE;")
    maxk.step(HZ // 2)
    before = xy(maxk)
    maxk.step(HZ // 4)
    assert xy(maxk)[1] == before[1] == 0
    assert xy(maxk)[0] - before[0] == pytest.approx(5000 / 4, abs=10)
    maxk.send("AX ST;")
    maxk.step(HZ)
    assert xy(maxk)[1] == 0
    maxk.send("AA; VPR100,100; VE;")
    rest = xy(maxk)
    maxk.step(HZ // 2)
    assert xy(maxk) == (rest[0] + 100, 100)
