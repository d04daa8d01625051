"""Reports and settings of chapters 5 and 6: DE/TD (the auxiliary encoder), IP (incremental
position), LZ (leading zeros), variables, TM and TIME, ^R^V and RS."""

from __future__ import annotations

import ctypes

import pytest
from vdevclient import galil

from tests.devices.galil.conftest import LATENCY_S, TM_S, Dmc, move_time, stored_acc

IP_INCORRECT_SIGN = 16  # "IP incorrect sign during position move or IP given during forced deceleration"
NUMBER_OUT_OF_RANGE = 6
VARIABLE_ERROR = 9
DEFAULTS = {"SP": 25_000, "AC": 256_000, "DC": 256_000}


def default_move_time(distance: float) -> float:
    acc = stored_acc(DEFAULTS["AC"])
    return move_time(distance, DEFAULTS["SP"], acc, stored_acc(DEFAULTS["DC"]))


# -- DE / TD --------------------------------------------------------------------------------------
def test_de_defines_the_auxiliary_encoders_the_manuals_way(dmc: Dmc) -> None:
    """"DE 0,500,-30,300 sets their initial values ... DE ?,,? returns the value of the X and Z
    auxiliary encoders ... V1= _DEX ... TD XYZW returns the current position of the auxiliary
    encoder" [M Ch6 §Continuous Dual Loop]."""
    dmc.cmd("DE 0,500,-30,300")
    assert dmc.cmd("DE ?,,?") == "0000000000,-0000000030"
    assert dmc.cmd("TD XYZW") == "0000000000,0000000500,-0000000030,0000000300"
    dmc.cmd("V1= _DEY")
    assert dmc.value("MG V1") == 500


def test_de_500_then_td_x_is_500_on_a_servo_card(dmc: Dmc) -> None:
    """A servo axis has no auxiliary encoder model: TD is what DE set (README "Motion"), also
    while the main encoder moves."""
    dmc.cmd("DE 500")
    assert dmc.value("TD X") == 500
    dmc.cmd("PR 1000;BG X;AM X")
    assert dmc.value("TD X") == 500
    assert dmc.value("MG _TDX") == 500


# -- IP -------------------------------------------------------------------------------------------
def test_ip_when_idle_is_pr_and_bg(dmc: Dmc) -> None:
    """"If the motor is not moving, the IP command is equivalent to the PR and BG command
    combination" [M Ch6 §Independent Axis Positioning]."""
    dmc.cmd("DP 1000")
    expected = default_move_time(300)
    took = dmc.timed("IP 300;AM X")
    assert expected <= took <= expected + LATENCY_S
    assert dmc.value("RP X") == 1300


def test_ip_during_a_move_in_the_same_direction_extends_the_target(dmc: Dmc) -> None:
    """"The new target is equal to the old target plus the increment, n ... The IP command does
    not require a begin"."""
    dmc.cmd("SP 10000;PR 10000;BG X")
    dmc.step(0.2)
    dmc.cmd("IP 500")
    dmc.cmd("AM X")
    assert dmc.value("RP X") == 10_500
    dmc.cmd("PA 0;BG X")
    dmc.step(0.2)
    dmc.cmd("IP -700")
    dmc.cmd("AM X")
    assert dmc.value("RP X") == -700


@pytest.mark.parametrize("setup", ["PR 10000;BG X", "PA -10000;BG X"])
def test_ip_of_the_opposite_sign_is_tc_16(dmc: Dmc, setup: str) -> None:
    """"as long as the additional move is in the same direction"; the move goes on to its target."""
    dmc.cmd(setup)
    dmc.step(0.1)
    opposite = "-500" if "PR" in setup else "500"
    assert dmc.refused(f"IP {opposite}") == IP_INCORRECT_SIGN
    dmc.cmd("AM X")
    assert abs(dmc.value("RP X")) == 10_000


def test_ip_during_a_stop_is_tc_16(dmc: Dmc) -> None:
    """TC 16: "... or IP given during forced deceleration"."""
    dmc.cmd("PR 100000;BG X")
    dmc.step(0.2)
    dmc.cmd("ST X")
    assert dmc.refused("IP 500") == IP_INCORRECT_SIGN


