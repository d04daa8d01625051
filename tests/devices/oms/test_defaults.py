"""Parameters: the factory set, ranges, user units; the power-up defaults APP stores in flash and
RDF/RDP restore; the firmware state word [S §2.13-2.14, Table 3-4; spec oms.md §1.4, §2.3, §4.3,
§4.4, §6.2].

Flash is the card's NVRAM file in the daemon's state directory: two daemons on the same
directory, one after the other, are a power cycle of the card.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import vdevclient
from vdevmaps.oms import FirmwareState, Shm

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd.nvram import NvramStore

HZ = 1024
RESET_CONTROLLER = 3  # direct command (spec §2.6)
CHECKSUM_ERROR_STATE = (FirmwareState.RUNNING | FirmwareState.DEFAULTS_CHECKSUM_ERROR
                        | FirmwareState.FACTORY_SET)
FLASH_ERROR_STATE = FirmwareState.NOT_DOWNLOADED | FirmwareState.APPLICATION_CHECKSUM_ERROR


def cruise_velocity(maxk: Maxk, axis: str = "X", distance: str = "100000000") -> str:
    """RV while a long move cruises: the axis's VL (in the reply's units)."""
    maxk.send(f"A{axis} MR{distance}; GO;")
    maxk.step(HZ // 2)
    velocity = maxk.query("RV;")
    maxk.send("ST;")
    maxk.step(HZ)
    return velocity


# -- the firmware state word [S Table 3-4; spec §2.3] ----------------------------------------------
def test_fresh_card_runs_with_the_factory_set(maxk: Maxk) -> None:
    """spec §2.3: 0x00040004, running + factory set (no APP archive)."""
    assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00040004


def test_app_then_power_cycle_loads_the_power_up_set(tmp_path: Path) -> None:
    """[S §2.14]: "the APP command is executed to place the values into flash memory. From this
    point forward these defined values will be used after reset or power-up"; spec §2.3:
    0x00010004 after APP and a restart."""
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP25; KO-120; LTH; LMS; AY VL5000; AZ PSO; AA UU,,,100;")
        maxk.step(1)  # VL is queued: it runs at the next update cycle
        maxk.send("APP;")
        assert not maxk.command_error()
        # APP changes what is loaded only at power-up
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00040004
    with maxk_card(tmp_path) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00010004
        assert maxk.query("AX ?KP;") == "25.00"
        assert maxk.query("?KO;") == "-120.00"
        assert maxk.query("LT?;") == "=h"
        assert maxk.query("LM?;") == "=s"
        assert cruise_velocity(maxk, "Y") == "5000"
        assert maxk.query("AZ PS?;") == "=O"
        assert maxk.query("AT RP;") == "0.00"  # user units on


def test_changes_without_app_are_lost_at_power_up(tmp_path: Path) -> None:
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP25;")
    with maxk_card(tmp_path) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00040004
        assert maxk.query("AX ?KP;") == "10.00"


def test_app_writes_the_flash_at_once(tmp_path: Path) -> None:
    """The image is in the state directory when APP has run (a kill at any later moment keeps
    it), not when the daemon stops."""
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP33; APP;")
        image = NvramStore(tmp_path).load("maxk0")
        assert image is not None and image["values"]["KP"][0] == 33


def test_reset_loads_the_power_up_set(tmp_path: Path) -> None:
    """A reset (direct command 3, spec §2.6) is a power-up of the firmware."""
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP25; APP; KP40;")
        maxk.shm.write32(Shm.DIRECT_COMMAND, RESET_CONTROLLER)
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00010004
        assert maxk.query("AX ?KP;") == "25.00"


def test_rdf_loads_the_factory_set_and_rdp_the_power_up_set(tmp_path: Path) -> None:
    """[S §2.14]: "To restore the factory defaults the command RDF is executed. To restore the
    User Defined Default Parameters the command RDP is executed"; spec §2.3: after RDF bit 18 set
    and bit 16 clear, after RDP the reverse."""
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP25; APP;")
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP40; RDF;")
        maxk.step(1)
        state = maxk.shm.read32(Shm.FIRMWARE_STATE)
        assert state & FirmwareState.FACTORY_SET and not state & FirmwareState.POWER_UP_SET
        assert maxk.query("?KP;") == "10.00"
        maxk.send("RDP;")
        maxk.step(1)
        state = maxk.shm.read32(Shm.FIRMWARE_STATE)
        assert state & FirmwareState.POWER_UP_SET and not state & FirmwareState.FACTORY_SET
        assert maxk.query("?KP;") == "25.00"


def test_rdp_without_stored_defaults_is_a_command_error(maxk: Maxk) -> None:
    maxk.send("AX KP25; RDP;")
    assert maxk.command_error()
    assert maxk.query("?KP;") == "25.00"
    assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00040004


def test_factory_defaults_of_section_2_14(maxk: Maxk) -> None:
    """[S §2.14] list, spec §1.4: hard limits, enabled, active low; VL 200,000; AC 2,000,000;
    user units off; home active low; KP 10, KD 160, KI 1.00, KO 0, KV 0, KA 0. RDF brings them
    back."""
    maxk.send("AX KP1; KD2; KI3; KO4; KV5; KA6; LTH; LMS; VL1000; AC1000; UU10; HH;")
    maxk.step(1)
    maxk.send("RDF;")
    maxk.step(1)
    gains = [maxk.query(f"?{g};") for g in ("KP", "KD", "KI", "KO", "KV", "KA")]
    assert gains == ["10.00", "160.00", "1.00", "0.00", "0.00", "0.00"]
    assert maxk.query("LT?;") == "=l"
    assert maxk.query("LM?;") == "=h"
    assert maxk.query("RP;") == "0"  # user units off: whole counts
    assert maxk.query("QA;")[3] == "N"  # home input open (high), active low: not at home
    assert cruise_velocity(maxk) == "200000"
    maxk.send("MR100000000; GO;")
    maxk.step(HZ // 16)  # 1/16 s accelerating at 2,000,000 counts/s^2
    assert int(maxk.query("RV;")) == pytest.approx(2_000_000 / 16, abs=2_000_000 / HZ)


# -- the archive and the firmware backdoor [spec §2.3, §6.2] ----------------------------------------
def test_unreadable_archive_is_a_checksum_error_and_the_factory_set_loads(tmp_path: Path) -> None:
    (tmp_path / "maxk0.nvram").write_bytes(b"\xc1 not a parameter archive")
    with maxk_card(tmp_path) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == CHECKSUM_ERROR_STATE
        maxk.send("AX RDP;")
        assert maxk.command_error()
        maxk.send("KP20; APP;")
    with maxk_card(tmp_path) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00010004
        assert maxk.query("AX ?KP;") == "20.00"


def test_defaults_checksum_fault_loads_the_factory_set(tmp_path: Path) -> None:
    """spec §6.2: "an injected archive-corruption fault gives bit 12 plus fallback to factory
    (bit 18)"."""
    with maxk_card(tmp_path) as maxk:
        maxk.send("AX KP25; APP;")
        maxk.control("set_firmware_state", state="defaults_checksum")
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == CHECKSUM_ERROR_STATE
        assert maxk.query("AX ?KP;") == "10.00"
        maxk.control("set_firmware_state", state="running")
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00010004
        assert maxk.query("AX ?KP;") == "25.00"


