"""Q and `/` on a PVT scan through a real daemon (lockstep clock): downloaded with
vdevclient.pcomm's `PmacDownloadA`, run with `&1B7R`, stopped on a moving point, watched with
`#1P` while the test steps the clock [Turbo SRM Q, `/`, PVT, Ixx15; README "Calculation and
look-ahead", Move modes "Assumptions" (the PVT stop)]."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_ask, pcomm_device

DEVICE = 0
DT = PERIOD_NS / 1e9
#: PVT100: one unit (1000 counts) a segment at 10 units/s, the last point at rest
SCAN = "OPEN PROG 7 CLEAR\nABS PVT100\n" + "".join(f"X{k}:10\n" for k in range(1, 10)) \
    + "X10:0\nCLOSE\n"


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str) -> str:
    return pcomm_ask(DEVICE, command)


def running() -> bool:
    return bool(int(ask("&1??")[:6], 16) & 1)


def download(tmp_path: Path) -> None:
    source = tmp_path / "scan.pmc"
    source.write_text(SCAN)
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda t, nl: messages.append(t), None, None,
                               str(source)) == 1, messages


def watch(host: Pmac, seconds: float, every: int = 4) -> np.ndarray:
    """#1P (counts) every `every` servo cycles for `seconds`."""
    out = []
    for _ in range(round(seconds / DT / every)):
        host.step(every)
        out.append(float(ask("#1P")))
    return np.array(out)


@pytest.mark.parametrize(("command", "end"), [("Q", 5500.0), ("/", 4500.0)])
def test_stop_on_a_moving_pvt_point_decelerates_over_the_segment_time(
        host: Pmac, tmp_path: Path, command: str, end: float) -> None:
    """At 0.35 s segment 4 executes and segment 5 is calculated: Q runs both and stops v·T/2 =
    500 counts past X5, `/` stops 500 counts past X4; the velocity falls at 10 counts/ms over
    100 ms (0.1 counts/ms²), never in one step; R then runs the scan to X10."""
    ask("&1#1->1000X #1J/")
    download(tmp_path)
    ask("&1B7R")
    host.step(round(0.35 / DT))
    ask("&1" + command)
    trace = watch(host, 0.4)
    assert not running()
    assert trace[-1] == end
    dt = 4 * DT
    dv = np.abs(np.diff(np.diff(trace))) / dt / dt          # counts/s²
    assert dv.max() <= 0.1e6 * 1.1 + 2.0 / dt / dt           # 0.1 counts/ms² (± a count)
    ask("&1R")
    host.step(round(1.5 / DT))
    assert not running() and float(ask("#1P")) == 10000.0
