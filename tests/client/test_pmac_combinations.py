"""Acceptance: the Turbo PMAC's motion-program features together, through a real daemon on the
lockstep clock, driven by the clients a beamline uses: dls-pmaclib over the Ethernet port (text
commands) and vdevclient.pcomm (PComm32: download, gather, the DPRAM binary rotary ring). Each
test checks what the manual says the combination does [Turbo SRM, Turbo UM "Writing and
Executing Motion Programs", "Kinematic Calculations", "Data Gathering"; spec pmac.md §2.8, §3.1;
README "Motion programs", "Move modes", "Rotary buffers", "Kinematic programs"].

Positions are read with `#nP` while the test steps the clock (the `ideal` plant: the encoder's
whole counts); a program's time origin is the R that the test sends between steps (the first
program servo cycle is the next one)."""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_ask, pcomm_device

DEVICE = 0
DT = PERIOD_NS / 1e9
GATHER_BIT = 1 << 19          # global status word 1 (`???`) bit 19: data gathering [digest §2.1]
RUNNING = 1                   # `&n??` word 1 bit 0: program running [SRM ??]
RUN_TIME_ERROR = 1 << 22      # `&n??` word 2 bit 22: run-time error [SRM ??]


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


@pytest.fixture
def host_axes() -> Iterator[Pmac]:
    """The card with an axis world: motor 5 has limits at ±20000 and a home switch over
    4000-4400 counts."""
    axes: list[dict[str, list[int]]] = [{}, {}, {}, {},
                                        {"limits": [-20000, 20000], "home": [4000, 4400]}]
    with pcomm_device(DEVICE, plant="ideal", axis=axes) as h:
        yield h


@pytest.fixture
def host_limits() -> Iterator[Pmac]:
    """The card with an axis world: motor 1's +LIM at 3000 counts."""
    axes: list[dict[str, list[int]]] = [{"limits": [-20000, 3000]}]
    with pcomm_device(DEVICE, plant="ideal", axis=axes) as h:
        yield h


def ask(command: str) -> str:
    """One command through PComm (`PmacGetResponseA`): the reply without its CR/ACK framing."""
    return pcomm_ask(DEVICE, command)


def positions(*motors: int) -> np.ndarray:
    return np.array([float(ask(f"#{m}P")) for m in motors])


def cs_words(cs: int) -> tuple[int, int]:
    """`&s??`: C.S. status words 1 and 2."""
    status = ask(f"&{cs}??")
    return int(status[:6], 16), int(status[6:12], 16)


def running(cs: int) -> bool:
    return bool(cs_words(cs)[0] & RUNNING)


def send_all(host: Pmac, lines: list[str]) -> None:
    """Lines through dls-pmaclib's sendCommand (the Ethernet port), each acknowledged."""
    pmac = host.dls()
    for line in lines:
        reply, ok = pmac.sendCommand(line)
        assert ok and reply.endswith("\x06") and "\x07" not in reply, (line, reply)


def download(tmp_path: Path, text: str) -> None:
    """A source file through PComm's `PmacDownloadA` (its #define preprocessing)."""
    source = tmp_path / "prog.pmc"
    source.write_text(text)
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda t, nl: messages.append(t), None, None,
                               str(source)) == 1, messages


def blended(t: np.ndarray, points: list[tuple[float, ...]], times: list[float], ta: float,
            ts: float) -> np.ndarray:
    """LINEAR moves through `points` (the start first) in `times` from rest to rest: each
    move's velocity over its span, blended with TA centred on each corner, the acceleration
    ramped over TS at both ends [UM "Linear Blended Moves"; SRM TA, TS]: the velocity steps
    smoothed by a TA-wide kernel, a box of TA − TS convolved with a box of TS (TA ≥ 2·TS)."""
    a = ta - ts

    def ramp(u: np.ndarray) -> np.ndarray:   # ∫ of a unit step smoothed by the TA − TS box
        return np.where(u < -a / 2, 0.0, np.where(u < a / 2, (u + a / 2) ** 2 / (2 * a), u))

    nodes, weights = np.polynomial.legendre.leggauss(64)

    def smooth(u: np.ndarray) -> np.ndarray:  # ... and by the TS box (Gauss-Legendre over it)
        if ts == 0:
            return ramp(u)
        return sum(w / 2 * ramp(u - x * ts / 2) for x, w in zip(nodes, weights, strict=True))

    pts = np.asarray(points, dtype=float)
    corners = ta / 2 + np.concatenate([[0.0], np.cumsum(times)])
    pos = np.tile(pts[0], (len(t), 1))
    for k, move_t in enumerate(times):
        v = (pts[k + 1] - pts[k]) / move_t
        pos += np.outer(smooth(t - corners[k]) - smooth(t - corners[k + 1]), v)
    return pos


