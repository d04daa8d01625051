"""Stopping a running contour: `ST`/`SA`/`SI` ramp it down on its path, a limit switch stops it
(hard: at once; soft: ramping) with over-travel, a command of several axes whose member was
flushed is dropped by the others, and a task's contours run one after another (spec oms.md
§4.3 "Vector / contouring", §5.6 "Over-travel", ST/SA/SI/KS in §8; card README "Contours").

The contour: task 1 from (0, 0) towards (40000, 20000) at VV 4000 counts/s and VA 20 000
counts/s², so it ramps up over 0.2 s (400 counts of path) and cruises; a stop at the cruise slows
it to rest over 0.2 s and 4000²/(2·20 000) = 400 counts of path, on the line y = x/2.
"""

from __future__ import annotations

import math

import pytest
from vdevmaps.oms import MaxkDoorbell

from tests.devices.oms.conftest import Maxk
from tests.devices.oms.test_trajectory_scan import contour, cycles, firmware
from vdevd.devices.oms.contour import ContourState
from vdevd.devices.oms.firmware import Firmware

HZ = 1024
V, A = 4000.0, 20_000.0
RAMP_S = V * V / (2 * A)  # 400 counts of path to stop
RAMP_CYCLES = round(V / A * HZ)  # 205 update cycles to stop
LINE = "AA; VV4000; VA20000; VP40000,20000; VE;"
DONE_XY = MaxkDoorbell.DONE_X | MaxkDoorbell.DONE_X << 1
OVERTRAVEL_Y = MaxkDoorbell.OVERTRAVEL_X << 1


def xy(card: Maxk) -> tuple[int, int]:
    return card.word(0), card.word(4)


def path(p: tuple[int, int]) -> float:
    return math.hypot(*p)


