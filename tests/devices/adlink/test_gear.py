"""The gear unit on the kernel alone [M §4.9.1; spec §2.15]: the slave commanded in the same
cycle as its master, every cycle, across the phase boundaries of the master's profile."""

from __future__ import annotations

import numpy as np
import pytest
from vdevmaps.adlink import BAR_SIZE
from vdevmaps.aps_defs import (
    GEAR_GANTRY,
    GEAR_STANDARD,
    OPT_RELATIVE,
    PRA_GEAR_MASTER,
    PRA_GEAR_RATIO,
    PRA_POS_UNIT_FACTOR,
)

from vdevd.devices.adlink import gear, motion
from vdevd.devices.adlink.cmd_system import set_axis_param_f
from vdevd.devices.adlink.kernel import Kernel

NAN = float("nan")


def kernel() -> Kernel:
    k = Kernel(bytearray(BAR_SIZE), 4, 0x204, 0, 1000, "ideal", lambda: None)
    k.servo(np.arange(4), True)
    return k


@pytest.mark.parametrize("sf", [0.0, 0.5, 1.0])
def test_gantry_slave_matches_the_master_every_cycle(sf: float) -> None:
    k = kernel()
    set_axis_param_f(k, 1, PRA_GEAR_MASTER, 0)
    gear.start_gear(k, 1, GEAR_GANTRY)
    motion.ptp(k, 0, OPT_RELATIVE, 1234.5, NAN, 20000.0, NAN, 4e5, 3e5, sf)
    worst = 0.0
    for _ in range(200):
        k.cycle()
        cmd, fbk = k.user_cmd(), k.user_fbk()
        worst = max(worst, abs(cmd[1] - cmd[0]))
        assert abs(fbk[1] - fbk[0]) <= 1.0  # the same tick (the encoder floors the counts)
    assert worst < 1e-6
    assert k.user_cmd()[1] == pytest.approx(1234.5)


def test_ratio_with_unit_factors_and_a_queued_chain() -> None:
    """Δslave = r × Δmaster, user units of each axis; buffered segments hand over mid-tick."""
    k = kernel()
    set_axis_param_f(k, 0, PRA_POS_UNIT_FACTOR, 4.0)
    set_axis_param_f(k, 1, PRA_POS_UNIT_FACTOR, 10.0)
    set_axis_param_f(k, 1, PRA_GEAR_MASTER, 0)
    set_axis_param_f(k, 1, PRA_GEAR_RATIO, -0.5)
    gear.start_gear(k, 1, GEAR_STANDARD)
    motion.ptp(k, 0, OPT_RELATIVE, 100.0, NAN, 1000.0, 300.0, NAN, NAN, NAN)
    motion.ptp(k, 0, OPT_RELATIVE | 0x1000, 50.0, NAN, 600.0, NAN, NAN, NAN, NAN)
    for _ in range(400):
        k.cycle()
        cmd = k.user_cmd()
        assert cmd[1] == pytest.approx(-0.5 * cmd[0], abs=1e-6)
    assert k.user_cmd()[0] == pytest.approx(150.0)
    assert k.user_cmd()[1] == pytest.approx(-75.0)