# -- a kinematic C.S. running a segmented LINEAR program -----------------------------------------
#: a polar stage: motor 1 the angle (100 counts a degree), motor 2 the radius (1000 counts a
#: unit); the C.S. is programmed in Cartesian X Y [UM "Kinematic Calculations": P1..P32 the
#: motors, Q7 Q8 the X Y axes; ATAN2 takes its cosine argument in Q0, A §ATAN2]
FORWARD = ["Q7=P2/1000*COS(P1/100)", "Q8=P2/1000*SIN(P1/100)"]
INVERSE = ["Q0=Q7", "P1=ATAN2(Q8)*100", "P2=SQRT(Q7*Q7+Q8*Q8)*1000"]
POLAR_PATH = ["LINEAR ABS TA200 TS50 F20", "X5 Y0", "X5 Y5", "X0 Y5"]
POLAR_POINTS = [(0.0, 0.0), (5.0, 0.0), (5.0, 5.0), (0.0, 5.0)]
POLAR_TIMES = [0.25, 0.25, 0.25]        # 5 units at F20 (units per Isx90 = 1000 ms)


def polar(xy: np.ndarray) -> np.ndarray:
    """The inverse kinematics above, in motor counts (degrees: I15 = 0)."""
    return np.column_stack([np.degrees(np.arctan2(xy[:, 1], xy[:, 0])) * 100,
                            np.hypot(xy[:, 0], xy[:, 1]) * 1000])


def setup_polar(host: Pmac) -> None:
    """C.S. 1: motors 1 and 2 `#n->I` through the kinematic programs (I5150 = 1); C.S. 2: motors
    3 and 4 the same X Y axes directly (1000 counts a unit); both segmented every 10 ms."""
    send_all(host, ["&1#1->I &1#2->I &2#3->1000X &2#4->1000Y #1J/ #2J/ #3J/ #4J/",
                    "I5113=10 I5213=10 I5150=1",
                    "&1OPEN FORWARD CLEAR", *FORWARD, "CLOSE",
                    "&1OPEN INVERSE CLEAR", *INVERSE, "CLOSE",
                    "OPEN PROG 5 CLEAR", *POLAR_PATH, "CLOSE"])


def test_kinematic_cs_runs_a_segmented_linear_program_through_its_inverse(host: Pmac) -> None:
    """The same LINEAR program (TA200 TS50 F20, Isx13 = 10 ms) in the kinematic C.S. 1 and in
    the Cartesian C.S. 2, started on one line: every servo cycle the inverse program gives
    motors 1 and 2 the polar coordinates of the axis positions C.S. 2's motors show, so they
    stay on the inverse of that path all along; both end in the same servo cycle, motors 1 and
    2 on 90° and radius 5 [UM "Kinematic Calculations"; SRM Isx13, Isx50]."""
    setup_polar(host)
    assert ask("&1B5R &2B5R") == ""
    worst = 0.0
    for _ in range(45):                                  # 0.8 s of the 0.95 s
        host.step(40)
        m = positions(1, 2, 3, 4)
        assert running(1) and running(2)
        # the inverse of C.S. 2's path, through the whole counts of its motors' encoders
        want = polar(m[None, 2:] / 1000)[0]
        worst = max(worst, float(np.abs(m[:2] - want).max()))
    assert worst < 2.0          # a count of X or Y at radius ≥ 5 units: ~1 count of either motor
    host.step(round(0.85 / DT) - 45 * 40)
    for _ in range(round(0.2 / DT)):             # the two C.S. end in the same servo cycle
        host.step(1)
        if not running(2):
            break
    assert not running(1) and not running(2)
    assert positions(1, 2, 3, 4) == pytest.approx([9000, 5000, 0, 5000], abs=1e-3)


def test_kinematic_motors_follow_the_inverse_of_the_blended_ta_ts_profile(host: Pmac) -> None:
    """Motors 1 and 2 of the kinematic C.S. against the inverse of the LINEAR profile the
    manual gives (TA centred on each corner, TS ramps), sampled every 40 servo cycles: within
    the segments' cubic fit (a few counts); the program ends after ΣT + TA [UM "Linear
    Blended Moves"; SRM Isx13]."""
    setup_polar(host)
    ask("&1B5R")
    t, got = [], []
    for k in range(1, 24):
        host.step(40)
        t.append(40 * k * DT)
        got.append(positions(1, 2))
    want = polar(blended(np.array(t), POLAR_POINTS, POLAR_TIMES, 0.2, 0.05))
    error = float(np.abs(np.array(got) - want).max())
    assert error < 10, error
    host.step(round(0.95 / DT) - 23 * 40 - 5)      # the program ends after ΣT + TA = 0.95 s
    assert running(1)
    host.step(10)
    assert not running(1)


#: the inverse program with the velocity flag: Q10 = 1 in PVT mode, the axis velocities in
#: Q17 Q18, the motor velocities into P101 P102 (the polar Jacobian) [UM "Kinematic
#: Calculations", "Velocity Calculation Flag"]
INVERSE_PVT = [*INVERSE, "IF (Q10 = 1)",
               "P101=(Q7*Q18-Q8*Q17)/(Q7*Q7+Q8*Q8)*5729.5779513",
               "P102=(Q7*Q17+Q8*Q18)/SQRT(Q7*Q7+Q8*Q8)*1000", "ENDIF"]


