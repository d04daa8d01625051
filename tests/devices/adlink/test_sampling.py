"""The sampling unit in a kernel without a daemon [spec adlink.md §2.19, Q28]: the auto-sampling
ring overruns (a ring of 16 records stands for the card's 65536)."""

from __future__ import annotations

from vdevmaps.adlink import BAR_SIZE, SampState

from vdevd.devices.adlink import sampling
from vdevd.devices.adlink.kernel import Kernel


def _kernel(size: int) -> Kernel:
    k = Kernel(bytearray(BAR_SIZE), 8, 0x208, 15, 1000, "ideal", lambda: None)
    unit = sampling.Sampling(k, size)
    k.units[k.units.index(k.sampling)] = k.sampling = unit
    return k


def test_auto_sampling_keeps_the_newest_records_and_reports_the_loss_once() -> None:
    k = _kernel(16)
    sampling.auto_sampling(k, 1)
    for _ in range(20):
        k.cycle()
    status, words = sampling.take_sampling(k, 100, 4)
    assert status & SampState.LOST and status & SampState.AUTO
    ticks = words[::5]
    assert ticks == list(range(5, 21))  # cycles 1-4 overwritten
    k.cycle()
    status, words = sampling.take_sampling(k, 100, 4)
    assert status == SampState.AUTO and words[::5] == [21]


def test_a_capture_holds_its_pre_trigger_records_in_a_small_ring() -> None:
    """Pre-trigger records wait in the ring while the trigger does not come."""
    k = _kernel(16)
    sampling.set_sampling_param(k, 0x3, 1)  # level 1: COM_POS of axis 0 reaching 1
    sampling.start_trigger_sampling(k, 8, 3)
    for _ in range(40):
        k.cycle()
    assert k.sampling.head - k.sampling.tail == 3
    k.core.axes.cmd_pos[0] = 5.0
    for _ in range(5):
        k.cycle()
    assert k.sampling.state & SampState.DONE
    (words,) = sampling.read_sampling(k, 0, 8, 4)
    assert words[1::5] == [0, 0, 0, 5, 5, 5, 5, 5]
    assert words[::5] == list(range(38, 46))
