"""NURBS contouring [Ch9], spec §5.10: the rational B-spline, checked against de Boor's algorithm
written here, and the run streamed through the DPR rings by a host that does what Ch9 tells it
(zero both pointers, fill, refill on the breakpoint interrupt)."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vdevd.devices.octavia.nurbs import (
    CONTROL_SLOTS,
    KNOT_CAPACITY,
    KNOT_SLOTS,
    NURBS_BUFBRK,
    NURBS_BUFBRK_BIT,
    NURBS_FEEDRATE,
    NURBS_INPTR,
    NURBS_RTC_FORMATS,
    NURBS_RUN_OUT_BIT,
    NURBS_START,
    DprRings,
    NurbsResult,
    NurbsRun,
    NurbsState,
    basis_functions,
    evaluate,
    pending,
)

P = 3
PROPS = settings(derandomize=True, max_examples=30, deadline=None)


def f32(x: float) -> float:
    """What a float argument becomes on its way through the DPR."""
    return float(np.float32(x))


def de_boor(ctrl: np.ndarray, weights: np.ndarray, knots: np.ndarray, u: float) -> np.ndarray:
    """Reference: de Boor's algorithm on the homogeneous points (w x, w y, w z, w)."""
    m = len(ctrl)
    if u >= knots[m]:
        k = m - 1
        while knots[k] == knots[k + 1]:
            k -= 1
    else:
        k = int(np.searchsorted(knots, u, side="right")) - 1
    pw = np.hstack([ctrl * weights[:, None], weights[:, None]])
    d = [pw[j + k - P].copy() for j in range(P + 1)]
    for r in range(1, P + 1):
        for j in range(P, r - 1, -1):
            i = j + k - P
            alpha = (u - knots[i]) / (knots[i + 1 + P - r] - knots[i])
            d[j] = (1 - alpha) * d[j - 1] + alpha * d[j]
    result: np.ndarray = d[P][:3] / d[P][3]
    return result


def cox_de_boor(knots: np.ndarray, i: int, p: int, u: float) -> float:
    """Reference: the recursion of spec §5.10 as written, 0/0 taken as 0."""
    if p == 0:
        return 1.0 if knots[i] <= u < knots[i + 1] else 0.0
    a = b = 0.0
    if knots[i + p] > knots[i]:
        a = (u - knots[i]) / (knots[i + p] - knots[i]) * cox_de_boor(knots, i, p - 1, u)
    if knots[i + p + 1] > knots[i + 1]:
        b = (knots[i + p + 1] - u) / (knots[i + p + 1] - knots[i + 1]) * cox_de_boor(knots, i + 1, p - 1, u)
    return a + b


