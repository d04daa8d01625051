"""The motion core's tick compiled (numba): one call per tick over two packed blocks instead of
~17 numpy calls on 4-8 element arrays (decision 0011).

The kernel does what `MotionCore.tick_numpy` does, in the same order and with the same IEEE
operations per axis, except two sums that numpy hands to BLAS (the profile's 3x3 product and the
PID's dot product): here they are added left to right, so results agree with the numpy path to
rounding, not to the bit. Without numba (or with VDEVD_JIT=0) the core runs the numpy path.

Blocks. `Axes.state` (11, n) as laid out by `Axes`, the encoder (int64), and the coefficient
block `coef` (ROWS, n) whose rows the core's parts own as views (they write them in place when
their parameters change): the servo plant's per-tick coefficients, the PID's gains and limits,
the following-error limit, the stepper's pulse generator, the profile's jerk step, and the core's
encoder and jam rows. `flags` holds per-axis switches (AX_*) and `m3` the profile's 3x3 step.

Staging (RECORD, issue 23 §1, decision 0016). While a scope records, `m3` is a taller block: its
rows 0-2 (columns 0-2) the step; column 0 of rows STAGED, COUNTDOWN, EVERY, NCOLS, SLOT, LIMIT the
stage's counters (as floats); rows CELL_ROWS and CELL_AXES the state row and the axis of each of
the NCOLS columns sampled; the rows from STAGE_HEAD on a ring of samples, one a row, in the
columns' order (the scope's recorder reads them there: no copy). The block is as wide as a sample
(3 columns at least), so the ring costs no more memory than the recorder's own. At the end of a
call with RECORD (`MotionCore.tick` sets it on the call that ends a tick) that does not return
1, the kernel counts COUNTDOWN down and, at 0, copies the state into ring row SLOT (then the
next, wrapping) and counts it in STAGED; it returns 2 once STAGED reaches LIMIT (the caller takes
the samples: STAGED 0, and sets SLOT and LIMIT). No extra argument (each costs the call some
30 ns), and nothing while RECORD is off.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

# -- rows of the coefficient block ----------------------------------------------------------------
GAIN_DT, PEAK_DT, DAMP, COUL_DT = 0, 1, 2, 3  # ServoPlant
PID_GAINS = 4  # 6 rows, matching Axes.pid_terms (cmd_vel, cmd_acc, one, integ, e_prev, ferr)
PID_INTEG = 10  # 1.0 where the axis integrates (ki != 0 and enabled)
PID_IL, PID_OUT_LIMIT = 11, 12
PID_HOLD_MOVING, PID_HOLD_SAT = 13, 14  # 1.0 where the integrator holds (Pid.set_hold)
FE_OVER = 15  # Limits: |ferr| above this trips (inf: off)
STEP_GEN, STEP_LIM = 16, 17  # StepperPlant: pulse generator position, pulses per tick
JSTEP = 18  # 3 rows: the profile's jerk step (j dt^3/6, j dt^2/2, j dt)
JAM_POS, SCALE, INV_SCALE, SLIP, ENC = 21, 22, 23, 24, 25  # MotionCore
ROWS = 26

# -- per-axis switches (MotionCore._configure) ----------------------------------------------------
AX_IDEAL, AX_STEP, AX_OFF, AX_JAM, AX_ENC_OK = 1, 2, 4, 8, 16

# -- what one call does (mode bits) ---------------------------------------------------------------
PLANT = 1  # the servo plant moves one period (axes of another kind: velocity 0)
PROFILE = 2  # the profile's step within its phases (no boundary due)
FOLLOW = 4  # ideal and stepper axes follow, jams, servo off, encoder, ferr, following-error check
PID = 8  # the controller output
PLAIN_ENCODER = 16  # no scale, slip or loss: fb = encoder = floor(pos)
STEPPERS = 32  # some stepper axis is on: the pulse generator runs (for every axis)
STEP_LIMITED = 64  # some stepper has a finite pulse rate
FRICTION = 128  # some servo axis has Coulomb friction
RECORD = 256  # a whole tick ends here: stage its sample (m3 is the stage block)
ALL = PLANT | PROFILE | FOLLOW | PID

# -- the stage block (RECORD): its counters' row and columns, then the samples' rows -----------------
STAGED, COUNTDOWN, EVERY, NCOLS, SLOT, LIMIT = range(3, 9)  # rows (column 0)
CELL_ROWS, CELL_AXES = 9, 10
STAGE_HEAD = 11  # rows before the ring's first
STAGE_COLS = 3  # the least width of a stage block (the step)

# the state rows (Axes)
_CMD_POS, _CMD_VEL, _CMD_ACC, _ONE, _INTEG, _E_PREV, _FERR, _POS, _VEL, _OUT, _FB = range(11)


def tick_py(mode: int, s: Any, encoder: Any, coef: Any, flags: Any, m3: Any, dt: float) -> int:
    """One tick (or the parts `mode` names) of every axis; 1 when a following error is over its
    limit (the PID is then not run: the caller trips and calls again with PID), 2 when the tick
    staged the LIMIT-th sample (RECORD), else 0."""
    n = s.shape[1]
    if mode & PLANT:
        friction = mode & FRICTION
        for i in range(n):  # ServoPlant.step
            dv = coef[GAIN_DT, i] * s[_OUT, i]
            dv = min(dv, coef[PEAK_DT, i])
            dv = max(dv, -coef[PEAK_DT, i])
            vel = s[_VEL, i] + dv
            if friction:
                c = coef[COUL_DT, i]
                vel = vel - max(min(vel, c), -c)
            vel = vel * coef[DAMP, i]
            s[_VEL, i] = vel
            s[_POS, i] = s[_POS, i] + vel * dt
    if mode & PROFILE:
        a01, a02, a12 = m3[0, 1], m3[0, 2], m3[1, 2]
        for i in range(n):
            p, v, a = s[_CMD_POS, i], s[_CMD_VEL, i], s[_CMD_ACC, i]
            s[_CMD_POS, i] = (p + a01 * v + a02 * a) + coef[JSTEP, i]
            s[_CMD_VEL, i] = (v + a12 * a) + coef[JSTEP + 1, i]
            s[_CMD_ACC, i] = a + coef[JSTEP + 2, i]
    over = 0
    if mode & FOLLOW:
        steppers = mode & STEPPERS
        limited = mode & STEP_LIMITED
        plain = mode & PLAIN_ENCODER
        for i in range(n):
            f = flags[i]
            if f & AX_IDEAL:
                s[_POS, i] = s[_CMD_POS, i]
                s[_VEL, i] = s[_CMD_VEL, i]
            if steppers and limited:  # StepperPlant.step: the generator runs for every axis
                d = np.rint(s[_CMD_POS, i]) - coef[STEP_GEN, i]
                d = min(d, coef[STEP_LIM, i])
                d = max(d, -coef[STEP_LIM, i])
                coef[STEP_GEN, i] = coef[STEP_GEN, i] + d
            elif steppers:
                coef[STEP_GEN, i] = np.rint(s[_CMD_POS, i])
            if f & AX_STEP:
                whole = np.rint(coef[STEP_GEN, i])
                s[_VEL, i] = (whole - s[_POS, i]) * (1.0 / dt)
                s[_POS, i] = whole
            if f & AX_JAM:
                s[_POS, i] = coef[JAM_POS, i]
                s[_VEL, i] = 0.0
            if f & AX_OFF:
                s[_CMD_POS, i] = s[_POS, i]
            if plain:
                fb = np.floor(s[_POS, i])
                s[_FB, i] = fb
                encoder[i] = np.int64(fb)
            else:
                e = np.floor(s[_POS, i] * coef[SCALE, i]) - coef[SLIP, i]
                if f & AX_ENC_OK:
                    coef[ENC, i] = e
                encoder[i] = np.int64(coef[ENC, i])
                s[_FB, i] = coef[ENC, i] * coef[INV_SCALE, i]
            ferr = s[_CMD_POS, i] - s[_FB, i]
            s[_FERR, i] = ferr
            if abs(ferr) > coef[FE_OVER, i]:  # inf where no limit is set
                over = 1
    if over:
        return 1
    if mode & PID:
        for i in range(n):  # Pid.update
            e = s[_FERR, i]
            integ = s[_INTEG, i]
            if coef[PID_INTEG, i] != 0.0:
                if ((coef[PID_HOLD_MOVING, i] != 0.0 and s[_CMD_VEL, i] != 0.0)
                        or (coef[PID_HOLD_SAT, i] != 0.0 and abs(s[_OUT, i]) >= coef[PID_OUT_LIMIT, i])):
                    integ = integ - e  # held: the error is taken back out (Pid.update)
                integ = integ + e
            integ = min(integ, coef[PID_IL, i])
            integ = max(integ, -coef[PID_IL, i])
            s[_INTEG, i] = integ
            out = coef[PID_GAINS, i] * s[_CMD_VEL, i]
            out = out + coef[PID_GAINS + 1, i] * s[_CMD_ACC, i]
            out = out + coef[PID_GAINS + 2, i] * s[_ONE, i]
            out = out + coef[PID_GAINS + 3, i] * integ
            out = out + coef[PID_GAINS + 4, i] * s[_E_PREV, i]
            out = out + coef[PID_GAINS + 5, i] * e
            out = min(out, coef[PID_OUT_LIMIT, i])
            out = max(out, -coef[PID_OUT_LIMIT, i])
            s[_OUT, i] = out
            s[_E_PREV, i] = e
    if mode & RECORD:  # the tick is whole: its sample, every EVERY ticks
        c = m3[COUNTDOWN, 0] - 1.0
        if c > 0.0:
            m3[COUNTDOWN, 0] = c
            return 0
        m3[COUNTDOWN, 0] = m3[EVERY, 0]
        row = STAGE_HEAD + int(m3[SLOT, 0])
        for j in range(int(m3[NCOLS, 0])):
            m3[row, j] = s[int(m3[CELL_ROWS, j]), int(m3[CELL_AXES, j])]
        m3[SLOT, 0] = 0.0 if row + 1 == m3.shape[0] else row + 1 - STAGE_HEAD
        k = m3[STAGED, 0] + 1.0
        m3[STAGED, 0] = k
        if k >= m3[LIMIT, 0]:
            return 2
    return 0


Kernel = Callable[[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, float], int]


def jit_disabled() -> bool:
    """Whether VDEVD_JIT turns the compiled core off (0, no, false, off)."""
    return os.environ.get("VDEVD_JIT", "1").strip().lower() in ("0", "no", "false", "off")


@cache
def compiled() -> Kernel | None:
    """The compiled tick (loaded from numba's cache after the first compilation on this
    machine), or None when numba is missing, VDEVD_JIT=0, or compiling failed (logged once)."""
    return _jit(tick_py, _probe_args(), "the compiled motion core", "the motion core runs its "
                "numpy path")


def _jit(fn: Callable[..., Any], probe: tuple[Any, ...], what: str, fallback: str) -> Any:
    """`fn` compiled (nopython, cached beside the module) and called once on `probe`; None
    without numba, with VDEVD_JIT=0, or when compiling fails (logged)."""
    if jit_disabled():
        return None
    try:
        import numba
    except ImportError:
        log.info("numba is not installed: %s", fallback)
        return None
    for cache_it in (True, False):  # an unwritable cache directory: compile for this process
        try:
            jitted = numba.njit(cache=cache_it, nogil=True, boundscheck=False)(fn)
            jitted(*probe)
            return jitted
        except Exception as exc:  # noqa: BLE001 - any failure: the Python path serves
            failure = exc
    log.warning("%s is unavailable (%s): %s", what, failure, fallback)
    return None


def _probe_args() -> tuple[Any, ...]:
    """Arguments of the kernel's one signature, for the first call (compile or cache load)."""
    n = 1
    return (0, np.zeros((11, n)), np.zeros(n, dtype=np.int64), np.zeros((ROWS, n)),
            np.zeros(n, dtype=np.int64), np.eye(3), 1e-3)
