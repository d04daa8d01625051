"""A PLC downloaded through a real daemon (lockstep clock) with vdevclient.pcomm's
`PmacDownloadA` from a file of OPEN PLC / CLOSE lines, enabled and watched through `P1` reads
[spec pmac.md §2.9; README "PLCs"]."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from vdevclient import pcomm

from tests.devices.pmac.conftest import Pmac, pcomm_ask, pcomm_device

DEVICE = 0


@pytest.fixture
def host() -> Iterator[Pmac]:
    with pcomm_device(DEVICE, plant="ideal") as h:
        yield h


def ask(command: str) -> str:
    return pcomm_ask(DEVICE, command)


def test_downloaded_plc_counts_every_background_cycle(host: Pmac, tmp_path: Path) -> None:
    source = tmp_path / "count.pmc"
    source.write_text("#define COUNT P1\n"
                      "OPEN PLC 7 CLEAR\n"
                      "COUNT = COUNT + 1   ; one per scan\n"
                      "If (COUNT > 1000)\n"
                      "  COUNT = 0\n"
                      "EndIf\n"
                      "CLOSE\n")
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda text, nl: messages.append(text), None, None,
                               str(source)) == 1, messages
    assert ask("LIST PLC 7").split("\r") == ["P1 = P1 + 1", "IF (P1 > 1000)", "P1 = 0", "ENDIF"]
    period = pcomm.PmacGetVariable(DEVICE, "I", 8) + 1
    host.step(10 * period)
    assert pcomm.PmacGetVariable(DEVICE, "P", 1) == 0  # CLOSE leaves it disabled
    ask("ENABLE PLC 7")
    host.step(25 * period)
    assert pcomm.PmacGetVariable(DEVICE, "P", 1) == 25
    ask("DISABLE PLC 7")
    host.step(5 * period)
    assert pcomm.PmacGetVariable(DEVICE, "P", 1) == 25


def test_download_stops_at_a_statement_the_buffer_refuses(host: Pmac, tmp_path: Path) -> None:
    source = tmp_path / "bad.pmc"
    source.write_text("OPEN PLC 3 CLEAR\nP1=1\nFROB 3\nCLOSE\n")
    messages: list[str] = []
    assert pcomm.PmacDownloadA(DEVICE, lambda text, nl: messages.append(text), None, None,
                               str(source)) == 0
    assert any("ERR003" in m for m in messages)
