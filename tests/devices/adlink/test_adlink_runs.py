"""Motion cycles that are the motion core's tick alone run as a loop of core ticks (card.py
`AdlinkCard.run`, runs.py): a card doing so and one running every cycle through `step` (its
`run` says none may) end every batch alike, in BAR0, interrupts, time, rest and kernel state,
through PTP T- and S-curves, buffered segments with Ve > 0, velocity moves, stops, pre- and
post-distance events, MDN delays, limits hit mid-move, interrupts enabled mid-way, gearing and
the watchdog [M §4.4, §4.6, §4.8.1, §4.9.1, §4.10, §4.11]."""

from __future__ import annotations

import math
import random
import struct
from typing import Any

import pytest
from vdevmaps.adlink import BY_NAME, Bar, encode
from vdevmaps.aps_defs import (
    GEAR_DISABLE,
    GEAR_STANDARD,
    IACC,
    IMDN,
    IPOSTD,
    IPRED,
    IVM,
    OPT_RELATIVE,
    PRA_EL_MODE,
    PRA_GEAR_MASTER,
    PRA_MDN_DELAY,
    PRA_SF,
    PRA_SPEL_EN,
    PRA_SPEL_POS,
    PTP_OPT_BLEND_HIGH,
    PTP_OPT_BLEND_LOW,
    PTP_OPT_BUFFERED,
)

from tests.devices.twins import TwinCards
from vdevd.devices.adlink.card import AdlinkCard
from vdevd.devices.rest import state_bytes

NAN = math.nan
PRE_DIST, POST_DIST = 0x2A, 0x2B
Command = tuple[str, list[Any]]


class Counting(AdlinkCard):
    """The card, counting the cycles it ran in runs."""

    in_runs = 0

    def run(self, room: int) -> int:
        ran = super().run(room)
        self.in_runs += ran
        return ran


class Twin(TwinCards):
    def __init__(self, skip_quiet: bool = True, **config: Any) -> None:
        super().__init__(Counting, "amp0", {"model": "AMP-208C"} | config, skip_quiet)
        for card in self.cards:  # the load figures follow the wall clock: the same for both
            card.wall_ns = lambda: 0
        self.seq = 0
        self.acks: list[list[tuple[int, int]]] = [[], []]

    def post(self, name: str, *args: Any) -> None:
        """One kernel command through the mailbox of both cards."""
        call = BY_NAME[name]
        data = encode(call.args, list(args))
        self.seq += 1
        for card, acks in zip(self.cards, self.acks, strict=True):
            card.bar.write(Bar.CODE, struct.pack("<II", call.code, len(data)) + data)
            card.bar.write(Bar.DOORBELL, struct.pack("<I", self.seq))
            acks.append(struct.unpack("<IiII", card.bar.read(Bar.ACK_SEQ, 16))[1:3])

    def send(self, command: Command) -> None:
        self.post(command[0], *command[1])

    def same(self) -> None:
        fast, general = self.cards
        assert self.events[0] == self.events[1]
        assert self.acks[0] == self.acks[1]
        assert (fast.ticks, fast.now_ns, fast.quiet_skipped, fast.inta.asserted) == (
            general.ticks, general.now_ns, general.quiet_skipped, general.inta.asserted)
        assert bytes(fast.bar.buf) == bytes(general.bar.buf)
        assert self._state(fast) == self._state(general)

    @staticmethod
    def _state(card: AdlinkCard) -> bytes:
        """Every array and number of the kernel, its units and its motion core (the over-cycle
        flag `sys_events` aside: it follows the wall time a cycle took)."""
        k = card.kernel
        core = k.core
        return state_bytes(k, core, core.axes, core.profile, *k.units, skip=("sys_events",)) + \
            repr((k.mdn_due, k.queue, k.seg_plan)).encode()


def ptp(a: int, dist: float, sf: float = NAN, option: int = 0, vm: float = NAN,
        ve: float = NAN) -> Command:
    return "ptp", [a, OPT_RELATIVE | option, dist, NAN, vm, ve, NAN, NAN, sf]


