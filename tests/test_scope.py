"""The scope through a real daemon with the lockstep clock (issue 23 §1; PROTOCOL.md "Scope"):
a generic servo card (`servo0`, 4 ideal axes, README of the card: registers) moves, the recorder
samples it every tick or every N, fills the ticks its card skips at rest, fires on each trigger
kind with its pre-trigger samples, reads in replies within the maximum message, and refuses
bad requests with the protocol's errors while the daemon keeps serving."""

from __future__ import annotations

import struct
from typing import Any

import msgpack
import numpy as np
import pytest
import vdevclient

from tests.conftest import RawClient, error_code
from vdevd.devices.generic.regions import AXIS_BASE, AXIS_STRIDE, IRQ_ENABLE, AxisReg, Command
from vdevd.protocol import MAX_MESSAGE
from vdevd.rt.axes import AxisFlag
from vdevd.scope.op import MAX_VALUES
from vdevd.testing import DaemonThread

PERIOD_NS = 1_000_000  # the generic card's default period


def reg(axis: int, r: AxisReg) -> int:
    return AXIS_BASE + AXIS_STRIDE * axis + r


def move(rack: vdevclient.Rack, axis: int, target: int, vmax: int = 10_000,
         acc: int = 100_000) -> None:
    """MOVE_ABS on the card's registers (generic card README)."""
    bar = rack.card("servo0").region("bar0")
    bar.write(reg(axis, AxisReg.TARGET), struct.pack("<i", target))
    bar.write(reg(axis, AxisReg.VMAX), struct.pack("<I", vmax))
    bar.write(reg(axis, AxisReg.ACC), struct.pack("<I", acc))
    bar.write(reg(axis, AxisReg.DEC), struct.pack("<I", acc))
    bar.write32(reg(axis, AxisReg.COMMAND), Command.MOVE_ABS)


def i32(rack: vdevclient.Rack, axis: int, r: AxisReg) -> int:
    data = rack.card("servo0").region("bar0").read(reg(axis, r), 4)
    return int(struct.unpack("<i", data)[0])


def scope(rack: vdevclient.Rack, action: str, **fields: Any) -> Any:
    return rack.request("scope", card="servo0", action=action, **fields)


def read_all(rack: vdevclient.Rack) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    trace = rack.card("servo0").scope_recorder().read()
    return trace.time_ns, trace.columns


def test_a_move_sampled_every_tick_matches_the_cards_registers(rack: vdevclient.Rack) -> None:
    t0 = rack.sim.now_ns()
    st = scope(rack, "arm", axes=["0", "1"], signals=["position", "command", "velocity",
                                                      "error", "status"], samples=300)
    assert st["state"] == "recording" and st["columns"][:2] == ["0.position", "0.command"]
    move(rack, 0, 1000)
    rack.sim.step(ns=300 * PERIOD_NS)
    t, cols = read_all(rack)
    assert len(t) == 300
    assert (np.diff(t) == PERIOD_NS).all() and t[0] == t0 + PERIOD_NS
    pos, cmd = cols["0.position"], cols["0.command"]
    assert (np.diff(pos) >= 0).all() and pos[0] < 100  # the move from 0 to 1000
    # 1000 counts at 10,000 counts/s with 0.1 s ramps: 0.2 s; done by the 300th tick
    assert pos[-1] == i32(rack, 0, AxisReg.POSITION) == 1000
    assert cmd[-1] == i32(rack, 0, AxisReg.COMMANDED) == 1000
    assert cols["0.velocity"].max() == pytest.approx(10_000, rel=1e-6)
    assert cols["0.status"][-1] == i32(rack, 0, AxisReg.STATUS)
    assert cols["0.status"][5] & AxisFlag.MOVING and not cols["0.status"][-1] & AxisFlag.MOVING
    assert (cols["1.position"] == 0).all()
    assert scope(rack, "status")["state"] == "done"


