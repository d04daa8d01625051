"""Update cycles that are the motion core's tick alone run as a loop of core ticks (card.py
`MaxkCard.run`, `_run_core`): a card doing so and one running every cycle through `step` (its
`run` says none may) end every batch alike, in memory, message unit, interrupts, time and
rest, through random commands, backdoor actions and batch lengths (spec oms.md §2.4-2.5)."""

from __future__ import annotations

import random
from typing import Any

import pytest
from vdevmaps.oms import RING_SIZE, Mu, Omisr, Shm

from tests.devices.twins import TwinCards
from vdevd.devices.oms import rings
from vdevd.devices.oms.card import MaxkCard
from vdevd.devices.rest import state_bytes

#: moves, jogs, stops, kills, homes, loop and gain changes, waits and queued work, replies
COMMANDS = ["AA JG20000,-25000,30000,-35000,20000,-25000,30000,-35000;", "AX JG-3000;", "AA ST;",
            "AA MR1000,2000,-3000,500,100,200,300,400;AA GO;", "AX MR50000 GO ID;", "AY HM0;",
            "AZ LP500;", "AA VL5000;", "AT CL0;", "AT CL1;", "AA KL;", "AA RP;", "AX RE;",
            "AU KF30;", "AU KF0;", "AV MR-700 GO;", "AS WT50;", "AX MR300 GO WT20 MR-300 GO;",
            "AA QA;", "AX KF30;", "AX KF0;", "AT CL0;AT KO500;", "AT KO0;AT CL1;",
            "AY CPH5;", "AY CPH0;", "AX CPH2;", "AX CPH0;", "AY JG2000;", "AY JG-2000;"]
#: backdoor actions (a limit, a home switch at a position, the E-stop chain)
CONTROLS: list[tuple[str, dict[str, Any]]] = [
    ("set_limit", {"axis": "X", "side": "positive", "active": True}),
    ("set_limit", {"axis": "X", "side": "positive", "active": False}),
    ("set_home_edge", {"axis": "Y", "position": 150.0}),
    ("set_home_edge", {"axis": "Y", "position": -150.0}),
    ("set_home_edge", {"axis": "Y", "position": None}),
    ("set_estop", {"active": True}),
    ("set_estop", {"active": False}),
]



class Twin(TwinCards):
    def __init__(self, skip_quiet: bool) -> None:
        super().__init__(MaxkCard, "maxk0", {"board": 1}, skip_quiet)

    def send(self, text: str) -> None:
        data = text.encode()
        for card in self.cards:
            put = rings.u32(card.mem, Shm.COMMAND_INSERT)
            for i, c in enumerate(data):
                card.shm.write(Shm.COMMAND_RING + (put + i) % RING_SIZE, bytes([c]))
            card.shm.write(Shm.COMMAND_INSERT, ((put + len(data)) % RING_SIZE).to_bytes(4, "big"))

    def release(self) -> None:
        """Hand back a posted reply (0x0FC := 0x0F8, OM0I W1C, semaphore 0)."""
        for card in self.cards:
            end = rings.u32(card.mem, Shm.RESPONSE_INSERT)
            card.shm.write(Shm.RESPONSE_PROCESS, end.to_bytes(4, "big"))
            card.mu_region.write(Mu.OMISR, int(Omisr.OM0I).to_bytes(4, "little"))
            card.shm.write(Shm.MESSAGE_SEMAPHORE, bytes(4))



    def same(self) -> None:
        fast, general = self.cards
        assert self.events[0] == self.events[1]
        assert (fast.ticks, fast.now_ns, fast.fw.now_ns, fast.quiet_skipped) == (
            general.ticks, general.now_ns, general.fw.now_ns, general.quiet_skipped)
        assert bytes(fast.mem) == bytes(general.mem)
        assert bytes(fast.mu_region.buf) == bytes(general.mu_region.buf)
        assert [fast.mu.read(o) for o in range(0, 0x40, 4)] == [general.mu.read(o) for o in range(0, 0x40, 4)]
        core, other = fast.fw.motion.core, general.fw.motion.core
        assert core.axes.state.tobytes() == other.axes.state.tobytes()
        assert core.axes.flags.tobytes() == other.axes.flags.tobytes()
        assert self._firmware(fast) == self._firmware(general)

    @staticmethod
    def _firmware(card: MaxkCard) -> bytes:
        """Every array and number of the firmware's objects (what rest_state compares)."""
        fw, m = card.fw, card.fw.motion
        return state_bytes(fw, m, m.encoders, m.servo, fw.capture, m.core.axes, m.core.profile)


