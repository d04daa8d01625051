"""The per-axis command queues (vdevd/devices/oms/queue.py; [S §6.2 "Theory of operation"],
[S App C "Programming": 2559 command values, loop counter], spec oms.md §3.4, §4.1, §5.1, §8.12):
`AxisQueue` without I/O, then ID, GO, AA/AM, ST/KL, RQC, LS/LE and the App C example through a
real card on the lockstep clock."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from vdevmaps.oms import MaxkDoorbell

from tests.devices.oms.conftest import Maxk
from vdevd.devices.oms.queue import CHAIN_LIMIT, QUEUE_UNITS, AxisQueue, Group, Item, Run

DONE_XY = MaxkDoorbell.DONE_X | MaxkDoorbell.DONE_Y
ALL_DONE = 0xFF

Log = list[tuple[str, int]]


# -- AxisQueue without I/O --------------------------------------------------------------------------
def at_once(log: Log, label: str, units: int = 1, group: Group | None = None) -> Item:
    """A command that completes when it runs (a parameter, MR/MA, ID)."""

    def make() -> Run:
        def run(axis: int) -> bool:
            log.append((label, axis))
            return True

        return run

    return Item(label, make, units, group)


def lasting(log: Log, label: str, cycles: int, units: int = 4,
            group: Group | None = None) -> Item:
    """A command that holds the queue for `cycles` update cycles (a move after GO)."""

    def make() -> Run:
        left = [cycles]

        def run(axis: int) -> bool:
            if left[0] == cycles:
                log.append((label, axis))
            left[0] -= 1
            return left[0] <= 0

        return run

    return Item(label, make, units, group)


def loop_start(count: int) -> Item:
    return Item("LS", lambda: (lambda axis: True), 2, kind="LS", count=count)


def loop_end() -> Item:
    return Item("LE", lambda: (lambda axis: True), 1, kind="LE")


def fill(queue: AxisQueue, *items: Item) -> None:
    for item in items:
        assert queue.push(item)


def run_cycles(queues: list[AxisQueue], cycles: int) -> None:
    """Update cycles as the firmware runs them: every axis's queue in canonical order."""
    for _ in range(cycles):
        for axis, queue in enumerate(queues):
            queue.advance(axis)


def labels(log: Log) -> list[str]:
    return [label for label, _ in log]


def test_commands_that_complete_at_once_are_chained_in_one_cycle() -> None:
    """spec §5.1 (3): "commands that complete instantly are chained within the same tick"."""
    log: Log = []
    q = AxisQueue()
    fill(q, at_once(log, "VL"), at_once(log, "AC"), at_once(log, "MR"))
    q.advance(0)
    assert labels(log) == ["VL", "AC", "MR"]
    assert q.idle and q.units == 0


def test_a_lasting_command_holds_the_commands_behind_it() -> None:
    """[S §6.2]: the commands are executed sequentially; GO expands into a move that takes time."""
    log: Log = []
    q = AxisQueue()
    fill(q, at_once(log, "MR"), lasting(log, "GO", cycles=3), at_once(log, "ID"))
    q.advance(0)
    assert labels(log) == ["MR", "GO"]
    q.advance(0)
    assert labels(log) == ["MR", "GO"]
    q.advance(0)
    assert labels(log) == ["MR", "GO", "ID"]
    assert q.idle


def test_chain_is_bounded_per_cycle() -> None:
    """spec §5.1: chained "up to a bound such as 64" commands per tick."""
    log: Log = []
    q = AxisQueue()
    fill(q, *(at_once(log, f"C{i}") for i in range(CHAIN_LIMIT + 10)))
    q.advance(0)
    assert len(log) == CHAIN_LIMIT
    q.advance(0)
    assert len(log) == CHAIN_LIMIT + 10


def test_queue_holds_2559_units() -> None:
    """[S App C]: "These command queues store 2559 command values"."""
    q = AxisQueue()
    assert q.free == QUEUE_UNITS == 2559
    for _ in range(2559):
        assert q.push(at_once([], "ID"))
    assert q.free == 0
    assert not q.push(at_once([], "ID"))
    assert q.units == 2559 and len(q.items) == 2559


def test_refused_push_changes_nothing() -> None:
    q = AxisQueue()
    fill(q, at_once([], "X", units=2558))
    assert not q.push(at_once([], "GO", units=4))
    assert q.units == 2558 and len(q.items) == 1
    assert q.push(at_once([], "ID", units=1))


def test_units_are_given_back_as_commands_complete() -> None:
    log: Log = []
    q = AxisQueue()
    fill(q, at_once(log, "MR", units=2), lasting(log, "GO", 2, units=4), at_once(log, "ID"))
    assert q.units == 7
    q.advance(0)
    assert q.units == 5  # MR done, GO running
    q.advance(0)
    assert q.units == 0


