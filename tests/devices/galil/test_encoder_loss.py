"""A lost encoder (backdoor `set_encoder_loss`) during a jog: the encoder reading (TP) freezes while
the reference (RP) goes on, so the position error grows until ER and OE act: TS bit 6, then with
OE 1 the motor turns off with stop code 8 [M Ch2 Step 7a, M Ch3 §Amplifier Interface]."""

from __future__ import annotations

import math

from tests.devices.galil.conftest import TM_S, Dmc

OFF_ON_ERROR = 8  # stop code (spec §4.4)
TS_ERROR_EXCEEDED, TS_MOTOR_OFF = 1 << 6, 1 << 5
SPEED = 10_000
MARGIN = 3  # samples either side of the moment |TE| passes ER


def jog_then_lose_the_encoder(dmc: Dmc) -> tuple[float, float]:
    """Jog X at SPEED, lose its encoder; TP and TE at that moment."""
    dmc.cmd(f"JG {SPEED};BG X")
    dmc.step(0.3)
    dmc.control("set_encoder_loss", axis="X", active=True)
    return dmc.value("TP X"), dmc.value("TE X")


def samples_to_exceed(limit: int, error: float) -> int:
    """Samples until |TE| > limit when TE grows by SPEED*TM a sample from `error`."""
    return math.floor((limit - error) / (SPEED * TM_S)) + 1


def test_tp_freezes_while_rp_goes_on(dmc: Dmc) -> None:
    """With the default ER (16384) and OE 0 nothing stops the jog: RP advances at JG, TP stays."""
    frozen, _ = jog_then_lose_the_encoder(dmc)
    start = dmc.value("RP X")
    dmc.step(0.05)
    assert dmc.value("TP X") == frozen
    assert dmc.value("RP X") - start == SPEED * 0.05
    assert dmc.value("TE X") == dmc.value("RP X") - frozen
    assert dmc.value("MG _MOX") == 0


def test_error_over_er_sets_ts_bit_6_without_oe(dmc: Dmc) -> None:
    dmc.cmd("ER 500")
    _, error = jog_then_lose_the_encoder(dmc)
    assert not int(dmc.value("TS X")) & TS_ERROR_EXCEEDED
    dmc.rack.sim.step(ticks=samples_to_exceed(500, error) + MARGIN)
    assert int(dmc.value("TS X")) & TS_ERROR_EXCEEDED
    assert dmc.value("MG _MOX") == 0
    assert dmc.value("SC X") == 0  # still jogging


def test_with_er_500_and_oe_1_the_motor_turns_off(dmc: Dmc) -> None:
    """ER 500; OE 1: once |TE| > 500, (500 - TE)/JG seconds after the loss (within a few samples),
    the motor is off (_MOX 1, TS bit 5) with SC 8."""
    dmc.cmd("ER 500;OE 1")
    _, error = jog_then_lose_the_encoder(dmc)
    trip = samples_to_exceed(500, error)
    dmc.rack.sim.step(ticks=trip - MARGIN)
    assert dmc.value("MG _MOX") == 0
    assert dmc.value("SC X") == 0
    dmc.rack.sim.step(ticks=2 * MARGIN)
    assert dmc.value("MG _MOX") == 1
    assert dmc.value("SC X") == OFF_ON_ERROR
    assert int(dmc.value("TS X")) & (TS_ERROR_EXCEEDED | TS_MOTOR_OFF) == TS_ERROR_EXCEEDED | TS_MOTOR_OFF
