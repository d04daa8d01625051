"""AF, analog feedback: an axis reads its position from the analog input of its number instead of
its encoder [M Ch1 §Encoder: "The DMC-13X8 can accept analog feedback instead of an encoder for
any axis"; spec §1 (AF)]. The seed refers to the command reference for AF; its form there: `AF n`
per axis, 1 on, 0 off, the analog input of the axis's number (X: AN1), 12 bits over ±10 V.

Model (README "Assumptions"): the analog sensor is on the stage, one ADC count per count of
motion (204.8 counts per volt: 20 V over 4096 codes, the card's analog inputs' step). `AF 1`
makes the axis's position read what the input reads then; from there the sensor follows the
motor, so TP, TE, the data record and the servo loop all use it, and the input (`@AN`, `TZ`, the
record's analog input) reads the sensor: TP / 204.8 volts, within ±10 V. The backdoor's
`set_analog` on that input moves the sensor's reading to the volts given (the loop then acts on
the new error). The encoder path of the motion core carries the reading (its slip, see
`MotionCore.slip_encoder`): no work per sample.

Simplified: beyond ±10 V the input clips but TP and the loop go on counting (the sensor's end of
range is not modelled); `AF 0` leaves the position reading where the sensor left it.
"""

from __future__ import annotations

import numpy as np

from vdevd.rt import MotionCore

COUNTS_PER_VOLT = 4096 / 20  # 12-bit ADC over ±10 V: 204.8 counts per volt
VOLT_STEP = 20 / 4096
ADC_MIN, ADC_MAX = -2048, 2047


def counts(volts: float) -> int:
    """The 12-bit reading of `volts` (-2048..2047)."""
    return int(min(max(round(volts * COUNTS_PER_VOLT), ADC_MIN), ADC_MAX))


def align(core: MotionCore, axis: int, reading: int, offset: float) -> None:
    """The main encoder of `axis` reads `reading` from now on (TP = encoder + `offset`, the
    card's stepper offset), the motor where it is: the difference is the encoder's slip."""
    ax = core.axes
    now = float(ax.encoder[axis]) + offset
    core.slip_encoder([axis], [now - reading])
    ax.encoder[axis] = reading - offset  # what the next tick's encoder will read
    ax.fb[axis] = ax.encoder[axis] / float(core.encoder_scale[axis])


def overlay(analog: np.ndarray, positions: np.ndarray, on: np.ndarray) -> np.ndarray:
    """The analog inputs AN1..AN8 as the card reads them: the channel of an AF axis reads its
    sensor, the axis's position in volts (quantised, within ±10 V)."""
    if not on.any():
        return analog
    volts = analog.copy()
    n = len(on)
    sensed = np.clip(np.rint(positions), ADC_MIN, ADC_MAX) * VOLT_STEP
    volts[:n] = np.where(on, sensed, analog[:n])
    return volts
