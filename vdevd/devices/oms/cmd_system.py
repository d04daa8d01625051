"""Axis selection, identity, flags and status queries [S App C; spec oms.md §4.2, §4.3]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevmaps.oms import AXES, UPDATE_RATES

from vdevd.devices.oms.syntax import Command, CommandError

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware


def select_axis(fw: Firmware, cmd: Command) -> None:
    """AX..AK: single-axis mode on that axis [S App C L1336-1342]; an axis the card does not
    have is a command error."""
    fw.axis = fw.check_axis(AXES.index(cmd.mnemonic[1]))
    fw.mode = "single"


def all_axes(fw: Firmware, cmd: Command) -> None:
    """Coordinated multi-axis mode: one operand per axis; GO starts them together."""
    fw.mode = "AA"


def multitasking(fw: Firmware, cmd: Command) -> None:
    """Multitasking mode: one operand per axis, each axis runs its own queue."""
    fw.mode = "AM"


def who_are_you(fw: Firmware, cmd: Command) -> str:
    """Model (MAXk-n000, A for 10 axes), firmware version, serial, FPGA [S §2.6]."""
    return fw.identity()


def clear_done(fw: Firmware, cmd: Command) -> None:
    for a in fw.selected():
        fw.done[a] = False


def interrupt_clear(fw: Firmware, cmd: Command) -> None:
    """Clear the done and slip latches of the addressed axes (scope assumed, README)."""
    for a in fw.selected():
        fw.done[a] = False
        fw.slip[a] = False


def accepted(fw: Firmware, cmd: Command) -> None:
    """Accepted without effect on this card (README)."""


def axis_status(fw: Firmware, a: int) -> str:
    """The four QA characters: direction P/M, done D/N, limit L/N, home H/N [spec §4.2]. The
    limit is the switch in the axis's direction, or its software travel limit there having
    stopped the last motion (README)."""
    m = fw.motion
    positive = bool(m.direction[a] >= 0)
    pos, neg = m.limit_active()
    limit = bool(pos[a]) if positive else bool(neg[a])
    limit |= m.at_travel_limit(a, positive)
    return ("P" if positive else "M") + ("D" if fw.done[a] else "N") + (
        "L" if limit else "N") + ("H" if m.home_active()[a] else "N")


def query_axis(fw: Firmware, cmd: Command) -> str:
    return ",".join(axis_status(fw, a) for a in fw.selected())


def report_axis(fw: Firmware, cmd: Command) -> str:
    """As QA, then clear the done flag(s) [spec §8.8]."""
    reply = query_axis(fw, cmd)
    for a in fw.selected():
        fw.done[a] = False
    return reply


def query_all(fw: Firmware, cmd: Command) -> str:
    return ",".join(axis_status(fw, a) for a in range(fw.n))


def report_all(fw: Firmware, cmd: Command) -> str:
    reply = query_all(fw, cmd)
    fw.done[:] = False
    return reply


def _ints(values: list[int]) -> str:
    return ",".join(str(v) for v in values)


def report_position(fw: Firmware, cmd: Command) -> str:
    """Motor position: counts, or user units when UU is on (firmware.report)."""
    return fw.report(fw.motor_position(), fw.selected())


def report_encoder(fw: Firmware, cmd: Command) -> str:
    return fw.report(fw.encoder_position(), fw.selected(), "encoder")


def report_velocity(fw: Firmware, cmd: Command) -> str:
    return fw.report(fw.motion.velocity(), fw.selected())


def positions(fw: Firmware, cmd: Command) -> str:
    return fw.report(fw.motor_position(), list(range(fw.n)))


def encoders(fw: Firmware, cmd: Command) -> str:
    return fw.report(fw.encoder_position(), list(range(fw.n)), "encoder")


def queue_free(fw: Firmware, cmd: Command) -> str:
    return _ints([fw.queues[a].free for a in fw.selected()])


def watchdog(fw: Firmware, cmd: Command) -> str:
    """The watchdog timeout counter, 0: the virtual card never misses its watchdog."""
    return "=0"


def update_rate(fw: Firmware, cmd: Command) -> str | None:
    """Update rate in Hz; `#UR?` answers without `=` (EPICS reads it with atol) [spec §8.10]."""
    if cmd.query:
        return str(fw.update_hz)
    try:
        hz = int(float(cmd.operand))
    except ValueError:
        raise CommandError("malformed number") from None
    if hz not in UPDATE_RATES:
        raise CommandError("update rate is 1024, 2048, 4096 or 8192")
    fw.set_update_rate(hz)
    return None


def store_defaults(fw: Firmware, cmd: Command) -> None:
    """Store the working parameters as the power-up defaults [S §2.13-2.14]."""
    fw.store_defaults()


def restore_factory(fw: Firmware, cmd: Command) -> None:
    fw.restore_defaults(factory=True)


def restore_power_up(fw: Firmware, cmd: Command) -> None:
    fw.restore_defaults(factory=False)


def reset(fw: Firmware, cmd: Command) -> None:
    """Reset the controller (as the direct command RESET_CONTROLLER, README)."""
    fw.reset_requested = True
