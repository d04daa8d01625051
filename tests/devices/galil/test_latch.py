"""The position latch: `AL` arms it, a falling edge of IN1..IN4 (the XLATCH..WLATCH inputs of
Fig 3-1) captures the X..W encoder, `RL` reports it [M Ch5 §Summary of Interrogation Commands];
`_ALx` reads 1 while armed, the record's switch byte bit 7 says a latch occurred and bit 6 gives
the latch input [M Ch4 §Explanation of Status Information]."""

from __future__ import annotations

import struct

import pytest
from vdevmaps.galil import AXIS_SIZE, FIRST_AXIS, AxisStatus, AxisSwitch
from vdevmaps.galil import REV4DMCDataRecordAxisOffsets as _A

from tests.devices.galil.conftest import Dmc

AXIS_BLOCK = FIRST_AXIS
STATUS, SWITCHES = int(_A.DRREV4AxisOffAxisStatus), int(_A.DRREV4AxisOffAxisSwitches)
LATCH_OCCURRED, LATCH_INPUT = int(AxisSwitch.LATCH_OCCURRED), int(AxisSwitch.LATCH_INPUT)
LATCH_ARMED = int(AxisStatus.LATCH_ARMED)  # axis status word
TS_LATCH_NOT_ARMED = 1 << 0  # TS bit 0 (spec §4.4)
SETTLE_S = 0.3


def switches(record: bytes, axis: int = 0) -> int:
    return record[AXIS_BLOCK + AXIS_SIZE * axis + SWITCHES]


def status(record: bytes, axis: int = 0) -> int:
    (word,) = struct.unpack_from("<H", record, AXIS_BLOCK + AXIS_SIZE * axis + STATUS)
    return int(word)


def test_al_arms_the_latch(dmc: Dmc) -> None:
    """_ALX 0 -> 1; TS bit 0 ("latch not armed") clears; status word bit 2 "Latch is armed"."""
    assert dmc.value("MG _ALX") == 0
    assert int(dmc.value("TS X")) & TS_LATCH_NOT_ARMED
    dmc.cmd("AL X")
    assert dmc.value("MG _ALX") == 1
    assert not int(dmc.value("TS X")) & TS_LATCH_NOT_ARMED
    dmc.step(0.02)
    assert status(dmc.record()) & LATCH_ARMED


@pytest.mark.parametrize(("axis", "letter"), list(enumerate("XYZW")))
def test_falling_edge_of_in1_to_in4_latches_the_x_to_w_encoder(dmc: Dmc, axis: int, letter: str) -> None:
    """A motor at rest at a known position: RL is its TP, the latch disarms, bit 7 is set and bit
    6 shows the input low; the other axes latch nothing."""
    target = [1234, -567, 89, -4321][axis]
    dmc.cmd(f"PR{',' * axis}{target};BG {letter};AM {letter}")
    dmc.step(SETTLE_S)
    dmc.cmd("AL XYZW")
    dmc.control("set_input", input=axis + 1, level=0)
    position = dmc.value(f"TP {letter}")
    assert abs(position - target) <= 1
    assert dmc.value(f"RL {letter}") == position
    assert dmc.value(f"MG _AL{letter}") == 0
    others = [a for a in "XYZW" if a != letter]
    assert all(dmc.value(f"MG _AL{a}") == 1 for a in others)
    dmc.step(0.02)
    record = dmc.record()
    assert switches(record, axis) & LATCH_OCCURRED
    assert not switches(record, axis) & LATCH_INPUT
    assert not status(record, axis) & LATCH_ARMED
    for other in set(range(4)) - {axis}:
        assert not switches(record, other) & LATCH_OCCURRED


def test_latch_during_a_jog_takes_the_position_of_the_edge(dmc: Dmc) -> None:
    """The latch captures the encoder when the edge comes, not when RL is asked."""
    dmc.cmd("AL X;JG 10000;BG X")
    dmc.step(0.2)
    before = dmc.value("TP X")
    dmc.control("set_input", input=1, level=0)
    after = dmc.value("TP X")
    latched = dmc.value("RL X")
    assert before <= latched <= after
    dmc.step(0.1)
    assert dmc.value("RL X") == latched
    assert dmc.value("TP X") >= latched + 10_000 * 0.1 - 10


def test_rising_edge_does_not_latch(dmc: Dmc) -> None:
    dmc.control("set_input", input=1, level=0)
    dmc.cmd("PR 500;BG X;AM X")
    dmc.step(SETTLE_S)
    dmc.cmd("AL X")
    dmc.control("set_input", input=1, level=1)
    assert dmc.value("MG _ALX") == 1
    assert dmc.value("RL X") == 0
    dmc.step(0.02)
    record = dmc.record()
    assert not switches(record) & LATCH_OCCURRED
    assert switches(record) & LATCH_INPUT


def test_unarmed_latch_ignores_edges_and_al_rearms_it(dmc: Dmc) -> None:
    """Without AL a falling edge latches nothing; after a latch a second edge does not overwrite it
    until AL again, which also clears "latch occurred"."""
    dmc.cmd("PR 300;BG X;AM X")
    dmc.step(SETTLE_S)
    dmc.control("set_input", input=1, level=0)
    assert dmc.value("RL X") == 0
    dmc.control("set_input", input=1, level=1)
    dmc.cmd("AL X")
    dmc.control("set_input", input=1, level=0)
    first = dmc.value("RL X")
    assert first == dmc.value("TP X")
    dmc.control("set_input", input=1, level=1)
    dmc.cmd("PR 700;BG X;AM X")
    dmc.step(SETTLE_S)
    dmc.control("set_input", input=1, level=0)
    assert dmc.value("RL X") == first
    dmc.control("set_input", input=1, level=1)
    dmc.cmd("AL X")
    dmc.step(0.02)
    assert not switches(dmc.record()) & LATCH_OCCURRED
    dmc.control("set_input", input=1, level=0)
    assert dmc.value("RL X") == dmc.value("TP X")
    assert abs(dmc.value("RL X") - 1000) <= 1