def vel(a: int, v: float, sf: float = NAN) -> Command:
    return "vel", [a, 0, v, NAN, NAN, NAN, NAN, sf]


def param(a: int, no: int, value: float) -> Command:
    return "set_axis_param_f", [a, no, value]


#: moves (T- and S-curves, buffered and blended with Ve > 0), velocity moves, stops, the events
#: and delays that fall due mid-move, interrupts switched on and off
COMMANDS: list[Command] = [
    ptp(0, 20_000), ptp(0, -15_000, sf=1.0), ptp(1, 30_000, sf=0.5), ptp(2, -7_777, vm=50_000),
    ptp(3, 12_345, sf=0.3, vm=80_000),
    ptp(0, 9_000, option=PTP_OPT_BUFFERED, vm=60_000, ve=20_000),
    ptp(1, 9_000, option=PTP_OPT_BLEND_LOW, vm=70_000),
    ptp(1, -4_000, option=PTP_OPT_BLEND_HIGH, vm=40_000),
    ptp(4, 5_000, option=PTP_OPT_BUFFERED, vm=30_000, ve=10_000),
    vel(5, 40_000), vel(5, -25_000, sf=1.0), vel(6, 17_000), vel(7, -33_000, sf=0.5),
    ("stop_move", [[5]]), ("stop_move", [[0, 1, 2, 3]]), ("emg_stop", [[6]]),
    ("stop_move", [[7]]),
    param(0, PRE_DIST, 3_000), param(0, POST_DIST, 2_000), param(1, PRE_DIST, 0),
    param(2, POST_DIST, 500), param(3, PRA_MDN_DELAY, 7), param(3, PRA_MDN_DELAY, 0),
    param(4, PRA_SF, 1.0), param(2, PRA_EL_MODE, 1),
    ("int_enable", [1]), ("int_enable", [0]),
    ("set_int_factor", [0, IMDN, 1]), ("set_int_factor", [1, IPRED, 1]),
    ("set_int_factor", [2, IPOSTD, 1]), ("set_int_factor", [5, IVM, 1]),
    ("set_int_factor", [5, IVM, 0]), ("set_int_factor", [6, IACC, 1]),
    ("reset_int", [0, IMDN]),
    ("start_gear", [4, GEAR_STANDARD]), ("start_gear", [4, GEAR_DISABLE]),
    ("wdt_start", [0, 150]), ("wdt_start", [0, 0]),
]
#: backdoor actions: a limit hit mid-move, an alarm
CONTROLS: list[tuple[str, dict[str, Any]]] = [
    ("set_limit", {"axis": 2, "side": "negative", "active": True}),
    ("set_limit", {"axis": 2, "side": "negative", "active": False}),
    ("set_limit", {"axis": 6, "side": "positive", "active": True}),
    ("set_limit", {"axis": 6, "side": "positive", "active": False}),
    ("set_alarm", {"axis": 7, "active": True}),
    ("set_alarm", {"axis": 7, "active": False}),
]


def servo_on(twin: Twin) -> None:
    for a in range(8):
        twin.post("set_servo_on", a, 1)
    twin.send(param(4, PRA_GEAR_MASTER, 5))  # axis 4 follows axis 5 when geared


@pytest.mark.parametrize("drive", ["ideal", "servo"])
@pytest.mark.parametrize("seed", range(5))
def test_runs_end_each_batch_as_cycles_one_by_one(seed: int, drive: str) -> None:
    rng = random.Random(seed)
    twin = Twin(skip_quiet=seed % 2 == 0, drive=drive)
    servo_on(twin)
    for _ in range(70):
        roll = rng.random()
        if roll < 0.7:
            twin.send(rng.choice(COMMANDS))
        elif roll < 0.8:
            twin.control(*rng.choice(CONTROLS))
        twin.tick(rng.choice([1, 2, 7, 33, 63, 64, 65, 200, 500]))
        twin.same()
    assert twin.cards[0].in_runs > 100  # some cycles ran in runs