def test_flush_empties_the_queue_and_its_loops() -> None:
    """FL/ST/KL flush the queue (spec §4.3): nothing queued runs afterwards."""
    log: Log = []
    q = AxisQueue()
    fill(q, loop_start(5), lasting(log, "GO", 2), at_once(log, "ID"), loop_end())
    q.advance(0)
    q.flush()
    assert q.idle and q.units == 0 and q.loops == []
    for _ in range(10):
        q.advance(0)
    assert labels(log) == ["GO"]


def test_loop_repeats_its_body_the_loop_count_times() -> None:
    """[S §6.2]: "The LE command will decrement the loop count and jump to the most recent LS
    command providing the loop count has not reached zero"."""
    log: Log = []
    q = AxisQueue()
    fill(q, loop_start(3), at_once(log, "MR"), lasting(log, "GO", 2), loop_end(), at_once(log, "ID"))
    for _ in range(20):
        q.advance(0)
    assert labels(log) == ["MR", "GO"] * 3 + ["ID"]
    assert q.idle and q.units == 0


def test_nested_loops() -> None:
    """LS2 (LS3 A LE B) LE: A six times, B twice, in order."""
    log: Log = []
    q = AxisQueue()
    fill(q, loop_start(2), loop_start(3), at_once(log, "A"), loop_end(), at_once(log, "B"),
         loop_end())
    for _ in range(10):
        q.advance(0)
    assert labels(log) == ["A", "A", "A", "B"] * 2
    assert q.idle and q.loops == []


def test_loop_repeats_reuse_the_queue_space() -> None:
    """[S §6.2]: "the queue space will be flagged as available"; repeats cost no units."""
    log: Log = []
    q = AxisQueue()
    fill(q, loop_start(50), lasting(log, "GO", 1, units=4), loop_end())
    assert q.units == 7
    for _ in range(60):
        q.advance(0)
        assert q.units <= 7
    assert labels(log) == ["GO"] * 50
    assert q.units == 0


def test_loop_end_without_start_repeats_nothing() -> None:
    log: Log = []
    q = AxisQueue()
    fill(q, at_once(log, "A"), loop_end(), at_once(log, "B"))
    q.advance(0)
    assert labels(log) == ["A", "B"]


def test_group_waits_for_every_member() -> None:
    """An AA GO/ID: the command starts only when every member axis has reached it."""
    log: Log = []
    queues = [AxisQueue(), AxisQueue()]
    group = Group(frozenset({0, 1}))
    fill(queues[0], at_once(log, "GO", group=group))
    fill(queues[1], lasting(log, "earlier move", 3), at_once(log, "GO", group=group))
    queues[0].advance(0)
    queues[0].advance(0)
    assert log == []
    run_cycles(queues, 2)  # Y's earlier move still runs
    assert labels(log) == ["earlier move"]
    run_cycles(queues, 2)
    assert sorted(log[1:]) == [("GO", 0), ("GO", 1)]
    assert all(q.idle for q in queues)


def test_group_runs_on_every_member_in_the_same_cycle() -> None:
    """[S App C]: "Each axis programmed to move will start together upon executing the GO
    command"; spec §3.4: AA ID sets the done flags of all participating axes together."""
    log: Log = []
    queues = [AxisQueue(), AxisQueue()]
    group = Group(frozenset({0, 1}))
    fill(queues[0], at_once(log, "GO", group=group))
    fill(queues[1], at_once(log, "GO", group=group))
    run_cycles(queues, 1)
    assert sorted(log) == [("GO", 0), ("GO", 1)]


def test_group_inside_a_loop_runs_every_pass() -> None:
    """[S §6.2] loops and AA groups together: `AA; LS2,2; ...; GO; LE`."""
    log: Log = []
    queues = [AxisQueue(), AxisQueue()]
    group = Group(frozenset({0, 1}))
    for q in queues:
        fill(q, loop_start(2), at_once(log, "GO", group=group), loop_end())
    run_cycles(queues, 10)
    assert sorted(log) == [("GO", 0), ("GO", 0), ("GO", 1), ("GO", 1)]
    assert all(q.idle for q in queues)


# -- through the card ------------------------------------------------------------------------------
def done_bits(maxk: Maxk) -> int:
    return maxk.odbr() & ALL_DONE


def step_until(maxk: Maxk, condition: Callable[[], bool], limit: int, every: int = 1) -> int:
    """Step `every` cycles at a time until `condition()`; the cycles it took."""
    ticks = 0
    while not condition():
        assert ticks < limit, f"condition not met within {limit} update cycles"
        maxk.step(every)
        ticks += every
    return ticks


