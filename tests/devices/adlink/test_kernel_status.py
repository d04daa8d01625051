"""The kernel's status words and interrupt conditions (one product of the stacked status rows),
and the edges of an interrupt enabled after cycles run with the interrupts off [M §4.8.1,
§4.1.1.4, §4.11]."""

from __future__ import annotations

import math

import numpy as np
from vdevmaps.adlink import BAR_SIZE, BY_NAME, encode
from vdevmaps.aps_defs import (
    MIO_ALM,
    MIO_EMG,
    MIO_EZ,
    MIO_INP,
    MIO_MEL,
    MIO_ORG,
    MIO_PEL,
    MIO_SMEL,
    MIO_SPEL,
    MIO_SVON,
    MTS_ACC,
    MTS_ASTP,
    MTS_BLD,
    MTS_CSTP,
    MTS_DEC,
    MTS_DIR,
    MTS_GER,
    MTS_HMV,
    MTS_JOG,
    MTS_MDN,
    MTS_POSTD,
    MTS_PRED,
    MTS_PTB,
    MTS_VM,
    MTS_WAIT,
)

from vdevd.devices.adlink.kernel import Kernel

NAN = math.nan
IMDN = 1 << 12


def kernel() -> tuple[Kernel, list[int]]:
    raised: list[int] = []
    k = Kernel(memoryview(bytearray(BAR_SIZE)), 8, 0x208, 15, 1000, "ideal",
               lambda: raised.append(k.cycles))
    for a in range(8):
        post(k, "set_servo_on", a, 1)
    return k, raised


def post(k: Kernel, name: str, *values: object) -> None:
    call = BY_NAME[name]
    k.execute(1, call.code, encode(call.args, list(values)))


def bit(flags: np.ndarray, n: int) -> np.ndarray:
    return flags.astype(np.int64) << n


