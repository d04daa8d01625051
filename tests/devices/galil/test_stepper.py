"""Stepper operation [M Ch6 §Stepper Motor Operation, Ch2 Step 7C]: a card with its SM jumpers
installed (`plant = "stepper"`), MT, the KS smoothing filter between the profiler's reference (RP)
and the step count register (TD), and the MC trippoint that waits for the step count. KS is a
single pole of 3*KS samples (spec §5.6: the manual's one figure is KS 2 = 6 samples)."""

from __future__ import annotations

import ctypes
import math
from collections.abc import Iterator

import pytest
import vdevclient
from vdevclient import galil
from vdevmaps.galil import FIRST_AXIS, AxisSwitch
from vdevmaps.galil import REV4DMCDataRecordAxisOffsets as _A

from tests.devices.galil.conftest import (
    LATENCY_S,
    TIMEOUT_MS,
    TM_S,
    Dmc,
    card_config,
    move_time,
    stored_acc,
)
from vdevd.testing import DaemonThread

SM_JUMPER_NEEDED = 96  # "SM jumper needs to be installed for stepper motor operation"
NUMBER_OUT_OF_RANGE = 6
# x,a axis switches in the data record; bit 0 "SM Jumper Installed" [M Ch4]
X_SWITCHES = FIRST_AXIS + int(_A.DRREV4AxisOffAxisSwitches)
SM_JUMPER = int(AxisSwitch.SM_JUMPER)
DEFAULT_AC = 256_000


def time_constant(ks: float) -> float:
    """The KS filter's time constant in samples: "KS is 2 which corresponds to a time constant
    of 6 sample periods" [M Ch6 §Monitoring Generated Pulses]."""
    return 3 * ks


@pytest.fixture
def stepper(monkeypatch: pytest.MonkeyPatch) -> Iterator[Dmc]:
    """Controller 1 on a DMC-1348 whose SM jumpers are installed."""
    with DaemonThread(card_config(plant="stepper")) as daemon, \
            vdevclient.connect(daemon.endpoint, daemon.events, timeout=10) as rack:
        monkeypatch.setenv("VDEVD_ENDPOINT", daemon.endpoint)
        handle = ctypes.c_long()
        assert galil.DMCOpen(1, 0, ctypes.byref(handle)) == galil.DMCNOERROR
        assert galil.DMCSetTimeout(handle, TIMEOUT_MS) == galil.DMCNOERROR
        try:
            yield Dmc(handle, rack)
        finally:
            galil.DMCClose(handle)


def samples(dmc: Dmc, n: int) -> None:
    dmc.rack.sim.step(ticks=n)


def lag(dmc: Dmc) -> float:
    """Steps the step count register is behind the reference: RP - TD."""
    return dmc.value("RP X") - dmc.value("TD X")


# -- MT and KS ------------------------------------------------------------------------------------
def test_mt_reads_2_on_a_card_with_the_sm_jumpers(stepper: Dmc) -> None:
    """"When configured for stepper motor operation" (SM jumpers) every axis is a stepper: MT 2."""
    assert stepper.cmd("MT ?,?,?,?") == "2.0,2.0,2.0,2.0"
    assert stepper.value("MG _MTX") == 2


@pytest.mark.parametrize("motor_type", ["-2", "2.5", "-2.5"])
def test_mt_accepts_the_stepper_types(stepper: Dmc, motor_type: str) -> None:
    """MT 2, -2, 2.5, -2.5: active low/high step pulses, normal/reversed direction [M Ch6]."""
    stepper.cmd(f"MT {motor_type}")
    assert stepper.value("MT ?") == float(motor_type)


@pytest.mark.parametrize("motor_type", ["2", "-2", "2.5", "-2.5"])
def test_mt_stepper_on_a_servo_card_is_tc_96(dmc: Dmc, motor_type: str) -> None:
    """"In order to command stepper motor operation, the appropriate stepper mode jumpers must be
    installed": without them MT is refused with TC 96 and stays 1."""
    assert dmc.refused(f"MT {motor_type}") == SM_JUMPER_NEEDED
    assert dmc.cmd("MT ?") == "1.0"


def test_ks_defaults_to_2_and_takes_0_5_to_8(stepper: Dmc) -> None:
    """"The KS parameter has a range between 0.5 and 8" [M Ch2 Step 7C]; default 2 [M Ch6]."""
    assert stepper.value("KS ?") == 2
    stepper.cmd("KS 0.5")
    assert stepper.value("KS ?") == 0.5
    stepper.cmd("KS 8")
    assert stepper.value("KS ?") == 8


@pytest.mark.parametrize("ks", ["0.4", "8.5", "-1"])
def test_ks_outside_0_5_to_8_is_tc_6_and_changes_nothing(stepper: Dmc, ks: str) -> None:
    stepper.cmd("KS 3")
    assert stepper.refused(f"KS {ks}") == NUMBER_OUT_OF_RANGE
    assert stepper.value("KS ?") == 3


