"""The axis world on the DMC-13X8 (README.md "Axis world", "Backdoor"): the stage's switches, index
pulses and probe positions given only by the card's `[[card.axis]]` tables, found by the card's
own routines (HM, FE, FI, limit stops) as an application runs them through the DMC library; the
positions stay physical when DP, DE, a home or RS redefine zero; the shared backdoor vocabulary
with its deprecated aliases."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
import vdevclient

from tests.devices.galil.conftest import (
    CARD,
    TM_S,
    Dmc,
    card_config,
    host_command,
    stop_distance,
    stored_acc,
)
from tests.devices.galil.test_interrupts import LIMIT_SWITCH, enable, service, status, wait
from vdevd.devices.base import CardContext
from vdevd.devices.galil.card import GalilCard
from vdevd.testing import DaemonThread

# stop codes (spec §4.4) and the TS bits (spec §4.4: b3/b2 forward/reverse limit inactive if 1)
AT_POSITION, FORWARD_LIMIT, REVERSE_LIMIT = 1, 2, 3
ABORT_INPUT, OFF_ON_ERROR, AFTER_FE, AFTER_HM_OR_FI = 6, 8, 9, 10
BEGIN_LIMIT_SWITCH = 22
TS_MOVING, TS_FORWARD_INACTIVE, TS_REVERSE_INACTIVE, TS_HOME = 0x80, 0x08, 0x04, 0x02

# X: hard limits at +-20000, a home switch active from 3000 on (to past the forward limit), one
# index pulse per 4096 counts with one at 3500; Y: a probe at 1500; Z: an amplifier fault and
# W: a lost encoder from power-up. All in the stage's physical counts.
LIMIT = 20_000
HOME_EDGE = 3000
INDEX = 3500
PROBE = 1500
WORLD = [
    {"limits": [-LIMIT, LIMIT], "home": [HOME_EDGE, 30_000], "index": {"period": 4096, "phase": INDEX}},
    {"probe": [PROBE]},
    {"amp_fault": True},
    {"encoder_loss": True},
]
SPEED, ACC = 5000, 256_000
DEC = stored_acc(ACC)


@pytest.fixture
def galil_daemon() -> Iterator[DaemonThread]:
    """The card of conftest.py with the stage of WORLD (the only place the switches are set)."""
    with DaemonThread(card_config(axis=WORLD)) as d:
        yield d


def ts(dmc: Dmc, axis: str = "X") -> int:
    return int(dmc.value(f"TS {axis}"))


def past(dmc: Dmc, at: float, speed: float = SPEED, axis: str = "X") -> float:
    """How far the reference stopped beyond `at` (counts, in the direction of `speed`)."""
    return (dmc.value(f"RP {axis}") - at) * (1 if speed > 0 else -1)


def assert_stopped_past(dmc: Dmc, at: float, speed: float) -> None:
    """A DC stop from `speed` begun in the sample the switch or index acted: the reference ends
    speed^2/(2 DC) beyond `at`, plus up to one sample of travel."""
    distance = stop_distance(speed, DEC)
    assert distance - 1 <= past(dmc, at, speed) <= distance + abs(speed) * TM_S + 1


# -- the manual's homing routines find the stage's switches ---------------------------------------
def test_m_ch3_home_switch_input_hm_bg_ends_at_position_0_on_the_index_past_the_switch(
        dmc: Dmc) -> None:
    """[M Ch3 §Home Switch Input] HM then BG: forward to the home switch's transition (the input
    reads 1 below the switch), back at 256 counts/s until it changes again, forward at 256
    counts/s to the index, which becomes position 0; SC 10 [spec §4.4]."""
    assert dmc.value("MG _HMX") == 1
    dmc.cmd(f"SP {SPEED};AC {ACC};DC {ACC}")
    dmc.cmd("HM X;BG X;AM X")
    assert dmc.value("SC X") == AFTER_HM_OR_FI
    assert dmc.value("RP X") == 0
    assert abs(dmc.value("TP X")) <= 2
    assert dmc.value("MG _HMX") == 0  # resting on the switch (3500 is inside 3000..30000)
    # the switches stayed on the stage: the home edge is at -500 now, the forward limit at 16500
    dmc.cmd(f"PA {HOME_EDGE - INDEX - 10};BG X;AM X")
    assert dmc.value("MG _HMX") == 1
    dmc.cmd(f"JG {SPEED};BG X;AM X")
    assert dmc.value("SC X") == FORWARD_LIMIT
    assert_stopped_past(dmc, LIMIT - INDEX, SPEED)


def test_m_ch3_home_switch_input_fe_bg_stops_past_the_switch_edge_with_sc_9(dmc: Dmc) -> None:
    """[M Ch3 §Home Switch Input] FE then BG: "slew at constant speed until a transition is
    detected in the logic state of the Home input ... decelerate to a stop"; forward because the
    input is high below the switch; SC 9 (spec §4.4)."""
    dmc.cmd(f"SP {SPEED};AC {ACC};DC {ACC}")
    dmc.cmd("FE X;BG X;AM X")
    assert dmc.value("SC X") == AFTER_FE
    assert dmc.value("MG _HMX") == 0
    assert not ts(dmc) & TS_HOME
    assert_stopped_past(dmc, HOME_EDGE, SPEED)
    # on the switch the input is low: the next FE goes the other way, back across the edge
    dmc.cmd("FE X;BG X;AM X")
    assert dmc.value("SC X") == AFTER_FE
    assert dmc.value("MG _HMX") == 1
    assert dmc.value("RP X") < HOME_EDGE


@pytest.mark.parametrize(("jog", "index"), [(SPEED, INDEX), (-SPEED, INDEX - 4096)])
def test_m_ch3_home_switch_input_fi_bg_finds_the_index_in_the_direction_of_jg(
        dmc: Dmc, jog: int, index: int) -> None:
    """[M Ch3 §Home Switch Input] FI then BG: slew at SP (direction of JG) until the index pulse,
    define it as position 0 and decelerate with DC; SC 10 (spec §4.4). The stage's pulses are at
    3500 + k * 4096: the first one forward is 3500, backward -596."""
    dmc.cmd(f"SP {SPEED};JG {jog};AC {ACC};DC {ACC}")
    dmc.cmd("FI X;BG X;AM X")
    assert dmc.value("SC X") == AFTER_HM_OR_FI
    assert_stopped_past(dmc, 0, jog)
    # the index is 0 now: the forward limit at physical 20000 reads 20000 - index
    dmc.cmd(f"JG {SPEED};BG X;AM X")
    assert dmc.value("SC X") == FORWARD_LIMIT
    assert_stopped_past(dmc, LIMIT - index, SPEED)


@pytest.mark.parametrize(("speed", "code", "ts_bit", "operand"), [
    (10_000, FORWARD_LIMIT, TS_FORWARD_INACTIVE, "_LFX"),
    (-10_000, REVERSE_LIMIT, TS_REVERSE_INACTIVE, "_LRX"),
])
def test_m_ch3_limit_switch_input_jg_into_the_stages_limit_stops_with_its_stop_code(
        dmc: Dmc, speed: int, code: int, ts_bit: int, operand: str) -> None:
    """[M Ch3 §Limit Switch Input] a jog into a limit switch of the stage makes a decelerated stop
    with DC; SC 2 forward / 3 reverse, TS bit 3 / 2 and _LFX / _LRX read 0 (switch active); the
    motor stays on; BG further toward the switch is TC 22, away is allowed."""
    assert ts(dmc) & ts_bit
    dmc.cmd(f"AC {ACC};DC {ACC};JG {speed};BG X;AM X")
    assert dmc.value("SC X") == code
    assert_stopped_past(dmc, LIMIT * (1 if speed > 0 else -1), speed)
    assert not ts(dmc) & (ts_bit | TS_MOVING)
    assert dmc.value(f"MG {operand}") == 0
    assert dmc.value("MG _MOX") == 0
    assert dmc.refused("BG X") == BEGIN_LIMIT_SWITCH
    dmc.cmd("PA 0;BG X;AM X")
    assert dmc.value("SC X") == AT_POSITION
    assert ts(dmc) & ts_bit


def test_m_ch4_configuring_interrupts_the_stages_limit_raises_c0(
        rack: vdevclient.Rack, a16: vdevclient.Region) -> None:
    """EI bit 10: a jog reaching the stage's forward limit queues C0 [M Ch4 §Configuring
    Interrupts, §Servicing Interrupts]; nothing but the configured stage trips the switch."""
    enable(a16)
    host_command(a16, b"EI 1024,,32\r")
    host_command(a16, b"JG 20000;BGX\r", replies=2)
    event = wait(rack.card(CARD), timeout_s=5.0)
    assert event["status"] == status(LIMIT_SWITCH, 32)
    assert service(a16) == LIMIT_SWITCH
    assert host_command(a16, b"MG _LFX\r").strip().startswith(b"0")


def test_m_ch6_independent_axis_positioning_a_move_past_the_limit_stops_at_the_switch(
        dmc: Dmc) -> None:
    """A PA move whose target lies beyond the stage's reverse limit stops at the switch with DC
    (SC 3) [M Ch3 §Limit Switch Input], not at the target."""
    dmc.cmd(f"SP {SPEED};AC {ACC};DC {ACC};PA -25000;BG X;AM X")
    assert dmc.value("SC X") == REVERSE_LIMIT
    assert_stopped_past(dmc, -LIMIT, -SPEED)


# -- positions stay physical when zero is redefined -----------------------------------------------
@pytest.mark.parametrize(("define", "offset"), [("DP 10000", 10_000), ("DE 10000", 0), ("", 0)])
def test_dp_moves_the_switches_in_counts_de_and_rs_do_not_move_the_stage(
        dmc: Dmc, define: str, offset: int) -> None:
    """DP redefines the position [M Ch2 Ex6]: the stage's limit then reads 10000 counts further;
    DE (the auxiliary encoder on a servo card) changes nothing there."""
    if define:
        dmc.cmd(define)
    dmc.cmd(f"AC {ACC};DC {ACC};JG {SPEED};BG X;AM X")
    assert dmc.value("SC X") == FORWARD_LIMIT
    assert_stopped_past(dmc, LIMIT + offset, SPEED)


def test_rs_reads_position_0_where_the_stage_stands(dmc: Dmc) -> None:
    """RS: the positions read 0 [spec §1.4], the stage stays where it is (the switches too)."""
    dmc.cmd(f"SP {SPEED};AC {ACC};DC {ACC};PA 5000;BG X;AM X")
    dmc.step(0.2)  # the motor settles on 5000
    dmc.cmd("RS")
    assert dmc.value("TP X") == 0
    assert dmc.value("MG _HMX") == 0  # still on the home switch (from 3000)
    dmc.cmd(f"AC {ACC};DC {ACC};JG {SPEED};BG X;AM X")
    assert dmc.value("SC X") == FORWARD_LIMIT
    assert_stopped_past(dmc, LIMIT - 5000, SPEED)


# -- probe (latch), faults -------------------------------------------------------------------------
def test_fig_3_1_a_probe_position_latches_the_armed_axis_where_the_stage_crosses_it(
        dmc: Dmc) -> None:
    """AL arms the latch; the stage's probe at 1500 pulses IN2 (YLATCH, Fig 3-1) as Y crosses
    it: RL Y is the encoder there, the switch byte's "latch occurred" bit is set, AL is disarmed.
    After DP Y=1000 the same probe latches 2500."""
    dmc.cmd("DP ,1000;AL Y")
    assert dmc.value("MG _ALY") == 1
    dmc.cmd(f"SP {SPEED};PR ,3000;BG Y;AM Y")
    assert dmc.value("RL Y") == PROBE + 1000
    assert dmc.value("MG _ALY") == 0
    assert dmc.value("RP Y") == 4000
    dmc.cmd("PR ,-3000;BG Y;AM Y")  # not armed: crossing it again latches nothing new
    assert dmc.value("RL Y") == PROBE + 1000


def test_an_amplifier_fault_in_the_config_holds_from_power_up(dmc: Dmc) -> None:
    """Z's amplifier is faulted from power-up: it does not drive the motor, the error grows past
    ER and OE1 turns the motor off (SC 8) [M Ch2 Step 7a]; set_amp_fault clears it."""
    dmc.cmd("ER ,,100;OE ,,1;PR ,,2000;BG Z;AM Z")
    assert dmc.value("SC Z") == OFF_ON_ERROR
    assert abs(dmc.value("TP Z")) < 100
    dmc.control("set_amp_fault", axis="Z", active=False)
    dmc.cmd("SH Z;PR ,,100;BG Z;AM Z")
    assert dmc.value("SC Z") == AT_POSITION


def test_an_encoder_loss_in_the_config_freezes_tp_from_power_up(dmc: Dmc) -> None:
    dmc.cmd("ER ,,,-1;PR ,,,500;BG W")
    dmc.step(0.1)
    assert dmc.value("TP W") == 0
    assert dmc.value("TE W") != 0
    dmc.cmd("AB")


def test_jam_blocks_the_motor_and_the_error_grows_until_released(dmc: Dmc) -> None:
    dmc.control("jam", axis="X")
    dmc.cmd("ER -1;PR 1000;BG X")
    dmc.step(0.05)
    error = dmc.value("TE X")
    dmc.step(0.05)
    assert dmc.value("TP X") == 0
    assert 0 < error < dmc.value("TE X")
    dmc.control("jam", axis="X", active=False)
    dmc.cmd("AM X")
    dmc.step(0.5)
    assert abs(dmc.value("TP X") - 1000) <= 1


# -- the shared vocabulary --------------------------------------------------------------------------
@pytest.mark.parametrize("axis", ["Y", "y", "B", "b", 1])
def test_set_limit_names_axes_x_to_w_or_a_to_d_in_any_case(dmc: Dmc, axis: str | int) -> None:
    dmc.control("set_limit", axis=axis, side="negative")
    assert dmc.value("MG _LRY") == 0
    assert not ts(dmc, "Y") & TS_REVERSE_INACTIVE
    dmc.control("set_limit", axis=axis, side="negative", active=False)
    assert dmc.value("MG _LRY") == 1


def test_the_shared_actions_drive_the_cards_inputs(dmc: Dmc) -> None:
    dmc.control("set_limit", axis="Y")
    assert dmc.value("MG _LFY") == 0
    dmc.control("set_home", axis="Y")
    assert dmc.value("MG _HMY") == 0
    dmc.control("set_home", axis="Y", active=False)
    assert dmc.value("MG _HMY") == 1
    dmc.control("set_home_window", axis="Y", low=-10, high=10)
    assert dmc.value("MG _HMY") == 0
    dmc.control("set_input", line=8, level=False)
    assert dmc.value("MG @IN[8]") == 0
    dmc.control("set_analog", channel=2, volts=5.0)
    assert dmc.value("MG @AN[2]") == pytest.approx(5.0, abs=0.005)
    dmc.cmd("JG 1000;BG X")
    dmc.control("set_estop")
    dmc.step(0.01)
    assert dmc.value("SC X") == ABORT_INPUT


def test_set_index_moves_the_stages_pulses(dmc: Dmc) -> None:
    dmc.control("set_index", axis="A", period=10_000, phase=700)
    dmc.cmd(f"SP {SPEED};JG {SPEED};AC {ACC};DC {ACC};FI X;BG X;AM X")
    assert_stopped_past(dmc, 0, SPEED)
    dmc.cmd(f"JG {SPEED};BG X;AM X")
    assert_stopped_past(dmc, LIMIT - 700, SPEED)


def test_the_deprecated_names_still_drive_the_same_inputs(dmc: Dmc, rack: vdevclient.Rack) -> None:
    dmc.control("set_switches", axis="Y", forward_limit=True, home=0)
    assert (dmc.value("MG _LFY"), dmc.value("MG _HMY")) == (0, 0)
    dmc.control("set_switches", axis="Y", forward_limit=False, home=1)
    assert (dmc.value("MG _LFY"), dmc.value("MG _HMY")) == (1, 1)
    dmc.control("set_input", input=3, level=0)
    assert dmc.value("MG @IN[3]") == 0
    dmc.control("set_analog", input=1, volts=-2.5)
    assert dmc.value("MG @AN[1]") == pytest.approx(-2.5, abs=0.005)
    dmc.cmd("JG ,1000;BG Y")
    dmc.control("set_abort", active=True)
    dmc.step(0.01)
    assert dmc.value("SC Y") == ABORT_INPUT
    deprecated = rack.info["cards"][0]["deprecated"]
    assert deprecated == {"set_switches": "set_limit", "set_abort": "set_estop"}


@pytest.mark.parametrize(("action", "params", "message"), [
    ("set_limits", {"axis": "X"}, "has no control action 'set_limits' (has: "),
    ("set_limit", {"axis": "X", "level": 1}, "set_limit(axis"),
    ("set_limit", {"axis": "X", "side": "up"}, "side 'up' is not one of positive, negative"),
    ("set_home", {"axis": "Q"}, "no axis 'Q' (axes: X, Y, Z, W or 0..3)"),
    ("set_input", {"line": 9, "level": True}, "line 9 outside 1..8"),
    ("set_input", {"input": 0, "level": True}, "line 0 outside 1..8"),
    ("set_analog", {"channel": 0, "volts": 1.0}, "channel 0 outside 1..8"),
    ("set_switches", {"axis": "X", "limit": True}, "set_switches(axis"),
    ("set_analog", {"channel": 1, "volts": float("inf")}, "volts inf outside -100..100"),
    ("set_analog", {"channel": 1, "volts": 1e308}, "volts 1e+308 outside -100..100"),
    ("set_input", {"input": 1, "line": 2, "level": True},
     "'input' is the old name of 'line': give one of them"),
])
def test_a_wrong_action_or_parameter_is_an_error_naming_it(
        dmc: Dmc, action: str, params: dict[str, Any], message: str) -> None:
    with pytest.raises(vdevclient.VdevClientError) as info:
        dmc.control(action, **params)
    assert message in str(info.value)
    assert dmc.value("TP X") == 0  # still serving


# -- options --------------------------------------------------------------------------------------
def test_options_are_read_as_declared_base_0_kept_the_period_from_tm_us() -> None:
    """`base` 0 (JP10 all jumpers in) is legal and kept; the servo period is the sample time
    `tm_us` (what TM reports), and a `period_ns` of its own is refused."""
    card = GalilCard(CARD, {"base": 0, "tm_us": 500}, CardContext(emit=lambda event: None))
    assert (card.base, card.configured_tm_us, card.period_ns) == (0, 500, 500_000)
    with pytest.raises(ValueError, match=r"period_ns: a galil-dmc13x8 runs at its sample time"):
        GalilCard(CARD, {"tm_us": 500, "period_ns": 250_000}, CardContext(emit=lambda e: None))


def test_set_switches_home_level_replaces_a_home_edge_as_before(dmc: Dmc) -> None:
    """The deprecated `set_switches(home=...)` set the HOME level over a `set_home_edge` switch
    (issue 16: old names keep working)."""
    dmc.control("set_home_edge", axis="Y", position=-100)  # the stage at 0 is on the switch
    assert dmc.value("MG _HMY") == 0
    dmc.control("set_switches", axis="Y", home=1)
    assert dmc.value("MG _HMY") == 1
    dmc.control("set_switches", axis="Y", home=0)
    assert dmc.value("MG _HMY") == 0
