"""The axis world on the Turbo PMAC (README "Axis world", "Backdoor"): `[[card.axis]]` switches the
card finds by itself where the stage has them, through PComm as an application drives it; the
shared backdoor vocabulary with its deprecated names; the options; the PCI configuration header.

Sources: §x = spec pmac.md; SRM = Turbo SRM (Ixx23, Ixx26, I7mn2, I7mn3, Ixx24); [A Lnnn] = the
addendum; README = the card's README.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
import vdevclient
from vdevclient.cli import main as vdevctl
from vdevmaps import pci
from vdevmaps.pmac import (
    DPRAM_SIZE,
    HOST_SIZE,
    IR_MASK,
    IR_STATUS,
    PCI_DEVICE_ID,
    PCI_SUBSYSTEM_ID,
    PCI_SUBSYSTEM_VENDOR_ID,
    PCI_VENDOR_ID,
    HostIrq,
)

from tests.devices.pmac.conftest import Pmac, card_config, pmac_card
from tests.devices.pmac.test_acceptance import (
    AMP_ENABLED,
    FATAL_FE,
    HOME_COMPLETE,
    HOME_SEARCH,
    IN_POSITION,
    NEG_LIMIT,
    POS_LIMIT,
    STOPPED_ON_LIMIT,
    motor_words,
    pc,
    pmac_pcomm,
)
from vdevd.devices.base import CardContext
from vdevd.devices.pmac.card import PmacCard
from vdevd.testing import DaemonThread

AMP_FAULT = 1 << 3  # word 2 bit 3 [§2.6]
#: the +LIM at physical 5000 stops a 32 counts/ms jog at Ixx15 = 0.25 counts/ms^2: at most
#: 32^2 / (2 x 0.25) = 2048 counts past it, plus the cycle in which the switch was crossed
STOP_DISTANCE = 2048 + 32




@pytest.fixture
def world(request: pytest.FixtureRequest) -> Iterator[Pmac]:
    """A card (plant ideal) opened by PComm, with the `[[card.axis]]` tables the test gives as
    its (indirect) parameter."""
    with pmac_pcomm(axis=getattr(request, "param", [])) as host:
        yield host


def value(line: str) -> float:
    (reply,) = pc(line)
    return float(reply)


def encoder(motor: int) -> int:
    """The motor's 24-bit encoder counter X:b+1 (channel base $078000 + 8(n-1), §1.5), signed."""
    pc(f"M{motor}01->X:${0x078001 + 8 * (motor - 1):06X},0,24,S")
    return int(value(f"M{motor}01"))


def flag(motor: int, bit: int) -> int:
    """Bit `bit` of the motor's Servo IC flag register X:b+0 [§1.5 register table]."""
    pc(f"M{motor}90->X:${0x078000 + 8 * (motor - 1):06X},{bit}")
    return int(value(f"M{motor}90"))


# -- homing finds the configured switches [§2.7 "Homing"; SRM Ixx23, Ixx26, I7mn2, I7mn3] ---------
@pytest.mark.parametrize("world", [[{"home": [1000, 1200]}]], indirect=True, ids=["axis"])
def test_hm_finds_the_home_flag_and_ends_at_the_home_offset(world: Pmac) -> None:
    """SRM Ixx23/Ixx26 and I7mn2 = 2 (capture on the flag I7mn3 = 0 selects, HMFLn high): HM jogs
    at Ixx23 until the home switch (physical 1000-1200, config only), the counter is captured at
    the flag's edge and trigger + Ixx26/16 becomes motor position 0, where the motor ends with
    word 2 bit 10 (home complete) and bit 0 (in position) [§2.6]."""
    assert flag(1, 16) == 0
    pc("I7012=2 I7013=0 I123=32 I126=160 #1HM")  # home offset 160/16 = 10 counts
    world.step_ms(50)
    w1, w2 = motor_words(1)
    assert w1 & HOME_SEARCH and not w2 & HOME_COMPLETE
    world.step_ms(3000)
    w1, w2 = motor_words(1)
    assert not w1 & HOME_SEARCH
    assert w2 & (HOME_COMPLETE | IN_POSITION) == HOME_COMPLETE | IN_POSITION
    assert value("#1P") == 0
    assert encoder(1) == 1000 + 10  # the stage: the switch's edge plus the home offset
    assert flag(1, 16) == 1  # it rests inside the window: HMFL reads 1


