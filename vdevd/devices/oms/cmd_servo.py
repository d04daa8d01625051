"""Axis types, servo gains, closed loop and encoders [S §2.9, §2.13-2.14, §4.7; spec oms.md §4.3
"Servo (PSM) and position maintenance", §5.3-5.4]. The gain law is in servo.py."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevd.devices.oms.cmd_io import axis_letters
from vdevd.devices.oms.params import PARAMS
from vdevd.devices.oms.syntax import Command, CommandError

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware


def _type_reply(fw: Firmware, prefix: str) -> str:
    return ",".join(prefix + fw.params.ptype[a] for a in fw.selected())


def axis_type(fw: Firmware, cmd: Command) -> str | None:
    """PSO / PSE / PSM: open-loop stepper, stepper with encoder, servo (per axis in AA/AM:
    `PSM,M,O`); PS? -> =O/=E/=M. An axis made a servo starts with its loop open (CL0), as the
    balancing of [S §2.9] step 3 expects; a motion in progress stops at once."""
    if cmd.query:
        return _type_reply(fw, "=")
    pairs = axis_letters(fw, cmd, "OEM")
    for a, t in pairs:
        if t == "M" and fw.params.ptype[a] != "M":
            fw.params.closed_loop[a] = False
        fw.set_axis_type(a, t)
    fw.apply_gains()
    return None


def axis_type_old(fw: Firmware, cmd: Command) -> str:
    """The older query form: the type letter without `=` (firmware before 1.30, [A-base])."""
    return _type_reply(fw, "")


def gain(fw: Firmware, cmd: Command) -> str | None:
    """KP KI KD KU KV KA KF KO [S §2.13]: set per axis (a value out of range is refused and
    nothing changes); `KP?` replies `=10.00`, the older `?KP` `10.00`; either query is a
    command error on an axis that is not a servo (EPICS probes PSM with `?KP`)."""
    old = cmd.mnemonic.startswith("?")
    name = cmd.mnemonic.lstrip("?")
    if old or cmd.query:
        if any(fw.params.ptype[a] != "M" for a in fw.selected()):
            raise CommandError("not a servo axis")
        prefix = "" if old else "="
        return ",".join(f"{prefix}{fw.params.values[name][a]:.2f}" for a in fw.selected())
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


def closed_loop(fw: Firmware, cmd: Command) -> str | None:
    """CL1 closes the loop (PID hold), CL0 opens it (output KO only) [S §2.13]; one value per
    axis in AA/AM; CL? -> on/off."""
    if cmd.query:
        return ",".join("on" if fw.params.closed_loop[a] else "off" for a in fw.selected())
    pairs = fw.per_axis(cmd)
    if not pairs or any(v not in (0.0, 1.0) for _, v in pairs):
        raise CommandError("CL0 or CL1")
    for a, v in pairs:
        fw.set_closed_loop(a, v == 1.0)
    return None


def hold(fw: Firmware, cmd: Command) -> None:
    """Hold on / off: the older form of CL1 / CL0 [S §2.13]."""
    for a in fw.selected():
        fw.set_closed_loop(a, cmd.mnemonic == "HN")


def servo_polarity(fw: Firmware, cmd: Command) -> None:
    """SVP- inverts the servo output, KO included; SVP+ normal [S §2.9 step 5]."""
    for a, sign in axis_letters(fw, cmd, "+-"):
        fw.params.servo_inverted[a] = sign == "-"
    fw.apply_gains()


def encoder_direction(fw: Firmware, cmd: Command) -> None:
    """Encoder direction inverted / normal [S §2.9 step 5]: negates the encoder as the card
    reports it (RE, PE, the encoder words)."""
    for a in fw.selected():
        fw.params.encoder_inverted[a] = cmd.mnemonic == "EDI"


def _has_encoder(fw: Firmware, a: int) -> bool:
    return fw.params.ptype[a] in ("E", "M")


def encoder_status(fw: Firmware, cmd: Command) -> str:
    """Five characters per axis: slip detection E/D, position maintenance E/D, slip S/N,
    in deadband D/N, encoder home H/N [spec §4.2 EA]; a command error on an axis without
    encoder. Home is the home condition the firmware sees where the axis stands: HS the
    switch, HI the home truth table (HT/EH) [S §4.3, §4.8; encoder.py]."""
    axes = fw.selected()
    if not all(_has_encoder(fw, a) for a in axes):
        raise CommandError("axis has no encoder")
    m = fw.motion
    home = m.encoders.home_condition(m.home_index, m.home_active())
    out = []
    for a in axes:
        p = fw.params
        slip_on = p.values["ES"][a] > 0
        maint = p.closed_loop[a] and p.ptype[a] == "E"
        out.append(("E" if slip_on else "D") + ("E" if maint else "D")
                   + ("S" if fw.slip[a] else "N") + ("D" if fw.in_deadband(a) else "N")
                   + ("H" if home[a] else "N"))
    return ",".join(out)


def encoder_ratio(fw: Firmware, cmd: Command) -> None:
    """ER enc,motor: encoder counts per motor count, PSE axes only (spec §4.3, §4.4); the
    axis's position, velocity and acceleration operands are then encoder counts."""
    try:
        enc, mot = (float(x) for x in cmd.operand.split(","))
    except ValueError:
        raise CommandError("ER encoder,motor") from None
    if not (enc > 0 and mot > 0):
        raise CommandError("ratio terms must be positive")
    axes = fw.selected()
    if any(fw.params.ptype[a] != "E" for a in axes):
        raise CommandError("ER is for PSE axes")
    for a in axes:
        fw.params.ratio[a] = enc / mot
        fw.motion.core.set_encoder_scale(a, enc / mot)


def user_units(fw: Firmware, cmd: Command) -> None:
    """UU counts per user unit (one per axis in AA/AM): later position, velocity and
    acceleration operands and the RP/RE/RV replies are in user units [spec §4.1, §4.3]. Not
    queued: it changes how the commands after it are read."""
    pairs = fw.per_axis(cmd)
    if not pairs or any(not 0 < v <= 2_147_483_647 for _, v in pairs):
        raise CommandError("UU takes a positive number of counts per unit")
    for a, v in pairs:
        fw.params.user_units[a] = v


def user_units_off(fw: Firmware, cmd: Command) -> None:
    """User units off: counts again."""
    for a in fw.selected():
        fw.params.user_units[a] = 0.0
