"""The MAXk's PCI configuration header [S §3.2 "PCI interface"; spec oms.md §2.1] through the
client, and `vdevctl lspci`."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import maxk
from vdevclient.cli import main as vdevctl
from vdevmaps import pci

from tests.client.galil import card, rack_config
from vdevd.testing import DaemonThread


@pytest.fixture
def board3() -> Iterator[tuple[vdevclient.Rack, maxk.Maxk]]:
    """A MAXk whose J5 jumpers say board 3."""
    with DaemonThread(rack_config(card("oms-maxk", "maxk0", board=3, axes=4))) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack, \
            maxk.open(3, endpoint=d.endpoint) as m:
        yield rack, m


def test_the_header_names_the_bridge_and_oms_with_the_board_number(
        board3: tuple[vdevclient.Rack, maxk.Maxk]) -> None:
    """"0x000: The Device ID and Vendor ID. (0006 1057)", "0x02C: ... Subsystem ID and
    Subsystem Vendor ID. (0010 + NNNN 160C)" with NNNN the board number [S §3.2]."""
    config = board3[0].card("maxk0").region("config")
    assert config.read32(pci.VENDOR_ID) == 0x0006_1057
    assert config.read32(pci.SUBSYSTEM_VENDOR_ID) == 0x0013_160C  # 0x0010 + board 3
    assert config.read32(pci.REVISION_ID) == 0x0B20_0000  # class 0B2000 (README), revision 00
    assert config.read8(pci.HEADER_TYPE) == 0
    assert config.read8(pci.INTERRUPT_PIN) == 1  # INTA#


@pytest.mark.parametrize(("bar", "size"), [(0, 0), (1, 0), (2, 0x10000), (3, 0), (4, 0x1000),
                                           (5, 0)])
def test_bar2_is_the_shared_memory_and_bar4_the_message_unit(
        board3: tuple[vdevclient.Rack, maxk.Maxk], bar: int, size: int) -> None:
    """"0x018: The base address of the controller's dual port RAM" (64 KiB), "0x020: ... memory
    mapped I/O registers" (the message unit, 4 KiB) [S §3.2, Table 3-1]; the other BARs are not
    implemented. All-ones written and read back gives the size, as a BIOS sizes a BAR."""
    config = board3[0].card("maxk0").region("config")
    offset = pci.BAR0 + 4 * bar
    base = config.read32(offset)
    config.write32(offset, 0xFFFFFFFF)
    if size:
        assert base and base % size == 0
        assert config.read32(offset) == (~(size - 1)) & 0xFFFFFFFF
    else:
        assert base == 0
        assert config.read32(offset) == 0


def test_status_bit_3_follows_inta(board3: tuple[vdevclient.Rack, maxk.Maxk]) -> None:
    """A done doorbell asserts INTA (spec §3.2); reading and clearing the flags drops it."""
    rack, m = board3
    config = rack.card("maxk0").region("config")
    assert not config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    m.send_string("AX MR100 GO ID")
    rack.sim.step(seconds=0.5)
    assert config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    assert m.get_status_flags() == maxk.StatusFlags(done=1)
    assert not config.read16(pci.STATUS) & pci.STATUS_INTERRUPT


def test_vdevctl_lspci_lists_the_maxk(capsys: pytest.CaptureFixture[str]) -> None:
    with DaemonThread() as daemon:  # the embedded default rack
        assert vdevctl(["--endpoint", daemon.endpoint, "lspci"]) == 0
    assert "maxk0 0b20: 1057:0006 (rev 00)" in capsys.readouterr().out.splitlines()