def test_every_n_ticks_spaces_the_samples(rack: vdevclient.Rack) -> None:
    scope(rack, "arm", signals=["position"], samples=20, every=5)
    move(rack, 2, -500)
    rack.sim.step(ns=100 * PERIOD_NS)
    t, cols = read_all(rack)
    assert len(t) == 20 and (np.diff(t) == 5 * PERIOD_NS).all()
    assert list(cols) == [f"{a}.position" for a in range(4)]
    assert cols["2.position"][-1] == i32(rack, 2, AxisReg.POSITION)


def test_seconds_count_the_ticks_of_the_card(rack: vdevclient.Rack) -> None:
    st = scope(rack, "arm", seconds=0.25, every=2)
    assert st["samples"] == 125


def test_ticks_skipped_at_rest_still_give_samples(daemon: DaemonThread,
                                                  rack: vdevclient.Rack) -> None:
    """A move, then 2 s at rest: the card skips its quiet ticks (decision 0008) and the
    recorder fills them with the resting state, each at its tick's time."""
    scope(rack, "arm", axes=["0"], signals=["position", "velocity"], samples=2500)
    move(rack, 0, 300)
    before = rack.stats()["cards"]["servo0"]["quiet_ticks"]
    rack.sim.step(ns=2500 * PERIOD_NS)
    assert rack.stats()["cards"]["servo0"]["quiet_ticks"] - before > 2000  # skipped, not run
    t, cols = read_all(rack)
    assert len(t) == 2500 and (np.diff(t) == PERIOD_NS).all()
    assert (cols["0.position"][-2000:] == 300).all() and (cols["0.velocity"][-2000:] == 0).all()


def test_quiet_ticks_unchanged_after_a_recording_is_done(daemon: DaemonThread,
                                                        rack: vdevclient.Rack) -> None:
    """Done or cleared, the recorder leaves no hook on the card: it rests as before."""
    assert daemon.server is not None
    card = daemon.server.rack.cards["servo0"]
    scope(rack, "arm", samples=10)
    assert "tick" in vars(card.core)
    rack.sim.step(ns=10 * PERIOD_NS)
    assert scope(rack, "status")["state"] == "done"
    assert not {"tick", "skip"} & set(vars(card.core)) and "tick" not in vars(card)
    scope(rack, "arm", samples=10, trigger={"kind": "irq"})
    assert "tick" in vars(card)
    scope(rack, "clear")
    assert not {"tick", "skip"} & set(vars(card.core)) and "tick" not in vars(card)
    assert scope(rack, "status") == {"state": "idle", "card": "servo0"}


def test_position_crossing_with_pre_trigger_samples(rack: vdevclient.Rack) -> None:
    st = scope(rack, "arm", axes=["1"], signals=["position"], samples=50, pre=10,
               trigger={"kind": "position", "axis": "1", "level": 500, "direction": "rising"})
    assert st["state"] == "armed" and st["trigger"]["axis"] == "1"
    rack.sim.step(ns=20 * PERIOD_NS)
    assert scope(rack, "status")["available"] == 0  # armed: nothing kept yet
    move(rack, 1, 1000)
    rack.sim.step(ns=400 * PERIOD_NS)
    st = scope(rack, "status")
    assert st["state"] == "done" and st["trigger_index"] == 10
    t, cols = read_all(rack)
    pos = cols["1.position"]
    assert len(pos) == 50 and pos[9] < 500 <= pos[10]
    assert st["trigger_ns"] == t[10]


def test_position_falling_does_not_fire_on_the_way_up(rack: vdevclient.Rack) -> None:
    scope(rack, "arm", axes=["1"], signals=["position"], samples=20, pre=5,
          trigger={"kind": "position", "axis": 1, "level": 500, "direction": "falling"})
    move(rack, 1, 1000)
    rack.sim.step(ns=400 * PERIOD_NS)
    assert scope(rack, "status")["state"] == "armed"
    move(rack, 1, 0)
    rack.sim.step(ns=400 * PERIOD_NS)
    t, cols = read_all(rack)
    pos = cols["1.position"]
    assert len(pos) == 20 and pos[4] > 500 >= pos[5]


