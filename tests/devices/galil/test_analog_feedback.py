"""AF, analog feedback: an axis's position read from the analog input of its number [M Ch1
§Encoder; spec §1; 12 bits over ±10 V, the sensor on the stage (README "Assumptions")]."""

from __future__ import annotations

import numpy as np
import pytest

from tests.devices.galil.test_firmware import PERIOD_NS, Rig
from vdevd.devices.galil.bus import A16Window
from vdevd.devices.galil.firmware import Firmware
from vdevd.devices.galil.record import record_dtype


def _drive(fw: Firmware, channel: int, volts: float) -> None:
    """The backdoor's set_analog, as the card does it: 12 bits, then the firmware told."""
    step = 20 / 4096
    fw.analog[channel - 1] = min(max(round(volts / step), -2048), 2047) * step
    fw.analog_driven(channel - 1)


def test_an_af_axis_reads_its_analog_input_in_12_bit_counts() -> None:
    rig = Rig()
    _drive(rig.fw, 1, 1.0)
    _drive(rig.fw, 2, 3.0)
    assert rig.send(b"TP\r") == b"0000000000,0000000000,0000000000,0000000000\r\n:"
    assert rig.send(b"AF 1;TP;TE\r") == (
        b":0000000205,0000000000,0000000000,0000000000\r\n:"
        b"-0000000205,0000000000,0000000000,0000000000\r\n:")
    assert rig.send(b"AF ?,?;MG _AFX,_AFY\r") == b"1,0\r\n: 0000000001.0000 0000000000.0000\r\n:"
    _drive(rig.fw, 1, -2.0)  # the sensor now reads -2 V: -409.6 -> -410
    assert rig.send(b"TPX;TEX\r") == b"-0000000410\r\n:0000000410\r\n:"
    _drive(rig.fw, 2, -1.0)  # not an AF axis: its encoder stays
    assert rig.send(b"TPY\r") == b"0000000000\r\n:"


def test_the_sensor_follows_the_motion_and_the_input_reads_it() -> None:
    rig = Rig()  # ideal plant: the stage follows the command
    _drive(rig.fw, 1, 1.0)
    rig.send(b"AF 1;PR 100;AC 67107840;BG X\r")
    for _ in range(50):
        rig.sample()
    assert rig.send(b"TPX;TEX;MG @AN[1]\r") == b"0000000305\r\n:-0000000205\r\n: 0000000001.4893\r\n:"
    rec = np.frombuffer(rig.fw.data_record(), dtype=record_dtype(4), count=1)[0]
    assert rec["axis"]["motor_position"][0] == 305
    assert rec["axis"]["analog_in"][0] == round(305 * 20 / 4096 * 3276.8)


def test_a_servo_loop_closes_on_the_analog_reading() -> None:
    """The error is RP - the analog reading: with 1 V on AN1 the loop drives the motor until the
    sensor reads the commanded 0, the motor 205 counts back."""
    bus = A16Window()
    fw = Firmware(4, PERIOD_NS, "servo", 1000, bus, raise_irq=lambda s: None,
                  clear_irq=lambda: None)
    _drive(fw, 1, 1.0)
    start = float(fw.motion.core.physical()[0])
    fw.interp.execute("AF 1")
    assert fw.interp.execute("TEX") == b"-0000000205\r\n:"
    fw.step()
    assert fw.interp.execute("TTX").startswith(b"-")  # the DAC pushes back
    for _ in range(3000):
        fw.step()
    assert abs(float(fw.motion.position()[0])) <= 2
    assert float(fw.motion.core.physical()[0]) - start == pytest.approx(-205, abs=3)


@pytest.mark.parametrize("bad", [b"AF 2", b"AF -1", b"AFX=0.5", b"AF ,,,,1"])
def test_bad_af_is_refused_and_changes_nothing(bad: bytes) -> None:
    rig = Rig()
    _drive(rig.fw, 1, 1.0)
    assert rig.send(bad + b"\r") == b"?"
    assert rig.send(b"TC\r") in (b"006\r\n:", b"004\r\n:")
    assert rig.send(b"AF ?;TPX\r") == b"0\r\n:0000000000\r\n:"


def test_rs_turns_analog_feedback_off() -> None:
    rig = Rig()
    _drive(rig.fw, 1, 1.0)
    assert rig.send(b"AF 1;RS;AF ?;MG @AN[1]\r") == b"::0\r\n: 0000000001.0010\r\n:"
