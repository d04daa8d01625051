"""Motion programs without sockets: PROG buffers, the runner's look-ahead, LINEAR with TA/TS/F,
RAPID, DWELL/DELAY, run control B R S Q A H K and the C.S. status bits, the card's errors
[spec pmac.md §2.8; Turbo UM "Linear Blended Moves", "How PMAC Executes a Motion Program";
Turbo SRM B, R, S, Q, H, DWELL, DELAY, READ; README "Motion programs"]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.pmac.test_cycle_runs import Twin
from tests.devices.pmac.test_online import PERIOD_NS, Card
from vdevd.devices.pmac.online import PortState

DT = PERIOD_NS / 1e9
RUNNING, SINGLE_STEP, RUN_REQUEST = 1, 2, 16
IN_POSITION, RUNTIME_ERROR = 1 << 17, 1 << 22


@pytest.fixture
def card() -> Card:
    """Motors 1 and 2 as X and Y at 1000 counts per unit, loops closed, ideal plant; Ixx16 and
    Ixx17 out of the way unless a test sets them."""
    c = Card()
    c.raw("I3=2")
    c.ask("&1#1->1000X &1#2->1000Y #1J/#2J/")
    c.ask("I116=1000 I216=1000 I117=100 I217=100")
    return c


def download(card: Card, n: int, *lines: str) -> None:
    assert card.ask(f"OPEN PROG {n} CLEAR") == ""
    for line in lines:
        assert card.raw(line) == b"\x06", line
    assert card.raw("CLOSE") == b"\x06"


def xy(card: Card) -> tuple[float, float]:
    cmd = card.fw.reports.commanded()
    return float(cmd[0]), float(cmd[1])


def cs_words(card: Card) -> tuple[int, int, int]:
    text = card.ask("&1??")
    return int(text[:6], 16), int(text[6:12], 16), int(text[12:], 16)


def running(card: Card) -> bool:
    return bool(cs_words(card)[0] & RUNNING)


def trace(card: Card, seconds: float, t0: float = 0.0) -> np.ndarray:
    """(t, X counts, Y counts) every servo cycle for `seconds` or until the program ends."""
    rows = []
    for k in range(1, int(round(seconds / DT)) + 1):
        card.tick()
        rows.append((t0 + k * DT, *xy(card)))
        if not card.fw.motion.any_running():
            break
    return np.array(rows)


def seconds(card: Card, s: float) -> None:
    card.tick(int(round(s / DT)))


def crossing(rows: np.ndarray, col: int, level: float, rising: bool, after: float = 0.0) -> float:
    """The first time after `after` the column crosses `level`."""
    t, v = rows[:, 0], rows[:, col]
    ok = (v[1:] >= level) & (v[:-1] < level) if rising else (v[1:] <= level) & (v[:-1] > level)
    ok &= t[1:] > after
    k = int(np.flatnonzero(ok)[0])
    return float(t[k + 1])


# -- a raster (snake) scan: LINEAR, TA/TS/F, WHILE over P-variables ---------------------------------
RASTER = ("LINEAR ABS TA(P10) TS(P11) F(P12)",
          "P1=0",
          "WHILE (P1 < P2)",
          "  IF (P1 % 2 = 0)",
          "    X(P3)",
          "  ELSE",
          "    X0",
          "  ENDIF",
          "  Y((P1 + 1) * P4)",
          "  P1 = P1 + 1",
          "EndWhile")


def test_raster_scan_passes_row_middles_at_the_feedrate_times_and_ends_where_commanded(
        card: Card) -> None:
    """Rows of 10 units at F50 (units/s, Isx90 = 1000) take 0.2 s, the 1-unit steps TA = 0.1 s
    (a move takes at least TA), the first blend is centred on t = TA/2: row k passes its middle
    at 0.05 + 0.3k + 0.1 s at 50 units/s, and the scan ends at Σ T + TA = 1.3 s [UM "Linear
    Blended Moves"]."""
    card.ask("P2=4 P3=10 P4=1 P10=100 P11=20 P12=50")
    download(card, 10, *RASTER)
    card.ask("&1B10R")
    rows = trace(card, 3.0)
    assert not running(card)
    assert xy(card) == (0.0, 4000.0)          # 4 rows: back at X0, Y4
    assert card.fw.p[1] == 4
    end = rows[-1, 0]
    assert abs(end - 1.3) < 2 * DT
    for k in range(4):
        t_mid = 0.05 + 0.3 * k + 0.1
        t = crossing(rows, 1, 5000.0, rising=k % 2 == 0, after=t_mid - 0.1)
        assert abs(t - t_mid) < 2 * DT, (k, t, t_mid)
        y_row = rows[np.searchsorted(rows[:, 0], t_mid), 2]
        assert y_row == pytest.approx(1000.0 * k)          # on the row while crossing it
        seg = rows[(rows[:, 0] > t_mid) & (rows[:, 0] < t_mid + 0.2)]
        far = seg[:, 1].max() if k % 2 == 0 else seg[:, 1].min()
        assert far == pytest.approx(10000.0 if k % 2 == 0 else 0.0, abs=1.0)  # reaches the row end
    vx = np.diff(rows[:, 1]) / DT
    assert np.abs(vx).max() == pytest.approx(50_000.0, rel=1e-3)   # F: 50 units/s = 50000 cts/s


def test_feedrate_override_scales_the_program_time(card: Card) -> None:
    """%50: the time base at half speed, the same scan takes twice as long [digest §2.7]."""
    card.ask("P2=2 P3=10 P4=1 P10=100 P11=20 P12=50")
    download(card, 10, *RASTER)
    card.ask("I5194=0")  # Isx94 = 0: the new % at once
    card.ask("&1%50 B10R")
    rows = trace(card, 3.0)
    assert abs(rows[-1, 0] - 2 * (0.6 + 0.1)) < 3 * DT
    assert xy(card) == (0.0, 2000.0)


def test_feedrate_override_slews_at_isx94(card: Card) -> None:
    """With the factory Isx94 (1644, I10 units per servo cycle) a `%50` given while a program
    runs slows it gradually: 50 % of time base takes 50 / (Isx94 / I10 x 100) servo cycles,
    about half a second, and the program's speed follows the present time base X:$002002 [SRM
    Isx94; digest §2.2]."""
    download(card, 1, "LINEAR ABS TA10 TS0 F10", "X20")   # 10 units/s = 10000 counts/s
    card.ask("&1B1R")
    seconds(card, 0.5)                                    # at speed
    card.ask("&1%50")
    i10, i94 = float(card.ask("I10")), float(card.ask("I5194"))
    ramp_s = 50 / (i94 / i10 * 100) * DT
    assert 0.4 < ramp_s < 0.6
    rows = trace(card, ramp_s + 0.2, t0=0.0)
    v = np.diff(rows[:, 1]) / DT
    half = int(round(ramp_s / 2 / DT))
    assert v[half] == pytest.approx(7500.0, rel=0.02)       # halfway down the slew: 75 %
    assert v[-1] == pytest.approx(5000.0, rel=1e-3)         # then at 50 %
    assert v[0] > 9900.0                                    # not at once


def test_ixx16_slows_a_linear_move_in_proportion(card: Card) -> None:
    """Ixx16 (Isx13 = 0): all motors slowed so that none exceeds it, the path unchanged [SRM
    Ixx16]: X at 40 counts/ms asked, I116 = 20 -> the 10-unit move takes 0.5 s, not 0.25."""
    card.ask("I116=20")
    download(card, 1, "LINEAR ABS TA50 TS0 F40", "X10 Y5")
    card.ask("&1B1R")
    rows = trace(card, 2.0)
    assert abs(rows[-1, 0] - (0.5 + 0.05)) < 2 * DT
    assert xy(card) == (10000.0, 5000.0)
    assert np.abs(np.diff(rows[:, 1]) / DT).max() == pytest.approx(20_000.0, rel=1e-3)


def test_tm_sets_the_move_time_and_ta_below_twice_ts_becomes_2ts(card: Card) -> None:
    """TM500 with TA10 TS50: TA used = 2·TS = 100 ms, the move from rest takes TM + TA [UM]."""
    download(card, 1, "LINEAR INC TM500 TA10 TS50", "X3", "X-3")
    card.ask("&1B1R")
    rows = trace(card, 3.0)
    assert abs(rows[-1, 0] - (0.5 + 0.5 + 0.1)) < 2 * DT
    assert xy(card) == (0.0, 0.0)


@pytest.mark.parametrize(("ts", "peak"), [(0, 10.0 / 0.1), (50, 10.0 / 0.05), (20, 10.0 / 0.08)])
def test_ts_shapes_the_blend_peak_acceleration_is_dv_over_ta_minus_ts(card: Card, ts: int,
                                                                      peak: float) -> None:
    """TA100: with TS = 0 a constant acceleration of Δv/TA, with TS the S-curve's peak is
    Δv/(TA − TS) (TS = TA/2: pure S-curve) [UM "Linear Blended Moves"]; units/s²."""
    download(card, 1, f"LINEAR ABS TA100 TS{ts} F10", "X2")
    card.ask("&1B1R")
    rows = trace(card, 1.0)
    acc = np.diff(rows[:, 1], 2) / DT**2 / 1000
    assert np.abs(acc).max() == pytest.approx(peak, rel=0.02)
    assert abs(rows[-1, 0] - (0.2 + 0.1)) < 2 * DT


# -- RAPID --------------------------------------------------------------------------------------------
def test_rapid_moves_each_motor_at_its_jog_speed_and_waits_for_all(card: Card) -> None:
    """RAPID: each motor as a jog to its target at Ixx22 with Ixx19-Ixx21; not blended, the
    statements after it are calculated when every motor has finished [UM "When No Calculation
    Ahead"]: X 10000 counts at 20 counts/ms with 50 ms ramps ends at 0.55 s, Y 2000 counts at
    0.15 s; P5 is set only after both."""
    card.ask("I122=20 I222=20 I119=1 I219=1 I120=50 I220=50 I121=0 I221=0")
    download(card, 2, "RAPID ABS", "X10 Y2", "P5=1")
    card.ask("&1B2R")
    rows = trace(card, 2.0)
    t_x = rows[np.flatnonzero(rows[:, 1] >= 10000.0)[0], 0]
    t_y = rows[np.flatnonzero(rows[:, 2] >= 2000.0)[0], 0]
    assert abs(t_x - 0.55) < 2 * DT
    assert abs(t_y - 0.15) < 2 * DT
    assert xy(card) == (10000.0, 2000.0)
    assert card.fw.p[5] == 1
    assert cs_words(card)[1] & 2  # word 2 bit 1: RAPID mode [SRM ??]


def test_rapid_statements_after_it_wait_for_the_motors(card: Card) -> None:
    card.ask("I122=20 I222=20 I119=1 I219=1 I120=50 I220=50 I121=0 I221=0")
    download(card, 2, "RAPID ABS", "X10", "P5=1")
    card.ask("&1B2R")
    trace(card, 0.5)
    assert card.fw.p[5] == 0      # X still moving: not calculated yet
    trace(card, 0.2)
    assert card.fw.p[5] == 1


# -- DWELL and DELAY ----------------------------------------------------------------------------------
def test_dwell_is_real_time_and_stops_calculation(card: Card) -> None:
    """DWELL500 under %50: the move before takes twice its time, the dwell 0.5 s of real time,
    and the statement after it runs only when the dwell is over [SRM DWELL]."""
    download(card, 3, "LINEAR ABS TA100 TS0 F5", "X1", "DWELL500", "P7=1", "X2")
    card.ask("I5194=0")
    card.ask("&1%50 B3R")
    rows = trace(card, 0.59)
    assert card.fw.p[7] == 0
    rows = np.vstack([rows, trace(card, 3.0, t0=rows[-1, 0])])
    t_arrive = rows[np.flatnonzero(rows[:, 1] >= 1000.0)[0], 0]
    t_leave = crossing(rows, 1, 1000.0 + 1e-6, rising=True)
    assert abs(t_arrive - 0.6) < 2 * DT   # (0.2 + 0.1) s at %50
    assert abs((t_leave - t_arrive) - 0.5) < 3 * DT
    assert card.fw.p[7] == 1
    assert xy(card)[0] == 2000.0


def test_delay_is_scaled_by_the_override_and_calculated_through(card: Card) -> None:
    """DELAY500 under %50 holds 1.0 s of real time, and the calculation goes on past it: P7 is
    set at R [UM "DWELL Commands"]."""
    download(card, 3, "LINEAR ABS TA100 TS0 F5", "X1", "DELAY500", "P7=1", "X2")
    card.ask("I5194=0")
    card.ask("&1%50 B3R")
    card.tick()
    assert card.fw.p[7] == 1
    rows = trace(card, 4.0)
    t_arrive = rows[np.flatnonzero(rows[:, 1] >= 1000.0)[0], 0]
    t_leave = crossing(rows, 1, 1000.0 + 1e-6, rising=True)
    assert abs(t_arrive - 0.6) < 2 * DT
    assert abs((t_leave - t_arrive) - 1.0) < 3 * DT


# -- look-ahead ------------------------------------------------------------------------------------
def test_program_reads_p_variables_written_on_line_at_the_move_it_calculates(card: Card) -> None:
    """LINEAR with Isx13 = 0 calculates two moves ahead: move n + 2 when move n starts [UM
    "Calculating Ahead"]. Moves of 0.2 s (TA 0.1): move 4, X(P20), is calculated at 0.2 s
    when move 2 starts, so P20 written at 0.1 s counts; move 5, X(P21), is calculated at 0.4 s,
    so P21 written at 0.5 s does not."""
    card.ask("P20=10 P21=0")
    download(card, 4, "LINEAR ABS TA100 TS0 F5", "X1", "X2", "X3", "X(P20)", "X(P21)")
    card.ask("&1B4R")
    rows = trace(card, 0.1)
    card.ask("P20=7")
    rows = np.vstack([rows, trace(card, 0.4, t0=rows[-1, 0])])
    card.ask("P21=5")
    rows = np.vstack([rows, trace(card, 5.0, t0=rows[-1, 0])])
    # the corner at X7 rounded by the TA blend from +5 to -5 units/s: (Δv)·TA/8 inside it
    assert rows[:, 1].max() == pytest.approx(7000 - 10_000 * 0.1 / 8, abs=2.0)
    assert xy(card)[0] == 0.0


def test_a_wait_loop_without_moves_holds_the_program_and_sees_the_variable(card: Card) -> None:
    """WHILE (P30 = 0) ENDWHILE: no move in the loop, so each pass ends the calculation for the
    cycle (double-jump-back rule [UM]); the card keeps serving and the program goes on when P30
    is set on-line."""
    download(card, 5, "LINEAR ABS TA100 TS0 F5", "X1", "WHILE (P30 = 0)", "ENDWHILE", "X0")
    card.ask("&1B5R")
    trace(card, 1.0)
    assert running(card)
    assert xy(card)[0] == 1000.0
    assert card.ask("P30=1 VER") == "1.940"
    trace(card, 1.0)
    assert not running(card)
    assert xy(card)[0] == 0.0


def test_two_coordinate_systems_run_their_programs_at_once(card: Card) -> None:
    """&1 runs PROG 1 on motors 1-2, &2 PROG 2 on motor 3 (X of C.S. 2), each on its own time
    base: %50 in C.S. 2 doubles its time only."""
    card.ask("&2#3->500X #3J/ I316=1000 I317=100")
    download(card, 1, "LINEAR ABS TA100 TS0 F10", "X2 Y1")
    download(card, 2, "LINEAR ABS TA100 TS0 F10", "X-2")
    card.ask("I5294=0")
    card.ask("&2%50")  # (a % value takes an expression: `%50 &1` would be 50 AND 1)
    card.ask("&1B1R &2B2R")
    ends = {}
    for k in range(1, int(2.0 / DT)):
        card.tick()
        for cs in (1, 2):
            if cs not in ends and not card.fw.motion.runner(cs).running:
                ends[cs] = k * DT
    assert abs(ends[1] - (np.hypot(2, 1) / 10 + 0.1)) < 2 * DT
    assert abs(ends[2] - 2 * (0.2 + 0.1)) < 2 * DT
    cmd = card.fw.reports.commanded()
    assert (cmd[0], cmd[1], cmd[2]) == (2000.0, 1000.0, -1000.0)


# -- logic, subroutines, READ ----------------------------------------------------------------------------
def test_gosub_call_return_and_read(card: Card) -> None:
    """GOSUB to a label, CALL another program with arguments READ puts in Q101-Q126 (P -> Q116,
    X -> Q124) and a bit mask in Q100 [SRM READ; UM G04]."""
    download(card, 20, "READ(X,P)", "P40 = Q124 + Q116", "P41 = Q100", "RETURN")
    download(card, 6, "P1=0", "GOSUB100", "CALL20 X3 P4", "P2=P1", "RETURN",
             "N100 P1=P1+10", "RETURN")
    card.ask("&1B6R")
    trace(card, 0.1)
    assert not running(card)
    assert (card.fw.p[1], card.fw.p[2], card.fw.p[40]) == (10, 10, 7)
    assert card.fw.p[41] == (1 << 23) | (1 << 15)
    assert card.fw.q[0, 124] == 3 and card.fw.q[0, 116] == 4


def test_goto_a_missing_label_is_a_run_time_error(card: Card) -> None:
    download(card, 7, "P1=1", "GOTO 55", "P1=2")
    card.ask("&1B7R")
    trace(card, 0.1)
    assert not running(card)
    assert card.fw.p[1] == 1
    assert cs_words(card)[1] & RUNTIME_ERROR


def test_home_in_a_program_waits_for_the_motor_and_goes_on(card: Card) -> None:
    """HOMEZ1: motor 1's present position becomes 0 and the program continues from there; no
    calculation until the motor has finished [UM "When No Calculation Ahead"]."""
    download(card, 14, "LINEAR ABS TA100 TS0 F5", "X1", "HOMEZ1", "P9=1", "X1")
    card.ask("&1B14R")
    trace(card, 3.0)
    assert not running(card)
    assert card.fw.p[9] == 1
    assert card.ask("#1P") == "1000"
    assert int(card.ask("#1?")[6:], 16) & (1 << 10)   # home complete


def test_while_wait_holds_the_program_until_the_condition_clears(card: Card) -> None:
    """`WHILE (P30 = 0) WAIT`: the move before comes to a stop, the program waits, then goes on
    when P30 is written on-line [SRM WAIT]."""
    download(card, 16, "LINEAR ABS TA100 TS0 F5", "X1", "WHILE (P30 = 0) WAIT", "X0")
    card.ask("&1B16R")
    seconds(card, 1.0)
    assert running(card) and xy(card)[0] == 1000.0
    card.ask("P30=1")
    trace(card, 1.0)
    assert not running(card) and xy(card)[0] == 0.0


def test_pset_renames_the_present_position_without_moving(card: Card) -> None:
    """PSET X0 after X1: motor 1 stays at 1000 counts, X reads 0 there, X1 then moves it to
    2000 [SRM PSET]."""
    download(card, 17, "LINEAR ABS TA100 TS0 F5", "X1", "PSET X0", "P9=1", "X1")
    card.ask("&1B17R")
    trace(card, 3.0)
    assert not running(card)
    assert card.fw.p[9] == 1
    assert xy(card)[0] == 2000.0


def test_cmd_from_a_program_runs_on_line(card: Card) -> None:
    download(card, 15, 'CMD"P50=7"', "P51=1")
    card.ask("&1B15R")
    trace(card, 0.05)
    assert (card.fw.p[50], card.fw.p[51]) == (7, 1)


def test_pr_is_not_p_then_r(card: Card) -> None:
    """PR is the rotary buffer's lines remaining (rotary.py), not P then R."""
    download(card, 1, "LINEAR ABS TA100 TS0 F5", "X1")
    card.ask("&1B1")
    assert card.ask("#1PR") == "0"
    assert not running(card)


# -- run control and status ------------------------------------------------------------------------------
STEPS = ("LINEAR INC TA100 TS0 F10", "X1", "X1", "X1", "X1", "X1")


def test_step_runs_one_move_and_r_goes_on(card: Card) -> None:
    download(card, 8, *STEPS)
    card.ask("&1B8S")
    w1 = cs_words(card)[0]
    assert w1 & RUNNING and w1 & SINGLE_STEP and not w1 & RUN_REQUEST
    trace(card, 1.0)
    assert not running(card)
    assert xy(card)[0] == 1000.0
    card.ask("&1R")
    assert cs_words(card)[0] & RUN_REQUEST
    trace(card, 2.0)
    assert xy(card)[0] == 5000.0


def test_quit_finishes_the_calculated_moves_then_r_resumes(card: Card) -> None:
    download(card, 8, *STEPS)
    card.ask("&1B8R")
    trace(card, 0.05)
    card.ask("&1Q")
    trace(card, 2.0)
    assert not running(card)
    # calculated by then: moves 1 and 2 at R, move 3 when move 1 began (look-ahead of two)
    assert xy(card)[0] == 3000.0
    card.ask("&1R")
    trace(card, 2.0)
    assert xy(card)[0] == 5000.0


def test_feed_hold_stops_on_the_path_and_r_resumes(card: Card) -> None:
    """H: the time base slews to 0 at Isx95 (here 1 s from 100%), the program stays running;
    R brings it back and the program ends where commanded [SRM H]."""
    card.ask(f"I5195={int(card.fw.ivars.values[10] * DT / 1.0)}")
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    trace(card, 0.5)
    card.ask("&1H")
    trace(card, 1.2)
    held = xy(card)
    trace(card, 0.5)
    assert xy(card) == held and held[0] < 4000.0
    assert running(card)
    card.ask("&1R")
    trace(card, 5.0)
    assert not running(card)
    assert xy(card)[0] == 4000.0


def test_abort_stops_the_motors_and_the_program(card: Card) -> None:
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    trace(card, 0.5)
    card.ask("&1A")
    assert not running(card)
    seconds(card, 0.1)   # 2 counts/ms stopped at Ixx15 = 0.25 counts/ms^2: 8 ms, 8 counts
    x = xy(card)[0]
    assert 900.0 < x < 910.0
    seconds(card, 0.5)
    assert xy(card)[0] == x
    assert not cs_words(card)[1] & RUNTIME_ERROR


def test_kill_of_the_cs_stops_the_program_and_opens_the_loops(card: Card) -> None:
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    trace(card, 0.5)
    card.ask("&1K")
    assert not running(card)
    assert int(card.ask("#1?")[:6], 16) & (1 << 18)  # open loop


def test_status_bits_while_running_and_after(card: Card) -> None:
    download(card, 9, "LINEAR INC(X) TA100 TS0 F2", "X4")
    assert cs_words(card)[1] & IN_POSITION
    card.ask("&1B9R")
    trace(card, 0.3)
    w1, w2, _ = cs_words(card)
    assert w1 & RUNNING and w1 & RUN_REQUEST and w1 & 4   # continuous motion
    assert w1 & (1 << 18)                                 # X incremental
    assert not w2 & IN_POSITION
    assert int(card.ask("#1?")[:6], 16) & (1 << 17)       # move timer active
    trace(card, 3.0)
    w1, w2, _ = cs_words(card)
    assert not w1 & RUNNING and w2 & IN_POSITION


def test_modal_state_shows_in_word_1(card: Card) -> None:
    """INC(X), TM, ABS(R), NORMAL: word 1 bits 18 (X incremental), 3 (move time mode), 5 (radius
    vectors incremental) [SRM ??]."""
    download(card, 18, "INC(X) TM100 ABS(R) NORMAL K-1 X1")
    card.ask("&1B18")
    w1 = cs_words(card)[0]
    assert w1 & (1 << 5) and not w1 & (1 << 18) and not w1 & 8  # B: INC(R), ABS, F mode
    card.ask("&1R")
    trace(card, 1.0)
    w1 = cs_words(card)[0]
    assert w1 & (1 << 18) and w1 & 8 and not w1 & (1 << 5)
    assert xy(card)[0] == 1000.0


def test_motor_commands_and_b_are_refused_while_the_program_runs(card: Card) -> None:
    """ERR001: command not allowed during program execution [§2.4]."""
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    trace(card, 0.2)
    assert card.raw("#1J+") == b"\x07ERR001\r"
    assert card.raw("&1B9") == b"\x07ERR001\r"
    assert card.raw("OPEN PROG 3") == b"\x07ERR001\r"
    assert card.raw("#3J+") == b"\x06"  # not in the C.S.
    assert running(card)


def test_axis_definitions_are_refused_while_the_program_runs(card: Card) -> None:
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    card.tick()
    assert card.raw("&1#3->1000Z") == b"\x07ERR001\r"
    assert card.raw("&1UNDEFINE") == b"\x07ERR001\r"
    assert card.ask("&2#3->1000Z") == ""    # another C.S.
    assert card.ask("&1#1->") == "1000X"


def test_movetime_is_the_time_left_in_the_present_move(card: Card) -> None:
    """MOVETIME (V1.937 [A L3262]): X4 at F2 from rest is T + TA = 2.1 s of pieces; 0.5 s in,
    1.6 s are left; 0 once the program has ended."""
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    assert card.ask("&1MOVETIME") == "0"
    card.ask("&1B9R")
    seconds(card, 0.5)
    assert float(card.ask("&1MOVETIME")) == pytest.approx(1600.0, abs=1.0)
    trace(card, 3.0)
    assert card.ask("&1MOVETIME") == "0"


def test_control_o_holds_every_program(card: Card) -> None:
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    seconds(card, 0.5)
    card.fw.control(card.port, 0x0F)
    seconds(card, 2.0)
    held = xy(card)
    seconds(card, 0.5)
    assert xy(card) == held and running(card)


# -- faults during a program -------------------------------------------------------------------------------
def test_a_limit_on_the_way_aborts_the_program_with_a_run_time_error(card: Card) -> None:
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    trace(card, 0.5)
    mo = card.fw.motors
    plim = np.zeros(mo.n, dtype=bool)
    plim[0] = True
    off = np.zeros(mo.n, dtype=bool)
    mo.apply_inputs(plim, off, off, off)
    card.tick()
    assert not running(card)
    assert cs_words(card)[1] & RUNTIME_ERROR
    seconds(card, 0.5)
    assert 900.0 < xy(card)[0] < 1100.0      # stopped near where the limit was met
    mo.apply_inputs(off, off, off, off)
    card.ask("&1B9R")  # the error bit clears at the next run
    assert not cs_words(card)[1] & RUNTIME_ERROR


def test_a_software_limit_on_the_way_aborts_the_program(card: Card) -> None:
    """Ixx13 = 2000 counts: the program stops with the run-time error bit when motor 1 passes it,
    the motor stopping at Ixx15 just beyond [§2.7 "Software limits"]."""
    card.ask("I113=2000")
    download(card, 9, "LINEAR ABS TA100 TS0 F2", "X4")
    card.ask("&1B9R")
    seconds(card, 2.0)
    assert not running(card)
    assert cs_words(card)[1] & RUNTIME_ERROR
    assert 2000.0 < xy(card)[0] < 2020.0


def test_fatal_following_error_kills_and_stops_the_program() -> None:
    """A servo motor asked to follow a move it cannot: Ixx11 trips, the motor is killed and the
    program stops with the run-time error bit [§2.7]."""
    card = Card(plant="servo")
    card.raw("I3=2")
    card.ask("&1#1->1000X #1J/ I116=1000 I117=1000 I111=160")  # 10 counts
    download(card, 9, "LINEAR ABS TA10 TS0 F200", "X40")
    card.ask("&1B9R")
    for _ in range(int(1.0 / DT)):
        card.tick()
        if not running(card):
            break
    assert not running(card)
    assert cs_words(card)[1] & RUNTIME_ERROR
    assert int(card.ask("#1?")[6:], 16) & 4   # fatal following error


# -- bad input: the card's error, nothing else disturbed -----------------------------------------------------
def test_a_line_the_card_rejects_answers_err003_and_is_not_stored(card: Card) -> None:
    card.ask("OPEN PROG 11 CLEAR")
    assert card.raw("X10 Y20") == b"\x06"
    assert card.raw("FROB 3") == b"\x07ERR003\r"
    assert card.raw("X(3") == b"\x07ERR003\r"
    assert card.raw("X1 X2") == b"\x07ERR003\r"
    assert card.raw("Dwell 0 TA 100") == b"\x06"
    card.ask("CLOSE")
    assert card.ask("LIST PROG 11") == "X10 Y20\rDWELL 0 TA 100"
    assert card.ask("LIST PROG 11,1,1") == "DWELL 0 TA 100"


def test_running_a_missing_program_is_err015_and_nothing_moves(card: Card) -> None:
    assert card.raw("&1B77R") == b"\x07ERR015\r"
    assert card.raw("LIST PROG 77") == b"\x07ERR003\r"
    trace(card, 0.05)
    assert xy(card) == (0.0, 0.0) and not running(card)


def test_a_buffer_left_open_refuses_r_and_other_ports_open(card: Card) -> None:
    """OPEN PROG: no program may run while a PROG buffer is open (ERR015), no other buffer may
    be opened meanwhile (ERR007) [SRM OPEN PROGRAM]."""
    download(card, 1, "LINEAR ABS TA100 TS0 F5", "X1")
    other = PortState()
    assert card.fw.execute(other, "OPEN PROG 2").error is None
    assert card.raw("&1B1R") == b"\x07ERR015\r"
    assert card.raw("OPEN PROG 3") == b"\x07ERR007\r"
    assert card.raw("OPEN PLC 3") == b"\x07ERR007\r"
    assert card.fw.execute(other, "CLOSE").error is None
    assert card.raw("&1R") == b"\x06"


def test_close_with_an_unmatched_while_is_err009_and_r_err016(card: Card) -> None:
    card.ask("OPEN PROG 12 CLEAR")
    card.ask("WHILE (P1 < 3)")
    card.ask("X1")
    assert card.raw("CLOSE") == b"\x07ERR009\r"
    assert card.raw("&1B12R") == b"\x07ERR016\r"


@pytest.mark.parametrize(("setup", "code"), [
    ("#1K", 12),           # a motor open loop
    ("I100=0", 13),        # a motor not activated
    ("&1#1->0 &1#2->0", 14),  # no motors in the C.S.
    ("#1J+", 11),          # a motor moving
])
def test_run_refused_for_the_motors_with_the_cards_error(card: Card, setup: str, code: int) -> None:
    """[UM: R/S rejected with ERR010-ERR017]."""
    download(card, 1, "LINEAR ABS TA100 TS0 F5", "X1")
    card.ask(setup)
    assert card.raw("&1B1R") == f"\x07ERR{code:03d}\r".encode()
    assert not running(card)


def test_both_limits_refuse_run_with_err010(card: Card) -> None:
    download(card, 1, "LINEAR ABS TA100 TS0 F5", "X1")
    mo = card.fw.motors
    on = np.zeros(mo.n, dtype=bool)
    on[1] = True
    mo.apply_inputs(on, on, np.zeros(mo.n, bool), np.zeros(mo.n, bool))
    assert card.raw("&1B1R") == b"\x07ERR010\r"


def test_programs_survive_save_and_reset(card: Card) -> None:
    download(card, 13, "LINEAR ABS TA100 TS0 F5", "X1")
    card.ask("SAVE")
    card.ask("$$$")
    card.port = PortState()
    card.raw("I3=2")
    assert card.ask("LIST PROG 13") == "LINEAR ABS TA100 TS0 F5\rX1"


# -- rest (decision 0008) ------------------------------------------------------------------------------
def test_a_running_program_is_not_at_rest_and_batches_match_cycles_one_by_one() -> None:
    """A card running a program has work at every cycle: a card run in batches and one run
    cycle by cycle end each batch alike, and both rest once the program has ended."""
    twin = Twin(True, "servo")
    for line in ("&1#1->1000X", "#1J/", "I116=1000 I117=10", "OPEN PROG 1 CLEAR",
                 "LINEAR INC TA50 TS10 F20", "X1 DWELL20 X-1", "CLOSE", "&1B1R"):
        twin.send(line)
    fast = twin.cards[0]
    assert fast.rest_state() is None
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 12:
        twin.tick(n)
        twin.same()
    assert not fast.fw.motion.active
    twin.tick(2000)
    twin.same()
    assert fast.rest_state() is not None
