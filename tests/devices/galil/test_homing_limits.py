"""Manual chapter 3 "Using Optoisolated Inputs": limit switches, home switch and the FE/FI/HM
routines, the abort input, and the off-on-error function (ch. 2 Step 7a), with the switches
driven through the card's backdoor (`set_switches`, `set_home_edge`, `set_index`, `set_abort`,
`set_amp_fault`)."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.galil import FIRST_AXIS, AxisStatus
from vdevmaps.galil import REV4DMCDataRecordAxisOffsets as _A

from tests.devices.galil.conftest import LATENCY_S, TM_S, Dmc, stop_distance, stored_acc

# stop codes (spec §4.4)
AT_POSITION, FORWARD_LIMIT, REVERSE_LIMIT, STOPPED_BY_ST = 1, 2, 3, 4
ABORT_INPUT, OFF_ON_ERROR, AFTER_FE, AFTER_HM_OR_FI = 6, 8, 9, 10
BEGIN_LIMIT_SWITCH = 22  # "022 - Begin not possible due to limit switch" [M Ch3 §Limit Switch Input]
HOME_CREEP = 256  # counts/s of HM's second and third phases [M Ch3 §Home Switch Input]

# X axis block of the data record [M Ch4 §DMA / Secondary FIFO Memory Map]
SAMPLE = 0
X_STATUS = FIRST_AXIS + int(_A.DRREV4AxisOffAxisStatus)
X_SWITCHES = FIRST_AXIS + int(_A.DRREV4AxisOffAxisSwitches)
HM_IN_PROGRESS, HM_PHASE1_DONE = int(AxisStatus.HOMING), int(AxisStatus.HM_PHASE1)
HM_PHASE2_DONE = int(AxisStatus.HM_PHASE2_OR_FI)
MOVE_IN_PROGRESS = int(AxisStatus.MOVING)


def jog(dmc: Dmc, speed: int, dec: int = 51_200) -> None:
    """Jog X at `speed` with AC 256000 and DC `dec` (a multiple of 1024), at speed after 0.3 s."""
    dmc.cmd(f"AC 256000;DC {dec};JG {speed};BG X")
    dmc.step(0.3)


def assert_decelerated_stop(dmc: Dmc, speed: int, dec: int, before: float, took: float) -> None:
    """The stop from `speed` took speed/DC and travelled speed^2/(2 DC) from `before` (the
    reference one sample before the switch acted, so up to one sample of travel more)."""
    expected = abs(speed) / dec
    assert expected - TM_S <= took <= expected + LATENCY_S
    travel = abs(dmc.value("RP X") - before)
    distance = stop_distance(speed, dec)
    assert distance - 1 <= travel <= distance + abs(speed) * TM_S + 1


# -- limit switches -------------------------------------------------------------------------------
@pytest.mark.parametrize(("speed", "switch", "operand", "code"), [
    (10_000, "forward_limit", "_LFX", FORWARD_LIMIT),
    (-10_000, "reverse_limit", "_LRX", REVERSE_LIMIT),
])
def test_limit_switch_during_motion_makes_a_decelerated_stop_with_dc(
        dmc: Dmc, speed: int, switch: str, operand: str, code: int) -> None:
    """"If a limit switch is activated during motion, the controller will make a decelerated stop
    using the deceleration rate previously set with the DC command. The motor will remain on ...
    and will hold motor position." The operand gives the logic state of the switch."""
    dec = stored_acc(51_200)
    assert dmc.value(f"MG {operand}") == 1
    jog(dmc, speed, dec)
    before = dmc.value("RP X")
    dmc.control("set_switches", axis="X", **{switch: True})
    took = dmc.timed("AM X")
    assert_decelerated_stop(dmc, speed, dec, before, took)
    assert dmc.value("SC X") == code
    assert dmc.value(f"MG {operand}") == 0
    assert dmc.value("MG _MOX") == 0  # still in a servo state
    held = dmc.value("RP X")
    for _ in range(3):
        dmc.step(0.2)
        assert abs(dmc.value("TP X") - held) <= 1  # holds within the encoder's last count


@pytest.mark.parametrize(("switch", "toward", "away"), [
    ("forward_limit", ("JG 5000", "PR 1000"), ("JG -5000", "PR -1000")),
    ("reverse_limit", ("JG -5000", "PR -1000"), ("JG 5000", "PR 1000")),
])
def test_no_motion_toward_an_active_limit_switch_tc_22_motion_away_allowed(
        dmc: Dmc, switch: str, toward: tuple[str, str], away: tuple[str, str]) -> None:
    """"further motion in the direction of the limit switch will not be possible until the logic
    state of the switch returns back to an inactive state ... 022 - Begin not possible due to limit
    switch"; motion away is allowed (spec §5.4)."""
    dmc.control("set_switches", axis="X", **{switch: True})
    for line in toward:
        dmc.cmd(line)
        assert dmc.refused("BG X") == BEGIN_LIMIT_SWITCH
    jg, pr = away
    start = dmc.value("RP X")
    dmc.cmd(f"{pr};BG X;AM X")
    assert dmc.value("RP X") == start + float(pr.split()[1])
    dmc.cmd(f"{jg};BG X")
    dmc.step(0.1)
    dmc.cmd("ST X;AM X")
    assert dmc.value("SC X") == STOPPED_BY_ST
    dmc.control("set_switches", axis="X", **{switch: False})  # released: both ways again
    dmc.cmd(f"{toward[1]};BG X;AM X")
    assert dmc.value("SC X") == AT_POSITION


