"""Pure pieces of the point tables (vdevd.devices.adlink.ptable): the embedded arc, the dwell plan
and the dwell rounding [M §4.9.6; spec adlink.md §2.21]."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vdevd.devices.adlink import path
from vdevd.devices.adlink.group import Group, Transition
from vdevd.devices.adlink.profile import plan_ptp, plan_stop
from vdevd.devices.adlink.ptable import DwellPlan, Embedded, dwell_time


@pytest.mark.parametrize("ms, cycle_us, seconds", [(10.0, 1000, 0.010), (10.4, 1000, 0.011),
                                                   (0.0, 1000, 0.0), (1.2, 500, 0.0015),
                                                   (3.0, 2000, 0.004)])
def test_dwell_time_is_rounded_up_to_whole_cycles(ms: float, cycle_us: int, seconds: float) -> None:
    assert dwell_time(ms, cycle_us) == pytest.approx(seconds)


def test_an_arc_on_columns_2_and_0_of_a_3_axis_table_leaves_column_1() -> None:
    start = np.array([10.0, 7.0, 0.0])
    arc = path.arc2_ca(start[[2, 0]], [0.0, 0.0], math.pi / 2)  # (0, 10) -> (-10, 0) in (x2, x0)
    e = Embedded(arc, (2, 0), start)
    assert e.dims == 3 and e.length == pytest.approx(5 * math.pi)
    assert np.allclose(e.start, start) and np.allclose(e.end, [0.0, 7.0, -10.0])
    assert np.allclose(e.at(np.array([0.0, e.length]))[:, 1], 7.0)
    assert e.tangent_at(0.0)[1] == 0.0 and np.linalg.norm(e.tangent_at(1.0)) == pytest.approx(1.0)
    moved = e.rebased([10.0, 3.0, 0.0])
    assert np.allclose(moved.end, [0.0, 3.0, -10.0])


def test_a_point_blended_after_a_dwell_starts_when_the_dwell_ends() -> None:
    g = Group((0, 1), plan_stop=plan_stop)
    here = np.zeros(2)
    dwell = lambda d, v: DwellPlan(0.25)  # noqa: E731
    move = lambda d, v: plan_ptp(d, 0.0, 10.0, 0.0, 100.0, 100.0, 0.0)  # noqa: E731
    assert g.submit(path.line(here, here), dwell, int(Transition.BUFFERED), 0.0, 0.0) == 0
    # a residual distance longer than the dwell's (zero) travel: still its end
    assert g.submit(path.line(here, [1.0, 0.0]), move, int(Transition.BLEND_RES_DIST), 5.0, 0.0) == 0
    assert np.allclose(g.positions(0.2499), 0.0)
    flags = g.flags(0.2499)
    assert flags.moving and not flags.accelerating and g.queued == 1
    assert g.flags(0.26).accelerating and g.queued == 0