@pytest.mark.parametrize("world", [[{"home": [1000, 1200]}]], indirect=True, ids=["axis"])
def test_a_negative_home_search_triggers_at_the_window_s_upper_edge(world: Pmac) -> None:
    """Ixx23 < 0 searches in the negative direction [SRM Ixx23]: coming from above, the flag
    rises at 1200; Ixx26 = -320 puts motor zero 20 counts below it."""
    pc("#1J=3000")
    world.step_ms(3000)
    assert encoder(1) == 3000
    pc("I7012=2 I123=-32 I126=-320 #1HM")
    world.step_ms(3000)
    assert motor_words(1)[1] & HOME_COMPLETE
    assert value("#1P") == 0
    assert encoder(1) == 1200 - 20


@pytest.mark.parametrize("world", [[{"index": {"period": 4000, "phase": 300}}]], indirect=True, ids=["axis"])
def test_hm_on_the_configured_index_pulse(world: Pmac) -> None:
    """I7mn2 = 1 (the default: capture on the index alone) [SRM I7mn2]: the first index pulse
    above 0 is at physical 300."""
    pc("I126=0 #1HM")
    world.step_ms(3000)
    assert motor_words(1)[1] & HOME_COMPLETE
    assert value("#1P") == 0
    assert encoder(1) == 300


@pytest.mark.parametrize("world", [[{"probe": [1500]}]], indirect=True, ids=["axis"])
def test_hm_on_the_user_flag_captures_at_the_probe(world: Pmac) -> None:
    """The world's probe positions drive USERn, the registration input a capture selects with
    I7mn3 = 3 [SRM I7mn3] (README "Backdoor")."""
    pc("I7012=2 I7013=3 I126=0 #1HM")
    world.step_ms(3000)
    assert motor_words(1)[1] & HOME_COMPLETE
    assert encoder(1) == 1500


# -- limits stop motion where the stage has them [§2.7 "Limits"; SRM Ixx24, Ixx15] -------------------
@pytest.mark.parametrize("world", [[{"limits": [-100000, 5000]}]], indirect=True, ids=["axis"])
@pytest.mark.parametrize("command", ["#1J+", "#1J=10000"])
def test_a_jog_into_the_configured_plus_limit_stops_there(world: Pmac, command: str) -> None:
    """§2.7 "Limits": the +LIM input (configured at physical 5000, no backdoor) stops motion
    toward it at Ixx15; `#1?` shows word 1 bit 21 (positive end limit set) and word 2 bit 11
    (stopped on position limit); a jog toward it does not move, one away does."""
    pc(command)
    world.step_ms(4000)
    w1, w2 = motor_words(1)
    assert w1 & POS_LIMIT and w2 & STOPPED_ON_LIMIT
    stopped = value("#1P")
    assert 5000 <= stopped <= 5000 + STOP_DISTANCE
    assert flag(1, 17) == 1  # PLIM reads 1 at the limit
    pc("#1J+")
    world.step_ms(200)
    assert value("#1P") == stopped
    pc("#1J-")
    world.step_ms(300)
    assert value("#1P") < stopped


@pytest.mark.parametrize("world", [[{"limits": [-2000, 100000]}]], indirect=True, ids=["axis"])
def test_a_jog_into_the_configured_minus_limit_sets_word_1_bit_22(world: Pmac) -> None:
    pc("#1J-")
    world.step_ms(4000)
    w1, w2 = motor_words(1)
    assert w1 & NEG_LIMIT and w2 & STOPPED_ON_LIMIT
    assert -2000 - STOP_DISTANCE <= value("#1P") <= -2000


@pytest.mark.parametrize("world", [[{"limits": [-100000, 20000], "home": [1000, 1200]}]],
                         indirect=True, ids=["axis"])
@pytest.mark.parametrize("zero", ["#1HMZ", "I7012=2 I126=0 #1HM"])
def test_the_limit_stays_physical_when_motor_zero_moves(world: Pmac, zero: str) -> None:
    """HMZ makes the present position motor 0, HM the home trigger + Ixx26 [§2.7]: the +LIM
    stays at physical 20000 (README "Axis world"), so it now trips at a smaller motor position
    (far enough that the move back to the home position after the trigger, which overshoots
    about 11000 counts with the factory S-curve Ixx21 stretched by Ixx19, does not reach it)."""
    if zero == "#1HMZ":
        pc("#1J=2000")
        world.step_ms(3000)
    pc(zero)
    world.step_ms(3000)
    origin = encoder(1)
    assert origin in (2000, 1000)
    assert value("#1P") == 0
    pc("#1J+")
    world.step_ms(8000)
    w1, w2 = motor_words(1)
    assert w1 & POS_LIMIT and w2 & STOPPED_ON_LIMIT
    stopped = value("#1P")
    assert 20000 - origin <= stopped <= 20000 - origin + STOP_DISTANCE
    assert encoder(1) == stopped + origin