@pytest.mark.parametrize("skip_quiet", [True, False])
@pytest.mark.parametrize("seed", range(6))
def test_core_runs_end_each_batch_as_cycles_run_one_by_one(seed: int, skip_quiet: bool) -> None:
    rng = random.Random(seed)
    twin = Twin(skip_quiet)
    for _ in range(60):
        roll = rng.random()
        if roll < 0.55:
            twin.send(rng.choice(COMMANDS))
        elif roll < 0.65:
            twin.control(*rng.choice(CONTROLS))
        elif roll < 0.8:
            twin.release()
        twin.tick(rng.choice([1, 2, 7, 63, 64, 65, 200, 1000]))
        twin.same()


def test_a_jog_that_stops_runs_as_core_ticks_and_ends_as_one_by_one() -> None:
    """The plain case: a jog, a stop that ends in a DONE event inside a run, its interrupt."""
    twin = Twin(True)
    twin.send("AA JG20000,-25000,30000,-35000,20000,-25000,30000,-35000;")
    for n in (500, 1, 3, 700):
        twin.tick(n)
        twin.same()
    twin.send("AA ST ID;")
    for _ in range(40):
        twin.tick(97)
        twin.same()
    assert twin.events[0]  # the done interrupts came
    assert twin.cards[0].quiet_skipped > 0  # and the card came to rest


def test_a_home_search_over_a_switch_edge_ends_as_one_by_one() -> None:
    """Sensing the edge, the search, the capture of the home event: cycles with work."""
    twin = Twin(True)
    twin.control("set_home_edge", {"axis": "Y", "position": 3000.0})
    twin.send("AY CPH5;AY JG2000;")
    for _ in range(12):
        twin.tick(211)
        twin.same()
    twin.send("AY ST;")
    twin.tick(800)
    twin.send("AY HM0;")
    for _ in range(30):
        twin.tick(157)
        twin.release()
        twin.same()
    assert twin.events[0]


#: steps (commands, backdoor actions) that give the cycle a duty beside the core's tick
Step = str | tuple[str, dict[str, Any]]
DUTIES: dict[str, list[Step]] = {
    "friction output (KF)": ["AX KF30;", "AX JG5000;"],
    "open-loop output (KO)": ["AT CL0;AT KO500;"],
    "index capture": ["AX CPH2;", "AX JG20000;"],
    "index watched (HI)": ["AX HI;", "AX JG20000;"],
    "home capture": [("set_home_edge", {"axis": "Y", "position": 1000.0}), "AY CPH5;AY JG4000;"],
    "home switch edge": [("set_home_edge", {"axis": "Y", "position": 1000.0}), "AY JG4000;"],
    "home search": [("set_home_edge", {"axis": "Y", "position": 3000.0}), "AY HM0;"],
    "queued commands": ["AX MR3000 GO WT20 MR-3000 GO WT20 MR3000 GO;"],
    "position maintenance": ["AU PSE;AU CL1;AU HV500;AU HD2;AU MR1000 GO;",
                             ("set_encoder_slip", {"axis": "U", "counts": 40})],
    "sensed world": [("set_home_window", {"axis": "Z", "low": 500.0, "high": 900.0}), "AZ JG3000;"],
}


@pytest.mark.parametrize("duty", list(DUTIES))
def test_a_cycle_with_a_duty_beside_the_core_ends_as_one_by_one(duty: str) -> None:
    twin = Twin(True)
    for step in DUTIES[duty]:
        if isinstance(step, str):
            twin.send(step)
        else:
            twin.control(*step)
        twin.tick(5)
    twin.release()
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 25:  # no host access: runs up to 64 cycles
        twin.tick(n)
        twin.same()