def test_a_velocity_move_of_every_axis_runs_and_stops_as_one_by_one() -> None:
    """The plain case (bench/aps.py): eight velocity moves, stopped, to rest."""
    twin = Twin()
    servo_on(twin)
    for a in range(8):
        twin.send(vel(a, (10_000.0 + 3_000.0 * a) * (1 if a % 2 == 0 else -1)))
    for n in (1, 500, 3, 1000):
        twin.tick(n)
        twin.same()
    twin.post("stop_move", list(range(8)))
    for _ in range(20):
        twin.tick(97)
        twin.same()
    assert twin.cards[0].quiet_skipped > 0  # the card came to rest
    assert twin.cards[0].in_runs > 1000


@pytest.mark.parametrize("sf", [0.0, 1.0])
def test_buffered_segments_and_distance_events_fall_at_their_cycle(sf: float) -> None:
    """Segment ends at Ve > 0 [M §4.6.4] and PRED/POSTD [M §4.8.1 bits 18-19] are due inside
    what would be a run: the cycle they fall in runs whole; their interrupts come alike."""
    twin = Twin()
    servo_on(twin)
    for name, args in (param(0, PRE_DIST, 1_234), param(0, POST_DIST, 777), ("int_enable", [1]),
                       ("set_int_factor", [0, IPRED, 1]), ("set_int_factor", [0, IPOSTD, 1]),
                       ("set_int_factor", [0, IMDN, 1])):
        twin.post(name, *args)
    twin.send(ptp(0, 10_000, sf=sf, vm=50_000, ve=20_000))
    for _ in range(3):
        twin.send(ptp(0, 8_000, sf=sf, option=PTP_OPT_BUFFERED, vm=40_000, ve=15_000))
    twin.send(ptp(0, 6_000, sf=sf, option=PTP_OPT_BUFFERED, vm=30_000, ve=0.0))
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 20:
        twin.tick(n)
        twin.same()
    assert len(twin.events[0]) >= 3
    assert twin.cards[0].in_runs > 100


def test_a_limit_hit_mid_move_and_interrupts_enabled_mid_way_act_as_one_by_one() -> None:
    twin = Twin()
    servo_on(twin)
    twin.send(vel(2, -30_000))
    twin.send(vel(3, 30_000))
    twin.send(param(3, PRA_SPEL_POS, 20_000))
    twin.tick(300)
    twin.same()
    twin.control("set_limit", {"axis": 2, "side": "negative", "active": True})
    twin.tick(150)
    twin.same()
    twin.post("int_enable", 1)
    twin.post("set_int_factor", 3, IMDN, 1)
    twin.send(param(3, PRA_SPEL_EN, 1))  # the soft limit ahead of the moving axis
    for n in [1, 2, 3, 5, 7, 11, 13, 17, 19, 23] * 10:
        twin.tick(n)
        twin.same()
    assert twin.events[0]
    assert twin.cards[0].in_runs > 100


@pytest.mark.parametrize("drive", ["ideal", "servo"])
def test_a_reversal_that_ends_inside_a_run_holds_the_last_direction(drive: str) -> None:
    """DIR follows the command velocity of a moving axis and is held after a stop [M §4.8.1
    bit 4]: a PTP on the fly to a point behind decelerates, reverses and ends inside one run
    (no look for rest bounds it); DIR and INP come out as cycle by cycle."""
    twin = Twin(skip_quiet=False, drive=drive)
    servo_on(twin)
    twin.send(vel(0, 20_000))
    twin.send(vel(1, -20_000))
    twin.tick(100)
    twin.same()
    twin.send(ptp(0, -1_500, vm=30_000))
    twin.send(ptp(1, 1_500, sf=1.0, vm=30_000))
    for _ in range(4):
        twin.tick(2_000)
        twin.same()
    k = twin.cards[0].kernel
    assert not k.direction[0] and k.direction[1]
    assert twin.cards[0].in_runs > 1000
