"""PVT (and SPLINE) points streamed into a rotary buffer while it runs, without sockets [Turbo SRM
"PVT{data}", "OPEN ROT"; Turbo UM "PVT-Mode Moves", "Rotary Motion Program Buffers"; PMAC UM
p.213 "If the Buffer Runs Out"; README "Rotary buffers"].

In PVT the card calculates one segment ahead; with the rotary buffer empty "program operation
will suspend until more lines are entered" and a line then sent is executed "almost
immediately" [UM]. So a point is in time as long as it is in the buffer before the servo cycle
in which the executing segment ends (README): the trajectory is then that of the same points
stored in a PROG. A point later than that finds the sequence ended on the last point (PVT adds
nothing at the end of a sequence, README "Move modes"); it starts from rest when it comes.

The points: INC PVT100, X5:100 from rest (0.5 X5 at 100 units/s), X10:100 cruises (X = 100·(t −
0.05) units, 100 counts/ms at 1000 counts/unit), X5:0 to rest."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_kinematics import FORWARD, INVERSE
from tests.devices.pmac.test_online import PERIOD_NS, Card

DT = PERIOD_NS / 1e9
T = 0.1   # PVT100


def points(n: int) -> list[str]:
    """From rest to 100 units/s, n cruise segments, to rest (INC)."""
    return ["X5:100", *["X10:100"] * n, "X5:0"]


def run(mode: str, pts: list[str], send: list[float] | None, seconds: float) -> np.ndarray:
    """C.S. 1 runs `mode` then `pts`: with `send` None as PROG 1; else from its rotary buffer,
    the first point there at R and point k + 1 sent at send[k] s after R. Motor 1's commanded
    counts each cycle."""
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X", "#1J/", "&1 DEFINE ROT 200"]:
        c.ask(line)
    if send is None:
        for line in ["OPEN PROG 1 CLEAR", mode, *pts, "CLOSE", "&1 B1 R"]:
            c.ask(line)
        waiting: list[tuple[float, str]] = []
    else:
        for line in ["&1 B0", "OPEN ROT", mode, pts[0], "&1 R"]:
            c.ask(line)
        waiting = list(zip(send, pts[1:], strict=True))
    xs = [float(c.fw.reports.commanded()[0])]
    for k in range(round(seconds / DT)):
        while waiting and waiting[0][0] <= k * DT:
            c.ask(waiting.pop(0)[1])
        c.tick()
        xs.append(float(c.fw.reports.commanded()[0]))
    return np.array(xs)


def speed(xs: np.ndarray) -> np.ndarray:
    """Counts/ms each cycle."""
    return np.diff(xs) / (DT * 1000)


@pytest.mark.parametrize("ahead", [T, 0.5 * T, 0.001])
def test_pvt_points_fed_in_time_run_as_the_stored_program(ahead: float) -> None:
    """Point k + 1 (segment k) sent `ahead` s before segment k − 1 ends (at its start, in its
    middle, 1 ms before its end): the trajectory of the same points stored in a PROG, to 1e-6
    counts, cruising at 100 counts/ms and ending on X90 at rest."""
    pts = points(8)
    send = [k * T - ahead for k in range(1, len(pts))]
    fed = run("INC PVT100", pts, send, 1.2)
    assert np.allclose(fed, run("INC PVT100", pts, None, 1.2), rtol=0, atol=1e-6)
    v = speed(fed)[round(0.11 / DT):round(0.89 / DT)]
    assert np.all(np.abs(v - 100.0) < 1e-6)
    assert fed[-1] == 90000.0


def test_a_pvt_point_fed_late_finds_the_sequence_ended_on_the_last_point() -> None:
    """The third point sent 20 ms after the second segment ended (0.22 s): the axes stop on X15
    at the end of that segment (the velocity of 100 counts/ms drops to 0: PVT adds nothing at
    the end of a sequence), hold until the point comes, and the segment to it starts from rest
    there: the Hermite from (X15, 0) to (X25, 100 units/s) in 0.1 s, X18.75 half-way."""
    pts = points(3)
    send = [0.0, 0.22, 0.3, 0.4]   # the later ones sent while the one before runs: in time
    xs = run("INC PVT100", pts, send, 0.6)
    end = round(0.2 / DT)
    assert speed(xs)[end - 2] == pytest.approx(100.0, abs=0.1)
    came = round(0.22 / DT)
    assert np.all(xs[end + 1:came + 1] == 15000.0)
    start = came + 1 + int(np.argmax(xs[came + 1:] != 15000.0))   # the first cycle it moves
    assert start - came <= 2
    tau = (np.arange(start, start + round(0.09 / DT)) - (start - 1)) * DT
    hermite = 15000 + 1000 * (2000 * tau**2 - 10000 * tau**3)
    assert np.allclose(xs[start:start + len(tau)], hermite, rtol=0, atol=1e-6)
    assert xs[-1] == 40000.0


def test_a_stream_of_200_points_fed_one_segment_ahead_keeps_the_speed() -> None:
    """PVT10: 200 cruise points of X1 at 100 units/s, each sent as the segment before it
    starts (one segment ahead, the card's calculation depth in PVT): 100 counts/ms from the end
    of the first segment to the start of the last, no stop between points, X201 at 2.02 s."""
    t = 0.010
    pts = ["X0.5:100", *["X1:100"] * 200, "X0.5:0"]
    send = [k * t for k in range(len(pts) - 1)]
    xs = run("INC PVT10", pts, send, 2.1)
    v = speed(xs)[round(0.011 / DT):round(2.009 / DT)]
    assert np.all(np.abs(v - 100.0) < 1e-6)
    assert xs[round(2.0201 / DT)] == 201000.0
    assert xs[round(2.019 / DT)] < 201000.0


@pytest.mark.parametrize(("mode", "before"), [("SPLINE1 TM100", 0.05), ("SPLINE2 TM100", 0.15)])
def test_spline_points_fed_in_time_run_as_the_stored_program(mode: str, before: float) -> None:
    """SPLINE1/2 [UM "Cubic Spline Mode"]: the segment into a point (the added start segment
    first, at R) needs the point after it, SPLINE2 also the one after that (its time). Point
    k + 2 sent `before` s ahead of the start of segment k + 1 (SPLINE2: 50 ms ahead of segment
    k's) gives the stored program's trajectory, ending on X10."""
    pts = ["X10", "X20", "X5", "X30", "X0", "X10"]
    send = [max((k + 1) * T - before, 0.0) for k in range(len(pts) - 1)]
    fed = run(f"ABS {mode}", pts, send, 1.2)
    assert np.allclose(fed, run(f"ABS {mode}", pts, None, 1.2), rtol=0, atol=1e-6)
    assert fed[-1] == 10000.0


def test_a_spline_point_fed_late_ends_the_sequence_and_starts_a_new_one() -> None:
    """SPLINE1: X30 sent at 0.6 s, after the segment into X20 needed it (it began at 0.2 s): until
    it comes the axes run the stored program of X10 X20 X5 alone (its end segment to rest on X5
    included); from the cycle after, a new spline sequence from rest on X5 to X30, as a stored
    SPLINE1 move to X30 started on X5 runs."""
    fed = run("ABS SPLINE1 TM100", ["X10", "X20", "X5", "X30"], [0.05, 0.15, 0.6], 1.5)
    came = round(0.6 / DT)
    ended = run("ABS SPLINE1 TM100", ["X10", "X20", "X5"], None, 0.6)
    assert np.allclose(fed[:came + 1], ended, rtol=0, atol=1e-6)
    c = Card()
    c.raw("I3=2")
    for line in ["&1 #1->1000X", "#1J/", "#1J=5000"]:
        c.ask(line)
    c.tick(round(1.5 / DT))
    assert float(c.fw.reports.commanded()[0]) == 5000.0
    for line in ["OPEN PROG 1 CLEAR", "ABS SPLINE1 TM100", "X30", "CLOSE", "&1 B1 R"]:
        c.ask(line)
    fresh = [float(c.fw.reports.commanded()[0])]
    for _ in range(round(0.5 / DT)):
        c.tick()
        fresh.append(float(c.fw.reports.commanded()[0]))
    assert np.allclose(fed[came + 1:came + 1 + len(fresh)], fresh, rtol=0, atol=1e-6)
    assert fed[-1] == 30000.0


def test_a_segment_time_sent_on_a_line_of_its_own_does_not_end_the_sequence() -> None:
    """`PVT50` and `TM100` change the segment time on the fly [SRM PVT{data}]: sent on lines of
    their own while the buffer is empty (each point sent before the segment before it ends),
    they end nothing; the stored program's trajectory."""
    pts = ["X5:100", "X10:100", "PVT50", "X5:100", "X5:100", "TM100", "X10:100", "X5:0"]
    send = [0.05, 0.15, 0.151, 0.16, 0.22, 0.23, 0.27]
    fed = run("INC PVT100", pts, send, 0.8)
    assert np.allclose(fed, run("INC PVT100", pts, None, 0.8), rtol=0, atol=1e-6)
    assert fed[-1] == 40000.0


def test_a_pvt_stream_in_a_kinematic_cs_runs_as_the_stored_program() -> None:
    """The UM's shoulder-elbow robot (Isx50 = 1, #1->I #2->I, the motors' cubics from the
    inverse program with Q10 = 1 in PVT [UM "Kinematic Calculations"]): tip PVT points each sent
    1 ms before the segment before them ends give the motors the stored program's counts."""
    pts = ["X10:100 Y-10:-100", *["X20:100 Y-20:-100"] * 3, "X10:0 Y-10:0"]

    def motors(send: list[float] | None) -> np.ndarray:
        c = Card()
        c.raw("I3=2")
        for line in ["&1 #1->I #2->I", "&1 Q91=400 Q92=300 Q93=1000 I5150=1", "&1 OPEN FORWARD CLEAR",
                     *FORWARD, "CLOSE &1 OPEN INVERSE CLEAR", *INVERSE, "CLOSE", "#1J/ #2J/",
                     "#1J=30000 #2J=60000"]:
            c.ask(line)
        c.tick(round(3 / DT))
        c.ask("&1 DEFINE ROT 200")
        if send is None:
            start = ["OPEN PROG 1 CLEAR", "INC PVT200", *pts, "CLOSE", "&1 B1 R"]
        else:
            start = ["&1 B0", "OPEN ROT", "INC PVT200", pts[0], "&1 R"]
        for line in start:
            c.ask(line)
        waiting = [] if send is None else list(zip(send, pts[1:], strict=True))
        rows = [c.fw.reports.commanded()[:2].copy()]
        for k in range(round(1.2 / DT)):
            while waiting and waiting[0][0] <= k * DT:
                c.ask(waiting.pop(0)[1])
            c.tick()
            rows.append(c.fw.reports.commanded()[:2].copy())
        return np.array(rows)

    fed = motors([0.2 * k - 0.001 for k in range(1, len(pts))])
    stored = motors(None)
    assert np.allclose(fed, stored, rtol=0, atol=1e-6)
    assert not np.allclose(fed[-1], fed[0], rtol=0, atol=100.0)   # the motors moved
