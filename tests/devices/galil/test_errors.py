"""Invalid commands (manual ch. 5 "Controller Response to DATA"): the card answers '?', TC1 tells
the reason with the codes of the TC table (spec §4.3), the refused command changes nothing and
the card keeps working."""

from __future__ import annotations

import pytest
from vdevclient import galil

from tests.devices.galil.conftest import Dmc

UNRECOGNIZED = 1
UNDEFINED_LABEL = 10
NUMBER_OUT_OF_RANGE = 6
JG_ONLY_IN_JOG_MODE = 13
BEGIN_MOTOR_OFF = 20
BEGIN_WHILE_RUNNING = 21


def test_lower_case_bg_is_unrecognized(dmc: Dmc) -> None:
    """":bg <enter> invalid command, lower case ? ... TC1 ... 1 Unrecognized command"."""
    rc, reply = dmc.command("bg")
    assert (rc, reply) == (galil.DMCERROR_COMMAND, "?")
    assert dmc.cmd("TC1") == "1 Unrecognized command"
    assert dmc.value("MG _BGX") == 0  # nothing began


def test_dmc_error_reports_the_cards_reason(dmc: Dmc) -> None:
    """DMCError for DMCERROR_COMMAND asks the card (TC1)."""
    rc, _ = dmc.command("bg")
    assert dmc.error_text(rc) == "1 Unrecognized command."


@pytest.mark.parametrize(("line", "code"), [
    ("QQ", UNRECOGNIZED),
    ("KP 2000", NUMBER_OUT_OF_RANGE),  # KP maximum 1023 [M Ch2 Step 8]
    ("KD 5000", NUMBER_OUT_OF_RANGE),  # KD maximum 4095 [M Ch2 Step 8]
    ("TL 11", NUMBER_OUT_OF_RANGE),  # 9.998 V is the maximum [M Ch2 Ex8]
    ("AC 99999999999", NUMBER_OUT_OF_RANGE),
    ("EI ,,256", NUMBER_OUT_OF_RANGE),  # "The vector is selected as a value between 8 and 255"
    ("XQ #A", UNDEFINED_LABEL),  # no program downloaded
])
def test_refused_commands_and_their_codes(dmc: Dmc, line: str, code: int) -> None:
    dmc.cmd("KP 10;KD 100")
    assert dmc.refused(line) == code
    assert dmc.cmd("KP ?;KD ?") == "0010.00\r\n:0100.00"  # nothing changed
    assert dmc.cmd("TPX") == "0000000000"  # and the next command is served


def test_bg_while_moving_is_tc_21(dmc: Dmc) -> None:
    dmc.cmd("JG 1000;BGX")
    assert dmc.refused("BGX") == BEGIN_WHILE_RUNNING
    assert dmc.cmd("STX;AMX") == ":"


def test_bg_with_the_motor_off_is_tc_20(dmc: Dmc) -> None:
    dmc.cmd("MO X")
    assert dmc.value("MG _MOX") == 1
    assert dmc.refused("BGX") == BEGIN_MOTOR_OFF
    dmc.cmd("SH X")
    dmc.cmd("PR 100;BGX;AMX")
    assert dmc.value("RPX") == 100


def test_jg_during_a_position_move_is_tc_13(dmc: Dmc) -> None:
    """JG changes speed on the fly only in jog mode (TC 13 "JG only valid when running in jog
    mode")."""
    dmc.cmd("PR 5000;BGX")
    assert dmc.refused("JG 500") == JG_ONLY_IN_JOG_MODE
    dmc.cmd("AMX")
    assert dmc.value("RPX") == 5000


def test_the_rest_of_the_line_runs_after_a_refused_command(dmc: Dmc) -> None:
    """Each command of a line gets its own ':' or '?'."""
    rc, reply = dmc.command("KP 2000;KP 12;KP ?")
    assert rc == galil.DMCERROR_COMMAND
    assert reply == "?:0012.00\r\n:"


@pytest.mark.parametrize("line", ["bg", "KP 2000", "XQ #A", "QQ"])
def test_after_an_error_the_card_keeps_working(dmc: Dmc, line: str) -> None:
    dmc.refused(line)
    dmc.cmd("PR 250;BGX;AMX")
    assert dmc.value("RPX") == 250


def test_bg_of_a_coordinate_system_without_a_sequence_is_tc_24(dmc: Dmc) -> None:
    """`BG S` begins a vector sequence [M Ch5 §Coordinated Motion]; none can be defined yet, so
    the card gives TC 24 "Begin not valid because no sequence defined" and moves nothing."""
    assert dmc.refused("BG S") == 24
    assert dmc.refused("BG TW") == 24
    assert dmc.value("MG _BGW") == 0
