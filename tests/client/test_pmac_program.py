"""A motion program through a real daemon (lockstep clock): downloaded with vdevclient.pcomm's
`PmacDownloadA`, run with `&1B10R`, watched with `#nP` and `&1??` while the test steps the
clock; a buffer another port (dls-pmaclib over Ethernet) leaves open refuses the run [spec
pmac.md §2.8, §3.1, §3.3; Turbo UM "Linear Blended Moves"; README "Motion programs"]."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import PERIOD_NS, Pmac, pcomm_ask, pcomm_device

DEVICE = 0
DT = PERIOD_NS / 1e9

RASTER = """\
#define ROW      P1
#define ROWS     P2
#define WIDTH    P3
#define PITCH    P4
OPEN PROG 10 CLEAR
LINEAR ABS TA100 TS20 F50      ; 50 units/s, 100 ms blends
ROW = 0
WHILE (ROW < ROWS)
  IF (ROW % 2 = 0)
    X(WIDTH)
  ELSE
    X0
  ENDIF
  Y((ROW + 1) * PITCH)
  ROW = ROW + 1
ENDWHILE
CLOSE
"""


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str) -> str:
    return pcomm_ask(DEVICE, command)


def position(motor: int) -> float:
    return float(ask(f"#{motor}P"))


def running() -> bool:
    return bool(int(ask("&1??")[:6], 16) & 1)


def download(tmp_path: Path, text: str) -> list[str]:
    source = tmp_path / "prog.pmc"
    source.write_text(text)
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda t, nl: messages.append(t), None, None,
                               str(source)) == 1, messages
    return messages


def setup_axes() -> None:
    ask("&1#1->1000X &1#2->1000Y #1J/#2J/ I116=1000 I216=1000 I117=100 I217=100")


def test_raster_scan_runs_through_the_daemon_to_its_end(host: Pmac, tmp_path: Path) -> None:
    """Three rows of 10 units: row k passes its middle (X 5000 counts) at 0.05 + 0.3k + 0.1 s,
    on row Y = k; the scan ends at 0.9 + 0.1 s on X 10000, Y 3000."""
    setup_axes()
    download(tmp_path, RASTER)
    assert ask("LIST PROG 10").split("\r")[0] == "LINEAR ABS TA100 TS20 F50"
    ask("P2=3 P3=10 P4=1")
    ask("&1B10R")
    t = 0.0
    for k in range(3):
        t_mid = 0.05 + 0.3 * k + 0.1
        ticks = round((t_mid - t) / DT)
        host.step(ticks)
        t += ticks * DT
        assert position(1) == pytest.approx(5000.0, abs=50 * DT * 1000 * 2)  # ± 2 cycles at F50
        assert position(2) == pytest.approx(1000.0 * k)
        assert running()
    host.step(round((1.0 - t) / DT) + 5)
    assert not running()
    assert (position(1), position(2)) == (10000.0, 3000.0)
    assert float(ask("P1")) == 3


def test_bad_input_gets_the_cards_errors_and_the_card_keeps_serving(host: Pmac,
                                                                      tmp_path: Path) -> None:
    setup_axes()
    assert ask("&1B77R") == "\x07ERR015"                       # no such program
    source = tmp_path / "bad.pmc"
    source.write_text("OPEN PROG 3 CLEAR\nX1\nFROB 3\nCLOSE\n")
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda t, nl: messages.append(t), None, None,
                               str(source)) == 0
    assert any("ERR003" in m for m in messages)
    assert ask("CLOSE LIST PROG 3") == "X1"                    # the refused line is not stored
    other = host.dls()                                         # another port opens a buffer
    other.sendCommand("OPEN PROG 4")
    assert ask("&1B3R") == "\x07ERR015"                        # a buffer left open
    other.sendCommand("CLOSE")
    ask("#1K")
    assert ask("&1B3R") == "\x07ERR012"                        # a motor open loop
    assert ask("#1J/ &1B3R") == ""
    host.step(round(0.3 / DT))
    assert not running()
    assert position(1) == 1000.0
