"""MAXk encoder features through a real daemon (lockstep clock): slip and stall detection
[S §3.4.3, §4.7; spec oms.md §5.4], servo runaway [S §2.13], the amplifier fault, position
maintenance (HD/HG/HV, spec §5.4), real-time position capture [S §3.7, Tables 3-5/3-6; spec
§2.8] and SSI absolute encoders [S §4.9; spec §5.8].

Axes: X a stepper with encoder (PSE), Y a servo (PSM), Z a stepper with encoder, T an open-loop
stepper (PSO).
"""

from __future__ import annotations

import struct
from collections.abc import Iterator

import pytest
from vdevmaps.oms import CAPTURE_SIZE, MaxkDoorbell, Mu, Shm

from tests.devices.oms.conftest import Maxk, maxk_card

DT = 1 / 1024
OM1I = 1 << 1  # OMISR: OMR1 written (capture data) [S §3.7]


@pytest.fixture
def card() -> Iterator[Maxk]:
    types = ["stepper_encoder", "servo", "stepper_encoder", "stepper"]
    with maxk_card(axis_types=types) as maxk:
        maxk.send("AA VL10000,10000,10000,10000 AC100000,100000,100000,100000; AX;")
        yield maxk


def number(maxk: Maxk, text: str) -> int:
    return int(maxk.query(text + ";"))


def ea(maxk: Maxk, axis: str = "X") -> str:
    return maxk.query(f"A{axis} EA;")


def done_within(maxk: Maxk, bits: int = MaxkDoorbell.DONE_X, timeout_s: float = 10.0) -> bool:
    return maxk.mu.wait_value(Mu.ODBR, 0, mask=bits, timeout_s=timeout_s, equal=False) is not None


# -- slip and stall [S §4.7; spec §5.4] ----------------------------------------------------------
def test_slip_beyond_es_kills_the_axis_and_reports_it(card: Maxk) -> None:
    """|encoder − ratio·motor| > ES: EA char 3 'S', ODBR bit 16 + axis, the axis killed, its
    queue flushed so the pending ID never sets done (spec §5.4)."""
    card.send("AX ES20 MR50000 GO ID;")
    card.step(300)
    assert ea(card) == "EDNNN"
    card.control("set_encoder_slip", axis="X", counts=50)
    card.step(2)
    assert number(card, "AX RV") == 0
    assert ea(card)[2] == "S"
    assert card.odbr() & MaxkDoorbell.SLIP_X
    assert not done_within(card, timeout_s=1)
    motor, encoder = number(card, "AX RP"), number(card, "AX RE")
    assert motor - encoder == 50  # the encoder lost 50 counts; the motor's count is the pulses
    card.send("AX IC;")
    assert ea(card)[2] == "N"


@pytest.mark.parametrize("load", ["LP", "LPE"])
def test_loading_the_encoder_starts_slip_detection_again(card: Maxk, load: str) -> None:
    """After a slip, LP (both counters) or LPE (the encoder) re-reference the detection: the next
    move does not trip."""
    card.send("AX ES20 MR1000 GO ID;")
    assert done_within(card)
    card.control("set_encoder_slip", axis="X", counts=50)
    card.step(2)
    assert card.odbr() & MaxkDoorbell.SLIP_X
    card.send(f"AX IC {load}1000;")
    card.clear_odbr()
    card.step(2)
    assert number(card, "AX RE") == 1000
    card.send("AX MR1000 GO ID;")
    assert done_within(card)
    assert not card.odbr() & MaxkDoorbell.SLIP_X
    assert (number(card, "AX RP"), number(card, "AX RE")) == (2000, 2000)


def test_slip_within_es_and_es0_are_not_reported(card: Maxk) -> None:
    card.send("AX ES100 MR50000 GO; AZ MR50000 GO;")  # Z: ES 0, the factory value
    card.step(300)
    card.control("set_encoder_slip", axis="X", counts=50)
    card.control("set_encoder_slip", axis="Z", counts=5000)
    card.step(100)
    assert number(card, "AX RV") == 10000
    assert number(card, "AZ RV") == 10000
    assert not card.odbr() & (MaxkDoorbell.SLIP_X | 1 << 18)
    assert ea(card, "Z") == "DDNNN"


