"""NURBS contouring of the PCI Mx4 Octavia [Ch9], spec §5.10 and Q-27: the rational B-spline and
the streaming interpolator that follows it from the three DPR rings, sans-I/O.

The card reads the rings through `NurbsRings` (`DprRings` implements it over the DPR bytes) and
calls `NurbsRun.step` once per 200 µs sample; X, Y, Z command axes 1, 2, 3 (`NURBS_AXES`,
ASSUMPTION: Ch9 names no axes). The manual gives no opcodes, layouts or interrupt bit; these
are proposed here, every one an ASSUMPTION (Q-27):

* `NURBS_START` B8h, 20 bytes: FeedRate f32 (counts/200 µs), NURBSRate f32 (ms), FirstKnot f32,
  LastKnot f32, NumCtrlPts f32, in the order Ch9 lists them, little-endian IEEE-754 ("C formatted
  32-bit floating point") like every other multi-byte argument [Ch6 Real-Time Commands rule 3].
* `NURBS_BUFBRK` B9h, 1 byte: threshold u8 in knots, like EN_BUFBRK's u8 in slots (35 knots fit);
  0 disarms it. Edge-triggered like EN_BUFBRK (spec §3.2): fires when an OUTPTR advance makes
  `pending` fall below the threshold ("comes within 20 points" and "16 or more Knot points" may
  then be sent [Ch9 example], so strictly below), and stays armed.
* `NURBS_FEEDRATE` BAh, 4 bytes: FeedRate f32; it takes effect from the next curve point.
* B8h..BAh: the first codes above the highest documented one (B7h REL_AXMOVE); no documented
  opcode of spec §4.2 lies in B5h or B8h..BFh, and B5h, inside the documented range, is left for
  whatever undocumented command (CIRCLE, TABLE_ON, ... spec §4.2) the vendor may have put there.
* Report `NURBS_BUFBRK_BIT`: HOSTINT1 (1FFEh) b7, the one bit Table 6-9 leaves unused. The ring
  breakpoint it parallels (EN_BUFBRK, b0) is a direct HOSTINT1 bit with no DSPSTAT type or
  INTAXIS byte, so the host reads it without the 000h..065h lock; a bit of its own keeps it apart
  from the contouring breakpoint. Starvation (`NurbsState.STARVED`) is proposed to post the data
  run-out bit b5 (`NURBS_RUN_OUT_BIT`): Ch7's "data run-out in ring buffer" while moving; the
  NURBS rings overlay the contouring ring buffer (120h..3C1h), so the two never run together.

Ring indexing (ASSUMPTION, Q-27; Ch9 gives only knot pointers). Counting from 0 at the first
value the host writes, knot i is in knot slot (OUTPTR at start + i) mod 36, and control point i
and weight i are in slot i mod 32 of their rings (the host zeroes both pointers before filling
[Ch9], so all three start at slot 0). Knot i, control point i and weight i are released together,
so OUTPTR (unwrapped) also counts the control and weight slots the host may refill. This is the
reading under which Ch9's example adds up: 35 knots and 32 control points fill the rings, and at
OUTPTR 17 "17 Knot, Control, and Weight Points may be placed" (with INPTR 35; the example's 36 is
read as an erratum). The host must have sent control point i by the time knot i+4 is in.

Per span j (u_j <= u < u_j+1) the card keeps knots j-3..j+4 (the full support of the four basis
functions non-zero there) and control points j-3..j, and OUTPTR stays at knot j-3. A span is
used only once its 8 knots are in, so INPTR is at least 8 ahead of OUTPTR whenever the card
holds data: the manual's "at least 8 locations" rule [Ch9].
"""

from __future__ import annotations

import enum
import math
import mmap
import struct
from bisect import bisect_right
from collections.abc import Sequence
from typing import Protocol

import numpy as np
from vdevmaps.octavia import (
    BY_NAME,
    NURBS_CTRL,
    NURBS_CTRL_POINTS,
    NURBS_INPTR,
    NURBS_KNOT,
    NURBS_KNOTS,
    NURBS_OUTPTR,
    NURBS_WEIGHT,
    HostInt,
)

DEGREE = 3  # ASSUMPTION (spec §5.10): Ch9's example has 45 knots - 41 control points - 1 = 3
SAMPLE_NS = 200_000  # the interpolation sample [Ch9 "every 200μsec"]

NURBS_START = BY_NAME["NURBS"].code
NURBS_BUFBRK = BY_NAME["NURBS_BUFBRK"].code
NURBS_FEEDRATE = BY_NAME["NURBS_FEEDRATE"].code
NURBS_RTC_FORMATS: dict[int, str] = {
    BY_NAME[name].code: "<" + "".join(c for _, c in BY_NAME[name].head)
    for name in ("NURBS", "NURBS_BUFBRK", "NURBS_FEEDRATE")}
