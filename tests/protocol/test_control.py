"""`control`: the backdoor; actions run now or at a scheduled simulated time."""

from __future__ import annotations

import pytest
import vdevclient

from tests.conftest import RawClient, error_code, rack_config
from tests.protocol.motion import BAR, axis_reg
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg
from vdevd.rt import AxisFlag
from vdevd.testing import DaemonThread

MS = 1_000_000


def status(raw: RawClient, axis: int) -> int:
    data = raw.call(op="read", offset=axis_reg(axis, AxisReg.STATUS), size=4, **BAR)["ok"]
    return int.from_bytes(data, "little")


def test_limit_switch_shows_in_the_axis_status(raw: RawClient) -> None:
    reply = raw.call(op="control", card="servo0", action="set_limit",
                     params={"axis": 2, "positive": True})
    assert reply == {"id": 1, "ok": None}
    assert status(raw, 2) & AxisFlag.HARD_LIMIT_POS
    assert not status(raw, 1) & AxisFlag.HARD_LIMIT_POS
    raw.call(op="control", card="servo0", action="set_limit", params={"axis": 2, "positive": False})
    assert not status(raw, 2) & AxisFlag.HARD_LIMIT_POS


def test_control_returns_the_action_result(rack: vdevclient.Rack) -> None:
    state = rack.control("servo0", "axis_state", axis=0)
    assert state["encoder"] == 0 and state["flags"] & AxisFlag.SERVO_ON


def test_scheduled_control_runs_at_its_simulated_time(raw: RawClient) -> None:
    reply = raw.call(op="control", card="servo0", action="set_inputs", params={"value": 5},
                     at_ns=10 * MS)
    assert reply["ok"] == {"scheduled_ns": 10 * MS}
    raw.call(op="sim", action="step", ns=10 * MS - 1)
    assert raw.call(op="read", offset=R.INPUTS, size=4, **BAR)["ok"] == bytes(4)
    raw.call(op="sim", action="step", ns=1)
    assert raw.call(op="read", offset=R.INPUTS, size=4, **BAR)["ok"] == b"\5\0\0\0"


def test_scheduled_control_is_checked_when_scheduled(raw: RawClient) -> None:
    reply = raw.call(op="control", card="servo0", action="set_inputs", params={"bogus": 1},
                     after_ns=MS)
    assert error_code(reply) == "bad_param"


def test_bad_values_are_bad_param(raw: RawClient) -> None:
    reply = raw.call(op="control", card="servo0", action="set_inputs", params={"value": -1})
    assert error_code(reply) == "bad_param"


@pytest.mark.parametrize("peak_torque", [None, 10.0])
def test_plant_parameters_change_the_physics(peak_torque: float | None) -> None:
    """A weak amplifier (low peak torque) cannot follow a jog: the following error grows."""
    with DaemonThread(rack_config(plant="servo")) as d, vdevclient.connect(d.endpoint) as rack:
        with pytest.raises(vdevclient.RemoteError):
            rack.control("servo0", "set_plant", axis=0, warp=1.0)
        if peak_torque is not None:
            rack.control("servo0", "set_plant", axis=0, peak_torque=peak_torque)
        bar = rack.card("servo0").region("bar0")
        bar.write32(axis_reg(0, AxisReg.TARGET), 100_000)
        bar.write32(axis_reg(0, AxisReg.COMMAND), 3)  # JOG at 100000 counts/s
        rack.sim.step(seconds=0.5)
        ferr = abs(rack.control("servo0", "axis_state", axis=0)["ferr"])
    assert ferr > 1000 if peak_torque else ferr < 200