def reference(k: Kernel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MSTS, MIO and the interrupt conditions bit by bit (as the kernel computed them before the
    stacked rows; DIR as the kernel keeps it)."""
    ax = k.core.axes
    v, acc = ax.cmd_vel, ax.cmd_acc
    moving = k.moving()
    speeding = moving & (((acc * v) > 0) | ((v == 0) & (acc != 0)))
    slowing = moving & ((acc * v) < 0)
    own = k.phase
    ph_acc = np.where(own > 0, own == 1, speeding) & moving
    ph_dec = np.where(own > 0, own == 3, slowing) & moving
    ph_vm = np.where(own > 0, own == 2, moving & ~speeding & ~slowing) & moving
    msts = (bit(~moving, MTS_CSTP) | bit(ph_vm, MTS_VM) | bit(ph_acc, MTS_ACC)
            | bit(ph_dec, MTS_DEC) | bit(k.direction, MTS_DIR) | bit(k.mdn, MTS_MDN)
            | bit(k.hmv, MTS_HMV) | bit(k.wait, MTS_WAIT) | bit(k.ptb, MTS_PTB)
            | bit(k.jog, MTS_JOG) | bit(k.astp, MTS_ASTP) | bit(k.bld, MTS_BLD)
            | bit(k.pred, MTS_PRED) | bit(k.postd, MTS_POSTD) | bit(k.ger, MTS_GER))
    mio = (bit(k.alm, MIO_ALM) | bit(k.pel, MIO_PEL) | bit(k.mel, MIO_MEL) | bit(k.org, MIO_ORG)
           | bit(np.full(k.n, k.emg), MIO_EMG) | bit(k.ez, MIO_EZ) | bit(k.inp, MIO_INP)
           | bit(k.svon, MIO_SVON) | bit(k.spel, MIO_SPEL) | bit(k.smel, MIO_SMEL))
    cond = ((mio & 0x7F)
            | ((msts >> MTS_CSTP) & 1) << 8 | ((msts >> MTS_VM) & 1) << 9
            | ((msts >> MTS_ACC) & 1) << 10 | ((msts >> MTS_DEC) & 1) << 11
            | ((msts >> MTS_MDN) & 1) << 12 | ((msts >> MTS_ASTP) & 1) << 13
            | ((mio >> MIO_SPEL) & 1) << 15 | ((mio >> MIO_SMEL) & 1) << 16
            | ((msts >> MTS_PRED) & 1) << 18 | ((msts >> MTS_POSTD) & 1) << 19)
    return msts, mio, cond


def check_words(k: Kernel) -> None:
    k.status_words()
    msts, mio, cond = reference(k)
    assert k.msts.tolist() == msts.tolist()
    assert k.mio.tolist() == mio.tolist()
    assert k.axis_cond.tolist() == cond.tolist()


def test_the_stacked_rows_give_the_words_bit_by_bit() -> None:
    """Accelerating, at speed, decelerating, stopped, both directions, limits and EMG."""
    k, _ = kernel()
    check_words(k)
    for a in range(8):
        post(k, "vel", a, 0, (1000.0 + 500 * a) * (-1) ** a, NAN, NAN, NAN, NAN, NAN)
    post(k, "ptp", 7, 1, 50.0, NAN, NAN, NAN, NAN, NAN, NAN)
    post(k, "set_axis_param_f", 2, 0x08, 1.0)  # soft PEL on at 0: axis 2 beyond it
    for _ in range(3):
        k.cycle()
        check_words(k)
    k.raw_pel[1], k.raw_alm[3], k.raw_emg = True, True, True
    k.logic()
    check_words(k)
    k.raw_emg = False
    for _ in range(40):
        k.cycle()
        check_words(k)
    post(k, "stop_move", [0])
    for _ in range(5):
        k.cycle()
        check_words(k)
    assert k.msts[7] >> MTS_MDN & 1 and k.mio[1] >> MIO_PEL & 1
    k.unit_moving[5:8], k.phase[5:8] = True, [1, 2, 3]  # a unit's axes: its phases
    check_words(k)
    assert [k.msts[a] >> b & 1 for a, b in ((5, MTS_ACC), (6, MTS_VM), (7, MTS_DEC))] == [1, 1, 1]


def test_an_interrupt_enabled_after_quiet_cycles_fires_on_the_next_edge_only() -> None:
    """Cycles with INT_MAIN 0 leave the conditions unset; the first command settles them on
    the last cycle's state, so a motion done before the interrupt came on raises nothing and
    one done after it does [M §4.11: a factor on the rising edge of its condition]."""
    k, raised = kernel()
    post(k, "ptp", 0, 1, 10.0, NAN, NAN, NAN, NAN, NAN, NAN)
    post(k, "ptp", 1, 1, 1000.0, NAN, NAN, NAN, NAN, NAN, NAN)
    for _ in range(20):
        k.cycle()
    assert k.mdn[0] and not k.mdn[1]
    post(k, "get_axis_param_f", 0, 0x24)  # any command: the conditions of the last cycle
    k.int_main, k.int_enable[0], k.int_enable[1] = True, IMDN, IMDN
    k.cycle()
    assert raised == [] and k.int_signal[0] == 0
    for _ in range(200):
        k.cycle()
        if raised:
            break
    assert raised and k.int_signal[1] == IMDN and k.int_signal[0] == 0


def test_a_limit_reached_between_quiet_cycles_is_an_edge() -> None:
    """The axis world changed before the interrupt came on: its edge is still taken against
    the last cycle (`settle_conditions` before the world is applied)."""
    k, raised = kernel()
    for _ in range(3):
        k.cycle()
    k.settle_conditions()  # what the card's apply_world does first
    k.raw_pel[4] = True
    k.logic()
    post(k, "get_axis_param_f", 0, 0x24)
    k.int_main, k.int_enable[4] = True, 1 << 1  # IPEL
    k.cycle()
    assert raised == [k.cycles] and k.int_signal[4] == 1 << 1