NURBS_BUFBRK_BIT = int(HostInt.NURBS_BUFBRK)  # HOSTINT1 b7
NURBS_RUN_OUT_BIT = int(HostInt.RUN_OUT)  # HOSTINT1 b5, shared with contouring's data run-out
NURBS_AXES = 0x07  # X, Y, Z -> axes 1, 2, 3

# The DPR rings [Ch9], spec §5.10
CONTROL_RING = NURBS_CTRL  # 32 points x (X, Y, Z) float32
CONTROL_SLOTS = NURBS_CTRL_POINTS
WEIGHT_RING = NURBS_WEIGHT  # 32 float32
WEIGHT_SLOTS = NURBS_CTRL_POINTS
KNOT_RING = NURBS_KNOT  # 36 float32
KNOT_SLOTS = NURBS_KNOTS
# NURBS_INPTR (3B0h, u16, host: next knot slot it fills), NURBS_OUTPTR (3B2h, u16, card: next
# knot slot it reads): vdevmaps.octavia
KNOT_CAPACITY = KNOT_SLOTS - 1  # INPTR never catches OUTPTR [Ch9]
SPAN_KNOTS = 2 * DEGREE + 2  # knots one span needs: the "at least 8" of Ch9

_MAX_EXPAND = 64  # doublings of the trial step (the first is at least 2**-40 of the room left)
_MAX_REFINE = 50  # Illinois iterations on the chord length
_REL_TOL = 1e-9  # of the chord length


def find_span(knots: Sequence[float], p: int, u: float) -> int:
    """The index j of the knot span holding u, with p <= j < m (m = len(knots) - p - 1) and
    u_j < u_j+1; u == u_m, the end of the domain, belongs to the last non-empty span."""
    m = len(knots) - p - 1
    j = min(max(bisect_right(knots, u) - 1, p), m - 1)
    while j > p and knots[j] >= knots[j + 1]:
        j -= 1
    return j


def _nonzero_basis(knots: Sequence[float], j: int, p: int, u: float) -> list[float]:
    """N_j-p,p(u) .. N_j,p(u) by the Cox-de Boor recursion in its triangular form (Piegl and
    Tiller A2.2); it reads knots j-p+1..j+p and never divides by zero on a non-empty span."""
    n = [1.0] + [0.0] * p
    left = [0.0] * (p + 1)
    right = [0.0] * (p + 1)
    for d in range(1, p + 1):
        left[d] = u - knots[j + 1 - d]
        right[d] = knots[j + d] - u
        saved = 0.0
        for r in range(d):
            temp = n[r] / (right[r + 1] + left[d - r])
            n[r] = saved + right[r + 1] * temp
            saved = left[d - r] * temp
        n[d] = saved
    return n


def _check_domain(knots: Sequence[float], p: int, u: float) -> None:
    m = len(knots) - p - 1
    if m < p + 1:
        raise ValueError(f"{len(knots)} knots are too few for degree {p}")
    if any(b < a for a, b in zip(knots, knots[1:], strict=False)):
        raise ValueError("knots must not decrease")
    if not knots[p] <= u <= knots[m]:
        raise ValueError(f"u={u} is outside the domain [{knots[p]}, {knots[m]}]")


def basis_functions(knots: Sequence[float] | np.ndarray, p: int, u: float) -> np.ndarray:
    """All m = len(knots) - p - 1 B-spline basis functions N_i,p(u) (spec §5.10, Cox-de Boor);
    u must lie in [u_p, u_m], and u == u_m gives the left limit (the last control point's)."""
    kn = [float(k) for k in knots]
    _check_domain(kn, p, u)
    j = find_span(kn, p, u)
    out = np.zeros(len(kn) - p - 1)
    out[j - p : j + 1] = _nonzero_basis(kn, j, p, u)
    return out


def evaluate(ctrl: np.ndarray, weights: np.ndarray, knots: np.ndarray, u: float,
             p: int = DEGREE) -> np.ndarray:
    """C(u) = sum N_i,p(u) w_i P_i / sum N_i,p(u) w_i (spec §5.10) for ctrl (m, 3), weights (m,)
    and knots (m + p + 1,)."""
    ctrl = np.asarray(ctrl, dtype=float)
    weights = np.asarray(weights, dtype=float)
    if ctrl.ndim != 2 or len(weights) != len(ctrl) or len(knots) != len(ctrl) + p + 1:
        raise ValueError(f"shapes {ctrl.shape}, {weights.shape}, {np.shape(knots)} do not make a "
                         f"degree-{p} NURBS")
    nw = basis_functions(knots, p, u) * weights
    den = float(nw.sum())
    if not den > 0:
        raise ValueError(f"the weights sum to {den} at u={u}")
    result: np.ndarray = nw @ ctrl / den
    return result