@pytest.mark.parametrize(
    "when",
    [{"after_ns": -1}, {"after_ns": 2**64 - 1}, {"at_ns": 2**63}, {"at_ns": 5, "after_ns": 5}],
)
def test_a_schedule_out_of_range_or_twice_given_is_bad_param(raw: RawClient,
                                                              when: dict[str, int]) -> None:
    raw.call(op="sim", action="step", ns=MS)  # time above 0: now + a huge delay overflows
    reply = raw.call(op="control", card="servo0", action="set_inputs", params={"value": 5},
                     **when)
    assert error_code(reply) == "bad_param"
    # the daemon answers the next requests at once, and nothing was scheduled
    raw.call(op="sim", action="step", ns=10 * MS)
    assert raw.call(op="read", offset=R.INPUTS, size=4, **BAR)["ok"] == bytes(4)


def test_a_schedule_not_after_now_runs_the_action_at_once(raw: RawClient) -> None:
    raw.call(op="sim", action="step", ns=2 * MS)
    reply = raw.call(op="control", card="servo0", action="set_inputs", params={"value": 6},
                     at_ns=MS)
    assert reply == {"id": 1, "ok": None}  # the action's own result, not {scheduled_ns}
    assert raw.call(op="read", offset=R.INPUTS, size=4, **BAR)["ok"] == b"\6\0\0\0"


@pytest.mark.parametrize(("action", "params", "message"), [
    ("set_limit", {"axis": 2, "side": "positive", "active": "false"},
     "set_limit: active: expected true or false, got 'false'"),
    ("set_input", {"line": 3, "level": "0"}, "set_input: level: expected true or false, got '0'"),
    ("set_home", {"axis": 2, "active": None}, "set_home: active: expected true or false, got None"),
    ("set_estop", {"active": "False"}, "set_estop: active: expected true or false, got 'False'"),
    ("jam", {"axis": 2, "active": 2}, "jam: active: expected true or false, got 2"),
    ("set_limit", {"axis": 2, "positive": "no"}, "set_limit: positive: expected true or false"),
])
def test_a_flag_that_is_not_true_or_false_is_bad_param_naming_it(
        rack: vdevclient.Rack, action: str, params: dict[str, object], message: str) -> None:
    """bool("false") is True: a flag is a boolean (or 0 or 1), else the action does not run."""
    bar = rack.card("servo0").region("bar0")
    with pytest.raises(vdevclient.RemoteError, match="bad_param") as info:
        rack.control("servo0", action, **params)
    assert message in str(info.value)
    assert not bar.read32(axis_reg(2, AxisReg.STATUS)) & (AxisFlag.HARD_LIMIT_POS
                                                          | AxisFlag.HOME_SWITCH)
    assert bar.read32(R.INPUTS) == 0


def test_flags_take_booleans_and_the_integers_0_and_1(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    rack.control("servo0", "set_input", line=3, level=1)
    assert bar.read32(R.INPUTS) == 1 << 3
    rack.control("servo0", "set_input", line=3, level=0)
    assert bar.read32(R.INPUTS) == 0
    rack.control("servo0", "set_limit", axis=2, side="positive", active=True)
    assert bar.read32(axis_reg(2, AxisReg.STATUS)) & AxisFlag.HARD_LIMIT_POS
    rack.control("servo0", "set_limit", axis=2, side="positive", active=False)
    assert not bar.read32(axis_reg(2, AxisReg.STATUS)) & AxisFlag.HARD_LIMIT_POS


def test_a_scheduled_action_refused_when_it_runs_counts_as_a_request_error(
        rack: vdevclient.Rack) -> None:
    """PROTOCOL.md control: the values of a scheduled action are checked when it runs, and an
    error then is counted in stats requests.errors (there is no one left to reply to)."""
    assert rack.request("control", card="servo0", action="jam", params={"axis": 9},
                        after_ns=MS) == {"scheduled_ns": MS}
    before = rack.stats()["requests"]["errors"]
    rack.sim.step(ns=2 * MS)
    stats = rack.stats()
    assert stats["requests"]["errors"] == before + 1
    assert stats["scheduler"]["card_faults"] == 0  # a refused value, not a bug in the card