def test_kinematic_pvt_with_velocities_under_an_override(host: Pmac) -> None:
    """A PVT200 path of the polar C.S. from X5 Y0 round to X0 Y5, at `%50` (Isx94 = 0: at
    once): the inverse program runs at each segment's ends with Q10 = 1 and gives the motors'
    positions and velocities there, and each motor follows the cubic through them in its own
    space (a PVT move of the motor), on the program time, half the real time [UM "Kinematic
    Calculations"; SRM PVT, `%`]."""
    send_all(host, ["&1#1->I &1#2->I #1J/ #2J/ I5150=1 I5194=0", "#2J=5000",
                    "&1OPEN FORWARD CLEAR", *FORWARD, "CLOSE",
                    "&1OPEN INVERSE CLEAR", *INVERSE_PVT, "CLOSE",
                    "OPEN PROG 9 CLEAR", "ABS PVT200", "X5:0 Y2:10", "X4:-10 Y4:10",
                    "X2:-10 Y5:0", "X0 Y5", "CLOSE"])
    host.step_ms(1500)                                      # the jog to radius 5: X5 Y0
    assert (positions(1, 2) == [0.0, 5000.0]).all()
    assert ask("&1%50") == "" and ask("&1B9R") == ""
    servo = int(ask("I10")) / 2**23 / 1000
    ticks, seen = 0, []
    for _ in range(20):
        ticks += round(0.08 / servo)
        host.step(round(0.08 / servo))
        seen.append((ticks * servo / 2, *positions(1, 2)))    # program time: half
    got = np.array(seen)
    pts = np.array([(5, 0), (5, 2), (4, 4), (2, 5), (0, 5)], dtype=float)
    vel = np.array([(0, 0), (0, 10), (-10, 10), (-10, 0), (0, 0)], dtype=float)
    r2 = (pts**2).sum(axis=1)
    motor_pos = polar(pts)
    motor_vel = np.column_stack([np.degrees((pts[:, 0] * vel[:, 1] - pts[:, 1] * vel[:, 0]) / r2)
                                 * 100, (pts * vel).sum(axis=1) / np.sqrt(r2) * 1000])
    knots = 0.2 * np.arange(5)
    for m in range(2):
        want = hermite(got[:, 0], knots, motor_pos[:, m], motor_vel[:, m])
        error = float(np.abs(got[:, 1 + m] - want).max())
        assert error <= 1.0, (m, error)                     # the encoder's whole counts
    assert not running(1) and (positions(1, 2) == [9000.0, 5000.0]).all()

# -- a PVT scan gathered into the DPRAM ------------------------------------------------------------
PVT_SCAN = """\
; a PVT scan: point k at P(100+k) units with velocity P(200+k) units/s, every P3 ms
#define POINT  P1
#define POINTS P2
OPEN PROG 6 CLEAR
ABS
PVT(P3)
POINT = 0
WHILE (POINT < POINTS)
  X(P(100 + POINT)):(P(200 + POINT))
  POINT = POINT + 1
ENDWHILE
CLOSE
"""


