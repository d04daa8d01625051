"""The Octavia's compiled publish (vdevd.devices.octavia.pubkernel) against its numpy path: the
same card state published both ways leaves the same DPR, byte for byte (decision 0011's
pattern): moving axes, counts beyond 2^31 (the int32 words wrap), the host holding a window."""

from __future__ import annotations

import numpy as np
import pytest
from vdevmaps.octavia import Dpr

from tests.devices.octavia.host import Host
from vdevd.devices.octavia import pubkernel
from vdevd.rt import kernel


def vel_to_raw(vel: float) -> int:
    """Counts/sample as VELMODE's 16.16 word."""
    return round(vel * 65536)


def both(host: Host) -> tuple[bytes, bytes, np.ndarray, np.ndarray]:
    """The DPR and the rows after a compiled publish, then after a numpy one, from one state."""
    fw = host.card.fw
    assert fw._pub_kernel is not None
    before = bytes(fw.buf)
    fw.publish()
    fast, fast_rows = bytes(fw.buf), fw._published.copy()
    fw.buf[:] = before
    fw._published[:] = 0
    kept, fw._pub_kernel = fw._pub_kernel, None
    try:
        fw.publish()
    finally:
        fw._pub_kernel = kept
    return fast, bytes(fw.buf), fast_rows, fw._published.copy()


@pytest.fixture
def host() -> Host:
    if kernel.jit_disabled():
        pytest.skip("VDEVD_JIT=0: the numpy path only")
    assert pubkernel.compiled() is not None, "numba is a dependency: publish must compile"
    return Host(plant="servo")


def test_moving_axes_publish_the_same_bytes(host: Host) -> None:
    host.rtc("CTRL", {"n": 0xFF}, [{"ki": 100, "kp": 4000, "kf": 3000, "kd": 2500}] * 8)
    host.rtc("MAXACC", {"n": 0xFF}, [{"acc": 0x200}] * 8)
    host.rtc("VELMODE", {"n": 0xFF}, [{"vel": vel_to_raw((a - 3.5) * 7.3)} for a in range(8)])
    for _ in range(40):
        host.run(7)
        fast, ref, fast_rows, ref_rows = both(host)
        assert fast == ref
        assert (fast_rows == ref_rows).all()
    assert (host.card.fw._published[1] != 0).all()


def test_counts_beyond_2_31_wrap_as_int32_words(host: Host) -> None:
    ax = host.card.fw.core.axes
    ax.encoder[:] = [2**31 + 5, -(2**31) - 7, 2**40 + 3, -1, 0, 2**32 - 1, 123456789, -987654321]
    ax.vel[:] = np.linspace(-3e7, 3e7, 8) + 0.5
    ax.ferr[:] = [2.5, -2.5, 3.5, 2**33 + 0.5, -0.49999999999999994, 1e9, -1e9, 0.5]
    fast, ref, fast_rows, ref_rows = both(host)
    assert fast == ref
    assert (fast_rows == ref_rows).all()


def test_a_held_window_is_left_alone_both_ways(host: Host) -> None:
    host.rtc("VELMODE", {"n": 0x01}, [{"vel": vel_to_raw(3.0)}])
    host.run(20)
    host.write(Dpr.HOSTACC_ACTVEL, b"\x01")  # the host holds ACTVEL
    host.card.fw.core.axes.encoder[0] += 1000
    fast, ref, _, _ = both(host)
    assert fast == ref
