"""The Servo IC's counters computed when read (servo_ic.py `ServoIC.tick`: the motors' positions
and counters kept at each cycle) read what an IC that computes them at every cycle reads: a
firmware's own IC and a twin over the same motors that cannot defer (no `keep_into`), ticked
together through random motion, slips, lost encoders, compare and capture, their registers and
ECT sources read at random cycles [spec pmac.md §1.5]."""

from __future__ import annotations

import random

import numpy as np
import pytest

from vdevd.devices.pmac.firmware import Firmware
from vdevd.devices.pmac.ivars import SERVO_IC_BASE
from vdevd.devices.pmac.memory import Memory
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.servo_ic import ServoIC

PERIOD_NS = 442_710
#: every register of the eight channels, X and Y (X:b+3 re-arms capture: read on both ICs)
REGISTERS = [(space, SERVO_IC_BASE[ic] + 8 * ch + r) for ic in (0, 1) for ch in range(4)
             for r in range(8) for space in "XY"]
COMMANDS = ["#1J+#2J-#3J+#4J-#5J+#6J-#7J+#8J-", "#1J/#2J/#3J/#4J/", "#5K#6K", "#1J=1000#7J^-333",
            "#2J:2500.5", "I7019=1", "I7019=0", "I7012=1", "I7022=3", "#8J/"]


class EagerEncoders:
    """The firmware's encoders without the deferred reading: counters computed every cycle."""

    def __init__(self, fw: Firmware) -> None:
        self.source = fw.servo_ic.encoders

    def encoder(self) -> np.ndarray:
        return self.source.encoder()

    def encoder_into(self, out: np.ndarray) -> None:
        self.source.encoder_into(out)  # type: ignore[attr-defined]


class Twin:
    def __init__(self, plant: str) -> None:
        self.fw = Firmware(8, PERIOD_NS, plant)
        self.fw.restore({})
        self.port = PortState()
        self.lazy = self.fw.servo_ic
        self.eager = ServoIC(Memory(), self.fw.ivars, EagerEncoders(self.fw))
        self.now = 0

    def tick(self) -> None:
        self.now += PERIOD_NS
        self.fw.tick(self.now)
        self.eager.tick()

    def same(self, space: str, addr: int) -> None:
        assert self.lazy.read_word(space, addr) == self.eager.read_word(space, addr), (space, addr)

    def write(self, space: str, addr: int, value: int) -> None:
        self.lazy.write_word(space, addr, value)
        self.eager.write_word(space, addr, value)

    def check_all(self) -> None:
        for space, addr in REGISTERS:
            self.same(space, addr)
        for c, base in enumerate(self.lazy.bases):
            for bits, hardware in ((5, False), (5, True), (8, False)):
                assert (self.lazy.extended_position(base, bits, hardware)
                        == self.eager.extended_position(base, bits, hardware))
            assert self.lazy.counter(c) == self.eager.counter(c)


@pytest.mark.parametrize("seed", range(6))
def test_counters_computed_when_read_read_as_computed_every_cycle(seed: int) -> None:
    rng = random.Random(seed)
    twin = Twin(rng.choice(["servo", "ideal"]))
    core = twin.fw.motors.core
    for _ in range(120):
        roll = rng.random()
        if roll < 0.25:
            twin.fw.execute(twin.port, rng.choice(COMMANDS))
        elif roll < 0.3:
            core.slip_encoder(rng.randrange(8), rng.choice([-3, 5, 0.0]))
        elif roll < 0.35:
            twin.fw.motors.set_encoder_losses(np.array([rng.random() < 0.2 for _ in range(8)]))
        elif roll < 0.4:  # arm compare on a channel (B, auto-increment), or disarm it
            base = twin.lazy.bases[rng.randrange(8)]
            twin.write("X", base + 7, rng.randrange(-2000, 2000))
            twin.write("X", base + 6, rng.choice([0, 0, 100]))
        elif roll < 0.5:
            space, addr = rng.choice(REGISTERS)
            twin.same(space, addr)
        for _ in range(rng.choice([1, 1, 2, 7, 40])):
            twin.tick()
        if rng.random() < 0.3:
            twin.check_all()
    twin.check_all()
    assert twin.lazy.materialize() is None
    assert twin.lazy._pos.tobytes() == twin.eager._pos.tobytes()
    assert twin.lazy._prev.tobytes() == twin.eager._prev.tobytes()


def test_armed_compare_sees_each_cycle_counters() -> None:
    """Compare runs at every cycle on the counters of this cycle and the last: the EQU output
    of a motor jogging through an auto-incremented compare toggles at the same cycles."""
    twin = Twin("servo")
    twin.fw.execute(twin.port, "#1J+#2J-")
    for c in (0, 1):
        twin.write("X", twin.lazy.bases[c] + 7, 200 * (1 - 2 * c))
        twin.write("X", twin.lazy.bases[c] + 6, 100)
    toggles = 0
    for _ in range(400):
        before = twin.eager.equ.copy()
        twin.tick()
        assert twin.lazy.equ.tolist() == twin.eager.equ.tolist()
        toggles += int((before != twin.eager.equ).any())
    assert toggles >= 4