def hermite(t: np.ndarray, knots: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> np.ndarray:
    """The PVT path: on each segment the cubic of its end positions and velocities [SRM PVT:
    "the unique cubic position profile"]; before the first knot and after the last, held."""
    t = np.clip(t, knots[0], knots[-1])
    k = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
    h = knots[k + 1] - knots[k]
    s = (t - knots[k]) / h
    return ((2 * s**3 - 3 * s**2 + 1) * pos[k] + (s**3 - 2 * s**2 + s) * h * vel[k]
            + (-2 * s**3 + 3 * s**2) * pos[k + 1] + (s**3 - s**2) * h * vel[k + 1])


@pytest.mark.parametrize("mode", [pcomm.GAT_DPR_NOWRAP, pcomm.GAT_DPR_WRAP])
def test_pvt_scan_gathered_into_the_dpram_follows_the_commanded_path(
        host: Pmac, tmp_path: Path, mode: int) -> None:
    """A 12-point PVT scan whose points and velocities come from P-variables (PVT50), motor 1
    commanded position gathered into the DPRAM every 4 servo cycles (PComm GATMODE
    GAT_DPR_NOWRAP / GAT_DPR_WRAP: I5000 = 2 / 3), started on the R's servo cycle: every sample
    read back with PmacCollectGatherData / PmacGetGatherSamples is the Hermite cubic of the
    programmed points at its program time, in 1/(Ixx08·32) counts [SRM PVT, DEFINE GATHER;
    UM "Real-Time Data Gathering Through the Dual-Ported RAM"]. Without wrap gathering ends
    when the buffer is full; with wrap it goes on, the upload holding the samples since the
    last wrap."""
    send_all(host, ["&1#1->1000X #1J/"])
    download(tmp_path, PVT_SCAN)
    points = 12
    seg = 0.05
    x = 2.0 * np.sin(np.linspace(0, 2 * np.pi, points + 1))[1:]     # units; ends on 0
    v = 2.0 * 2 * np.pi / (points * seg) * np.cos(np.linspace(0, 2 * np.pi, points + 1))[1:]
    v[-1] = 0.0                                                       # ends at rest
    x, v = x.round(6), v.round(6)             # the values as the assignments carry them
    assigns = [f"P{100 + k}={x[k]:.6f} P{200 + k}={v[k]:.6f}" for k in range(points)]
    send_all(host, [*assigns, f"P2={points} P3={seg * 1000:g}"])
    period, samples = 4, 100                  # 0.177 s of the 0.6 s scan
    assert pcomm.PmacSetGatherMode(DEVICE, mode)
    assert pcomm.PmacSetGather(DEVICE, 0, "D:$000088", True)          # motor 1 commanded
    assert pcomm.PmacInitPlotGather(DEVICE, samples, period)
    assert pcomm.PmacStartGather(DEVICE) == 1
    assert ask("&1B6R") == ""
    host.step(period * samples + 10)
    gathering = bool(int(ask("???")[:6], 16) & GATHER_BIT)
    assert gathering == (mode == pcomm.GAT_DPR_WRAP)
    sources, count = ctypes.c_uint(), ctypes.c_uint()
    assert pcomm.PmacCollectGatherData(DEVICE, ctypes.byref(sources), ctypes.byref(count))
    n = count.value
    got: list[float] = []
    assert pcomm.PmacGetGatherSamples(DEVICE, 0, None, got, n)
    if mode == pcomm.GAT_DPR_NOWRAP:
        assert (sources.value, n) == (1, samples)
        first = 0
    else:                                     # wrapped after 100 samples: those since the wrap
        assert sources.value == 1 and 0 < n <= 3
        first = samples
    scale = pcomm.PmacGetVariable(DEVICE, "I", 108) * 32
    knots = seg * np.arange(points + 1)
    servo = int(ask("I10")) / 2**23 / 1000    # the exact servo period, s [SRM I10]
    t = (1 + period * (first + np.arange(n))) * servo
    want = 1000 * hermite(t, knots, np.concatenate([[0.0], x]), np.concatenate([[0.0], v]))
    assert np.abs(np.array(got) / scale - want).max() <= 1 / scale   # the register's LSB
    host.step(round(0.6 / DT))
    assert not running(1)
    assert positions(1)[0] == pytest.approx(1000 * x[-1], abs=1e-3)


# -- rotary buffers fed while they run -----------------------------------------------------------
def test_rotary_buffer_fed_from_dls_pmaclib_while_it_runs(host: Pmac) -> None:
    """`&1 DEFINE ROT`, `B0`, `OPEN ROT` and three lines, R; then one line every 100 ms over
    the Ethernet port while it runs, with `PR` from the same port: the moves (TM100 TA50,
    1 unit each) blend into one motion at 10 counts/ms as long as a line waits (X at time t is
    10000·(t − TA/2)); once the buffer runs dry the program waits (still running) with the
    last move done, and a line sent then moves from rest in TM + TA [UM "Rotary Motion Program
    Buffers"; SRM OPEN ROT, PR, B0]."""
    pmac = host.dls()

    def send(line: str) -> str:
        reply, ok = pmac.sendCommand(line)
        assert ok and reply.endswith("\x06"), (line, reply)
        return reply.rstrip("\r\x06")

    for line in ("&1#1->1000X #1J/", "&1 DEFINE ROT 200", "&1B0", "OPEN ROT",
                 "LINEAR ABS TA50 TS0 TM100", "X1", "X2", "X3"):
        send(line)
    assert send("PR") == "4"                                   # lines waiting [SRM PR]
    send("R")
    ticks = 0
    servo = int(ask("I10")) / 2**23 / 1000
    for k in range(4, 13):                                     # lines 4 ... 12, one per move
        step = round(0.1 * (k - 3) / DT) - ticks
        host.step(step)
        ticks += step
        x = positions(1)[0]
        assert x == pytest.approx(10_000 * (ticks * servo - 0.025), abs=1.0)
        assert int(send("PR")) <= 1                          # taken as the calculation needs it
        send(f"X{k}")
    host.step(round(1.3 / DT) - ticks)                         # 12 moves + TA: done at 1.25 s
    assert positions(1)[0] == 12_000.0
    assert running(1) and send("PR") == "0"                    # waiting for lines
    send("X11.5")
    host.step(round(0.14 / DT))
    assert 11_500 < positions(1)[0] < 11_550
    host.step(round(0.02 / DT))
    assert positions(1)[0] == 11_500.0                         # TM100 + TA50 from rest
    send("CLOSE")
    assert ask("&1A") == ""
    assert not running(1)


def ring_through_lookahead(host: Pmac) -> np.ndarray:
    """C.S. 1's rotary buffer fed through the PComm binary rotary ring (PmacDPRRotBufInit,
    PmacDPRAsciiStrToRotA) with `DEFINE LOOKAHEAD` active (Isx13 = 10 ms, Isx20 = 20
    segments, Ixx16 = 15 counts/ms, Ixx17 = 0.1 counts/ms²): three sides of a 5-unit square at
    F20, R, and at 0.6 s (on the second side) two more lines back along the fourth side and
    the first again; both motors gathered into the DPRAM every 9 servo cycles, for 2.2 s. The
    program ends waiting for lines with the motors on the last point. Returns the gathered path
    (counts, samples x 2)."""
    send_all(host, ["&1#1->1000X &1#2->1000Y #1J/ #2J/", "&1 DEFINE ROT 200",
                    "&1 DEFINE LOOKAHEAD 100,0",
                    "I5113=10 I5120=20 I116=15 I117=0.1 I216=15 I217=0.1", "&1B0"])
    dev = DEVICE
    assert pcomm.PmacDPRRotBufInit(dev, 0) == pcomm.DprOk        # the ring of C.S. 1
    for line in ("LINEAR ABS TA50 TS0 F20", "X5", "X5 Y5", "X0 Y5"):
        assert pcomm.PmacDPRAsciiStrToRotA(dev, line, 0) == pcomm.DprOk
    period, samples = 9, 560                                     # 2.2 s, 2240 DPRAM words
    assert pcomm.PmacSetGatherMode(dev, pcomm.GAT_DPR_NOWRAP)
    assert pcomm.PmacSetGather(dev, 0, "D:$000088", True)
    assert pcomm.PmacSetGather(dev, 1, "D:$000108", True)
    assert pcomm.PmacInitPlotGather(dev, samples, period)
    host.step(1)                                                 # the card takes the ring
    assert ask("PR") == "4"
    assert pcomm.PmacStartGather(dev) == 1 and ask("&1R") == ""
    host.step(round(0.6 / DT))                                   # on the second side
    assert cs_words(1)[1] & 1 << 23                              # running in the lookahead
    for line in ("X0 Y0", "X5 Y0"):
        assert pcomm.PmacDPRAsciiStrToRotA(dev, line, 0) == pcomm.DprOk
    host.step(period * samples + 10 - round(0.6 / DT))
    assert running(1) and ask("PR") == "0"                       # waiting for more lines
    assert (positions(1, 2) == [5000, 0]).all()
    count = ctypes.c_uint()
    assert pcomm.PmacCollectGatherData(dev, None, ctypes.byref(count))
    assert count.value == samples
    xs: list[float] = []
    ys: list[float] = []
    assert pcomm.PmacGetGatherSamples(dev, 0, None, xs, samples)
    assert pcomm.PmacGetGatherSamples(dev, 1, None, ys, samples)
    scale = pcomm.PmacGetVariable(dev, "I", 108) * 32
    return np.column_stack([xs, ys]) / scale


def ring_velocity(path: np.ndarray) -> np.ndarray:
    """Counts/ms of each motor between the samples (9 servo cycles apart)."""
    return np.diff(path, axis=0) / (9 * int(ask("I10")) / 2**23)


def test_dpram_binary_rotary_ring_runs_through_the_special_lookahead(host: Pmac) -> None:
    """The lookahead keeps every motor within Ixx16 = 15 counts/ms (F20 asks for 20) and its
    change of velocity within twice Ixx17 (the README's bound in a right-angle corner); the
    lines sent while it runs are run and the motors end on the last one's point [SRM DEFINE
    LOOKAHEAD, Isx13, Isx20, Ixx16, Ixx17; UM "Special Lookahead"; PComm32 dpr.h rotbuf]."""
    path = ring_through_lookahead(host)
    v = ring_velocity(path)
    dt_ms = 9 * int(ask("I10")) / 2**23
    assert np.abs(v).max() <= 15 * 1.0001
    assert np.abs(v).max() > 14.9                               # Ixx16, not F, sets the speed
    assert np.abs(np.diff(v, axis=0) / dt_ms).max() <= 2 * 0.1
    assert tuple(path[-1]) == (5000.0, 0.0) and np.abs(v[-10:]).max() == 0  # ended in the window
    assert path[:, 1].max() == 5000.0 and path[:, 0].min() == 0.0  # the square's far corner


def test_lines_fed_through_the_ring_while_it_runs_blend_in_without_a_stop(host: Pmac) -> None:
    """The lookahead calculates ahead over what the buffer holds: lines that arrive 0.67 s
    before the motion reaches the end of the earlier ones continue it without a stop (the
    speed stays up between the first ramp and the last) [UM "Special Lookahead", "Rotary
    Motion Program Buffers"]."""
    speed = np.hypot(*ring_velocity(ring_through_lookahead(host)).T)
    fast = np.flatnonzero(speed > 7.0)    # from the end of the first ramp to the last's start
    slowest = float(speed[fast[0]:fast[-1]].min())
    assert slowest > 5.0, slowest


# -- `%` override, a PLC's CMD to another C.S., holds and resumes on a CIRCLE program -------------
CIRCLE = ["OPEN PROG 7 CLEAR", "CIRCLE1 INC TA100 TS0 F20",
          "X10 Y0 I5 J0", "X-10 Y0 I-5 J0", "CLOSE"]       # a full circle, two half circles
START_PLC = ["OPEN PLC 1 CLEAR", "IF (P10 = 1)", 'CMD"&2B8R"', "P10 = 2", "DISABLE PLC 1",
             "ENDIF", "CLOSE"]
SLEW = 18569          # Isx94 / Isx95 in I10 units per servo cycle: 0.5 % a cycle at I10 3713707


def circle_setup(host: Pmac) -> None:
    """C.S. 1: X Y on motors 1 and 2, Isx13 = 10 ms (arcs), Isx94 = Isx95 = SLEW; C.S. 2: X on
    motor 3 with PROG 8 (5 units at F10); PLC 1 starts it with CMD"&2B8R" once P10 = 1."""
    send_all(host, ["&1#1->1000X &1#2->1000Y &2#3->1000X #1J/ #2J/ #3J/",
                    f"I5113=10 I5194={SLEW} I5195={SLEW}", *CIRCLE,
                    "OPEN PROG 8 CLEAR", "LINEAR INC TA50 TS0 F10", "X5", "CLOSE",
                    *START_PLC, "P10=0 ENABLE PLC 1"])


def angle() -> float:
    """The angle (degrees) of motors 1 and 2 about the circle's centre (5000, 0); their radius
    must be the circle's, 5 units, within the segments' cubic fit."""
    x, y = positions(1, 2)
    assert np.hypot(x - 5000, y) == pytest.approx(5000, abs=2.0)
    return float(np.degrees(np.arctan2(y, x - 5000)))


def program_cycles(cycles: int, start: float, target: float) -> float:
    """Servo cycles of program time in `cycles` real ones while the time base slews from
    `start` to `target` percent at SLEW (`%` slewing, Isx94/Isx95 [SRM p.191])."""
    rate = SLEW / 3_713_707 * 100
    k = np.arange(1, cycles + 1)
    step = np.sign(target - start) * np.minimum(rate * k, abs(target - start))
    return float(np.sum(start + step) / 100)


#: degrees of the arc a servo cycle at 100 %: F20 on radius 5 is 4 rad/s
DEG_PER_CYCLE = np.degrees(20 / 5 * PERIOD_NS / 1e9)


def test_override_slews_on_a_circle_while_a_plc_starts_another_cs_then_hold_and_resume(
        host: Pmac) -> None:
    """C.S. 1 runs a full circle (CIRCLE1, two half circles, F20 on radius 5, Isx13 = 10 ms).
    At its cruise `&1%50`: the time base slews to 50 % at Isx94, the arc goes on at the speed
    the time base gives (its angle the program time's), on the circle; at the same time P10 = 1
    lets PLC 1 send CMD"&2B8R": C.S. 2 runs its own program at its own 100 % (`&2%`) while C.S.
    1 keeps its 50 %. `&1H` slews the time base to 0 at Isx95 and holds the motors on the
    circle; `R` slews back to the 50 % commanded; `\\` (a feed hold outside a lookahead
    sequence) holds the same way and `R` resumes; the circle ends where it started [SRM `%`,
    `H`, `\\`, `R`, Isx94, Isx95, CIRCLE1, CMD; UM "Time-Base Control"]."""
    circle_setup(host)
    assert ask("&1B7R") == ""
    host.step(550)                                           # cruising on the first half
    a0 = angle()
    assert ask("&1%50 P10=1") == ""
    host.step(300)
    want = a0 - DEG_PER_CYCLE * program_cycles(300, 100, 50)  # clockwise: the angle falls
    assert angle() == pytest.approx(want, abs=DEG_PER_CYCLE)
    assert running(1) and running(2)                          # the PLC's CMD started C.S. 2
    assert (ask("&1%"), ask("&2%")) == ("50", "100")
    assert float(ask("P10")) == 2 and positions(3)[0] > 0
    a1 = angle()
    assert ask("&1H") == ""                                   # feed hold: slew to 0 at Isx95
    host.step(150)
    held = angle()
    assert held == pytest.approx(a1 - DEG_PER_CYCLE * program_cycles(150, 50, 0),
                                 abs=DEG_PER_CYCLE)
    host.step(100)
    assert angle() == held and running(1)                     # held on the path, not ended
    assert ask("&1R") == ""                                   # back to the commanded 50 %
    host.step(300)
    a2 = angle()
    assert a2 == pytest.approx(held - DEG_PER_CYCLE * program_cycles(300, 0, 50),
                               abs=DEG_PER_CYCLE)
    assert running(2) and 3000 < positions(3)[0] < 5000      # C.S. 2 at its 100 %: 0.55 s
    assert ask("&1\\") == ""                                  # quick stop: a hold here
    host.step(150)
    held = angle()
    host.step(50)
    assert angle() == held and held < a2
    assert ask("&1R") == ""
    host.step(round(3.0 / DT))
    assert not running(1) and not cs_words(1)[1] & RUN_TIME_ERROR
    assert (positions(1, 2) == [0.0, 0.0]).all()              # the full circle, back at its start
    assert positions(3)[0] == 5000.0 and not running(2)



def test_stop_at_end_of_move_while_the_override_slews_then_resume(host: Pmac) -> None:
    """A segmented LINEAR square side by side (Isx13 = 10 ms, F10) with `&1%50` slewing the time
    base at the factory Isx94 (about a second from 100 % to 0): `/` during the first move stops
    the program on that move's end point, X5 Y0 (the blend into the next move becomes the
    deceleration, X never passes 5, Y never moves), the program no longer runs; `R` goes on
    with the next moves to X0 Y5 [SRM `/`, `R`, Isx13; README "Motion programs" `/`]."""
    send_all(host, ["&1#1->1000X &1#2->1000Y #1J/ #2J/",
                    "I116=1000 I117=100 I216=1000 I217=100 I5113=10",
                    "OPEN PROG 1 CLEAR", "LINEAR ABS TA100 TS0 F10", "X5", "Y5", "X0", "CLOSE"])
    assert ask("&1%50") == "" and ask("&1B1R") == ""
    host.step(800)
    assert ask("&1/") == ""
    path = []
    for _ in range(14):
        host.step(200)
        path.append(positions(1, 2))
    assert max(x for x, _ in path) == 5000.0 and all(y == 0 for _, y in path)
    assert tuple(path[-1]) == (5000.0, 0.0) and not running(1)
    assert ask("PE") == "P1:1" and not cs_words(1)[1] & RUN_TIME_ERROR
    assert ask("&1R") == ""
    host.step(round(3.0 / DT))
    assert not running(1) and (positions(1, 2) == [0.0, 5000.0]).all()

# -- two C.S. running at once and a homing PLC on a third motor ----------------------------------
RASTER = ["OPEN PROG 10 CLEAR", "LINEAR ABS TA100 TS0 F50",
          "X10", "Y1", "X0", "Y2", "X10", "CLOSE"]
RASTER_POINTS = [(0, 0), (10, 0), (10, 1), (0, 1), (0, 2), (10, 2)]
RASTER_TIMES = [0.2, 0.1, 0.2, 0.1, 0.2]   # 10 units at F50; 1-unit steps last TA (a move ≥ TA)
SWEEP = ["OPEN PROG 11 CLEAR", "LINEAR INC TA50 TS0 TM250", "X-4", "X4", "X-4", "X4", "CLOSE"]


def test_two_cs_and_a_homing_plc_run_at_once_while_ethernet_reads_positions(
        host_axes: Pmac, tmp_path: Path) -> None:
    """C.S. 1 runs a snake raster (motors 1, 2), C.S. 2 a back-and-forth sweep (motor 3) and
    PLC 11, generated by pmac_motorhome (HSW), homes motor 5 on its switch at 4000, all at
    once (the bench's shape): every `#1P` / `#2P` / `#3P` dls-pmaclib reads over Ethernet while
    they run is its motor's programmed path at that time (the blended LINEAR profile, within a
    count); each program ends on its last point at ΣT + TA, the PLC homes the motor (capture
    at the switch's edge, position 0 there plus Ixx26/16) [UM "Linear Blended Moves";
    README "PLCs" homing PLCs; issue 21 performance shape]."""
    from pmac_motorhome.commands import ControllerType, group, motor, plc
    from pmac_motorhome.sequences import home_hsw

    host = host_axes
    send_all(host, ["&1#1->1000X &1#2->1000Y &2#3->1000X #1J/ #2J/ #3J/ #5J/", *RASTER, *SWEEP,
                    "I116=1000 I216=1000 I316=1000 I117=100 I217=100 I317=100",
                    "I523=32 I526=160 I7112=2 I7113=0",
                    "M530->Y:$0002C0,11 M540->Y:$0002C0,0 M542->Y:$0002C0,2",
                    "M545->Y:$0002C0,10 M562->D:$00028B M572->L:$0002D7",
                    "M573->Y:$0002CE,0,24,S"])
    source = tmp_path / "plc11.pmc"
    with plc(plc_num=11, controller=ControllerType.brick, filepath=source), group(group_num=2):
        motor(axis=5, jdist=0)
        home_hsw()
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda t, nl: messages.append(t), None, None,
                               str(source)) == 1, messages
    pmac = host.dls()
    reply, _ = pmac.sendCommand("&1B10R &2B11R P1102=1 ENABLE PLC 11")
    assert reply == "\x06"
    servo = int(ask("I10")) / 2**23 / 1000
    ticks, seen = 0, []
    for step in (150, 333, 200, 251, 400, 97, 300, 190):   # 0.85 s: both run
        host.step(step)
        ticks += step
        reply, ok = pmac.sendCommand("#1P #2P #3P")
        assert ok
        seen.append((ticks * servo, *map(float, reply.rstrip("\r\x06").split("\r"))))
        assert running(1) and running(2)
    got = np.array(seen)
    xy = 1000 * blended(got[:, 0], RASTER_POINTS, RASTER_TIMES, 0.1, 0.0)
    x3 = 1000 * blended(got[:, 0], [(0,), (-4,), (0,), (-4,), (0,)], [0.25] * 4, 0.05, 0.0)
    assert np.abs(got[:, 1:3] - xy).max() <= 1.0
    assert np.abs(got[:, 3] - x3[:, 0]).max() <= 1.0
    host.step(round(1.1 / DT) - ticks)              # ends: 0.9 s and 1.05 s
    assert not running(1) and not running(2)
    assert pmac.sendCommand("#1P #2P #3P")[0] == "10000\r2000\r0\r\x06"
    for _ in range(40):                                    # the homing goes on after them
        if int(float(ask("P1100"))) == 7:                  # pmac_motorhome's StateDone
            break
        host.step_ms(250)
    assert int(float(ask("P1101"))) == 0                   # StatusDone
    assert int(float(ask("M573"))) == 4000 and float(ask("#5P")) == 0
    assert ask("M545") == "1"