@pytest.mark.parametrize(("speed", "switch"), [(-10_000, "forward_limit"), (10_000, "reverse_limit")])
def test_a_limit_switch_does_not_stop_motion_away_from_it(dmc: Dmc, speed: int, switch: str) -> None:
    """"The forward limit switch (FLSx) inhibits motion in the forward direction"; the reverse
    switch in the reverse direction: moving the other way, the axis goes on."""
    jog(dmc, speed)
    dmc.control("set_switches", axis="X", **{switch: True})
    before = dmc.value("RP X")
    dmc.step(0.3)
    assert dmc.value("MG _BGX") == 1
    assert dmc.value("SC X") == 0  # still running
    assert dmc.value("RP X") - before == pytest.approx(speed * 0.3, abs=abs(speed) * LATENCY_S)
    dmc.cmd("ST X;AM X")


def test_limit_switch_state_in_the_record_switch_byte(dmc: Dmc) -> None:
    """The switch byte of the data record holds the "State of Forward Limit" (bit 3) and "State of
    Reverse Limit" (bit 2) [M Ch4 §Explanation of Status Information], as _LFX and _LRX do."""
    dmc.cmd("DR-1")
    for forward, reverse in ((False, False), (True, False), (False, True), (True, True)):
        dmc.control("set_switches", axis="X", forward_limit=forward, reverse_limit=reverse)
        switches = dmc.record()[X_SWITCHES]
        assert (switches >> 3) & 1 == dmc.value("MG _LFX") == (0 if forward else 1)
        assert (switches >> 2) & 1 == dmc.value("MG _LRX") == (0 if reverse else 1)


# -- abort input ----------------------------------------------------------------------------------
def test_abort_input_stops_motion_at_once_and_the_motor_stays_on_without_oe(dmc: Dmc) -> None:
    """"When the abort input is activated, the controller stops generating motion commands
    immediately, whereas the limit switch response causes ... a decelerated stop." With the
    off-on-error function disabled the motor remains in a servo state [M Ch3 §Abort Input]."""
    speed = 10_000
    jog(dmc, speed)
    before = dmc.value("RP X")
    dmc.control("set_abort", active=True)
    dmc.step(0.1)
    stopped = dmc.value("RP X")
    assert 0 <= stopped - before <= speed * TM_S  # at most the sample in progress, no ramp
    dmc.step(0.1)
    assert dmc.value("RP X") == stopped
    assert dmc.value("SC X") == ABORT_INPUT
    assert dmc.value("MG _MOX") == 0


def test_abort_input_turns_the_motor_off_with_oe1(dmc: Dmc) -> None:
    """"If the Off-On-Error function is enabled for any given axis, the motor for that axis will
    be turned off when the abort signal is generated" [M Ch3 §Abort Input]."""
    dmc.cmd("OE 1")
    jog(dmc, 10_000)
    dmc.control("set_abort", active=True)
    dmc.step(0.01)
    assert dmc.value("SC X") == ABORT_INPUT
    assert dmc.value("MG _MOX") == 1


# -- error limit and off-on-error -----------------------------------------------------------------
def test_off_on_error_turns_the_motor_off_when_the_error_exceeds_er(dmc: Dmc) -> None:
    """[M Ch2 Step 7a]: ER sets the error limit, OE 1 turns the motor off when |TE| exceeds it;
    here the amplifier stops driving the motor during a move (SC 8, off-on-error)."""
    dmc.cmd("ER 100;OE 1")
    jog(dmc, 5000)
    dmc.control("set_amp_fault", axis="X", active=True)
    dmc.cmd("AM X")
    assert dmc.value("SC X") == OFF_ON_ERROR
    assert dmc.value("MG _MOX") == 1
    assert dmc.refused("BG X") == 20  # Begin not valid with motor off
    dmc.control("set_amp_fault", axis="X", active=False)
    dmc.cmd("SH X")
    dmc.cmd("PR 100;BG X;AM X")
    assert dmc.value("SC X") == AT_POSITION