def test_data_record_says_the_sm_jumper_is_installed(stepper: Dmc, dmc: Dmc) -> None:
    """Axis switch byte bit 0 "SM Jumper Installed" [M Ch4 §Explanation of Status Information]."""
    assert stepper.record()[X_SWITCHES] & SM_JUMPER
    assert not dmc.record()[X_SWITCHES] & SM_JUMPER


# -- the step count register behind the KS filter -------------------------------------------------
def test_pr_move_ends_with_rp_at_target_while_td_lags_then_mc_waits_for_the_steps(stepper: Dmc) -> None:
    """AM releases when the profiler is done, RP at the target; "the controller may still be
    generating step pulses" (TD < RP with KS 8); MC "will hold up execution ... until the controller
    has generated the same number of steps out of the step count register as specified in the
    commanded position" [M Ch6 §Motion Complete Trippoint]. After the profile the remaining steps
    decay as exp(-t/tau): MC releases once fewer than half a step remain."""
    distance, speed, ks = 1000, 3000, 8
    stepper.cmd(f"KS {ks};SP {speed};PR {distance}")
    expected = move_time(distance, speed, stored_acc(DEFAULT_AC), stored_acc(DEFAULT_AC))
    took = stepper.timed("BG X;AM X")
    assert expected <= took <= expected + LATENCY_S
    assert stepper.value("RP X") == distance
    behind = lag(stepper)
    assert behind > 0  # TD < RP right after the profile ends
    tau = time_constant(ks)
    # the first sample with less than half a step left; the true lag is within 0.5 of `behind`
    earliest = math.floor(tau * math.log((behind - 0.5) / 0.5)) * TM_S
    latest = math.ceil(tau * math.log((behind + 0.5) / 0.5)) * TM_S + LATENCY_S
    took = stepper.timed("MC X")
    assert earliest <= took <= latest
    assert stepper.value("TD X") == stepper.value("RP X") == distance


def test_mc_returns_at_once_when_the_steps_are_out(stepper: Dmc) -> None:
    stepper.cmd("KS 0.5;PR 200;BG X;AM X")
    stepper.step(0.1)  # 100 samples, about 67 time constants of 1.5 samples
    assert stepper.value("TD X") == 200
    assert stepper.timed("MC X") <= LATENCY_S


def test_step_count_approaches_the_reference_with_a_time_constant_of_3_ks_samples(stepper: Dmc) -> None:
    """A single pole: once RP stops, RP - TD falls by exp(-n/tau) in n samples, tau = 3*KS
    (within a step: TD is whole steps)."""
    ks = 8
    stepper.cmd(f"KS {ks};SP 3000;PR 1000;BG X;AM X")
    start = lag(stepper)
    elapsed = 0
    for n in (5, 10, 20, 40):
        samples(stepper, n - elapsed)
        elapsed = n
        assert lag(stepper) == pytest.approx(start * math.exp(-n / time_constant(ks)), abs=1)


@pytest.mark.parametrize("ks", [2, 8])
def test_at_constant_speed_td_lags_rp_by_about_speed_times_3_ks_samples(stepper: Dmc, ks: int) -> None:
    """Jogging at v steps/s, a single pole of tau samples lags v*tau*TM steps (a sampled pole lags
    by between tau - 1 and tau samples; TD is whole steps): KS 2 lags 6 samples [M Ch6]."""
    speed = 3000
    stepper.cmd(f"KS {ks};JG {speed};BG X")
    stepper.step(1.0)  # over 40 time constants at speed
    per_sample = speed * TM_S
    tau = time_constant(ks)
    assert per_sample * (tau - 1) - 1 <= lag(stepper) <= per_sample * tau + 1


def test_dp_sets_the_reference_and_the_step_count(stepper: Dmc) -> None:
    """"The command, DP sets the value of the step count register as well as the value of the
    reference position" [M Ch6 §Monitoring Generated Pulses]."""
    stepper.cmd("DP 500,-40")
    assert stepper.cmd("RP XY") == "0000000500,-0000000040"
    assert stepper.cmd("TD XY") == "0000000500,-0000000040"
    stepper.cmd("PR 100;BG X;MC X")
    assert stepper.value("TD X") == stepper.value("RP X") == 600


def test_de_defines_the_encoder_not_the_step_count(stepper: Dmc) -> None:
    """"The position of the encoder can be interrogated by using the command, TP. The position value
    can be defined by using the command, DE" [M Ch6 §Using an Encoder with Stepper Motors];
    "DP Define Reference Position and Step Count Register" [M Ch6 §Command Summary - Stepper]."""
    stepper.cmd("DP 500")
    stepper.cmd("DE 100")
    assert stepper.value("TP X") == 100
    assert stepper.value("TD X") == stepper.value("RP X") == 500
    stepper.cmd("PR 100;BG X;MC X")
    assert stepper.value("TD X") == stepper.value("RP X") == 600