# -- faults from the config and the backdoor ----------------------------------------------------------
@pytest.mark.parametrize("world", [[{}, {"amp_fault": True}, {"encoder_loss": True}]],
                         indirect=True, ids=["axis"])
def test_configured_faults_are_there_at_power_up(world: Pmac) -> None:
    """Motor 2's amplifier faults from power-up: FAULT (X:b+0 bit 15) reads 1 and its loop does
    not close; motor 3's encoder does not count, so its following error grows to the fatal limit
    Ixx11 [§2.7]."""
    assert flag(2, 15) == 1 and flag(1, 15) == 0
    pc("#2J/")
    world.step(2)
    assert not motor_words(2)[0] & AMP_ENABLED
    pc("I324=$400001 #3J+")  # Ixx24 bits 21-22 = 10: the fatal error kills motor 3 alone
    world.step_ms(1000)
    assert encoder(3) == 0
    assert motor_words(3)[1] & FATAL_FE


def test_high_true_fault_polarity_reads_1_on_the_fault_bit(world: Pmac) -> None:
    """Ixx24 bit 23 set (a 1 in the fault bit is a fault [A L1873]): FAULT (X:b+0 bit 15) reads 0
    until the amplifier faults, then 1, and the enabled motor gets word 2 bit 3."""
    pc("I124=$800001 #1J/")
    world.step(2)
    assert flag(1, 15) == 0
    world.control("set_amp_fault", axis=1)
    world.step(2)
    assert flag(1, 15) == 1
    assert motor_words(1)[1] & AMP_FAULT


def test_a_jammed_motor_stays_put_while_its_error_grows(world: Pmac) -> None:
    world.control("jam", axis=1)
    pc("#1J+")
    world.step_ms(1000)
    assert encoder(1) == 0
    assert motor_words(1)[1] & FATAL_FE
    world.control("jam", axis=1, active=False)
    pc("#1J/")
    world.step(2)
    pc("#1J=100")
    world.step_ms(1000)
    assert encoder(1) == 100


def test_set_estop_faults_every_amplifier(world: Pmac) -> None:
    """README "Backdoor": set_estop is every motor's amplifier-fault input (the stop chain cuts
    the amplifiers): enabled motors are killed with word 2 bit 3; released, they close again."""
    pc("#1J/ #2J/")
    world.step(2)
    world.control("set_estop", active=True)
    world.step(2)
    for motor in (1, 2):
        w1, w2 = motor_words(motor)
        assert not w1 & AMP_ENABLED and w2 & AMP_FAULT
        assert flag(motor, 15) == 1
    world.control("set_estop", active=False)
    pc("#1J/")
    world.step(2)
    assert motor_words(1)[0] & AMP_ENABLED


# -- the shared vocabulary, its deprecated names, its errors ------------------------------------------
def test_the_shared_vocabulary_drives_the_flags(world: Pmac) -> None:
    pc("#1J/")
    world.step(2)
    world.control("set_limit", axis=1, side="positive")
    world.control("set_home", axis=1)
    world.step(2)
    assert motor_words(1)[0] & POS_LIMIT
    assert (flag(1, 17), flag(1, 16)) == (1, 1)
    world.control("set_limit", axis=1, side="positive", active=False)
    world.control("set_limit", axis=1, side="negative")
    world.step(2)
    w1 = motor_words(1)[0]
    assert w1 & NEG_LIMIT and not w1 & POS_LIMIT


def test_set_home_window_moves_the_switch_a_home_search_finds(world: Pmac) -> None:
    world.control("set_home_window", axis=1, low=500, high=600)
    pc("I7012=2 I126=0 #1HM")
    world.step_ms(3000)
    assert motor_words(1)[1] & HOME_COMPLETE
    assert encoder(1) == 500


def test_the_deprecated_names_still_work(world: Pmac) -> None:
    """set_limits(motor, plus, minus) and motor= for axis= (README "Backdoor")."""
    info = next(c for c in world.rack.info["cards"] if c["name"] == "pmac0")
    assert info["deprecated"] == {"set_limits": "set_limit"}
    pc("#1J/")
    world.step(2)
    world.control("set_limits", motor=1, minus=True)
    world.step(2)
    assert motor_words(1)[0] & NEG_LIMIT
    world.control("set_limits", motor=1, minus=False)
    world.control("set_index", motor=1, period=4000)  # today's signature: period only
    pc("#1J=1000")
    world.step_ms(2000)
    pc("I126=0 #1HM")
    world.step_ms(3000)
    assert encoder(1) == 4000