def cruising(card: Maxk, text: str = LINE) -> tuple[int, int]:
    """The contour sent and run half a second (at its cruise); where it is."""
    card.send(text)
    assert not card.command_error()
    card.step(HZ // 2)
    here = xy(card)
    assert 1500 < path(here) < 1800
    return here


def samples(card: Maxk, n: int) -> list[tuple[int, int]]:
    out = []
    for _ in range(n):
        card.step(1)
        out.append(xy(card))
    return out


@pytest.mark.parametrize("stop", ["AX ST;", "AY ST;", "AA SA;", "AM SI1;", "AM SI,1;"])
def test_a_stop_ramps_the_contour_down_on_its_path(maxk: Maxk, stop: str) -> None:
    """ST/SA/SI on any axis of the contour: the path slows to rest at the contour's VA (not
    dead, as KS): 0.2 s and 400 counts of path on, every point on the line; no done flag."""
    here = cruising(maxk)
    maxk.send(stop)
    assert not maxk.command_error()
    after = samples(maxk, RAMP_CYCLES + 20)
    assert all(abs(x - 2 * y) <= 2 for x, y in after)
    s = [path(p) for p in [here, *after]]
    steps = [b - a for a, b in zip(s, s[1:], strict=False)]
    assert steps[0] > 3  # still at speed (4000 counts/s is ~3.9 counts a cycle)
    assert all(b <= a + 1.5 for a, b in zip(steps, steps[1:], strict=False))  # never speeds up (rounding)
    assert s[-1] - s[0] == pytest.approx(RAMP_S, abs=8)
    moving = [i for i, d in enumerate(steps) if d > 0]
    assert RAMP_CYCLES - 15 <= moving[-1] <= RAMP_CYCLES + 2
    assert after[-1] == after[-20]
    assert maxk.odbr() & DONE_XY == 0
    assert maxk.query("QI;")[1::5][:2] == "NN"


@pytest.mark.parametrize("ramping", [False, True])
def test_kill_stops_the_contour_dead_even_while_it_ramps_down(maxk: Maxk, ramping: bool) -> None:
    cruising(maxk)
    if ramping:
        maxk.send("AX ST;")
        maxk.step(50)
    maxk.send("AM; KS1;")
    maxk.step(1)
    here = xy(maxk)
    maxk.step(HZ // 4)
    assert xy(maxk) == here


def test_a_move_sent_with_the_stop_waits_for_the_contour_to_rest(maxk: Maxk) -> None:
    """The axes' queues hold until the ramp-down ends (on the line y = x/2); the move then
    runs from where the contour rested."""
    cruising(maxk)
    maxk.send("AX ST; AA; MR100,100; GO;")
    assert not maxk.command_error()
    ramp = samples(maxk, RAMP_CYCLES - 10)
    assert all(abs(x - 2 * y) <= 2 for x, y in ramp)
    maxk.step(HZ)
    end_x, end_y = xy(maxk)
    assert abs((end_x - 100) - 2 * (end_y - 100)) <= 2  # the rest point was on the line
    assert 0 <= (end_x - 100) - ramp[-1][0] <= 4


# -- limits ---------------------------------------------------------------------------------------
def test_a_hard_limit_stops_the_contour_at_once_with_over_travel(maxk: Maxk) -> None:
    """[spec §5.6] moving into an active limit stops the axis without deceleration in hard
    mode and flushes its queue: the whole path stops in the next cycle; ODBR over-travel X, QA
    'L'; no done flags; a move away from the switch is allowed."""
    cruising(maxk)
    maxk.clear_odbr()
    maxk.control("set_limits", axis="X", positive=True)
    maxk.step(1)
    here = xy(maxk)
    maxk.step(HZ // 4)
    assert xy(maxk) == here
    assert maxk.odbr() & (MaxkDoorbell.OVERTRAVEL_X | OVERTRAVEL_Y | DONE_XY) == MaxkDoorbell.OVERTRAVEL_X
    assert maxk.query("AX QA;")[2] == "L"
    maxk.send("AX MR-100; GO;")
    maxk.step(HZ // 4)
    assert xy(maxk) == (here[0] - 100, here[1])


def test_a_soft_limit_ramps_the_contour_down_on_its_path(maxk: Maxk) -> None:
    """LMS: the path decelerates at the contour's VA through the switch, over-travel once."""
    maxk.send("AA; LMS,S,S,S;")
    here = cruising(maxk)
    maxk.clear_odbr()
    maxk.control("set_limits", axis="Y", positive=True)
    after = samples(maxk, RAMP_CYCLES + 20)
    assert all(abs(x - 2 * y) <= 2 for x, y in after)
    assert path(after[-1]) - path(here) == pytest.approx(RAMP_S, abs=8)
    assert after[-1] == after[-20]
    assert maxk.odbr() & (MaxkDoorbell.OVERTRAVEL_X | OVERTRAVEL_Y | DONE_XY) == OVERTRAVEL_Y


def test_a_contour_into_an_active_limit_does_not_move_and_one_away_runs(maxk: Maxk) -> None:
    maxk.control("set_limits", axis="X", positive=True)
    maxk.clear_odbr()
    maxk.send("AA; VID; VV4000; VA20000; VP1000,500; VE;")
    maxk.step(HZ // 2)
    assert xy(maxk) == (0, 0)
    assert maxk.odbr() & (MaxkDoorbell.OVERTRAVEL_X | DONE_XY) == MaxkDoorbell.OVERTRAVEL_X
    maxk.clear_odbr()
    maxk.send("AA; VID; VV4000; VA20000; VP-1000,-500; VE;")
    maxk.step(HZ)
    assert xy(maxk) == (-1000, -500)
    assert maxk.odbr() & (MaxkDoorbell.OVERTRAVEL_X | DONE_XY) == DONE_XY


# -- several axes, several contours --------------------------------------------------------------
def test_a_move_of_several_axes_is_dropped_when_one_of_them_is_flushed_first(
        maxk: Maxk) -> None:
    """AA MR waits on Y behind a SW; ST on X flushes X's part before it ran: Y drops its part
    when the input comes (instead of waiting for X forever) and runs what follows."""
    maxk.control("set_input", bit=3, level=0)
    maxk.send("AY SW3; AA; MR100,100; GO;")
    maxk.step(10)
    maxk.send("AX ST;")
    maxk.control("set_input", bit=3, level=1)
    maxk.send("AY MR500; GO;")
    maxk.step(HZ)
    assert xy(maxk) == (0, 500)


def test_a_contour_whose_axis_was_flushed_before_its_start_never_moves_it() -> None:
    fw = firmware()
    fw.gpio_in &= ~(1 << 3)
    fw.feed(b"AY SW3; AA; VV1000; VA1000000; VP100,50; VE;")
    cycles(fw, 5)
    fw.feed(b"AX ST;")
    fw.gpio_in |= 1 << 3
    fw.feed(b"AY MR500; GO;")
    cycles(fw, 400)
    assert fw.motor_position()[:2].tolist() == [0, 500]
    assert not fw.live_contours and all(q.idle for q in fw.queues)


def test_the_contours_of_one_task_run_one_after_the_other() -> None:
    """Task 1: a contour on X, then one on Z (its VE reaches Z's queue at once): Z waits until
    X's contour has ended; VID sets each one's done flag at its own end."""
    fw = firmware()
    fw.feed(b"AM; VID[1]; VV[1]1000; VA[1]1000000; VP[1]100; VE[1];"
            b" VP[1],,100; VID[1]; VE[1];")  # VID while defined: this one's (README)
    cycles(fw, 50)
    assert fw.motor_position()[[0, 2]].tolist() == [pytest.approx(48, abs=3), 0]
    states = [c.state for c in fw.live_contours]
    assert states == [ContourState.RUNNING, ContourState.READY]
    cycles(fw, 60)
    assert fw.motor_position()[0] == 100 and 0 < fw.motor_position()[2] < 20
    assert fw.done.tolist()[:3] == [True, False, False]
    cycles(fw, 100)
    assert fw.motor_position()[[0, 2]].tolist() == [100, 100]
    assert fw.done.tolist()[:3] == [True, False, True]


@pytest.mark.parametrize(("kill", "z_end"), [(b"KS1;", 100), (b"KS1,,1;", 0)])
def test_a_kill_of_the_running_contour_lets_the_tasks_next_one_start_unless_killed_too(
        kill: bytes, z_end: int) -> None:
    """KS on X ends the running contour (X) and the task's READY one (Z) starts; KS on X and
    Z ends both."""
    fw = firmware()
    fw.feed(b"AM; " + contour(1) + b" VP[1],,100; VE[1];")
    cycles(fw, 20)
    fw.feed(kill)
    cycles(fw, 200)
    assert 15 < fw.motor_position()[0] < 25 and fw.motor_position()[2] == z_end
    assert not fw.live_contours


def test_a_move_of_several_axes_already_running_goes_on_on_the_others() -> None:
    """ST on X during an AA move: X ramps down, Y's part (running) ends at its target."""
    fw = firmware()
    fw.feed(b"AA; VL1000,1000; AC100000,100000; MR1000,1000; GO;")
    cycles(fw, 100)
    fw.feed(b"AX ST;")
    cycles(fw, 1200)
    x, y = fw.motor_position()[:2].tolist()
    assert 90 < x < 110 and y == 1000
    assert all(q.idle for q in fw.queues)


# -- found in review ------------------------------------------------------------------------------
def over_travels(rung: list[int], a: int) -> int:
    """How many times axis a's over-travel doorbell bit was rung."""
    return rung.count(1 << (8 + a))


def ringing_firmware(travel_limits: list[tuple[float, float] | None] | None = None,
                     ) -> tuple[Firmware, list[int]]:
    """firmware(travel_limits) and the list of every doorbell it rings."""
    fw = firmware(travel_limits)
    rung: list[int] = []
    fw.ring_doorbell = rung.append
    return fw, rung


def switch(fw: Firmware, a: int) -> None:
    """The positive limit switch of axis a becomes active."""
    fw.motion.limit_pos_level[a] = bool(fw.params.limit_high[a])
    fw.motion.apply_limits()


@pytest.mark.parametrize("stop", [b"AX ST;", b"AM; KS1;"])
def test_stopping_a_waiting_contour_lets_vg_start_the_tasks_next_one(stop: bytes) -> None:
    fw = firmware()
    fw.feed(b"AM; VH[1]0; " + contour(1) + b" VP[1],,100; VE[1];")
    cycles(fw, 5)
    fw.feed(stop + b" VG[1];")
    cycles(fw, 300)
    assert fw.motor_position()[[0, 2]].tolist() == [0, 100] and not fw.live_contours


@pytest.mark.parametrize("hold", [b"VH[1]0;", b"VH[1]1;"])
def test_a_flush_of_a_ready_contours_axis_keeps_the_running_ones_hold(hold: bytes) -> None:
    fw = firmware()
    fw.feed(b"AM; " + hold + contour(1) + b" VP[1],,100; VE[1];")
    cycles(fw, 5)
    fw.feed(b"KS,,1;")
    cycles(fw, 300)
    assert float(fw.motor_position()[0]) < 10 and len(fw.live_contours) == 1
    fw.feed(b"VG[1];")
    cycles(fw, 300)
    assert fw.motor_position()[[0, 2]].tolist() == [100, 0]


def test_a_flush_cancels_a_group_the_other_axis_has_reached_in_a_later_loop_pass() -> None:
    fw = firmware()
    fw.feed(b"AA; VL10000,10000; AC100000,100000; LS3,3; MR100,5000; GO; LE;")
    cycles(fw, 200)  # X has done pass 1 and waits at pass 2; Y still runs pass 1
    fw.feed(b"AY ST; AX MR1000; GO;")
    cycles(fw, 600)
    assert fw.motor_position()[0] == 1100 and all(q.idle for q in fw.queues)


def test_over_travel_is_flagged_once_per_axis_and_during_a_ramp_down() -> None:
    fw, rung = ringing_firmware()
    fw.feed(b"AA; LMS,S,S,S; VV4000; VA20000; VP40000,20000; VE; AM; ID;")
    cycles(fw, 512)
    fw.feed(b"AX ST;")
    cycles(fw, 5)
    switch(fw, 1)
    cycles(fw, 300)
    assert over_travels(rung, 1) == 1 and over_travels(rung, 0) == 0
    assert not fw.done[:2].any()  # the switch flushed Y's queued ID
    fw, rung = ringing_firmware()
    fw.feed(b"AA; LMH,S,H,H; VV4000; VA20000; VP40000,20000; VE;")
    cycles(fw, 400)
    switch(fw, 1)
    cycles(fw, 5)
    switch(fw, 0)
    cycles(fw, 300)
    assert (over_travels(rung, 0), over_travels(rung, 1)) == (1, 1)


def test_a_hard_limit_stop_rests_on_whole_counts() -> None:
    fw = firmware()
    fw.feed(b"AA; VV3000; VA20000; VP40000,21111; VE;")
    cycles(fw, 500)
    switch(fw, 0)
    cycles(fw, 3)
    assert all(float(p) == round(float(p)) for p in fw.motion.core.axes.cmd_pos[:2])


def test_a_ramp_down_that_reaches_the_path_end_sets_no_done_flags() -> None:
    fw = firmware()
    fw.feed(b"AA; VID; VV4000; VA2000; VP10,5; VA200000; VP4000,2000; VE;")
    cycles(fw, 700)
    fw.feed(b"AX ST;")
    cycles(fw, 2000)
    assert fw.motor_position()[:2].tolist() == [4000, 2000] and not fw.done[:2].any()


def test_a_contour_inside_a_loop_runs_every_pass() -> None:
    """LS3/LE around a contour out and back: three round trips (0 -> 1000 -> 0 each)."""
    fw = firmware()
    fw.feed(b"AA; LS3,3; VV20000; VA1000000; VP1000,0; VP0,0; VE; LE;")
    peaks = 0
    rising = True
    for _ in range(600):
        cycles(fw, 1)
        x = float(fw.motor_position()[0])
        if rising and x >= 950:  # the reversal at 1000 runs on at speed (VV v alone)
            peaks, rising = peaks + 1, False
        elif x == 0:
            rising = True
    assert peaks == 3 and all(q.idle for q in fw.queues)


def test_vid_after_a_later_contours_ve_applies_to_that_one() -> None:
    fw = firmware()
    fw.feed(b"AM; VV[1]1000; VA[1]1000000; VP[1]100; VE[1]; VP[1],,100; VE[1];")
    cycles(fw, 1)
    fw.feed(b"VID[1];")
    cycles(fw, 400)
    assert fw.done.tolist()[:3] == [False, False, True]


# -- found in the second review -------------------------------------------------------------------
@pytest.mark.parametrize("stop", ["ST", "soft limit"])
def test_a_stop_that_ramps_the_contour_down_drops_the_tasks_vh0(stop: str) -> None:
    """README "Stops": the flush takes the task's VH0 with it, as KS does, so the task's READY
    contour starts when the ramp ends instead of waiting for a VG."""
    fw = firmware()
    fw.feed(b"AA; LMS,S,S,S; AM; " + contour(1))
    cycles(fw, 20)
    fw.feed(b"AM; VH[1]0; VP[1],,100; VE[1];")
    cycles(fw, 2)
    if stop == "ST":
        fw.feed(b"AX ST;")
    else:
        switch(fw, 0)
    cycles(fw, 400)
    assert fw.motor_position()[2] == 100 and not fw.live_contours and not fw.vector_gated


@pytest.mark.parametrize("travel", [False, True])
def test_an_arc_away_from_an_active_limit_runs(travel: bool) -> None:
    """README "Limits": X stands at 0 on its active positive switch (or its high travel limit);
    an arc from (0, 1000) round (0, 0), 90° counter-clockwise, moves X negative, away from it,
    and runs to (-1000, 0) with no over-travel (its start point is exact, not cos/sin's)."""
    fw, rung = ringing_firmware([(-10**6, 0), None, None, None] if travel else None)
    fw.feed(b"AY LP1000;")
    if not travel:
        switch(fw, 0)
    fw.feed(b"AA; VV1000; VA100000; VC0,0,90; VE;")
    cycles(fw, 3000)
    assert fw.motor_position()[:2].tolist() == [-1000, 0] and over_travels(rung, 0) == 0


# -- found in the third review --------------------------------------------------------------------
@pytest.mark.parametrize(("halt", "after"), [(b"VH1;", 500), (b"AX ST;", 500), (b"VH1;", 4400)])
def test_a_halt_or_stop_slows_the_path_at_va_also_while_it_ramps(halt: bytes,
                                                                   after: int) -> None:
    """README "Halt"/"Stops": the path speed falls at the contour's VA, also when the halt
    comes while the path ramps up (500 cycles in) or down (4400): at VV5000 VA5000 from
    speed v the path rests v/VA later, v²/(2·VA) on."""
    fw = firmware()
    fw.feed(b"AA; VV5000; VA5000; VP20000,0; VE;")
    cycles(fw, after)
    xs = [float(fw.motion.core.axes.cmd_pos[0])]
    cycles(fw, 1)
    xs.append(float(fw.motion.core.axes.cmd_pos[0]))
    fw.feed(halt)
    for _ in range(1500):
        cycles(fw, 1)
        xs.append(float(fw.motion.core.axes.cmd_pos[0]))
    v = [(b - a) * HZ for a, b in zip(xs, xs[1:], strict=False)]
    rest = next(i for i, s in enumerate(v) if s <= 1e-6)
    assert rest == pytest.approx(v[0] / 5000 * HZ, abs=3)
    assert xs[-1] - xs[1] == pytest.approx(v[0] ** 2 / (2 * 5000), rel=0.02, abs=2)
    assert all(b <= a + 1e-6 for a, b in zip(v[1:rest], v[2:rest], strict=False))  # slows
