"""NURBS on the card [Ch9]: the rings filled through the DPR, the NURBS RTCs (codes assigned by
vdevd, vdevmaps.octavia NURBS_RTCS), axes 1-3 following the curve sample by sample."""

from __future__ import annotations

import struct

import numpy as np
from vdevmaps.octavia import (
    NURBS_CTRL,
    NURBS_INPTR,
    NURBS_KNOT,
    NURBS_OUTPTR,
    NURBS_WEIGHT,
    Dpr,
    DspStat1,
    HostInt,
)

from tests.devices.octavia.host import Host
from vdevd.devices.octavia.nurbs import evaluate

CTRL = np.array([(0, 0, 0), (1000, 0, 0), (2000, 1500, 0), (3000, 1500, 300), (4000, 0, 300),
                 (5000, 0, 0)], dtype=float)
WEIGHTS = np.array([1, 1, 2, 1, 1, 1], dtype=float)
KNOTS = np.array([0, 0, 0, 0, 1, 2, 3, 3, 3, 3], dtype=float)


def fill(host: Host, ctrl: np.ndarray = CTRL, weights: np.ndarray = WEIGHTS,
         knots: np.ndarray = KNOTS) -> None:
    """The host zeroes the pointers, writes the rings, then INPTR [Ch9]."""
    host.write(NURBS_OUTPTR, b"\x00\x00")
    for i, p in enumerate(ctrl):
        host.write(NURBS_CTRL + 12 * i, struct.pack("<3f", *p))
        host.write(NURBS_WEIGHT + 4 * i, struct.pack("<f", weights[i]))
    for i, k in enumerate(knots):
        host.write(NURBS_KNOT + 4 * i, struct.pack("<f", k))
    host.write(NURBS_INPTR, struct.pack("<H", len(knots)))


def test_a_nurbs_curve_runs_on_axes_1_to_3_and_ends_on_its_last_point() -> None:
    host = Host(plant="ideal")
    fill(host)
    host.rtc("NURBS", {"feed": 4.0, "rate": 3.0, "first": 0.0, "last": 3.0, "npts": 6.0})
    assert host.card.fw.mode[:3].tolist() == [4, 4, 4]
    path = []
    for _ in range(20_000):
        host.run(1)
        path.append(host.card.fw.core.axes.cmd_pos[:3].copy())
        if host.card.fw.mode[0] == 0:
            break
    path_a = np.array(path)
    assert host.card.fw.mode[:3].tolist() == [0, 0, 0]
    assert np.allclose(path_a[-1], CTRL[-1], atol=1e-6)
    steps = np.linalg.norm(np.diff(path_a, axis=0), axis=1)
    assert steps.max() <= 4.0 * 1.05  # the feed: counts per sample
    on_curve = [evaluate(CTRL, WEIGHTS, KNOTS, u) for u in (0.5, 1.5, 2.5)]
    for point in on_curve:  # the path passes (within a chord's sag) through the curve
        assert np.linalg.norm(path_a - point, axis=1).min() < 2.0
    host.run(5)
    assert [host.position(a) for a in (1, 2, 3)] == [5000, 0, 0]
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.MOTCP == 0  # contouring: no motion complete


def test_nurbs_starves_without_its_knots_and_stop_ends_it() -> None:
    """Only the first span's knots in: the run starves (1FFEh b5 data run-out) and holds; STOP
    ends it at MAXACC; the breakpoint interrupt (1FFEh b7) when pending falls below it."""
    host = Host(plant="ideal")
    fill(host)
    host.write(NURBS_INPTR, struct.pack("<H", 8))
    host.rtc("NURBS_BUFBRK", {"threshold": 6})
    host.rtc("NURBS", {"feed": 4.0, "rate": 1.0, "first": 0.0, "last": 3.0, "npts": 6.0})
    seen = 0
    for _ in range(3000):
        host.run(1)
        seen |= host.u8(Dpr.HOSTINT1)
    assert seen & HostInt.RUN_OUT
    host.rtc("MAXACC", {"n": 0x07}, [{"acc": 0x100}] * 3)
    host.rtc("STOP", {"n": 0x01})
    host.run(2000)
    fw = host.card.fw
    assert not fw.nurbs_axes and fw.mode[:3].tolist() == [0, 0, 0]
    assert fw.core.axes.cmd_vel[:3].tolist() == [0.0, 0.0, 0.0]


def test_a_nurbs_start_with_bad_arguments_is_ignored() -> None:
    host = Host(plant="ideal")
    fill(host)
    host.rtc("NURBS", {"feed": 4.0, "rate": 3.0, "first": 2.0, "last": 1.0, "npts": 6.0})
    assert host.card.fw.mode[:3].tolist() == [0, 0, 0] and host.card.fw.refused == 1
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0x100, "pos": 10_000, "vel": 0x10000}])
    host.rtc("NURBS", {"feed": 4.0, "rate": 3.0, "first": 0.0, "last": 3.0, "npts": 6.0})
    assert host.u8(Dpr.DSPSTAT1) & DspStat1.CONFLICT and host.u8(Dpr.INTAXIS_CONFLICT) == 1


def test_a_nurbs_circle_on_the_card_keeps_its_radius_and_closes() -> None:
    """A circle of radius 1000 (four rational quarter arcs raised to degree 3: 13 control
    points, 17 knots) through the DPR rings: axes 1 and 2 stay on it (within a chord's sagitta
    and the counts' rounding) and close it after ~2 pi 1000 / FeedRate samples [Ch9]."""
    from tests.devices.octavia.test_nurbs import circle

    ctrl, weights, knots = circle(1000.0)
    host = Host(plant="ideal")
    host.rtc("POS_PRESET", {"n": 0x01}, [{"pset": 1000}])  # start on the circle
    fill(host, ctrl, weights, knots)
    host.rtc("NURBS", {"feed": 2.0, "rate": 2.0, "first": 0.0, "last": 4.0, "npts": 13.0})
    radii, samples = [], 0
    while host.card.fw.mode[0] == 4 and samples < 10_000:
        host.run(1)
        samples += 1
        pos = host.card.fw.core.axes.cmd_pos[:2]
        radii.append(float(np.hypot(*pos)))
    assert abs(samples - 2 * np.pi * 1000 / 2.0) < 25
    assert max(radii) <= 1000.0 + 0.01 and min(radii) >= 1000.0 - 20.0**2 / 8000 - 0.01
    host.run(2)
    assert [host.position(1), host.position(2)] == [1000, 0]
