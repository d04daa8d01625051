"""Limits, home switches, general-purpose I/O and analog inputs [S §4.2-4.5; spec oms.md §4.3
"Limits, home, I/O", §5.6-5.7]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevd.devices.oms.servo import COUNTS_PER_VOLT
from vdevd.devices.oms.syntax import Command, CommandError, beyond_axes, hex_words

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware


def axis_letters(fw: Firmware, cmd: Command, allowed: str) -> list[tuple[int, str]]:
    """Per-axis letters (`LMH,,S` in AA/AM, `LMH` in single-axis mode)."""
    fields = cmd.operand.split(",") if cmd.operand else []
    if fw.mode == "single":
        if len(fields) != 1:
            raise CommandError("one value in single-axis mode")
        pairs = [(fw.axis, fields[0])]
    else:
        if beyond_axes(fields, fw.n):
            raise CommandError("more values than axes")
        pairs = [(a, f) for a, f in enumerate(fields) if f]
    for _, f in pairs:
        if f not in allowed or len(f) != 1:
            raise CommandError(f"expected one of {allowed}")
    return pairs


def _polarity_reply(fw: Firmware, high: list[bool]) -> str:
    return ",".join("=h" if high[a] else "=l" for a in fw.selected())


def limit_level(fw: Firmware, cmd: Command) -> str | None:
    """LTH / LTL: limit switches active high / low; LT? -> =h / =l [S §4.2]."""
    if cmd.query:
        return _polarity_reply(fw, fw.params.limit_high.tolist())
    for a, f in axis_letters(fw, cmd, "HL"):
        fw.params.limit_high[a] = f == "H"
    fw.motion.apply_limits()
    return None


def limit_level_legacy(fw: Firmware, cmd: Command) -> None:
    """The older spelling of LTH / LTL ("LL - low (default)")."""
    for a in fw.selected():
        fw.params.limit_high[a] = cmd.mnemonic == "LH"
    fw.motion.apply_limits()


def limit_mode(fw: Firmware, cmd: Command) -> str | None:
    """LMH hard (stop at once), LMS soft (decelerate), LMF off; LM? -> =h / =s / =f."""
    if cmd.query:
        return ",".join("=" + fw.params.limit_mode[a].lower() for a in fw.selected())
    for a, f in axis_letters(fw, cmd, "HSF"):
        fw.params.limit_mode[a] = f
    fw.motion.apply_limits()
    return None


def limits_off_on(fw: Firmware, cmd: Command) -> None:
    """LF limits off, LN limits on (hard) for the addressed axes (README)."""
    for a in fw.selected():
        fw.params.limit_mode[a] = "F" if cmd.mnemonic == "LF" else "H"
    fw.motion.apply_limits()


def home_level(fw: Firmware, cmd: Command) -> None:
    """Home switch active high / low (factory low) [S §2.14]."""
    for a in fw.selected():
        fw.params.home_high[a] = cmd.mnemonic == "HH"
    fw.motion.apply_limits()


def query_limits(fw: Firmware, cmd: Command) -> str:
    """The limit word (Table 3-2, raw levels) in hex (RL: the same report, spec §4.3)."""
    return f"{fw.limit_word():x}"


# -- general-purpose I/O ---------------------------------------------------------------------------
def _bit(cmd: Command) -> int:
    try:
        bit = int(cmd.operand)
    except ValueError:
        raise CommandError("an I/O bit number is required") from None
    if not 0 <= bit <= 15:
        raise CommandError("I/O bit is 0-15")
    return bit


def _hex_word(cmd: Command, what: str) -> int:
    """The one 16-bit hex operand of BD / BW."""
    words = hex_words(cmd.operand) if cmd.operand else []
    if len(words) != 1 or words[0] is None or words[0] > 0xFFFF:
        raise CommandError(f"one 16-bit hex {what}")
    return words[0]


def bit_direction(fw: Firmware, cmd: Command) -> None:
    """Directions of the 16 I/O bits, 1 = output (`BD%04x`) [S §4.4]."""
    fw.gpio_dir = _hex_word(cmd, "mask")


def io_direction(fw: Firmware, cmd: Command) -> None:
    """IO bit,dir: one bit's direction (1 = output)."""
    try:
        bit, direction = (int(x) for x in cmd.operand.split(","))
    except ValueError:
        raise CommandError("IO bit,direction") from None
    if not 0 <= bit <= 15 or direction not in (0, 1):
        raise CommandError("IO bit 0-15, direction 0/1")
    fw.gpio_dir = fw.gpio_dir | 1 << bit if direction else fw.gpio_dir & ~(1 << bit)


def bit_high_low(fw: Firmware, cmd: Command) -> None:
    bit = _bit(cmd)
    if not fw.gpio_dir >> bit & 1:
        raise CommandError(f"I/O bit {bit} is an input")
    fw.gpio_out = fw.gpio_out | 1 << bit if cmd.mnemonic == "BH" else fw.gpio_out & ~(1 << bit)


def bit_write(fw: Firmware, cmd: Command) -> None:
    """Write all output bits at once (hex)."""
    fw.gpio_out = _hex_word(cmd, "word")


def bit_report(fw: Firmware, cmd: Command) -> str:
    """The 16 I/O bits, exactly 4 hex digits [E-traj]."""
    return f"{fw.gpio_levels():04x}"


def analog_input(fw: Firmware, cmd: Command) -> str:
    """AI ch: the input in volts, three decimals (format assumed, README)."""
    try:
        ch = int(cmd.operand)
    except ValueError:
        raise CommandError("a channel is required") from None
    if not 0 <= ch < fw.analog_channels:
        raise CommandError("no such analog input")
    return f"{fw.analog_in[ch]:.3f}"


def analog_output(fw: Firmware, cmd: Command) -> None:
    """AO volts (one per axis in AA/AM): the DAC of an axis that is not a servo as a
    general-purpose analog output, -10..+10 V [S §4.5.2]; refused on a servo axis, whose DAC
    the loop drives. Shown in the axis's DAC word (0x2E80 + 4·axis) (README)."""
    pairs = fw.per_axis(cmd)
    if not pairs or any(not -10.0 <= v <= 10.0 for _, v in pairs):
        raise CommandError("AO takes -10..+10 V")
    if any(fw.params.ptype[a] == "M" for a, _ in pairs):
        raise CommandError("the DAC of a servo axis is not an analog output")
    for a, v in pairs:
        fw.motion.servo.set_analog_out(a, round(v * COUNTS_PER_VOLT))


def aux_output(fw: Firmware, cmd: Command) -> None:
    """Auxiliary output of the addressed axes on / off [S §4.6; spec §4.3 AN/AF]; the backdoor
    `get_outputs` shows them (README)."""
    for a in fw.selected():
        fw.aux[a] = cmd.mnemonic == "AN"