@pytest.mark.parametrize(("state", "word"), [("no_firmware", FirmwareState.NOT_DOWNLOADED),
                                             ("flash_checksum", FLASH_ERROR_STATE)])
def test_without_firmware_the_card_takes_no_command(maxk: Maxk, state: str, word: int) -> None:
    """Table 3-4 bit 0 "application code not downloaded to RAM": nothing parses the command
    ring, so its process index stays (EPICS waits for 0x0F4 to reach 0x0F0, spec §2.4)."""
    maxk.control("set_firmware_state", state=state)
    assert maxk.shm.read32(Shm.FIRMWARE_STATE) == word
    maxk.send("WY;")
    maxk.step(4)
    assert maxk.shm.read32(Shm.COMMAND_PROCESS) != maxk.shm.read32(Shm.COMMAND_INSERT)
    assert maxk.reply() is None
    maxk.control("set_firmware_state", state="running")
    assert maxk.shm.read32(Shm.FIRMWARE_STATE) == 0x00040004
    assert maxk.query("WY;").startswith("MAXk-4000")


def test_unknown_firmware_state_is_refused(maxk: Maxk) -> None:
    with pytest.raises(vdevclient.RemoteError):
        maxk.control("set_firmware_state", state="half_flashed")


# -- the update rate [S §2.13; spec §4.2] --------------------------------------------------------
@pytest.mark.parametrize("rate", [1024, 2048, 4096, 8192])
def test_update_rate_is_one_of_the_four_and_reads_back_without_equals(maxk: Maxk,
                                                                     rate: int) -> None:
    assert maxk.query(f"#UR{rate}; #UR?;") == str(rate)


