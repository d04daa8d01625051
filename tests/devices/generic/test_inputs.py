"""The generic card's switch inputs through the client: home switch and homing, abort input,
general inputs (vdevd/devices/generic/README.md)."""

from __future__ import annotations

import pytest
import vdevclient

from vdevd.devices.generic import regions as R
from vdevd.devices.generic.regions import AxisReg, CardStatus, Command, CommandError
from vdevd.rt import AxisFlag

MS = 1_000_000


def reg(axis: int, name: AxisReg) -> int:
    return R.AXIS_BASE + R.AXIS_STRIDE * axis + name


def i32(value: int) -> int:
    return value - (1 << 32) if value & 0x80000000 else value


@pytest.fixture
def bar(rack: vdevclient.Rack) -> vdevclient.Region:
    bar = rack.card("servo0").region("bar0")
    bar.write32(R.IRQ_ENABLE, 0xFFFFFFFF)
    return bar


def command(bar: vdevclient.Region, axis: int, cmd: Command, target: int = 0, vmax: int = 10_000,
            acc: int = 100_000, dec: int = 100_000) -> int:
    """Write the motion parameters and the command; the ERROR register after it."""
    bar.write32(reg(axis, AxisReg.TARGET), target & 0xFFFFFFFF)
    bar.write32(reg(axis, AxisReg.VMAX), vmax)
    bar.write32(reg(axis, AxisReg.ACC), acc)
    bar.write32(reg(axis, AxisReg.DEC), dec)
    bar.write32(reg(axis, AxisReg.COMMAND), cmd)
    return bar.read32(reg(axis, AxisReg.ERROR))


def test_home_switch_shows_in_status_and_follows_the_input(rack: vdevclient.Rack,
                                                          bar: vdevclient.Region) -> None:
    rack.control("servo0", "set_home", axis=2)
    assert bar.read32(reg(2, AxisReg.STATUS)) & AxisFlag.HOME_SWITCH
    assert not bar.read32(reg(1, AxisReg.STATUS)) & AxisFlag.HOME_SWITCH
    rack.control("servo0", "set_home", axis=2, active=False)
    assert not bar.read32(reg(2, AxisReg.STATUS)) & AxisFlag.HOME_SWITCH


def test_home_stops_past_the_switch_with_dec_and_counts_from_zero_where_it_was_found(
        rack: vdevclient.Rack, bar: vdevclient.Region) -> None:
    card = rack.card("servo0")
    assert command(bar, 0, Command.HOME, target=1) == CommandError.OK
    rack.sim.step(seconds=0.3)  # 0.1 s ramp to 10000 counts/s, then cruise: at 2500
    assert bar.read32(reg(0, AxisReg.POSITION)) == 2500
    assert not bar.read32(reg(0, AxisReg.STATUS)) & AxisFlag.HOMED
    rack.control("servo0", "set_home", axis=0)  # the switch is found at 2500
    assert i32(bar.read32(reg(0, AxisReg.POSITION))) == 0
    event = card.irq.wait(timeout_s=1.0)
    assert event is not None and event["status"] == 1
    assert event["sim_time_ns"] == 400 * MS  # from the tick at 300 ms, 10000 c/s at 100000 c/s^2
    status = bar.read32(reg(0, AxisReg.STATUS))
    assert status & AxisFlag.DONE and status & AxisFlag.HOMED and status & AxisFlag.HOME_SWITCH
    assert not status & (AxisFlag.MOVING | AxisFlag.ABORTED)
    assert bar.read32(reg(0, AxisReg.POSITION)) == 500  # v^2 / (2 dec) past the switch
    bar.write32(R.IRQ_STATUS, 1)
    command(bar, 0, Command.MOVE_ABS, target=0)
    assert card.irq.wait(timeout_s=1.0) is not None
    assert bar.read32(reg(0, AxisReg.POSITION)) == 0
    assert rack.control("servo0", "axis_state", axis=0)["pos"] == 0.0


def test_home_with_a_negative_target_searches_in_the_negative_direction(
        rack: vdevclient.Rack, bar: vdevclient.Region) -> None:
    command(bar, 1, Command.HOME, target=-1)
    rack.sim.step(seconds=0.2)
    assert i32(bar.read32(reg(1, AxisReg.POSITION))) == -1500
    rack.control("servo0", "set_home", axis=1)
    assert rack.card("servo0").irq.wait(timeout_s=1.0) is not None
    assert i32(bar.read32(reg(1, AxisReg.POSITION))) == -500
    assert bar.read32(reg(1, AxisReg.STATUS)) & AxisFlag.HOMED


def test_home_on_an_active_switch_homes_where_the_axis_is(rack: vdevclient.Rack,
                                                          bar: vdevclient.Region) -> None:
    command(bar, 0, Command.MOVE_ABS, target=700)
    assert rack.card("servo0").irq.wait(timeout_s=1.0) is not None
    bar.write32(R.IRQ_STATUS, 1)  # acknowledge, so that the next DONE is a new cause
    rack.control("servo0", "set_home", axis=0)
    assert command(bar, 0, Command.HOME, target=1) == CommandError.OK
    event = rack.card("servo0").irq.wait(timeout_s=1.0)
    assert event is not None and event["status"] == 1
    assert bar.read32(reg(0, AxisReg.POSITION)) == 0
    assert bar.read32(reg(0, AxisReg.STATUS)) & (AxisFlag.DONE | AxisFlag.HOMED) == (
        AxisFlag.DONE | AxisFlag.HOMED)