def random_curve(seed: int, n: int, step: float = 60.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A clamped cubic NURBS of n control points: a random walk in counts, weights 0.3..3, and
    non-uniform knots with some interior knots doubled."""
    rng = np.random.default_rng(seed)
    inc = rng.uniform(0.05, 3.0, n - 3)
    double = rng.random(n - 3) < 0.2
    double[1:] &= ~double[:-1]
    double[0] = double[-1] = False
    inc[double] = 0.0
    t = np.cumsum(inc)
    knots = np.concatenate([[0.0] * 4, t[:-1], [t[-1]] * 4])
    ctrl = np.cumsum(rng.normal(0.0, step, (n, 3)), axis=0)
    return ctrl, rng.uniform(0.3, 3.0, n), knots


def ch9_curve() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The shape of Ch9's example: 41 control points and weights, 45 knots 0, 0, 0, 0, 1.12 ...
    100.02, 103.45 x 4 (the interior knots between are not given: seeded random here)."""
    rng = np.random.default_rng(9)
    inner = np.sort(rng.uniform(1.12, 100.02, 35))
    knots = np.concatenate([[0.0] * 4, [1.12], inner, [100.02], [103.45] * 4])
    i = np.arange(41)
    r = 400.0 + 20.0 * i
    ctrl = np.column_stack([r * np.cos(0.35 * i), r * np.sin(0.35 * i), 10.0 * i])
    return ctrl, rng.uniform(0.5, 2.0, 41), knots


class Host:
    """The host side of [Ch9] over a DPR: both pointers zeroed, then control point and weight i
    to slot i mod 32 and knot k to slot k mod 36, knot k only once control point k-4 is in,
    never more than 35 knots or 32 control points ahead of OUTPTR."""

    def __init__(self, ctrl: np.ndarray, weights: np.ndarray, knots: np.ndarray) -> None:
        self.dpr = bytearray(0x2000)
        self.ring = DprRings(self.dpr)
        self.ctrl = np.asarray(ctrl, np.float32)
        self.weights = np.asarray(weights, np.float32)
        self.knots = np.asarray(knots, np.float32)
        self.k_in = self.c_in = 0

    def reference(self, u: float) -> np.ndarray:
        return de_boor(self.ctrl.astype(float), self.weights.astype(float), self.knots.astype(float), u)

    def released(self) -> int:
        """OUTPTR unwrapped: knots (and control points) the card has given back."""
        return self.k_in - pending(self.ring)

    def free(self) -> tuple[int, int]:
        """Knot and control slots the host may fill now."""
        out = self.released()
        return KNOT_CAPACITY - (self.k_in - out), CONTROL_SLOTS - (self.c_in - out)

    def fill(self) -> tuple[int, int]:
        """Send all it may; the knots and control points sent."""
        out = self.released()
        k0, c0 = self.k_in, self.c_in
        while self.c_in < len(self.ctrl) and self.c_in - out < CONTROL_SLOTS:
            slot = self.c_in % CONTROL_SLOTS
            struct.pack_into("<3f", self.dpr, 0x120 + 12 * slot, *self.ctrl[self.c_in])
            struct.pack_into("<f", self.dpr, 0x2A0 + 4 * slot, self.weights[self.c_in])
            self.c_in += 1
        while (self.k_in < len(self.knots) and self.k_in - out < KNOT_CAPACITY
               and self.k_in < self.c_in + P + 1):
            struct.pack_into("<f", self.dpr, 0x320 + 4 * (self.k_in % KNOT_SLOTS), self.knots[self.k_in])
            self.k_in += 1
        struct.pack_into("<H", self.dpr, NURBS_INPTR, self.k_in % KNOT_SLOTS)
        return self.k_in - k0, self.c_in - c0


@dataclass
class Trace:
    positions: list[np.ndarray]
    states: list[NurbsState] = field(default_factory=list)
    pending: list[int] = field(default_factory=list)
    released: list[int] = field(default_factory=list)
    outptr: list[int] = field(default_factory=list)
    points: list[tuple[int, float, np.ndarray, int]] = field(default_factory=list)  # step, u, C(u), pending
    fills: int = 0

    def steps(self) -> np.ndarray:
        return np.linalg.norm(np.diff(np.array(self.positions), axis=0), axis=1)


def drive(run: NurbsRun, host: Host, *, threshold: int = 20, latency: int = 0, refill: bool = True,
          max_steps: int = 200_000, trace: Trace | None = None) -> Trace:
    """Step the run until it stops commanding (or `max_steps`). Unless told not to, the host
    refills `latency` samples after the breakpoint interrupt (pending falls below `threshold`)
    or the run-out report (STARVED)."""
    tr = trace or Trace([run.point])
    due: int | None = None
    before = pending(host.ring)
    for _ in range(max_steps):
        u = run.u
        was = run.state
        pos = run.step(host.ring)
        if pos is None:
            break
        tr.positions.append(pos)
        now = pending(host.ring)
        if run.u != u:
            tr.points.append((len(tr.positions) - 1, run.u, run.point, before))
        tr.states.append(run.state)
        tr.pending.append(now)
        tr.released.append(host.released())
        tr.outptr.append(host.ring.outptr())
        edge = now < threshold <= before
        run_out = run.state is NurbsState.STARVED and was is not NurbsState.STARVED
        if refill and due is None and (edge or run_out):
            due = latency
        before = now
        if due is not None:
            if due == 0:
                host.fill()
                tr.fills += 1
                due = None
                before = pending(host.ring)
            else:
                due -= 1
    return tr


# --- the curve -------------------------------------------------------------------------------


@PROPS
@given(st.integers(0, 2**32 - 1), st.integers(4, 30), st.floats(0.0, 1.0))
def test_basis_functions_are_cox_de_boor_a_partition_of_unity(seed: int, n: int, s: float) -> None:
    _, _, knots = random_curve(seed, n)
    u = knots[P] + s * (knots[n] - knots[P])
    basis = basis_functions(knots, P, u)
    assert basis.shape == (n,)
    assert np.all(basis >= -1e-15)
    assert math.isclose(basis.sum(), 1.0, rel_tol=1e-12)
    if u < knots[n]:
        reference = [cox_de_boor(knots, i, P, u) for i in range(n)]
        np.testing.assert_allclose(basis, reference, atol=1e-12)


@PROPS
@given(st.integers(0, 2**32 - 1), st.integers(4, 30), st.floats(0.0, 1.0), st.booleans())
def test_evaluate_matches_de_boor(seed: int, n: int, s: float, unit_weights: bool) -> None:
    """With all weights 1 the NURBS is the B-spline; otherwise de Boor on homogeneous points."""
    ctrl, weights, knots = random_curve(seed, n)
    if unit_weights:
        weights = np.ones(n)
    u = knots[P] + s * (knots[n] - knots[P])
    np.testing.assert_allclose(evaluate(ctrl, weights, knots, u), de_boor(ctrl, weights, knots, u),
                               atol=1e-9)


def test_a_cubic_bezier_is_its_bernstein_form() -> None:
    ctrl = np.array([[0.0, 0.0, 0.0], [100.0, 300.0, -50.0], [400.0, -100.0, 20.0], [500.0, 200.0, 80.0]])
    knots = np.array([0.0] * 4 + [1.0] * 4)
    for u in np.linspace(0.0, 1.0, 11):
        bernstein = [math.comb(3, i) * u**i * (1 - u) ** (3 - i) for i in range(4)]
        np.testing.assert_allclose(evaluate(ctrl, np.ones(4), knots, u), bernstein @ ctrl, atol=1e-9)


def circle(radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A full circle as four rational quadratic quarter arcs (weights 1, √2/2, 1), each raised
    to degree 3 in homogeneous coordinates: 13 control points, knots 0⁴ 1³ 2³ 3³ 4⁴."""
    s = math.sqrt(0.5)
    ctrl, weights = [], []
    for q in range(4):
        a, b = q * math.pi / 2, (q + 1) * math.pi / 2
        p0 = radius * np.array([math.cos(a), math.sin(a), 0.0])
        p2 = radius * np.array([math.cos(b), math.sin(b), 0.0])
        p1 = radius * np.array([math.cos(a) + math.cos(b), math.sin(a) + math.sin(b), 0.0])
        hom = [np.append(p0, 1.0), np.append(p1 * s, s), np.append(p2, 1.0)]
        cubic = [hom[0], (hom[0] + 2 * hom[1]) / 3, (2 * hom[1] + hom[2]) / 3]
        for h in cubic:
            ctrl.append(h[:3] / h[3])
            weights.append(h[3])
    ctrl.append(ctrl[0])
    weights.append(1.0)
    knots = np.array([0.0] * 4 + [1.0] * 3 + [2.0] * 3 + [3.0] * 3 + [4.0] * 4)
    return np.array(ctrl), np.array(weights), knots


def test_a_circle_of_cubic_rational_arcs_keeps_its_radius() -> None:
    ctrl, weights, knots = circle(1000.0)
    for u in np.linspace(0.0, 4.0, 401):
        assert math.isclose(np.linalg.norm(evaluate(ctrl, weights, knots, u)), 1000.0, rel_tol=1e-12)
    np.testing.assert_allclose(evaluate(ctrl, weights, knots, 0.5), [1000 * math.sqrt(0.5)] * 2 + [0])


def test_a_streamed_circle_stays_on_it_and_closes() -> None:
    ctrl, weights, knots = circle(1000.0)
    host = Host(ctrl, weights, knots)
    assert host.fill() == (17, 13)
    run = NurbsRun()
    assert run.start(host.ring, 1.0, 3.0, 0.0, 4.0, 13.0) is NurbsResult.OK
    tr = drive(run, host)
    assert run.state is NurbsState.DONE
    radii = np.linalg.norm(np.array(tr.positions), axis=1)
    assert np.all(radii <= 1000.0 + 1e-3) and np.all(radii >= 1000.0 - 15.0**2 / 8000 - 1e-3)  # sagitta
    assert abs(len(tr.positions) - 1 - 2000 * math.pi) < 15
    np.testing.assert_allclose(tr.positions[-1], [1000.0, 0.0, 0.0], atol=1e-6)


def test_the_domain_ends_are_the_end_control_points() -> None:
    ctrl, weights, knots = ch9_curve()
    np.testing.assert_allclose(evaluate(ctrl, weights, knots, 0.0), ctrl[0], atol=1e-9)
    np.testing.assert_allclose(evaluate(ctrl, weights, knots, 103.45), ctrl[-1], atol=1e-9)


def test_evaluate_refuses_what_is_not_a_nurbs() -> None:
    ctrl, weights, knots = ch9_curve()
    with pytest.raises(ValueError, match="outside the domain"):
        evaluate(ctrl, weights, knots, 103.46)
    with pytest.raises(ValueError, match="shapes"):
        evaluate(ctrl, weights, knots[:-1], 1.0)
    with pytest.raises(ValueError, match="decrease"):
        evaluate(ctrl, weights, knots[::-1], 1.0)


# --- the RTCs and the DPR ----------------------------------------------------------------------

DOCUMENTED_OPCODES = {  # spec §4.2, 72 distinct codes
    0x55, 0x56, 0x58, 0x59, 0x5A, 0x5B, 0x5D, 0x5E, 0x5F, 0x60, 0x61, 0x62, 0x63, 0x64, 0x65, 0x66,
    0x67, 0x68, 0x69, 0x6B, 0x6C, 0x6D, 0x6E, 0x6F, 0x70, 0x71, 0x72, 0x73, 0x74, 0x75, 0x78, 0x7D,
    0x81, 0x82, 0x86, 0x87, 0x8B, 0x8D, 0x8E, 0x8F, 0x91, 0x94, 0x95, 0x97, 0x98, 0x99, 0x9A, 0x9B,
    0x9C, 0x9D, 0x9E, 0x9F, 0xA0, 0xA1, 0xA2, 0xA3, 0xA4, 0xA5, 0xA6, 0xA7, 0xA8, 0xAA, 0xAD, 0xAE,
    0xAF, 0xB0, 0xB1, 0xB2, 0xB3, 0xB4, 0xB6, 0xB7,
}


def test_the_nurbs_rtcs_take_unused_codes_and_fit_the_argument_window() -> None:
    assert len(DOCUMENTED_OPCODES) == 72
    codes = {NURBS_START, NURBS_BUFBRK, NURBS_FEEDRATE}
    assert len(codes) == 3 and not codes & DOCUMENTED_OPCODES
    sizes = {code: struct.calcsize(fmt) for code, fmt in NURBS_RTC_FORMATS.items()}
    assert sizes == {NURBS_START: 20, NURBS_BUFBRK: 1, NURBS_FEEDRATE: 4}
    assert max(sizes.values()) <= 57
    feed, rate, first, last, n = struct.unpack(NURBS_RTC_FORMATS[NURBS_START],
                                               struct.pack("<5f", 1.0, 3.0, 0.0, 103.45, 41.0))
    assert (feed, rate, first, n) == (1.0, 3.0, 0.0, 41.0) and last == f32(103.45)


HOSTINT1_BITS = {  # 1FFEh [Ch6 Table 6-9]; b7 unused
    0x01: "buffer breakpoint", 0x02: "DSPSTAT1", 0x04: "ESTOP detected",
    0x08: "vector-change buffer overflow", 0x10: "reset finished", 0x20: "data run-out",
    0x40: "DSPSTAT2",
}


def test_the_breakpoint_reports_in_the_hostint1_bit_left_unused() -> None:
    assert NURBS_BUFBRK_BIT not in HOSTINT1_BITS and 0 < NURBS_BUFBRK_BIT <= 0x80
    assert bin(NURBS_BUFBRK_BIT).count("1") == 1
    assert HOSTINT1_BITS[NURBS_RUN_OUT_BIT] == "data run-out"


def test_dpr_rings_read_the_addresses_of_ch9() -> None:
    dpr = bytearray(0x2000)
    ring = DprRings(dpr)
    struct.pack_into("<3f", dpr, 0x29F - 11, 1.5, -2.5, 3.5)  # control point slot 31 ends at 29Fh
    struct.pack_into("<f", dpr, 0x31F - 3, 0.75)  # weight slot 31 ends at 31Fh
    struct.pack_into("<f", dpr, 0x3AF - 3, 99.0)  # knot slot 35 ends at 3AFh
    struct.pack_into("<f", dpr, 0x2A0, 2.0)
    struct.pack_into("<H", dpr, 0x3B0, 0x0123)
    assert ring.control(31) == (1.5, -2.5, 3.5)
    assert ring.weight(31) == 0.75 and ring.weight(0) == 2.0
    assert ring.knot(35) == 99.0
    assert ring.inptr() == 0x0123
    ring.set_outptr(17)
    assert dpr[0x3B2:0x3B4] == b"\x11\x00" and ring.outptr() == 17


# --- the run: Ch9's example --------------------------------------------------------------------


def start_ch9(feed: float = 1.0, rate_ms: float = 3.0) -> tuple[NurbsRun, Host]:
    host = Host(*ch9_curve())
    assert host.fill() == (35, 32)  # "35 Knot points ... 32 Control points ... 32 Weight points"
    run = NurbsRun()
    assert run.start(host.ring, feed, rate_ms, 0.0, f32(103.45), 41.0) is NurbsResult.OK
    return run, host


def test_ch9_example_streams_through_the_36_knot_ring_at_the_feed_rate() -> None:
    run, host = start_ch9()
    tr = drive(run, host, threshold=20, latency=25)
    assert run.state is NurbsState.DONE and run.step(host.ring) is None
    # the end lands on the last control point
    np.testing.assert_allclose(tr.positions[-1], host.ctrl[-1], atol=1e-6)
    np.testing.assert_allclose(tr.positions[0], host.ctrl[0], atol=1e-6)
    # 1 count every 200 µs, the last chord (at most 15 samples) slower, no jump anywhere
    steps = tr.steps()
    assert np.all(steps <= 1.0 + 1e-9)
    np.testing.assert_allclose(steps[:-15], 1.0, rtol=1e-7)
    last_chord = np.linalg.norm(tr.points[-1][2] - tr.points[-2][2])
    assert len(tr.positions) - tr.points[-1][0] == math.ceil(last_chord / 1.0) < 15
    # a curve point every 3 ms, each on the curve
    assert [s for s, *_ in tr.points] == list(range(1, 15 * len(tr.points), 15))
    for _, u, point, _ in tr.points:
        np.testing.assert_allclose(point, host.reference(u), atol=1e-6)
    assert NurbsState.STARVED not in tr.states
    # the pointers: 8..35 knots pending while running, OUTPTR forward only and round the ring
    running = [p for p, s in zip(tr.pending, tr.states, strict=True) if s is NurbsState.RUNNING]
    assert min(running) == 8 and max(running) <= KNOT_CAPACITY
    assert np.all(np.diff(tr.released) >= 0)
    assert any(b < a for a, b in zip(tr.outptr, tr.outptr[1:], strict=False))
    assert tr.fills >= 1 and host.k_in == 45 and host.c_in == 41
    assert pending(host.ring) == 0 and host.ring.outptr() == 45 % KNOT_SLOTS


def test_ch9_example_at_outptr_17_frees_17_knots_and_17_control_points() -> None:
    """Ch9: with threshold 20 the interrupt comes when 16 or more knots may be sent, and at
    OUTPTR 17 "17 Knot, Control, and Weight Points may be placed" (INPTR 35; the manual's 36 is
    one past the ring)."""
    run, host = start_ch9()
    first_breakpoint = None
    while host.ring.outptr() < 17:
        assert run.step(host.ring) is not None
        if first_breakpoint is None and pending(host.ring) < 20:
            first_breakpoint = host.free()
    assert first_breakpoint == (16, 16)
    assert host.ring.outptr() == 17 and host.ring.inptr() == 35
    assert host.free() == (17, 17)
    assert host.fill() == (10, 9)  # "the host only has 10 Knot Points, 9 Control Points"
    tr = drive(run, host)
    assert run.state is NurbsState.DONE
    for _, u, point, _ in tr.points:  # control points 32..40 overwrote slots 0..8 unharmed
        np.testing.assert_allclose(point, host.reference(u), atol=1e-6)
    np.testing.assert_allclose(tr.positions[-1], host.ctrl[-1], atol=1e-6)


def test_a_starved_run_holds_its_point_and_carries_on_when_knots_come() -> None:
    run, host = start_ch9()
    tr = drive(run, host, refill=False, max_steps=20_000)
    assert run.state is NurbsState.STARVED
    held = tr.positions[-1]
    assert all(np.array_equal(run.step(host.ring), held) for _ in range(100))
    assert pending(host.ring) >= 8
    host.fill()
    tr = drive(run, host, trace=Trace([held]))
    assert run.state is NurbsState.DONE
    assert np.all(tr.steps() <= 1.0 + 1e-9)
    np.testing.assert_allclose(tr.positions[1] - held, (tr.points[0][2] - held) / 15, atol=1e-9)
    np.testing.assert_allclose(tr.positions[-1], host.ctrl[-1], atol=1e-6)


def test_the_feed_rate_rtc_changes_the_chords_from_the_next_curve_point() -> None:
    run, host = start_ch9()
    tr = drive(run, host, max_steps=100)
    assert run.set_feed(2.5) is NurbsResult.OK
    tr = drive(run, host, max_steps=200, trace=tr)
    steps = tr.steps()
    np.testing.assert_allclose(steps[:105], 1.0, rtol=1e-7)  # the segment begun at step 91 runs on
    np.testing.assert_allclose(steps[105:300], 2.5, rtol=1e-7)
    assert run.set_feed(-1.0) is NurbsResult.BAD_ARGUMENT and run.feed == 2.5


@pytest.mark.parametrize(("rate_ms", "samples"), [(3.0, 15), (1.0, 5), (0.2, 1), (2.95, 15), (0.35, 2),
                                                   (10.2, 51), (0.05, 1)])
def test_nurbs_rate_is_the_samples_between_curve_points(rate_ms: float, samples: int) -> None:
    run, host = start_ch9(rate_ms=rate_ms)
    assert run.samples_per_point == samples
    tr = drive(run, host, max_steps=20 * samples)
    assert [s for s, *_ in tr.points] == list(range(1, 20 * samples + 1, samples))
    np.testing.assert_allclose([np.linalg.norm(b[2] - a[2])
                                for a, b in zip(tr.points, tr.points[1:], strict=False)],
                               samples, rtol=1e-7)


def test_a_chord_longer_than_the_full_ring_is_cut_at_its_last_knot() -> None:
    """At 3000 counts a sample a 3 ms chord is longer than the whole curve: with 35 knots in
    (the host can send no more) the run takes what the ring holds instead of waiting forever."""
    run, host = start_ch9(feed=3000.0)
    tr = drive(run, host, threshold=20, latency=3, max_steps=1000)
    assert run.state is NurbsState.DONE
    (_, u_cut, _, full), _ = tr.points
    assert full == KNOT_CAPACITY and u_cut == host.knots[41 - 10]
    assert np.all(tr.steps() <= 3000.0 * (1 + 1e-9))
    np.testing.assert_allclose(tr.positions[-1], host.ctrl[-1], atol=1e-6)


# --- the run: starting and bad data --------------------------------------------------------------


@pytest.mark.parametrize(("args", "why"), [
    ((-1.0, 3.0, 0.0, 103.45, 41.0), "negative feed"),
    ((math.nan, 3.0, 0.0, 103.45, 41.0), "feed not a number"),
    ((1.0, 0.0, 0.0, 103.45, 41.0), "no NURBSRate"),
    ((1.0, 3.0, 50.0, 50.0, 41.0), "first knot not before the last"),
    ((1.0, 3.0, 0.0, 103.45, 3.0), "fewer control points than a cubic needs"),
    ((1.0, 3.0, 0.0, 103.45, 41.5), "a fraction of a control point"),
])
def test_start_refuses_bad_arguments(args: tuple[float, ...], why: str) -> None:
    host = Host(*ch9_curve())
    host.fill()
    run = NurbsRun()
    assert run.start(host.ring, *args) is NurbsResult.BAD_ARGUMENT, why
    assert run.state is NurbsState.IDLE and run.step(host.ring) is None


@pytest.mark.parametrize(("knots_in", "result"), [(7, NurbsResult.NO_DATA), (8, NurbsResult.OK)])
def test_start_needs_the_8_knots_of_the_first_span(knots_in: int, result: NurbsResult) -> None:
    host = Host(*ch9_curve())
    host.fill()
    struct.pack_into("<H", host.dpr, NURBS_INPTR, knots_in)
    assert NurbsRun().start(host.ring, 1.0, 3.0, 0.0, 103.45, 41.0) is result


def test_start_later_on_the_curve_releases_the_spans_before_first_knot() -> None:
    host = Host(*ch9_curve())
    host.fill()
    run = NurbsRun()
    first = f32(host.knots[20] + 0.01)
    assert run.start(host.ring, 1.0, 3.0, first, f32(103.45), 41.0) is NurbsResult.OK
    assert host.ring.outptr() == 20 - P
    np.testing.assert_allclose(run.point, host.reference(first), atol=1e-6)
    assert NurbsRun().start(host.ring, 1.0, 3.0, f32(host.knots[33]), 103.45, 41.0) is NurbsResult.NO_DATA


def test_start_past_the_end_of_a_curve_wholly_in_the_ring_is_refused() -> None:
    ctrl, weights, knots = random_curve(1, 10)
    host = Host(ctrl, weights, knots)
    assert host.fill() == (14, 10)
    end = float(host.knots[-1])
    assert NurbsRun().start(host.ring, 1.0, 3.0, end + 1, end + 2, 10.0) is NurbsResult.BAD_ARGUMENT


def test_start_refuses_a_ring_that_is_not_a_nurbs() -> None:
    ctrl, weights, knots = ch9_curve()
    weights[2] = 0.0
    host = Host(ctrl, weights, knots)
    host.fill()
    assert NurbsRun().start(host.ring, 1.0, 3.0, 0.0, 103.45, 41.0) is NurbsResult.BAD_DATA


def test_a_decreasing_knot_in_a_refill_ends_the_run() -> None:
    run, host = start_ch9()
    host.knots[38] = 50.0
    tr = drive(run, host, latency=5)
    assert run.state is NurbsState.FAULT and run.step(host.ring) is None
    assert np.all(tr.steps() <= 1.0 + 1e-9)


def test_a_stopped_run_commands_nothing() -> None:
    run, host = start_ch9()
    assert run.step(host.ring) is not None
    run.stop()
    assert run.state is NurbsState.IDLE and run.step(host.ring) is None


# --- the run: any curve ---------------------------------------------------------------------------


@settings(derandomize=True, max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(4, 80), step=st.floats(20.0, 1000.0),
       feed=st.floats(1.0, 40.0), rate_ms=st.sampled_from([0.2, 0.6, 1.0, 3.0, 7.4]),
       latency=st.integers(0, 40), threshold=st.integers(9, 35))
def test_any_curve_streams_continuously_at_the_feed_rate_to_its_end(
        seed: int, n: int, step: float, feed: float, rate_ms: float, latency: int, threshold: int) -> None:
    ctrl, weights, knots = random_curve(seed, n, step)
    host = Host(ctrl, weights, knots)
    host.fill()
    polygon = float(np.linalg.norm(np.diff(host.ctrl.astype(float), axis=0), axis=1).sum())
    feed = f32(max(feed, polygon / 5000))  # at most ~5000 samples (the curve is no longer than its polygon)
    run = NurbsRun()
    assert run.start(host.ring, feed, rate_ms, 0.0, f32(knots[-1]), float(n)) is NurbsResult.OK
    chord = feed * run.samples_per_point
    budget = int(polygon / feed * 1.2) + (latency + 2 * run.samples_per_point + 2) * (n + 10)
    tr = drive(run, host, threshold=threshold, latency=latency, max_steps=budget)
    assert run.state is NurbsState.DONE
    np.testing.assert_allclose(tr.positions[-1], host.ctrl[-1], atol=1e-6)
    assert np.all(tr.steps() <= feed * (1 + 1e-7) + 1e-9)
    points = np.array([point for _, _, point, _ in tr.points])
    reference = np.array([host.reference(u) for _, u, _, _ in tr.points])
    assert np.abs(points - reference).max() <= 1e-6
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)[:-1]  # the last may be short
    whole = np.array([before for *_, before in tr.points[1:-1]]) < KNOT_CAPACITY  # not cut
    np.testing.assert_allclose(chords[whole], chord, rtol=1e-7)
    holding = [p for p, s in zip(tr.pending, tr.states, strict=True) if s is not NurbsState.DONE]
    assert all(8 <= p <= KNOT_CAPACITY for p in holding)
    assert np.all(np.diff(tr.released) >= 0) and pending(host.ring) == 0
