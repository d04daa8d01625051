"""Servo cycles in which the card does nothing beside the firmware's tick run as a loop of those
ticks (card.py `PmacCard.run`): a card doing so and one running every cycle through `step` (its
`run` says none may) end every batch alike, in DPRAM, host port, interrupts, time, rest and
firmware state, with reporting buffers, motor interrupt sources, a sensed world, conversion
entries and A/D de-multiplexing that read memory at every cycle [spec pmac.md §2]."""

from __future__ import annotations

import random
from typing import Any

import pytest
from vdevmaps.pmac import IR_MASK

from tests.devices.twins import TwinCards
from vdevd.devices.pmac.card import PmacCard
from vdevd.devices.rest import state_bytes

JOG = "".join(f"#{m}J{'+' if m % 2 else '-'}" for m in range(1, 9))
#: motion, reporting buffers (I47-I50), a time-base entry on the servo clock (X:$000017, read at
#: every cycle), A/D de-multiplexing, software limits, kills
LINES = [JOG, "#1J/#2J/#3J/#4J/", "#5K#6K", "#1J=1000#7J^-333", "#2J:2500", "#1P#2V#3F#4?",
         "I48=1I47=3", "I48=0", "I49=1I50=7", "I49=0", "I8010=$400017I8011=1", "I8010=0",
         "I5060=2I5061=0I5080=1", "I5080=0", "I113=3000", "I113=0", "#8J=0", "#3J+"]
CONTROLS: list[tuple[str, dict[str, Any]]] = [
    ("set_home_window", {"axis": 2, "low": 300.0, "high": 900.0}),
    ("set_limit", {"axis": 1, "side": "positive", "active": True}),
    ("set_limit", {"axis": 1, "side": "positive", "active": False}),
]



class Twin(TwinCards):
    def __init__(self, skip_quiet: bool, plant: str) -> None:
        super().__init__(PmacCard, "pmac0", {"plant": plant, "ethernet": ""}, skip_quiet)
        self.replies: list[list[bytes]] = [[], []]

    def send(self, line: str) -> None:
        for card, replies in zip(self.cards, self.replies, strict=True):
            replies.append(card.host_port_state.command(line))

    def mask(self, value: int) -> None:
        for card in self.cards:
            card.host.write(IR_MASK, bytes([value]))

    def poke(self, offset: int, value: int) -> None:
        """A byte of the DPRAM written through the shared mapping: no access, no touch."""
        for card in self.cards:
            card.dpram.buf[offset] = value



    def same(self) -> None:
        fast, general = self.cards
        assert self.events[0] == self.events[1]
        assert self.replies[0] == self.replies[1]
        assert (fast.ticks, fast.now_ns, fast.quiet_skipped, fast.fw.now_ns, fast.fw.servo_cycles) == (
            general.ticks, general.now_ns, general.quiet_skipped, general.fw.now_ns,
            general.fw.servo_cycles)
        assert bytes(fast.dpram.buf) == bytes(general.dpram.buf)
        assert bytes(fast.host.buf) == bytes(general.host.buf)
        assert fast.fw.ect._res == general.fw.ect._res
        assert self._state(fast) == self._state(general)

    @staticmethod
    def _state(card: PmacCard) -> bytes:
        fw, m = card.fw, card.fw.motors
        fw.servo_ic.materialize()
        return state_bytes(card.irq, fw, m, m.pid, m.homing, fw.servo_ic, fw.gpio, fw.feedback,
                           m.core.axes, m.core.profile, skip=("p", "q"))


@pytest.mark.parametrize("skip_quiet", [True, False])
@pytest.mark.parametrize("seed", range(5))
def test_cycle_runs_end_each_batch_as_cycles_one_by_one(seed: int, skip_quiet: bool) -> None:
    rng = random.Random(seed)
    twin = Twin(skip_quiet, rng.choice(["servo", "ideal"]))
    for _ in range(40):
        roll = rng.random()
        if roll < 0.5:
            twin.send(rng.choice(LINES))
        elif roll < 0.6:
            twin.control(*rng.choice(CONTROLS))
        elif roll < 0.7:
            twin.mask(rng.choice([0, 0x0F]))
        elif roll < 0.8:  # the host takes a reporting buffer (data ready and host busy clear)
            for offset in rng.sample(range(0x000, 0x400, 2), 4):
                twin.poke(offset + 1, 0)
        for _ in range(rng.choice([1, 3])):
            twin.tick(rng.choice([1, 2, 5, 13, 63, 64, 65, 200, 700]))
            twin.same()


@pytest.mark.parametrize("setup", [["I48=1I47=5", JOG], ["I49=1I50=3", JOG],
                                   ["I8010=$400017I8011=1", JOG], ["I5060=2I5061=0I5080=1", JOG]])
def test_memory_read_at_every_cycle_reads_as_one_by_one(setup: list[str]) -> None:
    """A reporting buffer due at its multiple, an ECT entry on the servo clock, A/D pairs."""
    twin = Twin(True, "servo")
    for line in setup:
        twin.send(line)
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 20:
        twin.tick(n)
        twin.same()



@pytest.mark.parametrize("sensed", [True, False])
def test_a_sensed_stage_or_motor_interrupt_sources_act_as_one_by_one(sensed: bool) -> None:
    """A home switch crossed mid-batch (sensed at every cycle), or in-position and following
    error edges raising the host interrupt at their cycle."""
    twin = Twin(True, "servo")
    if sensed:
        twin.control("set_home_window", {"axis": 1, "low": 300.0, "high": 900.0})
        twin.send("#1HM")
    else:
        twin.mask(0x0D)  # in position, fatal and warning following error
    twin.send("I111=40I112=8#1J=1500#3J=-700#5J:900")
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 30:
        twin.tick(n)
        twin.same()
    assert twin.events[0] or sensed


@pytest.mark.parametrize("skip_quiet", [True, False])
def test_jog_until_trigger_a_sending_plc_and_a_slewing_override_act_as_one_by_one(
        skip_quiet: bool) -> None:
    """A jog-until-trigger meeting the home switch mid-batch, a PLC that SENDs into the DPRAM
    and waits on a C.S. timer, and `%` slewing at Isx94: batched cycles end as one by one."""
    twin = Twin(skip_quiet, "servo")
    twin.control("set_home_window", {"axis": 1, "low": 300.0, "high": 900.0})
    twin.send("I7012=2 #1J=3000^-50 #2J^-400^0 &1%20")
    twin.send("OPEN PLC 1 CLEAR")
    twin.send("I5111=30")
    twin.send("WHILE (I5111 > 0)")
    twin.send("ENDWHILE")
    twin.send('P1=P1+1 SEND"TICK" DISABLE PLC 1')
    twin.send("CLOSE ENABLE PLC 1")
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 30:
        twin.tick(n)
        twin.same()
    for card in twin.cards:
        assert card.fw.p[1] == 1  # the PLC ran past its timer and its SEND
        assert abs(card.fw.reports.position_of(0) - (300 - 50)) < 2  # triggered at the switch
        assert card.fw.timebase.present(0) == 20
