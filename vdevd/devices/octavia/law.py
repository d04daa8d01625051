"""The Octavia's control law mapped onto the shared motion core's PID [Ch1 Control Law, Ch5 CTRL,
CTRL_KA, KILIMIT, OUTGAIN, TRQ_LIMIT, OFFSET; spec octavia.md §5.2].

The manual gives the gains' scale factors, not the block diagram. vdevd's reading (README
"Control law"), with Ts = 200 us, e = command - actual (counts), velocities in counts/s:

    u [V] = 2^OUTGAIN * (Kp*0.595e-6*e + I + Kf*1.525e-8*v_cmd - Kd*1.9875e-8*v_act)
            + Ka*1.525e-8*Ts*a_cmd + V_offset,    I += Ki*3.308e-5*Ts*e, |I| <= 10 V / 2^KILIMIT

clamped to +-10 V * TRQ_LIMIT / 7FFFh. Kd acts on the actual velocity (state feedback, "dual
position and velocity loops"); with an exact encoder the speed estimate is the per-sample
difference, v_act = v_cmd - (e - e_prev)/Ts, so the law is the core's PID with
kd = G*Kd*1.9875e-8/Ts and a velocity feed-forward G*(Kf*1.525e-8 - Kd*1.9875e-8): the
manual's example gains (Kf 3000 ~ 1.3 x Kd 2500) nearly cancel the derivative's velocity term,
as the scales (1.9875/1.525 = 1.30) say they should. The core computes in DAC codes (7FFFh =
+10 V), so every gain is multiplied by 32767/10.
"""

from __future__ import annotations

import numpy as np

TS = 200e-6  # the sample [Ch5 State Variables]
DAC_PER_VOLT = 32767 / 10.0  # 7FFFh = +10 V [Ch5 DDAC]
KF_SCALE = 1.525e-8  # V/(counts/s) [Ch5 CTRL]
KP_SCALE = 0.595e-6  # V/count
KI_SCALE = 3.308e-5  # (V/s)/count
KD_SCALE = 1.9875e-8  # V/(counts/s)
#: Ka's scale is not given (spec Q-14): Kf's, applied to the per-sample velocity increment
KA_SCALE = KF_SCALE * TS
FULL_SCALE_V = 10.0
#: the servo plant every axis drives (an assumption, README): counts/s^2 per DAC code, chosen so
#: that the manual's example gains (Ki 100, Kp 4000, Kf 3000, Kd 2500 [Ch5 CTRL]) close the
#: loop at ~11 Hz with damping ~0.7
PLANT_AMP_GAIN = 575.0


def pid_params(ki: np.ndarray, kp: np.ndarray, kf: np.ndarray, kd: np.ndarray, ka: np.ndarray,
               outgain: np.ndarray, kilimit: np.ndarray, trq_limit: np.ndarray,
               offset_v: np.ndarray) -> dict[str, np.ndarray]:
    """The core PID's parameters (per axis, DAC codes) for the card's gains: CTRL's Ki, Kp, Kf,
    Kd, CTRL_KA's Ka (raw u16), OUTGAIN m (0..4), KILIMIT (0..14), TRQ_LIMIT (0..7FFFh), the
    OFFSET compensation in volts."""
    g = np.left_shift(1, outgain.astype(np.int64)) * DAC_PER_VOLT
    ki_v = ki * (KI_SCALE * TS)  # volts of integrator per count of error per sample
    # KILIMIT: the integral channel's action at most 10 V / 2^val (before OUTGAIN, spec §5.2)
    i_max = FULL_SCALE_V / np.left_shift(1, kilimit.astype(np.int64))
    il = np.divide(i_max, ki_v, out=np.full(len(ki), np.inf), where=ki_v > 0)
    return {
        "kp": g * kp * KP_SCALE,
        "ki": g * ki_v,
        "kd": g * kd * KD_SCALE / TS,
        "vff": g * (kf * KF_SCALE - kd * KD_SCALE),
        "aff": ka * KA_SCALE * DAC_PER_VOLT,
        "il": il,
        "offset": offset_v * DAC_PER_VOLT,
        "out_limit": np.asarray(trq_limit, dtype=float),
    }


def volts_to_dac(volts: float | np.ndarray) -> np.ndarray:
    """DAC codes of voltages: round(v/10 * 32767) within -32768..32767 [Ch5 DDAC]."""
    return np.clip(np.rint(np.asarray(volts, dtype=float) * DAC_PER_VOLT), -32768, 32767)


def dac_to_volts(dac: float | np.ndarray) -> np.ndarray:
    return np.asarray(dac, dtype=float) / DAC_PER_VOLT
