"""The status block of BAR0 as numpy views, and the motion status and motion I/O words
[M §4.8.1, §4.1.1.4; spec adlink.md §2.1, §2.14].

The axis records (`vdevmaps.adlink.Axis`) are two strided blocks over the bar's memory (their
I32 and their F64 fields), so the kernel publishes every axis in two assignments.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np
from vdevmaps.adlink import AXIS_STRIDE, Axis, Bar

from vdevd.region import Memory
from vdevd.rt.kernel import jit_disabled

log = logging.getLogger(__name__)


def axis_blocks(buf: Memory, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The n axis records of the bar as two (n, fields) views sharing its memory: the I32
    fields MSTS ... SERVO and the F64 fields CMD_POS ... FBK_VEL (each run contiguous in a
    record), so the kernel publishes every axis in two assignments."""
    ints = np.ndarray((n, 8), dtype="<i4", buffer=buf, offset=int(Bar.AXIS) + Axis.MSTS,
                      strides=(AXIS_STRIDE, 4))
    floats = np.ndarray((n, 6), dtype="<f8", buffer=buf, offset=int(Bar.AXIS) + Axis.CMD_POS,
                        strides=(AXIS_STRIDE, 8))
    return ints, floats


def u32_words(buf: Memory, offset: int, count: int) -> np.ndarray:
    return np.ndarray((count,), dtype="<u4", buffer=buf, offset=offset)


# -- compiled (numba): the status words and the axis records of every axis in one call each ------
# `Kernel.status_words` and `Kernel.publish` run these when numba is there (decision 0011's rule:
# the numpy path is the reference, the same IEEE operations per axis in the same order, so both
# write the same bytes; tests/devices/adlink/test_status_compiled.py compares them).

def words_py(vel: np.ndarray, gear_vel: np.ndarray, acc: np.ndarray, prof_moving: np.ndarray,
             unit_moving: np.ndarray, phase: np.ndarray, direction: np.ndarray,
             flags: tuple[np.ndarray, ...], emg: bool, weights: np.ndarray,
             out: np.ndarray) -> None:
    """`Kernel.status_words` per axis: the phase rows (CSTP, VM, ACC, DEC; a unit's `phase`
    first), DIR followed in place, then `out` (3, n) = `weights` @ the 25 rows (msts, mio, the
    interrupt conditions). `flags`: the rows after DIR in `_ROWS` order, EMG's left out (`emg`)."""
    mdn, hmv, wait, ptb, jog, astp, bld, pred, postd, ger, alm, pel, mel, org, ez, inp, svon, \
        spel, smel = flags
    for i in range(len(vel)):
        v = vel[i] + gear_vel[i]
        a = acc[i]
        mv = prof_moving[i] or unit_moving[i]
        av = a * v
        speeding = mv and (av > 0 or (v == 0 and a != 0))
        slowing = mv and av < 0
        own = phase[i]
        if own > 0:
            ph_acc, ph_vm, ph_dec = mv and own == 1, mv and own == 2, mv and own == 3
        else:
            ph_acc, ph_vm, ph_dec = speeding, mv and not speeding and not slowing, slowing
        if mv:
            d = v if v != 0 else a
            if d != 0:
                direction[i] = d > 0
        row = (not mv, ph_vm, ph_acc, ph_dec, direction[i], mdn[i], hmv[i], wait[i], ptb[i],
               jog[i], astp[i], bld[i], pred[i], postd[i], ger[i], alm[i], pel[i], mel[i],
               org[i], emg, ez[i], inp[i], svon[i], spel[i], smel[i])
        for w in range(3):
            total = 0
            for r in range(25):
                if row[r]:
                    total += weights[w, r]
            out[w, i] = total


def records_py(cmd_pos: np.ndarray, fb: np.ndarray, encoder: np.ndarray, factor: np.ndarray,
               cmd_off: np.ndarray, fb_off: np.ndarray, target: np.ndarray, at_cmd: np.ndarray,
               cmd_vel: np.ndarray, gear_vel: np.ndarray, vel: np.ndarray, servo_drive: bool,
               words: tuple[np.ndarray, ...], ints: np.ndarray, floats: np.ndarray) -> None:
    """`Kernel.publish`'s axis records: `ints` and `floats` as `axis_blocks` gives them.
    `words`: msts, mio, stop code, queue usage, gear status (int) and SVON (bool); `at_cmd`:
    the axes whose target shows the command position (velocity moves)."""
    msts, mio, stop_code, mq_usage, gear_status, svon = words
    for i in range(len(cmd_pos)):
        f = factor[i]
        ints[i, 0] = msts[i]
        ints[i, 1] = mio[i]
        ints[i, 2] = stop_code[i]
        ints[i, 3] = np.int64(np.rint(cmd_pos[i]))
        ints[i, 4] = encoder[i]
        ints[i, 5] = mq_usage[i]
        ints[i, 6] = gear_status[i]
        ints[i, 7] = 1 if svon[i] else 0
        cmd = cmd_pos[i] / f + cmd_off[i]
        fbk = fb[i] / f + fb_off[i]
        floats[i, 0] = cmd
        floats[i, 1] = fbk
        floats[i, 2] = cmd if at_cmd[i] else target[i]
        floats[i, 3] = cmd - fbk
        cv = cmd_vel[i] + gear_vel[i]
        floats[i, 4] = cv / f
        floats[i, 5] = (vel[i] if servo_drive else cv * (1.0 if svon[i] else 0.0)) / f


