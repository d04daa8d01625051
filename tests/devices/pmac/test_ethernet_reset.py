"""Ethernet after a reset: `$$$` and `$$$***` over an Ethernet connection leave it answering in the
framing its client set (vdevd/devices/pmac/eth_framing.py; README "Ethernet after a reset") [spec
§3.2 GETRESPONSE "as a serial port would give it with I3=2", §3.3 item 2: dls-pmaclib sets I3/I6
once, at connect]."""

from __future__ import annotations

import socket
import struct

import pytest

from tests.devices.pmac.conftest import Pmac
from vdevd.devices.pmac.eth_framing import KeptFraming


@pytest.mark.parametrize("reset", ["$$$", "$$$***"])
def test_dls_pmaclib_goes_on_after_a_reset_on_the_same_connection(pmac: Pmac, reset: str) -> None:
    """dls-pmaccontrol's reset button: sendCommand("$$$") then further commands, no reconnect."""
    dls = pmac.dls()
    assert dls.sendCommand("P1=5") == ("\x06", True)
    assert dls.sendCommand(reset) == ("\x06", True)
    assert dls.sendCommand("I10") == ("3713707\r\x06", True)
    assert dls.sendCommand("P1") == ("0\r\x06", True)          # the reset happened (P1 not saved)
    assert dls.sendCommand("I3 I6") == ("1\r1\r\x06", True)    # the card's own I3/I6 are the reset's
    assert dls.sendCommand("XYZ") == ("\x07ERR003\r", True)
    assert dls.getPmacModelCode() == 603382
    assert dls.sendCommand("#1J=100") == ("\x06", True)
    pmac.step_ms(500)
    assert dls.sendCommand("#1P") == ("100\r\x06", True)


def test_every_open_connection_keeps_its_framing_and_new_ones_get_the_cards(pmac: Pmac) -> None:
    """An EPICS-style second client keeps working when another one resets the card (or the DPRAM
    does); a connection opened afterwards frames with the card's I3 (1 after the reset: LF)."""
    first, second = pmac.dls(), pmac.dls()
    assert first.sendCommand("$$$") == ("\x06", True)
    assert second.sendCommand("I10") == ("3713707\r\x06", True)
    assert pmac.dpram_lines("$$$***")[-1][1] == ""
    assert first.sendCommand("I10") == ("3713707\r\x06", True)
    assert second.sendCommand("I10") == ("3713707\r\x06", True)
    host, port = pmac.ethernet.removeprefix("tcp://").rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as raw:  # a new connection
        raw.sendall(struct.pack("8B", 0x40, 0xBF, 0, 0, 0, 0, 0, 3) + b"I10")
        assert raw.recv(2048) == b"\n"  # I3 = 1: the first piece ends at the leading LF (README)


def test_kept_framing_gives_way_to_a_new_i3_or_i6() -> None:
    kept = KeptFraming()
    assert kept.modes(2, 1) == (2, 1)       # a reply framed with I3 = 2, I6 = 1
    kept.reset(1, 1)                        # the card reset to I3 = 1, I6 = 1
    assert kept.modes(1, 1) == (2, 1)
    assert kept.modes(1, 1) == (2, 1)       # still kept on the next line
    assert kept.modes(3, 1) == (3, 1)       # the client wrote I3 = 3: that rules from now on
    assert kept.modes(1, 1) == (1, 1)
    assert kept.kept is None


def test_a_connection_that_never_replied_has_nothing_to_keep() -> None:
    kept = KeptFraming()
    kept.reset(1, 1)
    assert kept.modes(1, 1) == (1, 1)
