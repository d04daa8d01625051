"""The axis world on the reference card (README.md "Axis world", "Backdoor"): switches found by
the card itself where the stage has them, physical positions that ignore redefined zeros, the
shared backdoor vocabulary and its deprecated aliases."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import vdevclient

from tests.conftest import rack_config
from tests.devices.generic.test_inputs import command, i32, reg
from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg, CardStatus, Command, CommandError
from vdevd.rt import AxisFlag
from vdevd.testing import DaemonThread

WORLD = [{"limits": [-3000, 3000], "home": [1200, 1400]}, {"index": {"period": 4000}},
         {"amp_fault": True}]


@pytest.fixture
def world() -> Iterator[vdevclient.Rack]:
    with DaemonThread(rack_config(axis=WORLD)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as r:
        bar = r.card("servo0").region("bar0")
        r.sim.step(seconds=0.001)  # the configured amplifier fault stops axis 2 at power-up
        bar.write32(R.IRQ_STATUS, 0xFFFFFFFF)
        bar.write32(R.IRQ_ENABLE, 0xFFFFFFFF)
        yield r


def status(bar: vdevclient.Region, axis: int) -> int:
    return bar.read32(reg(axis, AxisReg.STATUS))


def test_a_home_search_finds_the_switch_by_itself(world: vdevclient.Rack) -> None:
    bar = world.card("servo0").region("bar0")
    assert command(bar, 0, Command.HOME, target=1) == CommandError.OK
    done = world.card("servo0").irq.wait(timeout_s=5.0)  # no client flips the switch
    assert done is not None and done["status"] == 1
    s = status(bar, 0)
    assert s & AxisFlag.HOMED
    assert not s & AxisFlag.HOME_SWITCH  # it rests at physical 1700, past the 1200-1400 window
    # found at 1200 (the window's edge, in the tick that reached it), then 500 counts of
    # deceleration (10000 c/s at 100000 c/s^2) past it
    assert i32(bar.read32(reg(0, AxisReg.POSITION))) == pytest.approx(500, abs=10)
    physical = world.control("servo0", "axis_state", axis=0)["pos"]
    assert physical == pytest.approx(500, abs=10)  # the core counts from the new zero


def test_switches_stay_where_the_stage_has_them_after_zero_is_redefined(
        world: vdevclient.Rack) -> None:
    bar = world.card("servo0").region("bar0")
    command(bar, 0, Command.HOME, target=1)
    assert world.card("servo0").irq.wait(timeout_s=5.0) is not None
    bar.write32(R.IRQ_STATUS, 0xFFFFFFFF)
    # the positive limit is at physical 3000: with zero redefined at 1200 that is 1800 now;
    # the limit stop decelerates (500 counts at 10000 c/s and 100000 c/s^2)
    assert command(bar, 0, Command.MOVE_ABS, target=2500) == CommandError.OK
    world.sim.step(seconds=1.0)
    s = status(bar, 0)
    assert s & AxisFlag.HARD_LIMIT_POS and s & AxisFlag.STOPPED_BY_LIMIT
    assert i32(bar.read32(reg(0, AxisReg.POSITION))) == pytest.approx(2300, abs=10)


def test_a_move_into_the_negative_limit_stops_there(world: vdevclient.Rack) -> None:
    bar = world.card("servo0").region("bar0")
    assert command(bar, 0, Command.MOVE_ABS, target=-5000) == CommandError.OK
    world.sim.step(seconds=1.0)
    s = status(bar, 0)
    assert s & AxisFlag.HARD_LIMIT_NEG and s & AxisFlag.STOPPED_BY_LIMIT
    # found at -3000, then the limit stop's deceleration: 500 counts
    assert i32(bar.read32(reg(0, AxisReg.POSITION))) == pytest.approx(-3500, abs=10)
    assert command(bar, 0, Command.MOVE_ABS, target=-5000) == CommandError.OK
    world.sim.step(seconds=0.1)  # refused further out: stays
    assert i32(bar.read32(reg(0, AxisReg.POSITION))) == pytest.approx(-3500, abs=10)
    assert command(bar, 0, Command.MOVE_ABS, target=0) == CommandError.OK
    world.sim.step(seconds=1.0)  # back out: the switch releases
    assert i32(bar.read32(reg(0, AxisReg.POSITION))) == 0
    assert not status(bar, 0) & AxisFlag.HARD_LIMIT_NEG


def test_an_amp_fault_from_the_config_holds_at_power_up_and_clears_by_the_backdoor(
        world: vdevclient.Rack) -> None:
    bar = world.card("servo0").region("bar0")
    assert status(bar, 2) & AxisFlag.AMP_FAULT
    assert command(bar, 2, Command.MOVE_REL, target=10) == CommandError.FAULT
    world.control("servo0", "set_amp_fault", axis=2, active=False)
    assert not status(bar, 2) & AxisFlag.AMP_FAULT


def test_a_jammed_motor_does_not_move_and_its_following_error_grows(
        rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    rack.control("servo0", "jam", axis=1)
    command(bar, 1, Command.MOVE_REL, target=1000)
    rack.sim.step(seconds=0.05)
    ferr1 = i32(bar.read32(reg(1, AxisReg.FERR)))
    rack.sim.step(seconds=0.05)
    assert i32(bar.read32(reg(1, AxisReg.POSITION))) == 0
    assert 0 < ferr1 < i32(bar.read32(reg(1, AxisReg.FERR)))
    rack.control("servo0", "jam", axis=1, active=False)
    rack.sim.step(seconds=1.0)
    assert i32(bar.read32(reg(1, AxisReg.POSITION))) == 1000


def test_the_shared_vocabulary_drives_the_cards_signals(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    rack.control("servo0", "set_limit", axis=3, side="negative")
    assert status(bar, 3) & AxisFlag.HARD_LIMIT_NEG
    rack.control("servo0", "set_limit", axis=3, side="negative", active=False)
    assert not status(bar, 3) & AxisFlag.HARD_LIMIT_NEG
    rack.control("servo0", "set_home", axis=0, active=True)
    assert status(bar, 0) & AxisFlag.HOME_SWITCH
    rack.control("servo0", "set_input", line=4, level=True)
    assert bar.read32(R.INPUTS) == 1 << 4
    rack.control("servo0", "set_encoder_loss", axis=1)
    assert status(bar, 1) & AxisFlag.ENCODER_LOSS
    rack.control("servo0", "set_estop", active=True)
    assert bar.read32(R.CARD_STATUS) & CardStatus.ABORT_INPUT
    assert command(bar, 0, Command.MOVE_REL, target=5) == CommandError.ABORT_INPUT


def test_the_home_window_moves_by_the_backdoor(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    bar.write32(R.IRQ_ENABLE, 1)
    rack.control("servo0", "set_home_window", axis=0, low=-700, high=-600)
    command(bar, 0, Command.HOME, target=-1)
    assert rack.card("servo0").irq.wait(timeout_s=5.0) is not None
    assert status(bar, 0) & AxisFlag.HOMED


def test_deprecated_names_keep_working(rack: vdevclient.Rack) -> None:
    bar = rack.card("servo0").region("bar0")
    rack.control("servo0", "set_limit", axis=0, positive=True)
    assert status(bar, 0) & AxisFlag.HARD_LIMIT_POS
    rack.control("servo0", "amp_fault", axis=1)
    assert status(bar, 1) & AxisFlag.AMP_FAULT
    rack.control("servo0", "set_abort", active=True)
    assert bar.read32(R.CARD_STATUS) & CardStatus.ABORT_INPUT
    rack.control("servo0", "set_inputs", value=6)
    assert bar.read32(R.INPUTS) == 6


@pytest.mark.parametrize(("action", "params", "message"), [
    ("set_limits", {"axis": 0}, "has no control action 'set_limits' (has: "),
    ("set_limit", {"axis": 0, "level": 1}, "set_limit(axis"),
    ("set_limit", {"axis": 0, "side": "up"}, "side 'up' is not one of positive, negative"),
    ("set_home", {"axis": 9}, "no axis 9 (axes: 0..3)"),
    ("set_analog", {"channel": 0, "volts": 1.0}, "this card has no analog inputs"),
    ("set_limit", {"axis": 0, "side": "negative", "positive": True},
     "give side/active, or the deprecated positive/negative, not both"),
])
def test_a_wrong_action_or_parameter_is_an_error_naming_it(
        rack: vdevclient.Rack, action: str, params: dict[str, object], message: str) -> None:
    with pytest.raises(vdevclient.VdevClientError) as info:
        rack.control("servo0", action, **params)
    assert message in str(info.value)
    assert rack.control("servo0", "axis_state", axis=0)["pos"] == 0.0  # still serving
