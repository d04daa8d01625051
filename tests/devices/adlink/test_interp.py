"""The interpolation unit on a bare kernel (no daemon) [M §4.7.3; spec adlink.md §2.13]: seeded
property checks of queued chains through every queued transition against the invariants of
STYLE §5 (end exact in counts, speed bound, MDN at the end, the buffer emptied)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from vdevmaps.adlink import BAR_SIZE
from vdevmaps.aps_defs import (
    ITP_OPT_BLEND_DEC_EVENT,
    ITP_OPT_BLEND_RES_DIST,
    ITP_OPT_BLEND_RES_DIST_PERCENT,
    ITP_OPT_BUFFERED,
)

from vdevd.devices.adlink import cmd_interp
from vdevd.devices.adlink.kernel import Kernel

VM, ACC = 2000.0, 40000.0
PROFILE = (0.0, VM, 0.0, ACC, ACC, 0.0)
QUEUED = (ITP_OPT_BUFFERED, ITP_OPT_BLEND_DEC_EVENT, ITP_OPT_BLEND_RES_DIST,
          ITP_OPT_BLEND_RES_DIST_PERCENT)


def kernel() -> Kernel:
    k = Kernel(bytearray(BAR_SIZE), 8, 0x208, 0, 1000, "ideal", lambda: None)
    k.servo(np.arange(8), True)
    return k


coords = st.integers(-500, 500).map(float)
steps = st.lists(st.tuples(coords, coords, st.sampled_from(QUEUED), st.floats(0, 100)),
                 min_size=1, max_size=5)


@settings(max_examples=15, deadline=None, derandomize=True)
@given(steps)
def test_queued_chains_end_exactly_within_the_speed_bound(
        chain: list[tuple[float, float, int, float]]) -> None:
    k = kernel()
    for x, y, option, para in chain:
        cmd_interp.line(k, 2, [0, 1], option, [x, y], para, *PROFILE)
    end = np.array(chain[-1][:2])
    last = k.core.axes.cmd_pos[:2].copy()
    for _ in range(20000):
        k.cycle()
        now = k.core.axes.cmd_pos[:2].copy()
        # superposed blends add two path speeds at most [spec §2.13 ASSUMPTION]
        assert math.hypot(*(now - last)) <= 2 * VM * k.dt * (1 + 1e-9)
        last = now
        if not k.unit_moving[:2].any():
            break
    np.testing.assert_array_equal(k.core.axes.cmd_pos[:2], end)
    assert k.mdn[:2].all() and not k.owned[:2].any() and not k.bld[:2].any()
    assert (k.mq_usage[:2] == 0).all() and not any(u.busy() for u in k.units)


def test_axes_of_different_unit_factors_share_one_path_in_user_units() -> None:
    """The path is in user units; each axis turns it into its own pulses [M §4.2.2, §4.7]."""
    k = kernel()
    k.axis_params.row(0x86)[1] = 10.0  # axis 1: 10 pulses per unit
    cmd_interp.line(k, 2, [0, 1], 0, [300.0, 400.0], 0.0, *PROFILE)
    for _ in range(100):
        k.cycle()
    np.testing.assert_allclose(k.core.axes.cmd_vel[:2], [0.6 * VM, 8.0 * VM], rtol=1e-9)
    while k.unit_moving[:2].any():
        k.cycle()
    np.testing.assert_array_equal(k.core.axes.cmd_pos[:2], [300.0, 4000.0])
    np.testing.assert_allclose(k.user_cmd()[:2], [300.0, 400.0])


timed = st.lists(st.tuples(st.integers(0, 300), coords, coords, st.integers(0, 6),
                           st.floats(0, 100)), min_size=1, max_size=5)


@settings(max_examples=12, deadline=None, derandomize=True)
@given(timed)
def test_commands_at_any_time_with_any_transition_end_at_the_last_commands_end(
        commands: list[tuple[int, float, float, int, float]]) -> None:
    """Aborting transitions (0-2) issued while moving, queued ones (3-6) behind: the group
    ends where the last accepted command ends, continuously, at MDN."""
    k = kernel()
    last = k.core.axes.cmd_pos[:2].copy()
    end = last.copy()
    for wait, x, y, transition, para in commands:
        for _ in range(wait):
            k.cycle()
            now = k.core.axes.cmd_pos[:2].copy()
            assert math.hypot(*(now - last)) <= 2 * VM * k.dt * (1 + 1e-9)
            last = now
        cmd_interp.line(k, 2, [0, 1], transition << 12, [x, y], para, *PROFILE)
        end = np.array([x, y])
    for _ in range(20000):
        k.cycle()
        now = k.core.axes.cmd_pos[:2].copy()
        assert math.hypot(*(now - last)) <= 2 * VM * k.dt * (1 + 1e-9)
        last = now
        if not k.unit_moving[:2].any():
            break
    np.testing.assert_allclose(k.core.axes.cmd_pos[:2], end, atol=1e-6)
    assert k.mdn[:2].all() and not k.owned[:2].any()