def test_id_sets_done_only_when_the_move_has_ended(maxk: Maxk) -> None:
    """[S App C]: "set the done flag for that axis when the move is finished"; spec §3.4: the
    QA 'D' and ODBR bit 0 are set when the queued ID executes."""
    maxk.send("AX VL10000; MR1000; GO; ID;")
    cycles = 0
    while cycles == 0 or maxk.query("RV;") != "0":
        assert done_bits(maxk) == 0, f"done bit set at cycle {cycles}, while moving"
        assert maxk.query("QA;")[1] == "N"
        assert cycles < 400, "the move does not end"
        maxk.step(1)
        cycles += 1
    # |d|/VL + VL/AC = 0.1 s + 0.005 s (spec §5.2) = 107.5 cycles of 976.5625 us, +-2 ticks
    assert abs(cycles - 107.5) <= 3
    maxk.step(2)
    assert maxk.query("RP;") == "1000"
    assert done_bits(maxk) == MaxkDoorbell.DONE_X
    assert maxk.query("QA;") == "PDNN"


def test_clearing_the_doorbell_does_not_clear_the_done_flag(maxk: Maxk) -> None:
    """spec §3.4: "Clearing the ODBR bit does not clear D"."""
    maxk.send("AX MR100; GO; ID;")
    maxk.step(100)
    assert done_bits(maxk) == MaxkDoorbell.DONE_X
    maxk.clear_odbr(MaxkDoorbell.DONE_X)
    assert done_bits(maxk) == 0
    assert maxk.query("QA;")[1] == "D"


def test_aa_move_id_waits_for_both_axes(maxk: Maxk) -> None:
    """`AA MR100,200; GO; ID`: ID fires when both X and Y have finished [S App C; spec §3.4]."""
    maxk.send("AA VL10000,10000; MR100,200; GO; ID;")
    x_done = step_until(maxk, lambda: maxk.query("AA RP;").startswith("100,"), limit=200)
    assert maxk.query("AA RV;").split(",")[1] != "0", "Y is still moving"
    assert done_bits(maxk) == 0
    step_until(maxk, lambda: maxk.query("AA RP;") == "100,200,0,0", limit=200)
    maxk.step(3)
    assert x_done > 0
    assert done_bits(maxk) == DONE_XY
    assert maxk.query("QI;") == "PDNN,PDNN,PNNN,PNNN"


def test_aa_go_starts_both_axes_in_the_same_update_cycle(maxk: Maxk) -> None:
    """[S App C]: "Each axis programmed to move will start together upon executing the GO
    command": after the first cycle X and Y move at the same speed."""
    maxk.send("AA MR100000,-100000; GO;")
    for _ in range(3):
        maxk.step(1)
        x, y, _z, _t = (int(v) for v in maxk.query("AA RV;").split(","))
        assert x == -y, f"RV {x},{y}"


def test_aa_id_sets_the_done_flags_in_the_same_update_cycle(maxk: Maxk) -> None:
    """spec §3.4: "In AA mode ID sets the done flags of all participating axes when all have
    finished"."""
    maxk.send("AA VL10000,10000; MR100,200; GO; ID;")
    step_until(maxk, lambda: done_bits(maxk) != 0, limit=300)
    assert done_bits(maxk) == DONE_XY


def test_am_axes_run_their_own_queues(maxk: Maxk) -> None:
    """AM, "Axis multitasking mode": each axis runs from its own queue (spec §4.1): Y finishes
    and flags done while X is still moving."""
    maxk.send("AM; VL10000,10000; MR100000,100; GO; ID;")
    step_until(maxk, lambda: bool(done_bits(maxk) & MaxkDoorbell.DONE_Y), limit=200)
    assert not done_bits(maxk) & MaxkDoorbell.DONE_X
    assert maxk.query("AA RV;").startswith("10000,0,")
    assert maxk.query("AY QA;")[1] == "D" and maxk.query("AX QA;")[1] == "N"


def test_single_axis_queues_are_independent(maxk: Maxk) -> None:
    """A long X move does not hold Y's commands."""
    maxk.send("AX VL1000; MR100000; GO; ID; AY MR100; GO; ID;")
    maxk.step(200)
    assert done_bits(maxk) == MaxkDoorbell.DONE_Y
    assert maxk.query("AA RP;").split(",")[1] == "100"


@pytest.mark.parametrize("stop", ["AX ST;", "KL;", "AA SA;", "AX FL ST;"])
def test_stop_flushes_the_queue_so_a_queued_id_never_fires(maxk: Maxk, stop: str) -> None:
    """ST/SA decelerate, KL stops at once; all flush the queue (spec §4.3), so the ID behind the
    move is discarded: no done flag, no doorbell."""
    maxk.send("AX VL10000; MR100000; GO; ID; MR5; GO; ID;")
    maxk.step(50)
    maxk.send(stop)
    assert maxk.query("AX RQC;") == "2559"
    maxk.step(500)
    assert maxk.query("RV;") == "0"
    assert done_bits(maxk) == 0
    assert maxk.query("QA;")[1] == "N"
    assert int(maxk.query("RP;")) < 1000