def test_register_bit_change_with_pre_trigger_samples(rack: vdevclient.Rack) -> None:
    """STATUS of axis 3, bit MOVING, to 1: fires at the first tick of the move, with the
    resting samples before it."""
    scope(rack, "arm", axes=["3"], signals=["position", "status"], samples=30, pre=8,
          trigger={"kind": "register", "region": "bar0", "offset": reg(3, AxisReg.STATUS),
                   "width": 4, "mask": int(AxisFlag.MOVING), "value": int(AxisFlag.MOVING)})
    rack.sim.step(ns=50 * PERIOD_NS)
    assert scope(rack, "status")["state"] == "armed"
    t_cmd = rack.sim.now_ns()
    move(rack, 3, 2000)
    rack.sim.step(ns=100 * PERIOD_NS)
    st = scope(rack, "status")
    assert st["state"] == "done" and st["trigger_index"] == 8
    assert st["trigger_ns"] == t_cmd + PERIOD_NS  # the first tick after the command
    t, cols = read_all(rack)
    assert (cols["3.position"][:8] == 0).all() and cols["3.position"][-1] > 0
    assert not cols["3.status"][7] & AxisFlag.MOVING and cols["3.status"][8] & AxisFlag.MOVING
    assert (np.diff(t) == PERIOD_NS).all()


def test_interrupt_trigger_with_pre_trigger_samples(rack: vdevclient.Rack) -> None:
    """Axis 0 done interrupts (IRQ_ENABLE bit 0): the trigger's sample is the tick the move
    ended, the samples before it the move's end."""
    bar = rack.card("servo0").region("bar0")
    bar.write32(IRQ_ENABLE, 1)
    scope(rack, "arm", axes=["0"], signals=["position", "command"], samples=40, pre=20,
          trigger={"kind": "irq", "line": "inta"})
    move(rack, 0, 1000)
    rack.sim.step(ns=1000 * PERIOD_NS)
    st = scope(rack, "status")
    assert st["state"] == "done" and st["trigger_index"] == 20
    t, cols = read_all(rack)
    cmd = cols["0.command"]
    assert cmd[20] == 1000 and cmd[19] < 1000 and (np.diff(cmd[:21]) > 0).all()
    assert (cmd[20:] == 1000).all()


def test_read_comes_in_pieces_within_the_maximum_message(daemon: DaemonThread,
                                                        raw: RawClient) -> None:
    """Every signal of every axis, 20,000 samples: each read reply under max_message."""
    assert raw.call(op="scope", card="servo0", action="arm", samples=20_000)["ok"]
    signals = ["position", "command", "velocity", "command_velocity", "error", "output",
               "status", "inputs", "outputs"]
    assert raw.call(op="scope", card="servo0", action="arm", samples=20_000,
                    signals=signals)["ok"]["columns"][-1] == "3.outputs"
    raw.call(op="sim", action="step", ns=20_000 * PERIOD_NS)
    start, pieces = 0, 0
    while start is not None:
        raw.sock.send(msgpack.packb({"id": 1, "op": "scope", "card": "servo0", "action": "read",
                                     "start": start}))
        body = raw.sock.recv()
        assert len(body) <= MAX_MESSAGE
        ok = msgpack.unpackb(body)["ok"]
        assert ok["start"] == start and len(ok["time_ns"]) == 8 * ok["count"]
        assert len(ok["columns"]) == 36
        pieces += 1
        start = ok["next"]
    assert pieces > 1
    ok = raw.call(op="scope", card="servo0", action="read", start=19_990, count=5)["ok"]
    assert ok["count"] == 5 and ok["next"] == 19_995


