"""The scope's ring buffer and trigger machine, sans-I/O (vdevd/scope/recorder.py, trigger.py):
the window a trigger keeps with its pre-trigger samples across the ring's wrap, blocks written
past the window's end, rest fills, and each trigger kind's edges."""

from __future__ import annotations

import numpy as np
import pytest

from vdevd.scope.recorder import ARMED, DONE, RECORDING, Recorder
from vdevd.scope.trigger import Trigger, TriggerMachine


def block(first: int, m: int, columns: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Samples first .. first + m - 1: times 10 x index, column c = index + 1000 c."""
    idx = np.arange(first, first + m)
    return idx * 10, np.stack([idx + 1000.0 * c for c in range(columns)], axis=1)


def test_now_keeps_the_first_capacity_samples_then_is_done() -> None:
    rec = Recorder(2, 0, 5, 0, TriggerMachine(Trigger("now")))
    assert rec.state == RECORDING and rec.trigger_index == 0
    rec.write(*block(0, 3))
    assert rec.state == RECORDING and rec.available == 3
    rec.write(*block(3, 4))  # two past the end: dropped
    assert rec.state == DONE and rec.written == 5
    times, values, _ = rec.window(0, 100)
    assert times.tolist() == [0, 10, 20, 30, 40] and values[:, 1].tolist() == [
        1000, 1001, 1002, 1003, 1004]


def test_pre_trigger_samples_across_the_ring_wrap() -> None:
    """Capacity 8, pre 3: armed for 21 samples (the ring wrapped twice), fired at 21: keeps
    18..28."""
    machine = TriggerMachine(Trigger("irq"), irq_seq=4)
    rec = Recorder(2, 0, 8, 3, machine)
    for first in range(0, 21, 7):
        rec.write(*block(first, 7))
    assert rec.state == ARMED and rec.available == 0
    assert not machine.irq(4) and machine.irq(5)
    rec.fire(rec.written)  # the next sample is the trigger's
    assert rec.state == RECORDING and rec.start == 18 and rec.end == 26
    rec.write(*block(21, 10))
    assert rec.state == DONE
    times, values, _ = rec.window(0, 100)
    assert (times // 10).tolist() == list(range(18, 26))
    assert rec.trigger_index - rec.start == 3


def test_fewer_pre_trigger_samples_when_fewer_were_taken() -> None:
    rec = Recorder(1, 0, 10, 6, TriggerMachine(Trigger("irq")))
    rec.write(*block(0, 2, 1))
    rec.fire(1)
    assert rec.start == 0 and rec.end == 5
    rec.write(*block(2, 9, 1))
    times, _, _ = rec.window(0, 100)
    assert (times // 10).tolist() == [0, 1, 2, 3, 4]


def test_position_trigger_in_the_middle_of_a_block() -> None:
    t = Trigger("position", axis=0, level=5.5, direction="rising")
    rec = Recorder(1, 0, 6, 2, TriggerMachine(t), watch=0)
    rec.write(*block(0, 20, 1))  # crosses 5.5 between samples 5 and 6
    assert rec.state == DONE and rec.trigger_index == 6
    _, values, _ = rec.window(0, 100)
    assert values[:, 0].tolist() == [4, 5, 6, 7, 8, 9]


def test_rest_fills_with_the_resting_row_and_stops_at_the_end() -> None:
    rec = Recorder(2, 1, 4, 0, TriggerMachine(Trigger("now")))
    rec.write(*block(0, 1), np.array([[7]]))
    rec.rest(10**9, lambda j: 100 + j * 10, np.array([1.5, 2.5]), np.array([9]))
    assert rec.state == DONE and rec.written == 4
    times, values, words = rec.window(0, 10)
    assert times.tolist() == [0, 100, 110, 120]
    assert values[1:].tolist() == [[1.5, 2.5]] * 3 and words[:, 0].tolist() == [7, 9, 9, 9]


def test_rest_while_armed_keeps_the_last_capacity_samples() -> None:
    rec = Recorder(1, 0, 3, 2, TriggerMachine(Trigger("irq")))
    rec.rest(10**6, lambda j: j, np.array([4.0]))
    assert rec.written == 10**6 and rec.state == ARMED
    rec.fire(rec.written)
    rec.write(np.array([10**6]), np.array([[5.0]]))
    times, values, _ = rec.window(0, 10)
    assert times.tolist() == [10**6 - 2, 10**6 - 1, 10**6] and values[:, 0].tolist() == [4, 4, 5]


@pytest.mark.parametrize(("direction", "values", "hit"), [
    ("rising", [0, 4, 5, 9, 3], 2),  # reaching the level counts
    ("rising", [9, 4, 3], -1),
    ("falling", [0, 9, 5, 4], 2),
    ("falling", [0, 4, 9], -1),
    ("either", [9, 9, 2], 2),
    ("either", [0, 7], 1),
])
def test_position_directions(direction: str, values: list[float], hit: int) -> None:
    m = TriggerMachine(Trigger("position", level=5.0, direction=direction))
    assert m.position(np.array(values, dtype=float)) == hit
    assert m.fired == (hit >= 0)


def test_position_crossing_between_two_blocks_and_once_only() -> None:
    m = TriggerMachine(Trigger("position", level=5.0))
    assert m.position(np.array([1.0, 4.0])) == -1
    assert m.position(np.array([6.0, 7.0])) == 0  # 4 -> 6 across the blocks
    assert m.position(np.array([1.0, 8.0])) == -1  # fired: no more


def test_register_change_and_value() -> None:
    any_change = TriggerMachine(Trigger("register", mask=0x0F), register=0x31)
    assert not any_change.register(0xF1)  # outside the mask
    assert any_change.register(0x32)
    to_value = TriggerMachine(Trigger("register", mask=0x3, value=0x2), register=0x0)
    assert not to_value.register(0x1)  # a change, not to the value
    assert not to_value.register(0x1)
    assert to_value.register(0x6) and to_value.fired
    assert not to_value.register(0x0)


def test_irq_fires_on_a_later_sequence_number() -> None:
    m = TriggerMachine(Trigger("irq"), irq_seq=7)
    assert not m.irq(7) and m.irq(8) and not m.irq(9)


def test_bad_capacity_or_pre() -> None:
    with pytest.raises(ValueError):
        Recorder(1, 0, 4, 4, TriggerMachine(Trigger()))
    with pytest.raises(ValueError):
        Recorder(1, 0, 0, 0, TriggerMachine(Trigger()))


def test_an_armed_recording_pickles_and_records_on() -> None:
    """Snapshots pickle the rack: the recorder, its hooks and the trigger machine are plain
    objects (the card and its core are the snapshot's own business, referred to here by
    persistent ids and restored as a card brought to the same state). The restored recorder
    records on the restored core's state block (views rebuilt, not copies of the old one) and
    ends with the very samples of the original."""
    import io
    import pickle
    from typing import Any

    from vdevd.devices import card_class
    from vdevd.devices.base import CardContext
    from vdevd.rack import Rack
    from vdevd.scope.op import Scopes
    from vdevd.scope.probe import CoreSkip

    def make() -> tuple[Any, Rack]:
        card = card_class("generic-servo")("c", {"plant": "ideal"}, CardContext(emit=print))
        card.core.move_absolute(0, 100, 1000, 10_000, 10_000, 0)
        card.touched()
        return card, Rack([card])

    card, rack = make()
    scopes = Scopes()
    scopes.op(card, {"action": "arm", "axes": [0], "signals": ["position", "command"],
                     "samples": 60, "pre": 5,
                     "trigger": {"kind": "position", "axis": 0, "level": 50}})
    rack.sched.advance(40_000_000)
    twin, twin_rack = make()  # the card as a snapshot restores it: same state, new objects
    twin_rack.sched.advance(40_000_000)
    refs = {id(card): "card", id(card.core): "core"}

    class Out(pickle.Pickler):
        def persistent_id(self, obj: object) -> str | None:
            return refs.get(id(obj))

    class In(pickle.Unpickler):
        def persistent_load(self, pid: Any) -> object:
            return {"card": twin, "core": twin.core}[pid]

    buf = io.BytesIO()
    Out(buf).dump(scopes)
    buf.seek(0)
    copy: Scopes = In(buf).load()
    probe = copy.probes["c"]
    assert type(probe.hook).__name__ == "StaleCoreTick" and probe.hook.n == scopes.probes["c"].hook.n
    twin.core.tick, twin.core.skip = probe.hook, CoreSkip(probe)  # as the core's dict holds them
    for r in (rack, twin_rack):
        r.sched.advance(300_000_000)
    a = scopes.op(card, {"action": "read"})
    b = copy.op(twin, {"action": "read"})
    assert a is not None and b is not None and a["state"] == b["state"] == "done"
    assert a["count"] == b["count"] == 60
    assert a["columns"] == b["columns"] and a["time_ns"] == b["time_ns"]
    assert not {"tick", "skip"} & set(vars(twin.core))  # done: detached from the twin


def test_times_follow_a_change_of_period_during_the_recording() -> None:
    """Tick k after a period change at tick n is n's time + (k - n) x the new period
    (Card.set_period): the samples before it keep the old spacing."""
    from vdevd.devices import card_class
    from vdevd.devices.base import CardContext
    from vdevd.rack import Rack
    from vdevd.scope.op import Scopes

    card = card_class("generic-servo")("c", {"plant": "ideal"}, CardContext(emit=print))
    rack, scopes = Rack([card]), Scopes()
    scopes.op(card, {"action": "arm", "signals": ["position"], "samples": 20})
    rack.sched.advance(5_000_000)
    card.set_period(2_500_000)
    rack.sched.advance(rack.now_ns + 40_000_000)
    reply = scopes.op(card, {"action": "read"})
    assert reply is not None and reply["count"] == 20
    times = np.frombuffer(reply["time_ns"], dtype="<i8")
    # set at the time of tick 5: tick 6 one new period later (Card.set_period)
    assert times[:5].tolist() == [1_000_000 * k for k in range(1, 6)]
    assert np.diff(times).tolist() == [1_000_000] * 4 + [2_500_000] * 15