class NurbsRings(Protocol):
    """The card's view of the three rings and their pointers (spec §5.10); slots are ring
    indices (knot 0..35, control and weight 0..31)."""

    def knot(self, slot: int) -> float: ...
    def control(self, slot: int) -> Sequence[float]: ...
    def weight(self, slot: int) -> float: ...
    def inptr(self) -> int: ...
    def outptr(self) -> int: ...
    def set_outptr(self, value: int) -> None: ...


class DprRings:
    """`NurbsRings` over the DPR bytes at the addresses of [Ch9], little-endian."""

    def __init__(self, dpr: bytearray | memoryview | mmap.mmap) -> None:
        self.dpr = dpr

    def knot(self, slot: int) -> float:
        return float(struct.unpack_from("<f", self.dpr, KNOT_RING + 4 * slot)[0])

    def control(self, slot: int) -> tuple[float, float, float]:
        x, y, z = struct.unpack_from("<3f", self.dpr, CONTROL_RING + 12 * slot)
        return float(x), float(y), float(z)

    def weight(self, slot: int) -> float:
        return float(struct.unpack_from("<f", self.dpr, WEIGHT_RING + 4 * slot)[0])

    def inptr(self) -> int:
        return int(struct.unpack_from("<H", self.dpr, NURBS_INPTR)[0])

    def outptr(self) -> int:
        return int(struct.unpack_from("<H", self.dpr, NURBS_OUTPTR)[0])

    def set_outptr(self, value: int) -> None:
        struct.pack_into("<H", self.dpr, NURBS_OUTPTR, value)


def pending(ring: NurbsRings) -> int:
    """Knots between OUTPTR and INPTR (0..35) [Ch9]: what the breakpoint threshold compares.
    An INPTR of 36 or more is taken modulo 36."""
    return (ring.inptr() - ring.outptr()) % KNOT_SLOTS


class NurbsState(enum.Enum):
    IDLE = "idle"
    RUNNING = "running"
    STARVED = "starved"  # holding: the next curve point needs knots not yet in the ring
    DONE = "done"  # the last sample landed on C(LastKnot)
    FAULT = "fault"  # ring data not a NURBS (a decreasing or non-finite knot, a weight <= 0)


class NurbsResult(enum.Enum):
    OK = "ok"
    BAD_ARGUMENT = "bad argument"
    NO_DATA = "no data"  # fewer than 8 knots in, or FirstKnot beyond the ring's window
    BAD_DATA = "bad data"


def _feed_ok(feed: float) -> bool:
    return math.isfinite(feed) and feed >= 0