@pytest.mark.parametrize(("fields", "code", "words"), [
    ({"action": "fire", "samples": 1}, "bad_param", "action 'fire'"),
    ({"action": "arm", "samples": 10, "signals": ["torque"]}, "bad_param", "no signal 'torque'"),
    ({"action": "arm", "samples": 10, "axes": ["9"]}, "bad_param", "no axis '9'"),
    ({"action": "arm", "samples": 10, "axes": ["1", "1"]}, "bad_param", "named twice"),
    ({"action": "arm", "samples": MAX_VALUES}, "bad_param", "limit of 2,000,000 values"),
    ({"action": "arm", "seconds": 1e5}, "bad_param", "limit of 2,000,000 values"),
    ({"action": "arm"}, "bad_param", "exactly one of samples and seconds"),
    ({"action": "arm", "samples": 10, "seconds": 1.0}, "bad_param", "exactly one"),
    ({"action": "arm", "samples": 0}, "bad_param", "samples 0"),
    ({"action": "arm", "samples": 10, "every": 0}, "bad_param", "every 0"),
    ({"action": "arm", "samples": 10, "pre": 10, "trigger": {"kind": "irq"}}, "bad_param",
     "pre 10"),
    ({"action": "arm", "samples": 10, "pre": 2}, "bad_param", "need a trigger"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "edge"}}, "bad_param", "kind 'edge'"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "irq", "line": "intb"}}, "no_irq",
     "'intb'"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "register", "region": "bar9",
                                                  "offset": 0}}, "no_region", "'bar9'"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "register", "region": "bar0",
                                                  "offset": 0x1000}}, "out_of_range", ""),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "register", "region": "bar0",
                                                  "offset": 0, "width": 3}}, "bad_width", "3"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "register", "region": "bar0",
                                                  "offset": 0, "mask": 1, "value": 2}},
     "bad_param", "outside the mask"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "position", "axis": "0"}},
     "bad_param", "level None"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "position", "axis": "0", "level": 1,
                                                  "direction": "up"}}, "bad_param", "'up'"),
    ({"action": "arm", "samples": 10, "trigger": {"kind": "now", "line": "inta"}}, "bad_param",
     "unknown field 'line'"),
    ({"action": "arm", "samples": 10, "axes": []}, "bad_param", "non-empty list"),
    ({"action": "arm", "samples": 10, "axes": "0"}, "malformed", "'axes'"),
])
def test_bad_requests_are_refused_and_change_nothing(raw: RawClient, fields: dict[str, Any],
                                                    code: str, words: str) -> None:
    assert raw.call(op="scope", card="servo0", action="arm", samples=5)["ok"]["state"]
    reply = raw.call(op="scope", card="servo0", **fields)
    assert error_code(reply) == code and words in reply["error"]["message"]
    if fields["action"] != "read":
        assert raw.call(op="scope", card="servo0", action="status")["ok"]["samples"] == 5
    assert raw.call(op="hello")["ok"]["protocol"] == 1  # still serving


def test_unknown_card_and_malformed_fields(raw: RawClient) -> None:
    assert error_code(raw.call(op="scope", card="nope", action="status")) == "no_card"
    assert error_code(raw.call(op="scope", card="servo0", action="arm", samples="10")) \
        == "malformed"
    assert error_code(raw.call(op="scope", card="servo0")) == "malformed"
    reply = raw.call(op="scope", card="servo0", action="read")
    assert error_code(reply) == "bad_param" and "no recording" in reply["error"]["message"]


def test_every_n_ticks_across_a_move_and_the_rest_after_it(rack: vdevclient.Rack) -> None:
    """Every 7 ticks, 60 samples: the move's samples run, then the card rests and skips its
    ticks; the samples go on every 7 ticks all the same, the last one at rest."""
    t0 = rack.sim.now_ns()
    scope(rack, "arm", axes=["0"], signals=["position", "command_velocity"], samples=60, every=7)
    move(rack, 0, 200)
    rack.sim.step(ns=420 * PERIOD_NS)
    t, cols = read_all(rack)
    assert t.tolist() == [t0 + 7 * PERIOD_NS * (k + 1) for k in range(60)]
    assert cols["0.position"][-1] == 200 == i32(rack, 0, AxisReg.POSITION)
    assert cols["0.command_velocity"][2] > 0 and cols["0.command_velocity"][-1] == 0