# -- altered destination and rollover inside a running program -----------------------------------
ROTARY_PROGRAM = ["OPEN PROG 12 CLEAR", "ABS RAPID X10 A350", "LINEAR TA50 TS0 TM200 A10",
                  "INC X1", "DWELL 10", "ABS A200", "CLOSE"]


def test_altered_destination_and_rollover_inside_a_running_program(host: Pmac) -> None:
    """X on motor 1, a rotary A axis on motor 4 (100 counts a degree, I427 = 36000: one
    revolution). The program's RAPID move to X10 gets `&1!X4` from the host while it runs:
    X ends on 4 (never past it) and the program goes on from there (INC X1 ends on 5). Its ABS
    A moves take the shortest way round (Ixx27 > 0): A350 from 0 is −10°, A10 then +20°, A200
    from 10° is −170° (not +190°); the motor position itself does not roll over [UM
    "Altered-Destination Moves"; A L3232; SRM Ixx27]."""
    send_all(host, ["&1#1->1000X &1#4->100A #1J/ #4J/ I427=36000",
                    "I122=20 I422=20 I119=0.5 I419=0.5 I121=0 I421=0", *ROTARY_PROGRAM])
    assert ask("&1B12R") == ""
    seen: list[tuple[str, float, float]] = []         # (PE: the line executing, X, A motors)
    for k in range(30):
        host.step(100)
        x, a = positions(1, 4)
        seen.append((ask("PE"), x, a))
        if k == 2:
            assert seen[-1][0] == "P12:0" and 0 < x < 4000  # in the RAPID move
            assert ask("&1!X4") == ""
    rapid = [x for pe, x, _ in seen if pe == "P12:0"]
    assert rapid == sorted(rapid) and rapid[-1] <= 4000    # toward 4, never past it
    a_rapid = [a for pe, _, a in seen if pe == "P12:0"]
    assert min(a_rapid) == -1000 and max(a_rapid) <= 0     # A350: −10°, not +350°
    turning = [(x, a) for pe, x, a in seen if pe == "P12:1"]  # the LINEAR A move, from there
    assert turning and all(x == 4000.0 for x, _ in turning)
    assert all(-1000 <= a <= 1000 for _, a in turning)     # −10° to +10°: the short way
    host.step_ms(1000)
    assert not running(1) and not cs_words(1)[1] & RUN_TIME_ERROR
    assert (positions(1, 4) == [5000.0, -16000.0]).all()


