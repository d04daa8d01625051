"""The I/O configuration in the power-up defaults: GPIO directions (BD, IO), home modes (HI/HS),
capture triggers (CPH, CPR, CPF), SSI encoders (ECA) and the `#UR` rate as reported, stored by
APP, loaded at power-up and by RDP, reset by RDF; output levels (BH/BL/BW, AO, AN/AF) are not
part of it; images of the earlier format still load [S §2.14; spec oms.md §1.4, §2.3; README
"APP, RDF, RDP"].

Flash is the card's NVRAM file in the daemon's state directory: two daemons on the same
directory, one after the other, are a power cycle of the card.
"""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from vdevmaps.oms import CAPTURE_SIZE, FirmwareState, MaxkDoorbell, Mu, Shm

from tests.devices.oms.conftest import Maxk, maxk_card
from vdevd.devices.oms.params import PARAMS
from vdevd.nvram import NvramStore

# X and Z steppers with encoder (PSE), Y a servo (PSM), T an open-loop stepper (PSO)
TYPES = ["stepper_encoder", "servo", "stepper_encoder", "stepper"]
HZ = 1024
VL, AC = 10000, 100000
POWER_UP_LOADED = 0x00010004  # running, power-up set in working memory
FACTORY_LOADED = 0x00040004


def gpio(maxk: Maxk) -> int:
    """BX: outputs as driven (low after power-up), inputs as the outside drives them (open
    inputs read high), so with every output low BX is the complement of the directions."""
    return int(maxk.query("BX;"), 16)


def capture_entries(maxk: Maxk) -> list[tuple[int, int, int, int, int]]:
    """The capture entries the card has inserted (ring from 0, no wrap) [S Table 3-6]."""
    raw = maxk.shm.read(Shm.CAPTURE_INSERT, CAPTURE_SIZE)
    return [struct.unpack_from(">iBBHH", raw, 2 + 10 * i) for i in range(raw[0])]


def z_homes_on_the_index_pulse(maxk: Maxk) -> bool:
    """HM0 on Z with index pulses every 1000 counts from 250 and the home switch from 5000 up:
    in HI mode home is the pulse at 5250, so the switch edge ends 250 counts below the new
    zero (at -250 the axis is still on it); in HS mode the edge itself becomes 0 [S §4.8]."""
    maxk.control("set_index", axis="Z", period=1000, phase=250)
    maxk.control("set_home_edge", axis="Z", position=5000)
    maxk.send(f"AZ VL{VL} AC{AC} HM0 ID;")
    assert maxk.mu.wait_value(Mu.ODBR, 0, mask=MaxkDoorbell.DONE_Z, timeout_s=10, equal=False) is not None
    maxk.send("AZ MA-250 GO;")
    maxk.step(HZ // 2)
    return maxk.query("AZ QA;")[3] == "H"


def configure_io(maxk: Maxk) -> None:
    """Every setting of the I/O configuration away from its factory value."""
    maxk.send("BD00F0; IO0,1;")  # IO0 and IO4-7 outputs, IO8-15 inputs
    maxk.send("AZ HI;")
    maxk.send("AX CPH5; CPR0100; CPF0200;")
    maxk.send("AX ECA12,125000;")
    maxk.send("#UR4096;")
    assert not maxk.command_error()


def assert_io_configured(maxk: Maxk) -> None:
    """What configure_io set (HI apart: z_homes_on_the_index_pulse)."""
    assert gpio(maxk) == 0xFF0E
    assert maxk.query("AX CPH?;") == "=5"
    assert maxk.query("AX CPR?;") == "=0100"
    assert maxk.query("AX CPF?;") == "=0200"
    assert maxk.query("AX ECA?;") == "=12,125000"
    assert maxk.query("#UR?;") == "4096"


def assert_io_factory(maxk: Maxk, update_hz: int = HZ) -> None:
    """The factory I/O configuration: IO0-7 inputs, IO8-15 outputs [S §4.4], no capture, no
    SSI, #UR the card's update rate (HS homing apart: z_homes_on_the_index_pulse)."""
    assert gpio(maxk) == 0x00FF
    assert maxk.query("AX CPH?;") == "=0"
    assert maxk.query("AX CPR?;") == "=0000"
    assert maxk.query("AX CPF?;") == "=0000"
    assert maxk.query("AX ECA?;") == "=0,0"
    assert maxk.query("#UR?;") == str(update_hz)


# -- APP and a power cycle ------------------------------------------------------------------------
def test_app_stores_the_gpio_directions(tmp_path: Path) -> None:
    """BD and IO set the directions; after APP and a power cycle IO0 is still an output (BH
    accepted) and IO8 an input (BH refused) [S §4.4]."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("BD00F0; IO0,1; APP;")
        assert not maxk.command_error()
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == POWER_UP_LOADED
        assert gpio(maxk) == 0xFF0E
        maxk.send("BH0;")
        assert not maxk.command_error()
        maxk.send("BH8;")
        assert maxk.command_error()


def test_app_stores_the_home_mode(tmp_path: Path) -> None:
    """HI survives a power cycle: HM homes on the index pulse inside the switch."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AZ HI; APP;")
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert z_homes_on_the_index_pulse(maxk)