@pytest.mark.parametrize(("action", "params", "named"), [
    ("set_limit", {"axis": 1, "sid": "positive"}, "sid"),
    ("set_limitz", {"axis": 1}, "set_limitz"),
    ("set_limit", {"axis": 1, "side": "up"}, "up"),
    ("set_home", {"axis": 9}, "no motor 9"),
    ("set_home", {"axis": 0}, "no motor 0"),
    ("set_input", {"line": 32, "level": True}, "line"),
])
def test_a_wrong_action_or_parameter_is_an_error_naming_it(world: Pmac, action: str,
                                                           params: dict[str, Any],
                                                           named: str) -> None:
    with pytest.raises(Exception, match=named):
        world.control(action, **params)


# -- options [README "Configuration"] ------------------------------------------------------------------
def test_a_legal_zero_card_id_is_kept() -> None:
    """cid = 0 is in the declared range 0-999999: CID answers 0, not the default 603382."""
    with pmac_card(cid=0) as host:
        assert host.dls().sendCommand("cid")[0] == "0\r\x06"


def test_too_many_axis_tables_is_a_configuration_error() -> None:
    with pytest.raises(ValueError, match="3 \\[\\[card.axis\\]\\] tables for 2 axes"):
        PmacCard("pmac0", {"motors": 2, "ethernet": "", "axis": [{}, {}, {}]},
                 CardContext(emit=lambda e: None))


# -- PCI configuration space [README "PCI configuration space"] ----------------------------------------
@pytest.fixture
def config(world: Pmac) -> vdevclient.Region:
    return world.card.region("config")


def test_the_header_names_the_card(config: vdevclient.Region) -> None:
    assert config.read16(pci.VENDOR_ID) == PCI_VENDOR_ID
    assert config.read16(pci.DEVICE_ID) == PCI_DEVICE_ID
    assert config.read32(pci.REVISION_ID) == 0x11800001
    assert config.read16(pci.SUBSYSTEM_VENDOR_ID) == PCI_SUBSYSTEM_VENDOR_ID
    assert config.read16(pci.SUBSYSTEM_ID) == PCI_SUBSYSTEM_ID
    assert config.read8(pci.HEADER_TYPE) == 0
    assert config.read8(pci.INTERRUPT_PIN) == 1  # INTA#


def test_the_bars_size_the_dpram_and_the_host_port(config: vdevclient.Region) -> None:
    dpram, host = config.read32(pci.BAR0), config.read32(pci.BAR0 + 4)
    assert dpram & 0xF == 0 and dpram % DPRAM_SIZE == 0  # 32-bit memory, aligned
    assert host & 0x3 == 1  # I/O space
    config.write32(pci.BAR0, 0xFFFFFFFF)
    config.write32(pci.BAR0 + 4, 0xFFFFFFFF)
    assert config.read32(pci.BAR0) == (~(DPRAM_SIZE - 1)) & 0xFFFFFFFF  # 0xFFFFC000: 16 KiB
    assert config.read32(pci.BAR0 + 4) == ((~(HOST_SIZE - 1)) & 0xFFFFFFFC) | 1  # 16 bytes, I/O
    config.write32(pci.BAR0, dpram)
    assert config.read32(pci.BAR0) == dpram
    config.write32(pci.BAR0 + 8, 0xFFFFFFFF)  # BAR2 is not implemented
    assert config.read32(pci.BAR0 + 8) == 0


def test_status_bit_3_follows_the_interrupt_line(world: Pmac, config: vdevclient.Region) -> None:
    host = world.card.region("host")
    assert not config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    host.write8(IR_MASK, int(HostIrq.ASCII_READY))
    world.dpram_lines("I10")  # the response posted raises "ASCII response ready" on INTA
    assert config.read16(pci.STATUS) & pci.STATUS_INTERRUPT
    host.write8(IR_STATUS, 0xFF)  # the host acknowledges
    assert not config.read16(pci.STATUS) & pci.STATUS_INTERRUPT


def test_vdevctl_lspci_lists_the_pmac(capsys: pytest.CaptureFixture[str]) -> None:
    with DaemonThread(card_config()) as daemon:
        assert vdevctl(["--endpoint", daemon.endpoint, "lspci"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"pmac0 1180: {PCI_VENDOR_ID:04x}:{PCI_DEVICE_ID:04x} (rev 01)"]