# -- errors in combination ------------------------------------------------------------------------
def test_a_limit_in_one_cs_aborts_it_and_the_other_runs_on_and_running_refuses_commands(
        host_limits: Pmac) -> None:
    """C.S. 1 (motor 1, its +LIM at 3000 counts) runs X10 at F10, C.S. 2 (motor 3) X5 at F5.
    While they run, the commands the manual refuses during program execution answer ERR001
    and change nothing (OPEN PROG of the running program or any other, B, a motor command or
    an axis definition for one of the C.S.'s motors, UNDEFINE, DEFINE LOOKAHEAD, OPEN
    FORWARD, PMATCH) [digest §2.4 ERR001; SRM OPEN PROGRAM; README "Motion programs"]; a PLC's
    CMD"&2B1R" and CMD"#3J+" are refused the same way, without a reply to any port, and the PLC
    goes on [SRM p.424 COMMAND; README "PLCs"]. At the
    limit C.S. 1 stops with a run-time error (`??` word 2 bit 22, the motor's +limit bit) and
    its motor decelerates past the switch at Ixx15; C.S. 2 runs on to X5 at 1.1 s, unaltered
    (X at t is 5000·(t − TA/2) while it cruises); OPEN PROG is refused until it ends [SRM
    "Run-time error"; UM "Overtravel limits"]."""
    host = host_limits
    send_all(host, ["&1#1->1000X &2#3->1000X #1J/ #3J/ I116=1000 I117=100 I316=1000 I317=100",
                    "OPEN PROG 1 CLEAR", "LINEAR ABS TA100 TS0 F10", "X10", "CLOSE",
                    "OPEN PROG 2 CLEAR", "LINEAR ABS TA100 TS0 F5", "X5", "CLOSE",
                    "OPEN PLC 3 CLEAR", 'CMD"&2B1R"', 'CMD"#3J+"', "P30 = P30 + 1",
                    "DISABLE PLC 3", "CLOSE"])
    assert ask("&1B1R &2B2R") == ""
    assert ask("P30=0 ENABLE PLC 3") == ""    # a PLC's CMDs that C.S. 2 refuses (ERR001):
    host.step(20)                             # dropped without a reply, the PLC goes on
    assert float(ask("P30")) == 1
    host.step(80)
    for command in ("OPEN PROG 1", "OPEN PROG 2", "OPEN PROG 3", "&1B2", "&2B1", "#1J+",
                    "#1HM", "#3J/", "&1#1->500X", "&1#2->1000Y", "&2UNDEFINE",
                    "&1DEFINE LOOKAHEAD 10", "&1OPEN FORWARD", "&2PMATCH"):
        assert ask(command) == "\x07ERR001", command
    assert ask("CLOSE LIST PROG 1") == "LINEAR ABS TA100 TS0 F10\rX10"
    assert ask("&1#1->") == "1000X" and ask("&2#3->") == "1000X"
    servo = int(ask("I10")) / 2**23 / 1000
    host.step(round(0.3 / DT) - 100)
    ticks = round(0.3 / DT)
    assert running(1) and running(2)
    host.step(round(0.15 / DT))                             # X 3000 at 0.35 s: the limit
    ticks += round(0.15 / DT)
    assert not running(1) and cs_words(1)[1] & RUN_TIME_ERROR
    assert int(ask("#1?")[:6], 16) & 1 << 21                  # motor 1: +limit [SRM #n?]
    assert 3000 < positions(1)[0] < 3500
    assert running(2) and not cs_words(2)[1] & RUN_TIME_ERROR
    assert positions(3)[0] == pytest.approx(5000 * (ticks * servo - 0.05), abs=1.0)
    assert ask("OPEN PROG 3") == "\x07ERR001"                 # C.S. 2 still runs
    assert ask("#1J-") == ""                                  # off the limit: C.S. 1 is free
    host.step(round(0.65 / DT))
    assert not running(2) and positions(3)[0] == 5000.0
    assert ask("OPEN PROG 3") == "" and ask("CLOSE") == ""
