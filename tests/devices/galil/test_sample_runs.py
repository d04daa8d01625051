"""Samples with nothing to serve nor record run as a loop of motion and ER checks (card.py
`GalilCard.run`, firmware.py `run_samples`): a card doing so and one running every sample
through `step` (its `run` says none may) end every batch alike, in replies, data records,
interrupts, time, rest and firmware state, through random command lines, backdoor actions and
batch lengths [M Ch4]."""

from __future__ import annotations

import random
from typing import Any

import pytest
from vdevmaps.galil import IRQ_ENABLE_SEQUENCE, A16Reg

from tests.devices.twins import TwinCards
from vdevd.devices.galil.card import GalilCard
from vdevd.devices.rest import state_bytes

#: jogs, moves, stops, aborts, ER/OE trips, interrupts, data records, trippoints, searches
LINES = ["JG 20000,-25000,30000,-35000;BG ABCD", "JG -3000,4000;BG AB", "ST ABCD", "AB",
         "PR 1000,-2000,300,40;BG ABCD", "PA 0,0,0,0;BG ABCD", "KP 1;ER 1,2,3,4", "KP 6;ER 50",
         "OE 1,0,1,0", "MO C", "SH ABCD", "EI 255", "EI 0", "DR 2", "DR 0", "DR 5", "TP", "TV",
         "BG A;AM A", "PR 500;BG A;MC A", "WT 30", "FE B;BG B", "HM C;BG C", "JG 500;BG A",
         "IP 100", "PL 0.3", "PL 0", "AC 1000000;DC 1000000", "SP 3000",
         "PRN=3000;SPN=20000;BGN", "JGN=-4000;BG AN", "ST N", "GA N;GR 2", "GR 0"]
CONTROLS: list[tuple[str, dict[str, Any]]] = [
    ("set_home_window", {"axis": "B", "low": 300.0, "high": 900.0}),
    ("set_home_edge", {"axis": "B", "position": None}),
    ("set_limit", {"axis": "A", "side": "positive", "active": True}),
    ("set_limit", {"axis": "A", "side": "positive", "active": False}),
    ("set_estop", {"active": True}),
    ("set_estop", {"active": False}),
]



class Twin(TwinCards):
    def __init__(self, skip_quiet: bool, plant: str, **options: Any) -> None:
        super().__init__(GalilCard, "galil0", {"plant": plant, **options}, skip_quiet)
        for card in self.cards:
            for b in IRQ_ENABLE_SEQUENCE:  # the host enables the interrupt line
                card.a16.write(A16Reg.CONTROL, bytes([b]))

    def send(self, line: str) -> None:
        for card in self.cards:
            card.a16.write_rep(A16Reg.DATA, (line + "\r").encode())



    def same(self, read: bool) -> None:
        """Alike; `read`: the host reads the replies, the record and an interrupt status."""
        fast, general = self.cards
        assert self.events[0] == self.events[1]
        assert (fast.ticks, fast.now_ns, fast.quiet_skipped) == (
            general.ticks, general.now_ns, general.quiet_skipped)
        assert self._state(fast) == self._state(general)
        if read:
            for reg, size in ((A16Reg.DATA, 300), (A16Reg.SECONDARY_DATA, 400)):
                assert fast.a16.read_rep(reg, size) == general.a16.read_rep(reg, size)
            for b in (A16Reg.CONTROL,):
                assert fast.a16.read(b, 1) == general.a16.read(b, 1)

    @staticmethod
    def _state(card: GalilCard) -> bytes:
        fw, m, v = card.firmware, card.firmware.motion, card.firmware.virtual.core
        return b"".join((state_bytes(fw, m, m.core.axes, m.core.profile, v.axes, v.profile),
                         fw.bus.record_pending,
                         bytes(fw.bus.pending_interrupts), bytes(fw._out)))


@pytest.mark.parametrize("skip_quiet", [True, False])
@pytest.mark.parametrize("seed", range(6))
def test_sample_runs_end_each_batch_as_samples_one_by_one(seed: int, skip_quiet: bool) -> None:
    rng = random.Random(seed)
    twin = Twin(skip_quiet, rng.choice(["servo", "servo", "stepper", "ideal"]))
    for _ in range(50):
        roll = rng.random()
        if roll < 0.6:
            twin.send(rng.choice(LINES))
        elif roll < 0.7:
            twin.control(*rng.choice(CONTROLS))
        for _ in range(rng.choice([1, 3, 8])):
            twin.tick(rng.choice([1, 2, 5, 13, 63, 64, 65, 200, 700]))
            twin.same(read=rng.random() < 0.3)
    twin.same(read=True)


def test_a_move_that_completes_and_trips_er_in_a_run_ends_as_one_by_one() -> None:
    """The events a run stops at: axes completing (EI), an ER crossing with OE, a record."""
    twin = Twin(True, "servo")
    twin.send("EI 511;DR 4;KP 1;ER 3,3,3,3;OE 0,1,0,0;PR 4000,-4000,2000,0;BG ABC")
    for n in [1, 2, 5, 7, 11, 13, 17, 19, 23] * 30:
        twin.tick(n)
        twin.same(read=False)
    twin.same(read=True)
    assert len(twin.events[0]) >= 3


def test_a_stage_sensed_after_each_sample_ends_as_one_by_one() -> None:
    """A limit switch and a probe crossed mid-batch interrupt (EI bits 10, 15) at their sample."""
    twin = Twin(True, "servo", axis=[{"limits": [-3000, 3000]}, {"probe": [1500]}])
    twin.send("EI 33792,2;AL B;JG 8000,6000;BG AB")
    for n in [1, 2, 5, 7, 11, 13, 17, 19, 23] * 20:
        twin.tick(n)
        twin.same(read=False)
    assert len(twin.events[0]) >= 2


def test_a_reply_waiting_for_room_in_the_response_fifo_ends_as_one_by_one() -> None:
    """Replies that do not fit wait in the firmware until the host reads (at a sample)."""
    twin = Twin(False, "servo")
    twin.send("JG 20000,-25000,30000,-35000;BG ABCD")
    twin.send(";".join(["TP"] * 14))  # 14 replies of 42 bytes: the last waits in the firmware
    for n in [3, 64, 200, 7] * 8:
        twin.tick(n)
        twin.same(read=False)
        for card in twin.cards:
            card.a16.read_rep(A16Reg.DATA, 40)
