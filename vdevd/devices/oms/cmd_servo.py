"""Axis types, servo gains, closed loop and encoders [S §2.9, §2.13-2.14, §4.7; spec oms.md §4.3
"Servo (PSM) and position maintenance", §5.3-5.4]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevd.devices.oms.params import PARAMS
from vdevd.devices.oms.syntax import Command, Operand
from vdevd.devices.oms.table import CommandError, command

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware


@command("PS", operand=Operand.LETTERS)
def axis_type(fw: Firmware, cmd: Command) -> str | None:
    """PSO / PSE / PSM: open-loop stepper, stepper with encoder, servo; PS? -> =O/=E/=M."""
    if cmd.query:
        return ",".join("=" + fw.params.ptype[a] for a in fw.selected())
    if cmd.operand not in ("O", "E", "M"):
        raise CommandError("PSO, PSE or PSM")
    for a in fw.selected():
        fw.set_axis_type(a, cmd.operand)
    return None


def _gain(fw: Firmware, cmd: Command) -> str | None:
    name = cmd.mnemonic.lstrip("?")
    if cmd.query or cmd.mnemonic.startswith("?"):
        if any(fw.params.ptype[a] != "M" for a in fw.selected()):
            raise CommandError("not a servo axis")  # EPICS probes PSM with ?KP
        return ",".join(f"{fw.params.values[name][a]:.2f}" for a in fw.selected())
    pairs = fw.per_axis(cmd)
    if not pairs:
        raise CommandError("a value is required")
    param = PARAMS[name]
    values = [(a, param.coerce(v)) for a, v in pairs]
    if any(v is None for _, v in values):
        raise CommandError(f"{name} out of range")
    for a, v in values:
        fw.params.values[name][a] = v
    fw.apply_gains()
    return None


for _name in ("KP", "KI", "KD", "KU", "KV", "KA", "KF", "KO"):
    command(_name, operand=Operand.NUMBERS)(_gain)
    command("?" + _name)(_gain)


@command("CL", operand=Operand.NUMBERS)
def closed_loop(fw: Firmware, cmd: Command) -> str | None:
    """CL1 closes the loop (PID hold), CL0 opens it (output KO only); CL? -> on/off."""
    if cmd.query:
        return ",".join("on" if fw.params.closed_loop[a] else "off" for a in fw.selected())
    if cmd.operand not in ("0", "1"):
        raise CommandError("CL0 or CL1")
    for a in fw.selected():
        fw.set_closed_loop(a, cmd.operand == "1")
    return None


@command("HN", "HF")
def hold(fw: Firmware, cmd: Command) -> None:
    """Hold on / off: the older form of CL1 / CL0."""
    for a in fw.selected():
        fw.set_closed_loop(a, cmd.mnemonic == "HN")


@command("SVP", operand=Operand.LETTERS)
def servo_polarity(fw: Firmware, cmd: Command) -> None:
    if cmd.operand not in ("+", "-"):
        raise CommandError("SVP+ or SVP-")
    for a in fw.selected():
        fw.params.servo_inverted[a] = cmd.operand == "-"
    fw.apply_gains()


@command("EDI", "EDN")
def encoder_direction(fw: Firmware, cmd: Command) -> None:
    for a in fw.selected():
        fw.params.encoder_inverted[a] = cmd.mnemonic == "EDI"


def _has_encoder(fw: Firmware, a: int) -> bool:
    return fw.params.ptype[a] in ("E", "M")


@command("EA")
def encoder_status(fw: Firmware, cmd: Command) -> str:
    """Five characters per axis: slip detection E/D, position maintenance E/D, slip S/N,
    in deadband D/N, encoder home H/N; a command error on an axis without encoder."""
    out = []
    for a in fw.selected():
        if not _has_encoder(fw, a):
            raise CommandError("axis has no encoder")
        p = fw.params
        slip_on = p.values["ES"][a] > 0
        maint = p.closed_loop[a] and p.ptype[a] == "E"
        out.append(("E" if slip_on else "D") + ("E" if maint else "D")
                   + ("S" if fw.slip[a] else "N") + ("D" if fw.in_deadband(a) else "N")
                   + ("H" if fw.encoder_home(a) else "N"))
    return ",".join(out)


@command("ER", operand=Operand.NUMBERS)
def encoder_ratio(fw: Firmware, cmd: Command) -> None:
    """ER enc,motor: encoder counts per motor count; PSE axes only."""
    try:
        enc, mot = (float(x) for x in cmd.operand.split(","))
    except ValueError:
        raise CommandError("ER encoder,motor") from None
    if enc <= 0 or mot <= 0:
        raise CommandError("ratio terms must be positive")
    for a in fw.selected():
        if fw.params.ptype[a] != "E":
            raise CommandError("ER is for PSE axes")
    for a in fw.selected():
        fw.params.ratio[a] = enc / mot
        fw.motion.core.set_encoder_scale(a, enc / mot)


@command("UU", operand=Operand.NUMBERS)
def user_units(fw: Firmware, cmd: Command) -> None:
    try:
        factor = float(cmd.operand)
    except ValueError:
        raise CommandError("UU counts per unit") from None
    if factor <= 0:
        raise CommandError("UU must be positive")
    for a in fw.selected():
        fw.params.user_units[a] = factor


@command("UF")
def user_units_off(fw: Firmware, cmd: Command) -> None:
    for a in fw.selected():
        fw.params.user_units[a] = 0.0
