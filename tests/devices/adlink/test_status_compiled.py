"""The compiled status words and axis records (status.py `words_py`, `records_py`) write what
the kernel's numpy path writes, byte for byte, DIR included, through random moves, stops,
limits, gearing and unit factors, for both drives [M §4.8.1, §4.1.1.4; decision 0011]."""

from __future__ import annotations

import random

import numpy as np
import pytest
from vdevmaps.adlink import Bar

from tests.devices.adlink import test_adlink_runs as runs
from vdevd.devices.adlink.card import AdlinkCard
from vdevd.devices.adlink.kernel import Kernel
from vdevd.devices.adlink.status import compiled

pytestmark = pytest.mark.skipif(compiled() is None, reason="numba is not available")


def both_paths(k: Kernel) -> tuple[tuple[bytes, ...], tuple[bytes, ...]]:
    """The signals (`logic`), the bar's axis records, the words and DIR after `publish` on the
    numpy path, then on the compiled path, from the same state."""
    direction = k.direction.copy()
    out = []
    for jit in (None, compiled()):
        k.direction = direction.copy()
        k._jit = jit
        k.logic()
        k.publish()
        out.append((bytes(k.buf[Bar.AXIS:Bar.AXIS_END]), k.msts.tobytes(), k.mio.tobytes(),
                    k.axis_cond.tobytes(), k.direction.tobytes(),
                    *(row.tobytes() for row in (k.pel, k.mel, k.org, k.alm, k.ez, k.inp,
                                                k.spel, k.smel))))
    return out[0], out[1]


@pytest.mark.parametrize("drive", ["ideal", "servo"])
@pytest.mark.parametrize("seed", range(3))
def test_compiled_status_is_the_numpy_status(seed: int, drive: str) -> None:
    rng = random.Random(seed)
    twin = runs.Twin(drive=drive)
    card: AdlinkCard = twin.cards[0]
    runs.servo_on(twin)
    twin.send(runs.param(1, 0x86, 3.7))  # a unit factor: user units are not counts
    for a, no, value in ((3, 0x0A, 9_000.0), (3, 0x08, 1), (5, 0x0B, -4_000.0), (5, 0x09, 1),
                         (6, 0x01, 1), (7, 0x05, 1)):  # soft limits, ORG and INP logic
        twin.send(runs.param(a, no, value))
    twin.control("set_inp", {"axis": 4, "active": True})
    compared = 0
    for _ in range(60):
        if rng.random() < 0.7:
            twin.send(rng.choice(runs.COMMANDS))
        elif rng.random() < 0.5:
            twin.control(*rng.choice(runs.CONTROLS))
        twin.tick(rng.choice([1, 3, 40, 300]))
        a, phase = rng.randrange(8), rng.choice([0, 0, 1, 2, 3])
        for twin_card in twin.cards:  # a unit's phase, now and then
            twin_card.kernel.phase[a] = phase
        k = card.kernel
        numpy_path, compiled_path = both_paths(k)
        assert numpy_path == compiled_path
        compared += 1
    assert compared == 60


def test_counters_wrap_and_velocity_targets_alike() -> None:
    """Command counters past 2^31 wrap as I32 (spec Q20); a velocity move's target is its
    command position; a servo-off axis shows no feedback velocity."""
    twin = runs.Twin()
    k = twin.cards[0].kernel
    twin.post("set_servo_on", 2, 1)
    twin.send(runs.vel(2, -5_000))
    twin.tick(10)
    k.core.axes.cmd_pos[0] = 2.0**31 + 5.4
    k.core.axes.cmd_pos[1] = -(2.0**33) - 0.5
    k.core.axes.encoder[3] = 2**32 + 7
    k.core.axes.cmd_vel[5] = -123.0  # (state poked: a servo-off axis shows no feedback velocity)
    numpy_path, compiled_path = both_paths(k)
    assert numpy_path == compiled_path
    ints = np.frombuffer(numpy_path[0], dtype="<i4").reshape(8, -1)
    assert ints[0, 3] == -(2**31) + 5 and ints[3, 4] == 7
    floats = np.frombuffer(numpy_path[0], dtype="<f8").reshape(8, -1)
    assert floats[5, 8] == -123.0 and floats[5, 9] == 0.0  # CMD_VEL, FBK_VEL (0x40, 0x48)