def test_hs_is_the_power_up_home_mode_without_app(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AZ HI;")
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert not z_homes_on_the_index_pulse(maxk)


def test_app_stores_the_capture_triggers_and_they_capture_after_power_up(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX CPH5; CPR0001; AZ CPF0002; APP;")
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.query("AX CPH?;") == "=5"
        assert maxk.query("AX CPR?;") == "=0001"
        assert maxk.query("AZ CPF?;") == "=0002"
        maxk.control("set_input", bit=0, level=0)
        maxk.step(1)
        maxk.control("set_input", bit=0, level=1)  # a rising edge of IO0: X captures
        maxk.control("set_input", bit=1, level=0)  # a falling edge of IO1: Z captures
        maxk.step(1)
        assert [e[1:] for e in capture_entries(maxk)] == [(0, 0, 1, 0), (2, 0, 0, 2)]


def test_app_stores_the_ssi_encoder(tmp_path: Path) -> None:
    """ECA survives a power cycle: X's SSI word at 0x3520 is its encoder in 12 bits [S §4.9]."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX ECA12,125000; APP;")
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.query("AX ECA?;") == "=12,125000"
        maxk.send("AX LP-1;")
        maxk.step(1)
        assert maxk.shm.read32(Shm.SSI_POSITION) == 0xFFF


def test_app_stores_the_update_rate_and_the_card_powers_up_at_it(tmp_path: Path) -> None:
    """#UR is stored by APP [S §2.13-2.14]: after a power cycle the card reports it and runs
    4096 update cycles a second."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("#UR4096; APP;")
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.query("#UR?;") == "4096"
        t0 = maxk.rack.sim.now_ns()
        assert maxk.step(4096) - t0 == 1_000_000_000


def test_changes_to_the_io_configuration_without_app_are_lost(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AY KP25; APP;")
        configure_io(maxk)
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == POWER_UP_LOADED
        assert_io_factory(maxk)


def test_output_levels_are_not_stored(tmp_path: Path) -> None:
    """§2.14 stores how outputs behave, not the levels they are left at: after APP and a power
    cycle the I/O outputs are low, the aux outputs off and AO at 0 V; the directions stay."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("BD00F0; BH4; BW0080; AX AN; AT AO2.5; APP;")
        assert not maxk.command_error()
        out = maxk.control("get_outputs")
        assert out["gpio"] & 0x00F0 == 0x0080 and out["aux"][0]
        assert out["dac_volts"][3] == pytest.approx(2.5, abs=1e-3)
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        out = maxk.control("get_outputs")
        assert out["gpio"] == 0xFF0F  # IO4-7 outputs, all low
        assert out["aux"] == [False] * 4
        assert out["dac_volts"][3] == 0


def test_app_image_is_format_2_with_the_io_configuration(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        configure_io(maxk)
        maxk.send("APP;")
    image = NvramStore(tmp_path).load("maxk0")
    assert image is not None
    assert image["format"] == 2
    assert image["gpio_dir"] == 0x00F1
    assert image["update_hz"] == 4096
    assert image["home_index"] == [False, False, True, False]
    assert (image["capture_home"][0], image["capture_rising"][0],
            image["capture_falling"][0]) == (5, 0x0100, 0x0200)
    assert (image["ssi_bits"][0], image["ssi_clock"][0]) == (12, 125000)


# -- RDF and RDP ------------------------------------------------------------------------------------
def test_rdf_restores_the_factory_io_configuration(tmp_path: Path) -> None:
    """RDF: the factory I/O configuration, #UR the card's configured rate (2048 here)."""
    with maxk_card(tmp_path, axis_types=TYPES, update_hz=2048) as maxk:
        configure_io(maxk)
        maxk.send("APP;")
    with maxk_card(tmp_path, axis_types=TYPES, update_hz=2048) as maxk:
        assert_io_configured(maxk)
        maxk.send("RDF;")
        assert not maxk.command_error()
        maxk.step(1)  # the firmware state word is published every update cycle
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == FACTORY_LOADED
        assert_io_factory(maxk, update_hz=2048)
        assert not z_homes_on_the_index_pulse(maxk)


def test_rdf_turns_the_index_home_mode_back_to_hs(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AZ HI; RDF;")
        assert not z_homes_on_the_index_pulse(maxk)


def test_rdf_stops_the_capture_and_the_ssi_word(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX CPR0001; ECA12,125000; LP-1; RDF;")
        maxk.control("set_input", bit=0, level=0)
        maxk.step(1)
        maxk.control("set_input", bit=0, level=1)
        maxk.step(1)
        assert capture_entries(maxk) == []
        assert maxk.shm.read32(Shm.SSI_POSITION) == 0


def test_rdp_restores_the_stored_io_configuration(tmp_path: Path) -> None:
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        configure_io(maxk)
        maxk.send("APP; RDF;")
        assert_io_factory(maxk)
        maxk.send("RDP;")
        assert not maxk.command_error()
        assert_io_configured(maxk)
        assert z_homes_on_the_index_pulse(maxk)


def test_rdf_and_rdp_leave_the_output_levels(tmp_path: Path) -> None:
    """Levels are not part of the parameter sets, so loading a set does not switch outputs."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("APP; BH8; AX AN; AT AO-1.5; RDF; RDP;")
        assert not maxk.command_error()
        out = maxk.control("get_outputs")
        assert out["gpio"] & 0x0100 and out["aux"][0]
        assert out["dac_volts"][3] == pytest.approx(-1.5, abs=1e-3)


# -- images of the earlier format [spec §2.3] -------------------------------------------------------
def format_1_image(kp: float) -> dict[str, object]:
    """An image as APP wrote it before the I/O configuration was stored (format 1): the
    parameters, axis types, polarities, limit modes, loop state, ER and UU of 4 axes."""
    values = {k: [float(p.default)] * 4 for k, p in PARAMS.items()}
    values["KP"] = [10.0, kp, 10.0, 10.0]
    return {"format": 1, "values": values, "ptype": ["E", "M", "E", "O"],
            "limit_high": [False] * 4, "limit_mode": ["H"] * 4, "home_high": [False] * 4,
            "encoder_inverted": [False] * 4, "servo_inverted": [False] * 4,
            "closed_loop": [True] * 4, "ratio": [1.0] * 4, "user_units": [0.0] * 4}


def test_format_1_image_loads_with_the_factory_io_configuration(tmp_path: Path) -> None:
    NvramStore(tmp_path).save("maxk0", format_1_image(kp=25))
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == POWER_UP_LOADED
        assert maxk.query("AY ?KP;") == "25.00"
        assert_io_factory(maxk)
        configure_io(maxk)
        maxk.send("AY KP40; RDP;")  # what the format-1 set lacks takes factory values
        assert maxk.query("AY ?KP;") == "25.00"
        assert_io_factory(maxk)


def test_image_of_another_format_is_a_checksum_error(tmp_path: Path) -> None:
    NvramStore(tmp_path).save("maxk0", {**format_1_image(kp=25), "format": 3})
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        assert maxk.shm.read32(Shm.FIRMWARE_STATE) == (
            FirmwareState.RUNNING | FirmwareState.DEFAULTS_CHECKSUM_ERROR | FirmwareState.FACTORY_SET)
        assert maxk.query("AY ?KP;") == "10.00"
        maxk.send("RDP;")
        assert maxk.command_error()


def test_a_type_changed_after_app_leaves_the_stored_defaults_as_stored(tmp_path: Path) -> None:
    """APP stores the working parameters as they are then [S §2.13]: a PS after it changes the
    working set only, so RDP and a restart bring back the stored type."""
    with maxk_card(tmp_path, axis_types=TYPES) as maxk:
        maxk.send("AX PSM; APP; AX PSO;")
        assert maxk.query("AX PS?;") == "=O"
        maxk.send("RDP;")
        assert maxk.query("AX PS?;") == "=M"
        maxk.send("AX PSO; RS;")
        maxk.step(4)
        assert maxk.query("AX PS?;") == "=M"