def test_home_stopped_by_a_limit_switch_is_not_homed(rack: vdevclient.Rack,
                                                     bar: vdevclient.Region) -> None:
    command(bar, 0, Command.HOME, target=1)
    rack.sim.step(seconds=0.2)
    rack.control("servo0", "set_limit", axis=0, positive=True)
    card = rack.card("servo0")
    stopped = card.irq.wait(timeout_s=1.0)
    assert stopped is not None and stopped["status"] == 1 << 16
    done = card.irq.wait(timeout_s=1.0)
    assert done is not None and done["status"] == 1 | 1 << 16
    rack.control("servo0", "set_home", axis=0)  # the search has ended: no longer looked for
    status = bar.read32(reg(0, AxisReg.STATUS))
    assert status & AxisFlag.STOPPED_BY_LIMIT and not status & AxisFlag.HOMED
    assert bar.read32(reg(0, AxisReg.POSITION)) > 1000


def test_home_with_vmax_zero_is_a_bad_parameter(bar: vdevclient.Region) -> None:
    assert command(bar, 0, Command.HOME, target=1, vmax=0) == CommandError.BAD_PARAMETER
    assert not bar.read32(reg(0, AxisReg.STATUS)) & AxisFlag.MOVING


def test_abort_input_shows_in_card_status(rack: vdevclient.Rack, bar: vdevclient.Region) -> None:
    assert bar.read32(R.CARD_STATUS) == 0
    rack.control("servo0", "set_abort")
    assert bar.read32(R.CARD_STATUS) == CardStatus.ABORT_INPUT
    bar.write32(R.CARD_STATUS, 0)  # read-only
    assert bar.read32(R.CARD_STATUS) == CardStatus.ABORT_INPUT
    rack.control("servo0", "set_abort", active=False)
    assert bar.read32(R.CARD_STATUS) == 0


def test_abort_input_stops_moving_axes_at_once_with_aborted(rack: vdevclient.Rack,
                                                            bar: vdevclient.Region) -> None:
    card = rack.card("servo0")
    command(bar, 0, Command.MOVE_ABS, target=100_000)
    command(bar, 1, Command.JOG, target=-5_000)
    rack.sim.step(seconds=0.2)
    here = bar.read32(reg(0, AxisReg.POSITION))
    rack.control("servo0", "set_abort")
    event = card.irq.wait(timeout_s=1.0)
    assert event is not None and event["status"] == 0b11  # DONE of axes 0 and 1, no fault bit
    assert event["sim_time_ns"] == 201 * MS
    for axis in (0, 1):
        status = bar.read32(reg(axis, AxisReg.STATUS))
        assert status & AxisFlag.ABORTED and status & AxisFlag.DONE
        assert not status & AxisFlag.MOVING
    assert not bar.read32(reg(2, AxisReg.STATUS)) & AxisFlag.ABORTED  # idle: left alone
    rack.sim.step(seconds=0.1)
    assert bar.read32(reg(0, AxisReg.POSITION)) == here


def test_abort_input_refuses_motion_until_released(rack: vdevclient.Rack,
                                                   bar: vdevclient.Region) -> None:
    rack.control("servo0", "set_abort")
    for cmd in (Command.MOVE_ABS, Command.MOVE_REL, Command.JOG, Command.HOME):
        assert command(bar, 0, cmd, target=1000) == CommandError.ABORT_INPUT
    assert command(bar, 0, Command.SET_POSITION, target=5) == CommandError.OK
    rack.sim.step(seconds=0.2)
    assert bar.read32(reg(0, AxisReg.POSITION)) == 5
    assert not bar.read32(reg(0, AxisReg.STATUS)) & AxisFlag.MOVING
    rack.control("servo0", "set_abort", active=False)
    assert command(bar, 0, Command.MOVE_ABS, target=1000) == CommandError.OK
    assert rack.card("servo0").irq.wait(timeout_s=1.0) is not None
    assert bar.read32(reg(0, AxisReg.POSITION)) == 1000


def test_set_inputs_sets_the_inputs_register_beside_the_switches(rack: vdevclient.Rack,
                                                                 bar: vdevclient.Region) -> None:
    rack.control("servo0", "set_home", axis=0)
    rack.control("servo0", "set_abort")
    rack.control("servo0", "set_inputs", value=0xA5A5_0001)
    assert bar.read32(R.INPUTS) == 0xA5A5_0001
    assert bar.read32(R.CARD_STATUS) == CardStatus.ABORT_INPUT
    assert bar.read32(reg(0, AxisReg.STATUS)) & AxisFlag.HOME_SWITCH