def test_st_decelerates_kl_does_not(maxk: Maxk) -> None:
    """ST: "stop ... with deceleration at AC"; KL: stop "immediately" (spec §4.3)."""
    maxk.send("AX VL10000; MR100000; GO; AY VL10000; MR100000; GO;")
    maxk.step(50)
    x_at_st = int(maxk.query("AX ST; RP;"))
    maxk.step(50)
    assert int(maxk.query("RP;")) - x_at_st == 25  # 10000^2 / (2 x 2,000,000) counts
    y_at_kl = int(maxk.query("KL; AY RP;"))
    maxk.step(50)
    assert int(maxk.query("RP;")) == y_at_kl
    assert maxk.query("AA RV;") == "0,0,0,0"


def test_rqc_decreases_as_commands_are_queued(maxk: Maxk) -> None:
    """RQC: remaining queue units [CRM-1-11]; spec §8.12: one unit per command plus one per
    operand, GO four. A running move holds the later commands in the queue."""
    maxk.send("AX VL1000; MR100000; GO;")
    maxk.step(2)
    assert maxk.query("RQC;") == "2555"  # the running GO
    assert maxk.query("MR100; RQC;") == "2553"
    assert maxk.query("GO; RQC;") == "2549"
    assert maxk.query("ID; RQC;") == "2548"
    assert maxk.query("AM; RQC;") == "2548,2559,2559,2559"
    maxk.send("AX ST;")
    assert maxk.query("RQC;") == "2559"


def test_queue_overflow_is_a_command_error(maxk: Maxk) -> None:
    """spec §4.4: queue overflow (> 2559 units) is a command error; the queue keeps what it had."""
    maxk.send("AX VL1; MR1000; GO;")
    maxk.step(2)
    for _ in range(2555 // 255):
        maxk.send("ID " * 255)
    maxk.send("ID " * (2555 % 255))
    assert maxk.query("RQC;") == "0"
    assert not maxk.command_error()
    maxk.send("ID;")
    assert maxk.command_error()
    assert maxk.query("RQC;") == "0"


def test_loop_repeats_the_move_three_times(maxk: Maxk) -> None:
    """[S §6.2] LS/LE: `LS3; MR100; GO; LE; ID` ends 3 x 100 counts away, then done."""
    maxk.send("AX VL10000; LS3; MR100; GO; LE; ID;")
    step_until(maxk, lambda: done_bits(maxk) != 0, limit=1000, every=10)
    assert maxk.query("RP;") == "300"
    assert maxk.query("RQC;") == "2559"


def test_nested_loops_on_the_card(maxk: Maxk) -> None:
    """LS2 (LS3 MR10 GO LE; MR1000 GO) LE = 2 x (30 + 1000)."""
    maxk.send("AX VL100000; LS2; LS3; MR10; GO; LE; MR1000; GO; LE; ID;")
    step_until(maxk, lambda: done_bits(maxk) != 0, limit=2000, every=10)
    assert maxk.query("RP;") == "2060"


def test_aa_move_inside_a_loop(maxk: Maxk) -> None:
    """`AA; LS2,2; MR100,100; GO; LE; ID` moves X and Y 200 counts each, then done."""
    maxk.send("AA; VL10000,10000; LS2,2; MR100,100; GO; LE; ID;")
    maxk.step(1000)
    assert maxk.query("AA RP;") == "200,200,0,0"
    assert done_bits(maxk) == DONE_XY


def test_app_c_example_1_home_then_absolute_move(maxk: Maxk) -> None:
    """[S App C "Programming examples"]: `AX; VL5000; AC50000; KP20; KI1; KD45; CL1; HM0;
    MA10000; GO; ID;` "Perform the home operation initializing the position counter to zero.
    Perform a motion to an absolute position of 10,000 and set the done flag for that axis when
    the move is finished." The home switch closes 200 cycles into the search."""
    maxk.send("AX; VL5000; AC50000; KP20; KI1; KD45; CL1; HM0; MA10000; GO; ID;")
    maxk.step(200)
    assert int(maxk.query("RV;")) > 0, "HM searches in the positive direction"
    assert done_bits(maxk) == 0
    maxk.control("set_home", axis="X", active=True)
    step_until(maxk, lambda: done_bits(maxk) != 0, limit=5000, every=50)
    assert maxk.query("RP;") == "10000"
    assert done_bits(maxk) == MaxkDoorbell.DONE_X
    assert maxk.query("QA;") == "PDNH"
    assert not maxk.odbr() & MaxkDoorbell.COMMAND_ERROR