def test_a_lost_encoder_is_a_stall_once_the_motor_ran_es_counts(card: Maxk) -> None:
    card.send("AX ES200 JG10000;")
    card.step(200)
    card.control("set_encoder_loss", axis="X", active=True)
    card.step(round(0.015 / DT))  # 150 counts of 200
    assert not card.odbr() & MaxkDoorbell.SLIP_X
    card.step(round(0.01 / DT))
    assert card.odbr() & MaxkDoorbell.SLIP_X
    assert number(card, "AX RV") == 0


def test_servo_runaway_disables_the_pid_and_reports_a_slip(card: Maxk) -> None:
    """"if the error is greater than 32768, the controller will disable the PID so that you
    don't have a runaway motor" [S §2.13]: the loop opens (CL? off) and it reports as a slip."""
    card.send("AY MR400000 GO ID;")
    card.step(100)
    card.control("set_encoder_loss", axis="Y", active=True)
    card.step(round(4.0 / DT))
    assert card.odbr() & MaxkDoorbell.SLIP_Y
    assert ea(card, "Y")[2] == "S"
    assert card.query("AY CL?;") == "off"
    assert not card.odbr() & (1 << 1)  # no done


def test_servo_stall_beyond_es_kills_but_keeps_the_loop(card: Maxk) -> None:
    card.send("AY ES500 JG10000;")
    card.step(300)
    card.control("set_encoder_loss", axis="Y", active=True)
    card.step(round(0.2 / DT))
    assert card.odbr() & MaxkDoorbell.SLIP_Y
    assert card.query("AY CL?;") == "on"


def test_amplifier_fault_kills_the_servo_and_reports_a_slip(card: Maxk) -> None:
    """An amplifier fault (backdoor) on a servo axis: the axis stops, its loop opens, it is
    reported like a slip (README)."""
    card.send("AY MR100000 GO ID;")
    card.step(300)
    card.control("set_amp_fault", axis="Y", active=True)
    card.step(2)
    assert card.odbr() & MaxkDoorbell.SLIP_Y
    assert ea(card, "Y")[2] == "S"
    assert card.query("AY CL?;") == "off"
    assert number(card, "AY RV") == 0
    assert not done_within(card, bits=1 << 1, timeout_s=1)


def test_amp_fault_is_for_servo_axes() -> None:
    with maxk_card(axis_types=["stepper"] * 4) as maxk, pytest.raises(Exception, match="PSM"):
        maxk.control("set_amp_fault", axis="X", active=True)


# -- position maintenance [spec §5.4] ------------------------------------------------------------
def test_position_maintenance_brings_the_encoder_back_into_the_deadband(card: Maxk) -> None:
    """CL1 on a PSE axis: outside HD the motor is corrected at up to HV until the encoder is
    within HD of the target; EA char 2 'E', char 4 'D' while inside."""
    card.send("AX CL1 HD5 HG50 HV2000 MR1000 GO ID;")
    assert done_within(card)
    assert ea(card) == "DENDN"
    card.control("set_encoder_slip", axis="X", counts=100)
    card.step(1)
    assert ea(card)[3] == "N"
    card.step(1024)
    assert ea(card)[3] == "D"
    assert abs(number(card, "AX RE") - 1000) <= 5
    assert number(card, "AX RP") == pytest.approx(1100, abs=5)  # the motor made up the slip


def test_without_cl1_the_slip_stays(card: Maxk) -> None:
    card.send("AX HD5 HV2000 MR1000 GO ID;")
    assert done_within(card)
    card.control("set_encoder_slip", axis="X", counts=100)
    card.step(1024)
    assert number(card, "AX RE") == 900
    assert ea(card) == "DDNNN"


# -- real-time position capture [S §3.7; spec §2.8] ---------------------------------------------
def entries(card: Maxk) -> tuple[int, int, list[tuple[int, int, int, int, int]]]:
    """(insert, removal, every entry of the ring) [S Table 3-5, 3-6]."""
    raw = card.shm.read(Shm.CAPTURE_INSERT, CAPTURE_SIZE)
    table = [struct.unpack_from(">iBBHH", raw, 2 + 10 * i) for i in range(55)]
    return raw[0], raw[1], table


