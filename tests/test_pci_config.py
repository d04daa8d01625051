"""PCI configuration space (vdevd/pci.py; PCI Local Bus Specification 2.3 §6.1-6.2) on the
generic card, through the client, and `vdevctl lspci`."""

from __future__ import annotations

import pytest
import vdevclient
from vdevclient.cli import main as vdevctl
from vdevmaps import pci

from tests.devices.generic.test_inputs import command
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import Command
from vdevd.testing import DaemonThread


@pytest.fixture
def config(rack: vdevclient.Rack) -> vdevclient.Region:
    return rack.card("servo0").region("config")


def test_the_header_names_the_card(config: vdevclient.Region) -> None:
    assert config.read16(pci.VENDOR_ID) == 0x1234
    assert config.read16(pci.DEVICE_ID) == 0x5644
    assert config.read32(pci.REVISION_ID) == 0x11800001  # class 11 80 00, revision 01
    assert config.read8(pci.HEADER_TYPE) == 0
    assert config.read16(pci.SUBSYSTEM_VENDOR_ID) == 0x1234
    assert config.read16(pci.SUBSYSTEM_ID) == 0x0001
    assert config.read8(pci.INTERRUPT_PIN) == 1  # INTA#
    assert config.read(0, 4) == bytes([0x34, 0x12, 0x44, 0x56])  # little-endian, as on PCI


def test_a_bar_written_all_ones_reads_back_its_size(config: vdevclient.Region) -> None:
    base = config.read32(pci.BAR0)
    assert base & 0xFFF == 0 and base != 0  # a 4 KiB memory BAR at an aligned address
    config.write32(pci.BAR0, 0xFFFFFFFF)
    assert config.read32(pci.BAR0) == 0xFFFFF000  # ~(4096 - 1): 32-bit, not prefetchable
    config.write32(pci.BAR0, base)
    assert config.read32(pci.BAR0) == base
    config.write32(pci.BAR0 + 4, 0xFFFFFFFF)  # BAR1 is not implemented
    assert config.read32(pci.BAR0 + 4) == 0


def test_only_the_writable_fields_change(config: vdevclient.Region) -> None:
    config.write16(pci.COMMAND, 0xFFFF)
    assert config.read16(pci.COMMAND) == 0x0547  # I/O, memory, master, parity, SERR, INTx off
    config.write32(pci.VENDOR_ID, 0)
    assert config.read16(pci.VENDOR_ID) == 0x1234
    config.write8(pci.INTERRUPT_LINE, 11)
    config.write8(pci.INTERRUPT_PIN, 4)
    assert (config.read8(pci.INTERRUPT_LINE), config.read8(pci.INTERRUPT_PIN)) == (11, 1)


def test_status_bit_3_follows_the_interrupt_line(rack: vdevclient.Rack,
                                                 config: vdevclient.Region) -> None:
    bar = rack.card("servo0").region("bar0")
    assert not config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    bar.write32(R.IRQ_ENABLE, 1)
    assert command(bar, 0, Command.MOVE_REL, target=100) == 0
    rack.sim.step(seconds=0.5)  # the move ends: axis 0 done asserts INTA
    assert config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    assert config.read32(pci.COMMAND) >> 16 & pci.STATUS_INTERRUPT  # in a dword read too
    bar.write32(R.IRQ_STATUS, 1)  # the host acknowledges
    assert not config.read16(pci.STATUS) & pci.STATUS_INTERRUPT


def test_vdevctl_lspci_lists_every_pci_card(capsys: pytest.CaptureFixture[str]) -> None:
    with DaemonThread() as daemon:  # the embedded default rack
        assert vdevctl(["--endpoint", daemon.endpoint, "lspci"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "servo0 1180: 1234:5644 (rev 01)"
    assert not any(line.startswith("galil0") for line in lines)  # VME: no configuration space


def test_interrupt_disable_keeps_inta_from_the_host_until_cleared(
        rack: vdevclient.Rack, config: vdevclient.Region) -> None:
    """PCI 2.3 §6.2.2: command bit 10 set, the card's assertion reaches no one (no event, no
    wait woken) while status bit 3 shows it; cleared with the line still asserted, the host
    sees one assertion."""
    card = rack.card("servo0")
    bar = card.region("bar0")
    assert config.read16(pci.COMMAND) & pci.COMMAND_INTX_DISABLE == 0  # 0 after RST#
    config.write16(pci.COMMAND, pci.COMMAND_MEMORY | pci.COMMAND_INTX_DISABLE)
    bar.write32(R.IRQ_ENABLE, 1)
    assert command(bar, 0, Command.MOVE_REL, target=100) == 0
    assert card.irq.wait(timeout_s=0.5) is None  # the move ends inside these 0.5 s
    assert config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    stats = rack.stats()
    assert stats["events_published"] == 0 and stats["cards"]["servo0"]["irq_seq"] == 0
    now = rack.sim.now_ns()
    config.write16(pci.COMMAND, pci.COMMAND_MEMORY)
    fired = rack.request("wait", card="servo0", on="irq", after_seq=0, timeout_ns=0)
    assert fired["fired"] and fired["event"]["sim_time_ns"] == now
    assert fired["event"]["status"] == 1 and rack.stats()["events_published"] == 1
    config.write16(pci.COMMAND, pci.COMMAND_MEMORY | pci.COMMAND_INTX_DISABLE)
    config.write16(pci.COMMAND, pci.COMMAND_MEMORY)
    assert rack.stats()["events_published"] == 2  # each unmasking of an asserted line
    bar.write32(R.IRQ_STATUS, 1)  # acknowledged: nothing left to deliver
    config.write16(pci.COMMAND, pci.COMMAND_MEMORY | pci.COMMAND_INTX_DISABLE)
    config.write16(pci.COMMAND, pci.COMMAND_MEMORY)
    assert rack.stats()["events_published"] == 2
