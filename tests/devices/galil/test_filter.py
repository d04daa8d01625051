"""The digital filter's output stage (spec §5.1): OF offsets the DAC, TL clamps it, PL low-passes
the PID sum, on a motor held still by friction the DAC cannot overcome. TT is the DAC in volts;
the data record carries the torque as +-32767 for +-10 V [M Ch4 §Notes Regarding Velocity and
Torque]."""

from __future__ import annotations

import struct

import pytest

from tests.devices.galil.conftest import Dmc

COUNTS_PER_VOLT = 65536 / 20  # the 16-bit DAC: "K = 20/65536 = 0.0003 V/count" (spec §5.1)
TORQUE_FULL_SCALE = 32767  # the record's torque at +10 V
X_TORQUE = 40 + 24  # x,a axis torque, SW [M Ch4 §DMA / Secondary FIFO Memory Map]
STUCK_VOLTS = 10.0  # Coulomb friction beyond the DAC's +-10 V: the motor never moves


def dac_volts(volts: float) -> str:
    """TT of an output of `volts`: the nearest DAC count, in volts, format 1.4 (spec §5.1)."""
    return f"{round(volts * COUNTS_PER_VOLT) / COUNTS_PER_VOLT:.4f}"


def hold_still(dmc: Dmc) -> None:
    """X stuck by friction, its PID terms off: the DAC carries OF alone."""
    dmc.control("set_friction", axis="X", volts=STUCK_VOLTS)
    dmc.cmd("KP 0;KD 0;KI 0")


def test_of_1_volt_reads_on_tt_and_as_record_torque(dmc: Dmc) -> None:
    """OF 1: the DAC outputs 1 V (its nearest count, 3277); the record's torque is 1/10 of 32767."""
    hold_still(dmc)
    dmc.cmd("OF 1")
    dmc.step(0.01)
    assert dmc.cmd("TT X") == dac_volts(1.0)
    assert dmc.value("TP X") == 0
    (torque,) = struct.unpack_from("<h", dmc.record(), X_TORQUE)
    assert torque == pytest.approx(1.0 / 10 * TORQUE_FULL_SCALE, abs=1)


@pytest.mark.parametrize(("offset", "limit"), [(5, 2), (-5, 2), (1.5, 0.5)])
def test_tl_clamps_the_offset(dmc: Dmc, offset: float, limit: float) -> None:
    """TL limits the output in both directions: OF 5 with TL 2 gives 2 V (spec §5.1)."""
    hold_still(dmc)
    dmc.cmd(f"OF {offset};TL {limit}")
    dmc.step(0.002)
    assert dmc.cmd("TT X") == dac_volts(limit if offset > 0 else -limit)
    dmc.cmd("TL 9.998")
    dmc.step(0.002)
    assert dmc.cmd("TT X") == dac_volts(offset)


def test_pl_low_passes_the_pid_output_exponentially(dmc: Dmc) -> None:
    """PL B: L(z) = (1 - B)/(z - B) on the PID sum (spec §5.1). With the motor stuck 100 counts
    behind its reference and KP raised from 0 to 10, the PID sum steps to 4*KP*e counts; TT
    approaches it as 1 - B^n: 10 % after one sample at PL 0.9."""
    hold_still(dmc)
    error, kp, pole = 100, 10, 0.9
    dmc.cmd(f"PR {error};BG X;AM X")
    assert dmc.value("TE X") == error
    assert dmc.value("TT X") == 0
    dmc.cmd(f"PL {pole};KP {kp}")
    pid = 4 * kp * error / COUNTS_PER_VOLT  # volts
    for n in range(1, 8):
        dmc.rack.sim.step(ticks=1)
        assert dmc.cmd("TT X") == dac_volts(pid * (1 - pole**n)), n
    dmc.step(0.2)
    assert dmc.cmd("TT X") == dac_volts(pid)


def test_pl_leaves_the_offset_unfiltered(dmc: Dmc) -> None:
    """The card applies OF and TL after the low-pass (README "Motion": "PL is the low-pass ... on
    the PID sum, before OF and TL"): with PL 0.9 an OF step reaches TT in one sample."""
    hold_still(dmc)
    dmc.cmd("PL 0.9;OF 1")
    dmc.rack.sim.step(ticks=1)
    assert dmc.cmd("TT X") == dac_volts(1.0)