# -- home input -----------------------------------------------------------------------------------
@pytest.mark.parametrize("edge", [1500, -1500])
def test_find_edge_moves_toward_the_transition_and_stops_past_it_with_dc(dmc: Dmc, edge: int) -> None:
    """FE: "accelerate, then slew at constant speed until a transition is detected in the logic
    state of the Home input. The direction ... is dependent on the state of the home switch. High
    level causes forward motion. The motor will then decelerate to a stop" [M Ch3 §Home Switch
    Input]. The switch at `edge` reads 1 below it: forward from 0 to 1500, reverse to -1500."""
    speed, dec = 5000, stored_acc(256_000)
    dmc.control("set_home_edge", axis="X", position=edge)
    level = dmc.value("MG _HMX")  # the switch reads at once
    assert level == (1 if edge > 0 else 0)
    dmc.cmd(f"SP {speed};AC 256000;DC 256000")
    dmc.cmd("FE X;BG X;AM X")
    assert dmc.value("SC X") == AFTER_FE
    assert dmc.value("MG _HMX") == 1 - level
    past = dmc.value("RP X") - edge
    distance = stop_distance(speed, dec)
    direction = 1 if edge > 0 else -1
    assert distance - 1 <= direction * past <= distance + speed * TM_S + 1


def test_standard_home_phases_and_position_zero_at_the_index(dmc: Dmc) -> None:
    """HM: slew to the home transition and stop with DC (phase 1); back toward it at 256 counts/s
    until the logic state changes again (phase 2); forward at 256 counts/s to the index, stop and
    define this position as 0 [M Ch3 §Home Switch Input]. The axis status bits (record bytes 40-41)
    show HM in progress (11), phase 1 complete (10), phase 2 complete (9) in that order."""
    edge, index = 2000, 2100
    dmc.control("set_home_edge", axis="X", position=edge)
    dmc.control("set_index", axis="X", period=4096, phase=index)
    dmc.step(TM_S)
    dmc.cmd("DR-1")
    dmc.cmd("SP 5000;AC 256000;DC 256000")
    dmc.cmd("HM X;BG X")
    trace: list[tuple[int, int, int]] = []  # (status bits 9-11, sample, reference)
    while True:
        record = dmc.record()
        status, _, stop_code, reference = struct.unpack_from("<HBBi", record, X_STATUS)
        (sample,) = struct.unpack_from("<H", record, SAMPLE)
        trace.append((status & (HM_IN_PROGRESS | HM_PHASE1_DONE | HM_PHASE2_DONE), sample, reference))
        if not status & MOVE_IN_PROGRESS and len(trace) > 1:
            break
        dmc.step(0.01)
    phases = [bits for bits, _, _ in trace]
    order = [HM_IN_PROGRESS, HM_IN_PROGRESS | HM_PHASE1_DONE,
             HM_IN_PROGRESS | HM_PHASE1_DONE | HM_PHASE2_DONE, 0]
    assert [b for k, b in enumerate(phases) if k == 0 or b != phases[k - 1]] == order
    for bits, direction in ((order[1], -1), (order[2], 1)):  # the creep of phases 2 and 3
        points = [(s, r) for b, s, r in trace if b == bits][2:-2]  # away from the turns
        (s0, r0), (s1, r1) = points[0], points[-1]
        assert (r1 - r0) / ((s1 - s0) * TM_S) == pytest.approx(direction * HOME_CREEP, rel=0.05)
    assert dmc.value("SC X") == AFTER_HM_OR_FI
    assert dmc.value("RP X") == 0
    assert abs(dmc.value("TP X")) <= 2


def test_find_index_ends_with_stop_code_10_past_the_index(dmc: Dmc) -> None:
    """FI: "accelerate to the user-defined slew speed (SP) ... and slew until the controller senses
    a change in the index pulse signal from low to high" [M Ch3 §Home Switch Input]."""
    dmc.control("set_index", axis="X", period=4096, phase=1000)
    dmc.cmd("SP 5000;JG 5000")
    dmc.cmd("FI X;BG X;AM X")
    assert dmc.value("SC X") == AFTER_HM_OR_FI
    dmc.step(0.3)
    assert abs(dmc.value("TP X") - dmc.value("RP X")) <= 1


def test_find_index_decelerates_with_dc_after_the_index(dmc: Dmc) -> None:
    """FI: "The motor then decelerates to a stop at the rate previously specified by the user
    with the DC command" [M Ch3 §Home Switch Input]: from SP 5000 at DC 256000 (255 * 1024) the
    stop takes SP/DC and ends SP^2/(2 DC) past the index, where the position is 0 (README)."""
    speed, dec = 5000, stored_acc(256_000)
    dmc.control("set_index", axis="X", period=4096, phase=1000)
    dmc.cmd(f"SP {speed};JG {speed};AC 256000;DC 256000")
    dmc.cmd("FI X;BG X")
    dmc.step(0.15)  # slewing at SP well before the index (1000 counts at 5000 counts/s)
    before = dmc.value("RP X")
    assert before < 1000
    dmc.cmd("AM X")
    past = dmc.value("RP X")
    distance = stop_distance(speed, dec)
    assert distance - 1 <= past <= distance + speed * TM_S + 1