def signals_py(raw: tuple[np.ndarray, ...], values: np.ndarray, rows: np.ndarray,
               cmd_pos: np.ndarray, fb: np.ndarray, prof_moving: np.ndarray,
               unit_moving: np.ndarray, svon: np.ndarray, force: np.ndarray, window: float,
               cmd_off: np.ndarray, out: np.ndarray) -> None:
    """`Kernel.logic` per axis: `out` (8, n) = PEL, MEL, ORG, ALM, EZ, INP, SPEL, SMEL from the
    `raw` levels (PEL, MEL, ORG, ALM, EZ) and the axis parameters `values` at `rows` (EL, ORG,
    ALM, EZ and INP logic, soft limits on +/-, their positions, the unit factor)."""
    raw_pel, raw_mel, raw_org, raw_alm, raw_ez = raw
    el, org, alm, ez, inp_l, spel_en, smel_en, spel_at, smel_at, factor = (
        rows[0], rows[1], rows[2], rows[3], rows[4], rows[5], rows[6], rows[7], rows[8], rows[9])
    for i in range(len(cmd_pos)):
        out[0, i] = raw_pel[i] != (values[el, i] != 0)
        out[1, i] = raw_mel[i] != (values[el, i] != 0)
        out[2, i] = raw_org[i] != (values[org, i] != 0)
        out[3, i] = raw_alm[i] != (values[alm, i] != 0)
        out[4, i] = raw_ez[i] != (values[ez, i] != 0)
        if force[i] >= 0:
            inp = force[i] == 1
        else:
            mv = prof_moving[i] or unit_moving[i]
            inp = abs(cmd_pos[i] - fb[i]) <= window and not mv and svon[i]
        out[5, i] = inp != (values[inp_l, i] != 0)
        cmd = cmd_pos[i] / values[factor, i] + cmd_off[i]
        out[6, i] = values[spel_en, i] != 0 and cmd >= values[spel_at, i]
        out[7, i] = values[smel_en, i] != 0 and cmd <= values[smel_at, i]


@cache
def compiled() -> tuple[Callable[..., None], Callable[..., None], Callable[..., None]] | None:
    """(words, records, signals) compiled, or None without numba or with VDEVD_JIT=0 (as the
    motion core, vdevd.rt.kernel): then the kernel runs its numpy path."""
    if jit_disabled():
        return None
    try:
        import numba
    except ImportError:
        return None
    try:
        words = numba.njit(cache=True, nogil=True, boundscheck=False)(words_py)
        records = numba.njit(cache=True, nogil=True, boundscheck=False)(records_py)
        signals = numba.njit(cache=True, nogil=True, boundscheck=False)(signals_py)
        words(*_probe_words())
        records(*_probe_records())
        signals(*_probe_signals())
    except Exception as exc:  # noqa: BLE001 - any failure: the numpy path serves
        log.warning("the compiled status words are unavailable (%s): running numpy", exc)
        return None
    return words, records, signals


def _probe_words() -> tuple[Any, ...]:
    n, b = 1, np.zeros(1, dtype=bool)
    return (np.zeros(n), np.zeros(n), np.zeros(n), b, b, np.zeros(n, dtype=np.int8),
            np.zeros(n, dtype=bool), (b,) * 19, False, np.zeros((3, 25), dtype=np.int64),
            np.zeros((3, n), dtype=np.int64))


def _probe_records() -> tuple[Any, ...]:
    n, z, b = 1, np.zeros(1), np.zeros(1, dtype=bool)
    i32 = np.zeros(n, dtype=np.int32)
    ints, floats = axis_blocks(bytearray(0x2400), n)
    return (z, z, np.zeros(n, dtype=np.int64), np.ones(n), z, z, z, b, z, z, z, False,
            (np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64), i32, i32, i32, b),
            ints, floats)


def _probe_signals() -> tuple[Any, ...]:
    n, z, b = 1, np.zeros(1), np.zeros(1, dtype=bool)
    return ((b,) * 5, np.ones((12, n)), np.arange(10, dtype=np.intp), z, z, b, b, b,
            np.zeros(n, dtype=np.int8), 1.0, z, np.zeros((8, n), dtype=bool))