class NurbsRun:
    """One NURBS motion [Ch9]: every NURBSRate a new curve point a chord of FeedRate x samples
    away, the 200 µs samples in between on the straight line to it (spec §5.10).

    ASSUMPTIONS: positions are absolute counts and the run starts at C(FirstKnot) wherever the
    axes are (the host brings them there first). FirstKnot and LastKnot are parameter values,
    clamped to the domain [u_3, u_NumCtrlPts]. NURBSRate is rounded to the nearest whole sample
    (at least one). A new FeedRate applies from the next curve point. Starvation: when the next
    chord needs knots the host has not sent, the run holds its last point (STARVED) and carries
    on from it once they arrive; if the ring is full (35 knots) and still too short for one
    chord, the chord is cut at the ring's last usable knot instead, so that knots are released.
    The final chord takes ceil(length / FeedRate) samples and ends exactly on C(LastKnot); the
    run then releases every knot of the curve it was sent.
    """

    def __init__(self) -> None:
        self.state = NurbsState.IDLE
        self.feed = 0.0
        self.samples_per_point = 1
        self.u = 0.0  # the parameter of the latest curve point
        self._n_ctrl = 0
        self._last = 0.0  # LastKnot
        self._slot0 = 0  # knot slot of knot 0
        self._k0 = 0  # index of the oldest knot kept (= OUTPTR unwrapped)
        self._kn: list[float] = []  # knots k0, k0 + 1, ...
        self._cp: list[tuple[float, ...]] = []  # control points k0, k0 + 1, ...
        self._w: list[float] = []
        self._p0: tuple[float, ...] = (0.0, 0.0, 0.0)  # segment start
        self._p1: tuple[float, ...] = (0.0, 0.0, 0.0)  # segment end: C(u)
        self._k = 0  # samples of the segment done
        self._n = 0  # samples in the segment
        self._final = False
        self._du = 0.0  # last parameter step and its chord, to guess the next
        self._chord = 0.0

    @property
    def point(self) -> np.ndarray:
        """C(u), the latest curve point: where the segment being interpolated ends."""
        return np.array(self._p1)

    def start(self, ring: NurbsRings, feed: float, rate_ms: float, first_knot: float,
              last_knot: float, n_ctrl: float) -> NurbsResult:
        """The NURBS RTC [Ch9]: start at C(FirstKnot) from the rings as the host filled them.
        FirstKnot and LastKnot are parameter values (the knot vector's ends) and are clamped to
        the curve's domain; NURBSRate is rounded to whole samples (at least one)."""
        if not (_feed_ok(feed) and math.isfinite(rate_ms) and rate_ms > 0
                and math.isfinite(first_knot) and math.isfinite(last_knot)
                and first_knot < last_knot and math.isfinite(n_ctrl) and n_ctrl == round(n_ctrl)
                and DEGREE + 1 <= n_ctrl <= 2**24):
            return NurbsResult.BAD_ARGUMENT
        self.state = NurbsState.IDLE
        self.feed = feed
        self.samples_per_point = max(1, round(rate_ms * 1_000_000 / SAMPLE_NS))
        self._n_ctrl = int(n_ctrl)
        self._last = last_knot
        self._slot0 = ring.outptr() % KNOT_SLOTS
        self._k0 = 0
        self._kn, self._cp, self._w = [], [], []
        self._du = self._chord = 0.0
        if not self._read(ring):
            return NurbsResult.BAD_DATA
        if len(self._cp) <= DEGREE:
            return NurbsResult.NO_DATA
        u = max(first_knot, self._kn[DEGREE])
        u_stop, is_end = self._stop()
        if u > u_stop:
            return NurbsResult.BAD_ARGUMENT if is_end else NurbsResult.NO_DATA
        self.u = u
        self._p0 = self._p1 = self._at(u)
        self._k = self._n = 0
        self._final = False
        self._release(ring)
        self.state = NurbsState.RUNNING
        return NurbsResult.OK

    def set_feed(self, feed: float) -> NurbsResult:
        """The NURBS FeedRate RTC [Ch9]: the chords from the next curve point on."""
        if not _feed_ok(feed):
            return NurbsResult.BAD_ARGUMENT
        self.feed = feed
        return NurbsResult.OK

    def stop(self) -> None:
        """End the run where it is (the card's STOP of axes 1-3); the rings are left as they are."""
        self.state = NurbsState.IDLE

    def step(self, ring: NurbsRings) -> np.ndarray | None:
        """One 200 µs sample: the X, Y, Z command position (counts, float), or None once the run
        no longer commands the axes (idle, after the sample that ended it, or on bad data)."""
        if self.state not in (NurbsState.RUNNING, NurbsState.STARVED):
            return None
        if self._k >= self._n:
            outcome = self._next_point(ring)
            if outcome is not NurbsState.RUNNING:
                self.state = outcome
                return None if outcome is NurbsState.FAULT else np.array(self._p1)
            self.state = NurbsState.RUNNING
        self._k += 1
        if self._k >= self._n:
            if self._final:
                self._release_all(ring)
                self.state = NurbsState.DONE
            return np.array(self._p1)
        f = self._k / self._n
        return np.array([a + (b - a) * f for a, b in zip(self._p0, self._p1, strict=True)])

    def _next_point(self, ring: NurbsRings) -> NurbsState:
        """Start the next segment: the chord of FeedRate x NURBSRate from C(u) (spec §5.10)."""
        if not self._read(ring):
            return NurbsState.FAULT
        u_stop, is_end = self._stop()
        n = self.samples_per_point
        target = self.feed * n
        if target == 0:
            t, p, reached = self.u, self._p1, True
        elif self.u >= u_stop:
            t, p, reached = self.u, self._p1, False
        else:
            t, p, reached = self._solve(target, u_stop)
        final = False
        if not reached:
            chord = math.dist(p, self._p1)
            if is_end:
                final = True
                n = min(n, max(1, math.ceil(chord / self.feed * (1 - 1e-12))))
            elif len(self._kn) < KNOT_CAPACITY or t <= self.u:
                return NurbsState.STARVED
        self._p0, self._p1 = self._p1, p
        self.u = t
        self._k, self._n, self._final = 0, n, final
        self._release(ring)
        return NurbsState.RUNNING

    def _solve(self, target: float, u_stop: float) -> tuple[float, tuple[float, ...], bool]:
        """The first t in (u, u_stop] with |C(t) - C(u)| = target, by doubling a trial step and
        then the Illinois method; (u_stop, C(u_stop), False) if the chord stays shorter."""
        u, origin = self.u, self._p1
        room = u_stop - u
        guess = self._du * target / self._chord if self._chord > 0 else room / 64
        lo, f_lo = u, -target
        hi = min(u + max(guess, room * 2.0**-40), u_stop)
        for _ in range(_MAX_EXPAND):
            p_hi = self._at(hi)
            f_hi = math.dist(p_hi, origin) - target
            if f_hi >= 0:
                break
            if hi >= u_stop:
                return hi, p_hi, False
            lo, f_lo = hi, f_hi
            hi = min(u + 2 * (hi - u), u_stop)
        else:
            return lo, self._at(lo), False
        tol = _REL_TOL * target
        side = 0
        for _ in range(_MAX_REFINE):
            if f_hi <= tol or hi - lo <= 1e-15 * max(1.0, abs(hi)):
                break
            mid = hi - f_hi * (hi - lo) / (f_hi - f_lo)
            if not lo < mid < hi:
                mid = 0.5 * (lo + hi)
            p_mid = self._at(mid)
            f_mid = math.dist(p_mid, origin) - target
            if f_mid >= 0:
                hi, p_hi, f_hi = mid, p_mid, f_mid
                if side == 1:
                    f_lo *= 0.5
                side = 1
            else:
                lo, f_lo = mid, f_mid
                if side == -1:
                    f_hi *= 0.5
                side = -1
            if abs(f_mid) <= tol:
                hi, p_hi = mid, p_mid
                break
        self._du, self._chord = hi - u, target
        return hi, p_hi, True

    def _read(self, ring: NurbsRings) -> bool:
        """Take in the knots the host has added, and control point i once knot i+4 is in (span
        i's last of SPAN_KNOTS); False if they do not make a NURBS."""
        have = self._k0 + (ring.inptr() - (self._slot0 + self._k0)) % KNOT_SLOTS
        for i in range(self._k0 + len(self._kn), min(have, self._n_ctrl + DEGREE + 1)):
            k = ring.knot((self._slot0 + i) % KNOT_SLOTS)
            if not math.isfinite(k) or (self._kn and k < self._kn[-1]):
                return False
            self._kn.append(k)
        for i in range(self._k0 + len(self._cp),
                       min(self._k0 + len(self._kn) - (SPAN_KNOTS - DEGREE - 1), self._n_ctrl)):
            c = tuple(float(x) for x in ring.control(i % CONTROL_SLOTS))
            w = ring.weight(i % WEIGHT_SLOTS)
            if not (all(math.isfinite(x) for x in c) and math.isfinite(w) and w > 0):
                return False
            self._cp.append(c)
            self._w.append(w)
        return True

    def _stop(self) -> tuple[float, bool]:
        """How far the data in hand reaches in u, and whether that is the end of the motion."""
        u_lim = self._kn[len(self._cp)]
        done = self._k0 + len(self._cp) == self._n_ctrl
        return min(self._last, u_lim), done or self._last <= u_lim

    def _span(self, t: float) -> int:
        """The local index of t's span among the spans whose data is in hand."""
        j = min(max(bisect_right(self._kn, t) - 1, DEGREE), len(self._cp) - 1)
        while j > DEGREE and self._kn[j] >= self._kn[j + 1]:
            j -= 1
        return j

    def _at(self, t: float) -> tuple[float, ...]:
        j = self._span(t)
        n = _nonzero_basis(self._kn, j, DEGREE, t)
        acc = [0.0, 0.0, 0.0]
        den = 0.0
        for r, nr in enumerate(n):
            i = j - DEGREE + r
            nw = nr * self._w[i]
            den += nw
            for a in range(3):
                acc[a] += nw * self._cp[i][a]
        return tuple(a / den for a in acc)

    def _release(self, ring: NurbsRings) -> None:
        """Advance OUTPTR to the first knot of the current span's support (u_j-3)."""
        drop = self._span(self.u) - DEGREE
        if drop > 0:
            del self._kn[:drop], self._cp[:drop], self._w[:drop]
            self._k0 += drop
            ring.set_outptr((self._slot0 + self._k0) % KNOT_SLOTS)

    def _release_all(self, ring: NurbsRings) -> None:
        """At the end: every knot of this curve the host has sent is used up."""
        self._k0 += len(self._kn)
        self._kn, self._cp, self._w = [], [], []
        ring.set_outptr((self._slot0 + self._k0) % KNOT_SLOTS)