def test_ip_while_jogging_moves_the_position_at_once(dmc: Dmc) -> None:
    """"An instant change to the motor position can be made with the use of the IP command ... the
    controller commands the motor to a position which is equal to the specified increment plus the
    current position" [M Ch6 §Independent Jogging]; the jog goes on."""
    speed = 5000
    dmc.cmd(f"JG {speed};BG X")
    dmc.step(0.1)
    before = dmc.value("RP X")
    dmc.cmd("IP 1000")
    assert 1000 <= dmc.value("RP X") - before <= 1000 + speed * TM_S
    assert dmc.value("MG _BGX") == 1


# -- LZ -------------------------------------------------------------------------------------------
def test_lz_1_removes_the_leading_zeros(dmc: Dmc) -> None:
    """LZ (Leading Zeros) changes the format of returned data [M Ch5 §Interrogation Commands]."""
    dmc.cmd("LZ 1")
    assert dmc.cmd("TP X") == "0"
    dmc.cmd("DP -500,42")
    assert dmc.cmd("TP XY") == "-500,42"
    assert dmc.cmd("KP ?") == "6.00"
    assert dmc.cmd("MG 2.5") == " 2.5000"
    dmc.cmd("LZ 0")
    assert dmc.cmd("TP XY") == "-0000000500,0000000042"


# -- variables ------------------------------------------------------------------------------------
def test_variables_assign_compute_and_print(dmc: Dmc) -> None:
    """`V1=5`, `V1=V1*2`; `V1=` "Report the value of V1" [M Ch2 Ex14] in the variable format 10.4;
    MG prints it with a sign column."""
    dmc.cmd("V1=5")
    dmc.cmd("V1=V1*2")
    assert dmc.cmd("V1=") == "0000000010.0000"
    assert dmc.cmd("MG V1") == " 0000000010.0000"
    dmc.cmd("LZ 1")
    assert dmc.cmd("V1=") == "10.0000"
    dmc.cmd("V2=V1-30")
    assert dmc.cmd("MG V2") == "-20.0000"


def test_an_undefined_variable_is_tc_9(dmc: Dmc) -> None:
    assert dmc.refused("MG V7") == VARIABLE_ERROR


# -- TM and TIME ----------------------------------------------------------------------------------
def test_tm_reports_1000_us(dmc: Dmc) -> None:
    """The default sample time is TM 1000 [M Ch1]."""
    assert dmc.value("TM ?") == 1000
    assert dmc.value("MG _TM") == 1000


def test_time_counts_samples(dmc: Dmc) -> None:
    """TIME counts servo samples: 0.1 s at TM 1000 is 100."""
    before = dmc.value("MG TIME")
    dmc.step(0.1)
    assert dmc.value("MG TIME") - before == round(0.1 / TM_S)


def test_tm_is_reported_but_the_servo_period_stays(dmc: Dmc) -> None:
    """TM 2000 is kept and reported; the card's period stays the configured one (README
    "Motion"); TM outside 250..20000 is TC 6."""
    dmc.cmd("TM 2000")
    assert dmc.value("TM ?") == 2000
    before = dmc.value("MG TIME")
    dmc.step(0.1)
    assert dmc.value("MG TIME") - before == round(0.1 / TM_S)
    assert dmc.refused("TM 100") == NUMBER_OUT_OF_RANGE
    assert dmc.value("TM ?") == 2000


# -- ^R^V and RS ----------------------------------------------------------------------------------
def test_ctrl_r_ctrl_v_names_the_dmc_1348(dmc: Dmc) -> None:
    """^R^V reports the firmware revision [M Ch5]; DMCVersion sends it."""
    assert "DMC1348" in dmc.cmd("\x12\x16")
    buf = ctypes.create_string_buffer(128)
    assert galil.DMCVersion(dmc.handle, buf, ctypes.sizeof(buf)) == galil.DMCNOERROR
    assert b"DMC1348" in buf.value


def test_rs_resets_parameters_positions_time_and_the_data_record(dmc: Dmc) -> None:
    """RS: "clear the FIFO, then send the RS command" resets the controller [M Ch4]; parameters
    return to their defaults (KP 6, spec §1.4), positions to 0, TIME to 0, DR off (README)."""
    dmc.cmd("KP 20,30;DP 1234,-99;DR-4;TM 500")
    dmc.step(0.05)
    dmc.cmd("RS")
    assert dmc.cmd("KP ?,?") == "0006.00,0006.00"
    assert dmc.cmd("TP XY") == "0000000000,0000000000"
    assert dmc.cmd("RP XY") == "0000000000,0000000000"
    assert dmc.value("TM ?") == 1000
    assert dmc.value("MG TIME") == 0
    assert dmc.value("TB") == 0
