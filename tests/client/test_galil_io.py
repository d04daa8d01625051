"""PF/VF, CO, OC and AF through gclib's GCommand on a lockstep daemon with one DMC-13X8 card
[M Ch1 §General I/O, §Encoder; M Ch3 §TTL Outputs; M Ch5 §Interrogation Commands]."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import gclib

from tests.client.galil import GALIL, card, rack_config
from vdevd.testing import DaemonThread


@pytest.fixture
def daemon() -> Iterator[DaemonThread]:
    with DaemonThread(rack_config(card(GALIL, "galil0", plant="ideal"))) as d:
        yield d


@pytest.fixture
def g(daemon: DaemonThread) -> Iterator[gclib.py]:
    conn = gclib.py()
    conn.GOpen(f"galil0 --endpoint {daemon.endpoint}")
    yield conn
    conn.GClose()


def test_pf_and_vf_change_what_gcommand_returns(g: gclib.py) -> None:
    g.GCommand("DP 21;PF -4;VF 2.2;V1=10")
    assert g.GCommand("TPX") == "$0015"
    assert g.GCommand("V1=") == "10.00"
    with pytest.raises(gclib.GclibError):
        g.GCommand("PF 11")
    assert g.GCommand("TC") == "006"
    g.GCommand("RS")
    assert g.GCommand("PF ?") == "10"


def test_extended_outputs_and_driven_extended_inputs(g: gclib.py, rack: vdevclient.Rack) -> None:
    g.GCommand("CO 1;SB 17")
    assert g.GCommand("TI 2") == "001"
    rack.control("galil0", "set_input", line=30, level=0)
    assert g.GCommand("MG @IN[30],@IN[31]") == "0000000000.0000 0000000001.0000"
    with pytest.raises(gclib.GclibError):
        g.GCommand("SB 30")  # bank 3 is inputs
    assert g.GCommand("TC1") == "6 Number out of range"


def test_output_compare_pulses_publish_events_on_the_cmp_line(g: gclib.py,
                                                              rack: vdevclient.Rack) -> None:
    irq = rack.card("galil0").irq
    g.GCommand("OCX=1000,500;AC 67107840;SP 100000;PR 2100;BGX")
    seen = []
    while (event := irq.wait(1.0, line="cmp")) is not None:
        seen.append(event["status"])
        if event["status"] >= 3:
            break
    assert seen == [1, 2, 3]  # at 1000, 1500, 2000: one sample each at 100 counts a sample
    g.GMotionComplete("X")
    assert g.GCommand("TPX") == "0000002100"


def test_analog_feedback_reads_the_backdoor_volts(g: gclib.py, rack: vdevclient.Rack) -> None:
    rack.control("galil0", "set_analog", channel=2, volts=-1.0)
    g.GCommand("AF ,1")
    assert g.GCommand("TPY") == "-0000000205"
    assert g.GCommand("AF ?,?") == "0,1"