def test_input_edge_captures_the_encoder_and_writes_omr1(card: Maxk) -> None:
    """An edge of a GP input captures the axes watching it: one entry each, OMR1 = 2, OMISR
    bit 1 (INTA) [S §3.7]."""
    card.send("AX CPR0001; AZ CPF0001; AX MR1000 GO;")
    assert card.query("AX CPR?;") == "=0001"
    card.step(400)
    card.control("set_input", bit=0, level=0)
    card.step(1)
    insert, removal, table = entries(card)
    assert (insert, removal) == (1, 0)
    position, axis, home, rising, falling = table[0]
    assert (axis, home, rising, falling) == (2, 0, 0, 1)  # Z: falling edge of IO0
    assert card.mu.read32(Mu.OMR1) == 2 and card.mu.read32(Mu.OMISR) & OM1I
    card.control("set_input", bit=0, level=1)
    card.step(1)
    insert, _, table = entries(card)
    assert insert == 2
    position, axis, home, rising, falling = table[1]
    assert (axis, rising, falling) == (0, 1, 0)
    assert position == number(card, "AX RE")


def test_home_switch_edges_capture(card: Maxk) -> None:
    """CPH 1 rising, 4 falling: an active-low switch going active is a falling edge."""
    card.control("set_home_edge", axis="X", position=300)
    card.send("AX CPH5 MR1000 GO ID;")
    assert card.query("AX CPH?;") == "=5"
    assert done_within(card)
    _, _, table = entries(card)
    position, axis, home, _, _ = table[0]
    assert (axis, home) == (0, 0x04)
    assert position == pytest.approx(300, abs=10000 * DT + 1)
    card.send("AX MR-1000 GO;")
    card.step(1024)
    insert, _, table = entries(card)
    assert insert == 2 and table[1][2] == 0x01


def test_index_pulses_capture_their_exact_count(card: Maxk) -> None:
    card.control("set_index", axis="Z", period=256, phase=0)
    card.send("AZ CPH2 MR1000 GO ID;")
    assert done_within(card, bits=1 << 2)
    insert, _, table = entries(card)
    assert insert == 3
    assert [(e[0], e[1], e[2]) for e in table[:3]] == [(256, 2, 2), (512, 2, 2), (768, 2, 2)]


def test_capture_needs_an_encoder(card: Maxk) -> None:
    card.send("AT CPH1;")
    assert card.command_error()


def test_capture_ring_keeps_54_entries_and_pushes_the_removal_index(card: Maxk) -> None:
    """55 entries; when the insert index reaches the removal index the controller advances the
    removal index too (the oldest entry is lost), so 54 are readable [S §3.7]."""
    card.send("AX CPR0002 CPF0002;")
    for i in range(60):
        card.control("set_input", bit=1, level=i % 2)
        card.step(1)
    insert, removal, table = entries(card)
    assert (insert, removal) == (60 % 55, (60 + 1) % 55)
    assert (insert - removal) % 55 == 54
    newest = table[(insert - 1) % 55]
    assert newest[1:] == (0, 0, 2, 0)  # the 60th toggle: level 1, a rising edge


# -- SSI absolute encoders [S §4.9; spec §5.8] -----------------------------------------------------
def test_eca_publishes_the_masked_encoder_word(card: Maxk) -> None:
    """`AX; PSE; ECA12,125000;` [S §4.9.1]: the SSI word of X at 0x3520, 12 bits."""
    card.send("AX ECA12,125000 MR5000 GO ID;")
    assert done_within(card)
    assert card.shm.read32(Shm.SSI_POSITION) == 5000 & 0xFFF
    assert card.query("AX ECA?;") == "=12,125000"
    assert card.shm.read32(Shm.SSI_POSITION + 4 * 2) == 0  # Z has no SSI
    card.send("AX LP-1;")
    card.step(1)
    assert card.shm.read32(Shm.SSI_POSITION) == 0xFFF
    card.send("AZ ECA32,4000000 LP-2;")
    card.step(1)
    assert card.shm.read32(Shm.SSI_POSITION + 8) == 0xFFFFFFFE


@pytest.mark.parametrize("command", ["AX ECA33,125000", "AX ECA12,100000", "AY ECA12,125000",
                                     "AT ECA12,125000", "AX ECA12"])
def test_eca_refuses_bad_bits_clocks_and_axis_types(card: Maxk, command: str) -> None:
    card.send(command + ";")
    assert card.command_error()