@pytest.mark.parametrize("text", ["#UR1000;", "#UR0;", "#URx;"])
def test_other_update_rates_are_refused(maxk: Maxk, text: str) -> None:
    maxk.send(text)
    assert maxk.command_error()
    assert maxk.query("#UR?;") == "1024"


def test_configured_update_rate_is_reported_and_times_the_card() -> None:
    """The card option `update_hz` sets the update cycle; #UR? reports it."""
    with maxk_card(update_hz=4096) as maxk:
        assert maxk.query("#UR?;") == "4096"
        t0 = maxk.rack.sim.now_ns()
        assert maxk.step(4096) - t0 == pytest.approx(1e9, abs=4096)


# -- ranges: a command error and nothing changed [spec §4.4] ----------------------------------------
@pytest.mark.parametrize("text", ["AC0", "AC8000001", "VL0", "VL4194304", "VB200000",
                                  "VB4194304", "VL-5"])
def test_motion_parameter_out_of_range_changes_nothing(maxk: Maxk, text: str) -> None:
    """spec §4.4: AC outside 1..8,000,000, VL outside 1..4,194,303, VB not below VL."""
    maxk.send(f"AX {text};")
    assert maxk.command_error()
    assert cruise_velocity(maxk) == "200000"


def test_vb_below_vl_is_accepted(maxk: Maxk) -> None:
    maxk.send("AX VL8000000;")
    assert maxk.command_error()
    maxk.send("AX VB100; VL4194303; AC8000000; AC1;")
    assert not maxk.command_error()


# -- user units [spec §4.1, §4.3 UU/UF] ----------------------------------------------------------------
def test_user_units_scale_positions_and_replies(maxk: Maxk) -> None:
    """UU# = counts per user unit: operands and RP/RE in units, fixed point ("##.#", CRM-1-1)."""
    maxk.send("AX UU1000; MR1.5; GO;")
    maxk.step(HZ // 2)
    assert maxk.word(Shm.MOTOR_POSITION) == 1500  # the card counts in counts
    assert maxk.query("RP;") == "1.500"
    assert maxk.query("RE;") == "1.500"
    assert maxk.query("UF; RP;") == "1500"


def test_user_units_scale_velocity_and_acceleration(maxk: Maxk) -> None:
    maxk.send("AX UU1000; VL5; AC50;")
    maxk.step(1)
    assert cruise_velocity(maxk, distance="100000") == "5.000"
    maxk.send("UF;")
    assert cruise_velocity(maxk) == "5000"
    maxk.send("AX MR100000000; GO;")
    maxk.step(HZ // 16)  # 50 units/s^2 = 50,000 counts/s^2
    assert int(maxk.query("RV;")) == pytest.approx(50_000 / 16, abs=50_000 / HZ)


def test_user_unit_ranges_are_checked_in_counts(maxk: Maxk) -> None:
    """VL 5000 units/s at 1000 counts/unit is 5,000,000 counts/s: above 4,194,303."""
    maxk.send("AX UU1000; VL5000;")
    assert maxk.command_error()
    maxk.send("UU1000; VL4000;")
    assert not maxk.command_error()


def test_user_units_per_axis_in_aa_mode(maxk: Maxk) -> None:
    maxk.send("AA UU10,,4; LP1,2,3,4;")
    maxk.step(1)
    assert maxk.query("AA RP;") == "1.0,2,3.0,4"
    assert maxk.query("AA PP;") == "1.0,2,3.0,4"
    assert [maxk.word(Shm.MOTOR_POSITION + 4 * a) for a in range(4)] == [10, 2, 12, 4]


@pytest.mark.parametrize("text", ["UU0", "UU-5", "UUx"])
def test_user_units_must_be_positive(maxk: Maxk, text: str) -> None:
    maxk.send(f"AX {text};")
    assert maxk.command_error()
    assert maxk.query("RP;") == "0"
