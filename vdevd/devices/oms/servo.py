"""The MAXk servo law over the shared PID, in DAC counts (spec oms.md §5.3; [S §2.9, §2.13]).

    u   = KP·e + KI·I + KD·(e − e_prev) + KV·v·T + KA·a·T² + KF·sign(v) + KO
    I   = Σe, clamped so that |KI·I| <= KU (KU 0: no integral term)
    out = clamp(u, ±32767), negated by SVP−
    DAC = out (bipolar) or |out| with the sign on the direction output (unipolar)

e = command − encoder in counts, v and a the commanded velocity and acceleration, T the update
period: the gains act per update cycle, as the card computes them. ±32767 is ±10 V, so KO3277 is
about +1 V [S §2.9]. CL0/HF opens the loop: the output is KO alone [S §2.13], the command follows
the motor. An axis that is not a servo drives its DAC as a general-purpose analog output (AO,
[S §4.5.2]).

Unipolar output [S §4.6 "unipolar analog (0/+10V)", §2.14 "Servo axis unipolar/bipolar output";
spec §5.3]: the spec's clamp to 0..32767 alone could never drive a motor backwards, so a
unipolar servo axis drives |out| (0..+10 V) on its DAC and the sign on its direction output (the
axis's Direction pin of the connector, which a unipolar amplifier takes as its direction
input), as a sign-magnitude interface does. The amplifier, and so the simulated motor, still
gets the signed command: the loop closes both ways. SVP− negates `out`, so on a unipolar axis it
inverts the direction output and leaves the DAC word. The option (card option `servo_output`,
no command is known) applies to servo axes; a DAC used as an analog output (AO) stays ±10 V.

The simulated motor and amplifier (`MOTOR_SPEED_PER_VOLT`, `MOTOR_TIME_CONSTANT_S`) behave like a
velocity-mode drive tuned as [S §2.9] step 4 asks: one volt (KO3277) runs the motor at 10 % of a
400 000 counts/s peak, reached with a 5 ms time constant. On it the factory gains (KP 10, KD 160)
are stable at every update rate and settle a move to the count within about 0.15 s of its
profile's end. KI acts only once KU is set (KU 0 is the factory value: no integral term).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vdevd.devices.oms.params import Params
from vdevd.rt import MotionCore, PlantKind

DAC_FULL_SCALE = 32767  # 16-bit DAC, ±10 V [S §1.1]
COUNTS_PER_VOLT = DAC_FULL_SCALE / 10.0
MOTOR_SPEED_PER_VOLT = 40_000.0  # counts/s per volt, no load (1 V: 10 % of 400 000)
MOTOR_TIME_CONSTANT_S = 0.005


def plant_parameters() -> dict[str, float]:
    """The core's servo plant for the motor above: acceleration amp_gain·out − viscous·v, so
    that the speed settles at amp_gain/viscous counts/s per DAC count."""
    viscous = 1.0 / MOTOR_TIME_CONSTANT_S
    return {"amp_gain": MOTOR_SPEED_PER_VOLT / COUNTS_PER_VOLT * viscous, "viscous": viscous}


class ServoLaw:
    """Maps the gains of `params` onto `core.pid` and drives what the PID does not compute: the
    open-loop output (KO), the friction offset (KF·sign(v)) and the AO outputs. `apply()` once
    built and after any change of gains, axis type, polarity or loop state; `after_tick()` after
    every tick."""

    def __init__(self, core: MotionCore, params: Params) -> None:
        self.core = core
        self.params = params
        n = params.n
        self.analog_out = np.zeros(n)  # AO, DAC counts, axes that are not servos
        self._fixed = np.zeros(n, dtype=bool)  # outputs set here, not by the PID
        self._fixed_value = np.zeros(n)
        self._kf = np.zeros(n)  # signed KF of closed-loop servo axes (0 elsewhere)
        self._any_fixed = False
        self._any_kf = False
        self.acting = False  # `after_tick` sets an output (KF, KO, AO)
        self.unipolar_output = np.zeros(n, dtype=bool)  # card option servo_output, per axis
        self._unipolar = np.zeros(n, dtype=bool)  # ... on the axes that are servos now
        self._any_unipolar = False
        core.plant.set(slice(None), **plant_parameters())

    def set_output_modes(self, modes: Sequence[str]) -> None:
        """Per axis "bipolar" or "unipolar" (card option `servo_output` [S §2.14])."""
        self.unipolar_output[:] = [m == "unipolar" for m in modes]
        self.apply()

    def servo_axes(self) -> np.ndarray:
        """Axes that are servos (PSM) driving the servo plant (not under the ideal plant)."""
        kinds = self.core.kinds == PlantKind.SERVO
        return kinds & np.array([t == "M" for t in self.params.ptype])

    def apply(self) -> None:
        """The gains of every axis onto the PID, and the outputs set after each tick."""
        p, dt = self.params, self.core.dt
        v = p.values
        sign = np.where(p.servo_inverted, -1.0, 1.0)  # SVP- [S §2.9 step 5]
        ki = v["KI"]
        il = np.divide(v["KU"], ki, out=np.zeros(p.n), where=ki > 0)  # |KI·I| <= KU
        self.core.pid.set(slice(None), kp=sign * v["KP"], ki=sign * ki, kd=sign * v["KD"],
                          il=il, vff=sign * v["KV"] * dt, aff=sign * v["KA"] * dt * dt,
                          offset=sign * v["KO"], out_limit=DAC_FULL_SCALE)
        servo = self.servo_axes()
        closed = servo & self.core.servo_on_mask
        self._kf = np.where(closed, sign * v["KF"], 0.0)
        self._any_kf = bool(self._kf.any())
        self._fixed = ~closed
        self._fixed_value = np.where(servo, sign * v["KO"], self.analog_out)
        self._any_fixed = bool(self._fixed_value[self._fixed].any())
        self.acting = self._any_kf or self._any_fixed
        np.copyto(self.core.axes.out, self._fixed_value, where=self._fixed)  # the DAC at once
        self._unipolar = self.unipolar_output & np.array([t == "M" for t in p.ptype])
        self._any_unipolar = bool(self._unipolar.any())

    def set_analog_out(self, a: int, counts: float) -> None:
        """AO: the DAC of a non-servo axis as a general-purpose output."""
        self.analog_out[a] = counts
        self.apply()

    def after_tick(self) -> None:
        """KF on closed-loop servo axes, KO on open-loop ones, AO on the others (the PID wrote
        the output of this tick; the plant takes it at the next)."""
        out = self.core.axes.out
        if self._any_kf:
            out += self._kf * np.sign(self.core.axes.cmd_vel)
            np.clip(out, -DAC_FULL_SCALE, DAC_FULL_SCALE, out=out)
        if self._any_fixed:
            np.copyto(out, self._fixed_value, where=self._fixed)

    def signed_words(self) -> np.ndarray:
        """The output of every axis in whole DAC counts, signed, as a bipolar DAC holds it."""
        return np.rint(np.clip(self.core.axes.out, -DAC_FULL_SCALE, DAC_FULL_SCALE))

    def dac_words(self) -> np.ndarray:
        """The DAC words the card publishes [spec §2.2, §5.3]: the signed output, its magnitude
        on unipolar servo axes (0..32767 = 0..+10 V)."""
        words = self.signed_words()
        if self._any_unipolar:
            np.abs(words, out=words, where=self._unipolar)
        return words

    def direction_outputs(self, last_motion: np.ndarray) -> np.ndarray:
        """Each axis's direction output, True = positive: on a unipolar servo axis the sign of
        its output (the DAC word 0 counts as positive), elsewhere the direction of the last
        motion command (`last_motion`, +1/-1: a stepper's step direction)."""
        return np.where(self._unipolar, self.signed_words() >= 0, last_motion > 0)
