"""Motion commands, motion parameters and the queue commands [S §2.13, §6.2, App C; spec oms.md
§4.3 "Motion", "Motion parameters"]."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from vdevd.devices.oms.params import (
    ENCODER_TERMS,
    HOME_TERMS,
    PARAMS,
    defines_home,
    format_home_pattern,
    parse_home_pattern,
)
from vdevd.devices.oms.queue import Group, Run, at_once
from vdevd.devices.oms.ssi import CLOCKS, MAX_BITS
from vdevd.devices.oms.syntax import Command, CommandError, beyond_axes, hex_words

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware

Make = Callable[[], Run]


def _no_operand(cmd: Command) -> None:
    if cmd.operand:
        raise CommandError("no operand expected")


def _refused(fw: Firmware, axis: int) -> bool:
    """A motion command toward an active limit is not executed: the over-travel event comes at
    once (ODBR bit, the axis's queue flushed so a pending ID never sets done) and the queue
    stops there [S §4.2; spec §3.4, §5.6]."""
    if not fw.motion.stopped_by_limit(axis):
        return False
    fw.on_motion_events(0)
    return True


def _starts(fw: Firmware, start: Callable[[int], None]) -> Make:
    """A queued command that starts a motion and completes at once (JG), unless a limit
    refuses it."""

    def make() -> Run:
        def run(axis: int) -> bool:
            start(axis)
            return not _refused(fw, axis)

        return run

    return make


# -- parameters (queued: they apply to the moves that follow them) -------------------------------
def motion_parameter(fw: Firmware, cmd: Command) -> str | None:
    """Queued per-axis parameters [S §2.14]: `ES` the encoder slip tolerance, `SE` the aux
    output settle time in ms (both proposed, spec §4.3); `ES?` and `SE?` reply `=n` per
    addressed axis."""
    name, param = cmd.mnemonic, PARAMS[cmd.mnemonic]
    if cmd.query:
        if name not in _QUERIED:
            raise CommandError(f"{name}? is not a query")
        return ",".join(f"={fw.params.values[name][a]:.0f}" for a in fw.selected())
    pairs = fw.per_axis(cmd)
    for a, v in pairs:
        value = param.coerce(v)
        if value is None:
            raise CommandError(f"{name} out of range")
        vl, vb = fw.queued_speed(a)  # as the commands queued before this one leave them
        if name == "VB" and value >= vl or name == "VL" and value <= vb:
            raise CommandError("VB must be below VL")  # "OMS errors if VB = VL"
    for a, v in pairs:
        value = param.coerce(v)
        if name in ("VL", "VB"):
            fw.queued[name][a] = value

        def set_value(axis: int, value: float | None = value) -> None:
            fw.params.values[name][axis] = value
            if name in ("AC", "ES"):  # the soft-limit deceleration, the slip tolerance
                fw.motion.apply_limits()

        fw.enqueue([a], name, at_once(set_value), units=2)
    return None


_QUERIED = ("ES", "SE")  # the queries the digest names (`SE?`); the others have none known


# -- targets and GO --------------------------------------------------------------------------
def _target(fw: Firmware, cmd: Command, relative: bool) -> None:
    pairs = fw.per_axis(cmd)
    if not pairs:
        raise CommandError("a position is required")
    for a, v in pairs:
        if not math.isfinite(v) or abs(v) > 2**31 - 1:
            raise CommandError("position out of range")
        fw.enqueue([a], cmd.mnemonic, _loads_target(fw, float(math.trunc(v)), relative),
                   units=_TARGET_UNITS)
        fw.armed.add(a)


def _loads_target(fw: Firmware, d: float, relative: bool) -> Make:
    """A queued command that loads the axis's target for the next GO: `d`, or `d` from the
    last target (relative)."""

    def set_target(axis: int) -> None:
        fw.pending[axis] = fw.motion.target_base(axis) + d if relative else d

    return at_once(set_target)


def move_absolute(fw: Firmware, cmd: Command) -> None:
    _target(fw, cmd, relative=False)


def move_relative(fw: Firmware, cmd: Command) -> None:
    _target(fw, cmd, relative=True)


def direction_logic(fw: Firmware, cmd: Command) -> None:
    """Direction logic positive / minus of the addressed axes: the direction `MO` steps in;
    `MA`/`MR` take their direction from the target (README)."""
    _no_operand(cmd)
    for a in fw.selected():
        fw.step_direction[a] = 1.0 if cmd.mnemonic == "MP" else -1.0


def move_one(fw: Firmware, cmd: Command) -> None:
    """Move one count in the direction `MP`/`MM` set (plus at power-up), each addressed axis on
    its own, as `MR1 GO` / `MR-1 GO` (proposed: the issue names MO, no retrieved source gives
    it; README)."""
    _no_operand(cmd)
    axes = fw.selected()
    if any(fw.queues[a].free < _MO_UNITS for a in axes):
        raise CommandError("command queue full")  # all or nothing, as any command
    for a in axes:
        fw.enqueue([a], "MO", _loads_target(fw, float(fw.step_direction[a]), relative=True),
                   units=_TARGET_UNITS)
        fw.enqueue([a], "MO", _go(fw, clear_done=False), units=_GO_UNITS)


_TARGET_UNITS = 2  # queue units of an MA/MR
_GO_UNITS = 4
_MO_UNITS = _TARGET_UNITS + _GO_UNITS


def _go(fw: Firmware, clear_done: bool) -> Make:
    def make() -> Run:
        started = False

        def run(axis: int) -> bool:
            nonlocal started
            if not started:
                started = True
                if clear_done:
                    fw.done[axis] = False
                target = fw.pending[axis]
                if math.isnan(target):
                    return True
                fw.pending[axis] = math.nan
                fw.motion.move_to(axis, target)
                if _refused(fw, axis):
                    return False
            return not fw.motion.moving(axis)

        return run

    return make


def go(fw: Firmware, cmd: Command) -> None:
    """Start the pending moves: in AA mode together (a group), in AM mode each axis on its own;
    the queue waits for the move to end [S App C]."""
    _no_operand(cmd)
    clear = cmd.mnemonic == "GD"
    axes = [fw.axis] if fw.mode == "single" else sorted(fw.armed) or list(range(fw.n))
    group = None
    if fw.mode == "AA":
        group = Group(frozenset(axes))
        fw.aa_members = group.members
    fw.enqueue(axes, cmd.mnemonic, _go(fw, clear), units=_GO_UNITS, group=group)
    fw.armed.clear()


def jog(fw: Firmware, cmd: Command) -> None:
    """Run at the signed velocity until stopped; a new JG changes the velocity on the fly."""
    pairs = fw.per_axis(cmd, integer=True)
    if any(abs(v) > PARAMS["VL"].hi for _, v in pairs):
        raise CommandError("jog velocity out of range")
    for a, v in pairs:

        def start(axis: int, v: float = v) -> None:
            fw.motion.jog(axis, v)

        fw.enqueue([a], "JG", _starts(fw, start), units=2)


def interrupt_done(fw: Firmware, cmd: Command) -> None:
    """At this point of the queue set the done flag and the doorbell done bit; in AA mode when
    every axis of the last AA move has reached it [S App C; spec §3.4]."""
    _no_operand(cmd)
    if fw.mode == "AA":
        axes = sorted(fw.aa_members)
        group = Group(frozenset(axes))
    else:
        axes, group = fw.selected(), None
    fw.enqueue(axes, "ID", at_once(fw.set_done), group=group)


# -- stopping --------------------------------------------------------------------------------
def _flags(fw: Firmware, cmd: Command) -> list[int]:
    """The axes of KS/SI: `1` per axis in AA/AM (`KS1,,1`), the axis in single-axis mode."""
    if not cmd.operand:
        return fw.selected()
    if fw.mode == "single":
        return [fw.axis]
    return [a for a, v in fw.per_axis(cmd) if v]


def stop(fw: Firmware, cmd: Command) -> None:
    """Decelerate the addressed axes to a stop at AC and flush their queues; a contour on one
    of them slows to rest on its path (Firmware.flush)."""
    for a in fw.selected():
        fw.flush(a, ramp=True)
        fw.motion.stop(a)


def stop_all(fw: Firmware, cmd: Command) -> None:
    for a in range(fw.n):
        fw.flush(a, ramp=True)
        fw.motion.stop(a)


def kill_all(fw: Firmware, cmd: Command) -> None:
    fw.kill(list(range(fw.n)))


def kill_selected(fw: Firmware, cmd: Command) -> None:
    fw.kill(_flags(fw, cmd))


def stop_individual(fw: Firmware, cmd: Command) -> None:
    for a in _flags(fw, cmd):
        fw.flush(a, ramp=True)
        fw.motion.stop(a)


def flush(fw: Firmware, cmd: Command) -> None:
    for a in fw.selected():
        fw.flush(a)


def wait_queue(fw: Firmware, cmd: Command) -> None:
    """Accepted: the host-side wait of EPICS' stop string needs nothing here (README)."""


# -- loops and waits (queued) --------------------------------------------------------------------
def loop_start(fw: Firmware, cmd: Command) -> None:
    pairs = fw.per_axis(cmd, integer=True) if fw.mode == "single" else [
        (a, v) for a, v in fw.per_axis(cmd, integer=True)]
    if not pairs:
        raise CommandError("a loop count is required")
    for a, v in pairs:
        if not 1 <= v <= 2_147_483_647:
            raise CommandError("loop count out of range")
        fw.enqueue([a], "LS", at_once(lambda axis: None), units=2, kind="LS", count=int(v))


def loop_end(fw: Firmware, cmd: Command) -> None:
    fw.enqueue(fw.selected(), "LE", at_once(lambda axis: None), kind="LE")


def wait_input(fw: Firmware, cmd: Command) -> None:
    """Hold the queue until general-purpose input bit # is high."""
    pairs = fw.per_axis(cmd, integer=True)
    for a, bit in pairs:
        if not 0 <= bit <= 15:
            raise CommandError("I/O bit is 0-15")

        def make(bit: int = int(bit)) -> Run:
            return lambda axis: bool(fw.gpio_levels() >> bit & 1)

        fw.enqueue([a], "SW", make, units=2)


def wait_time(fw: Firmware, cmd: Command) -> None:
    """Hold the queue for # milliseconds (README)."""
    pairs = fw.per_axis(cmd, integer=True)
    for a, ms in pairs:
        if not 0 <= ms <= 2_147_483_647:
            raise CommandError("time out of range")

        def make(ms: float = ms) -> Run:
            end: list[int] = []

            def run(axis: int) -> bool:
                if not end:
                    end.append(fw.now_ns + int(ms * 1e6))
                return fw.now_ns >= end[0]

            return run

        fw.enqueue([a], "WT", make, units=2)


# -- position registers (queued) ------------------------------------------------------------------
def _load(fw: Firmware, cmd: Command, which: str) -> None:
    pairs = fw.per_axis(cmd, integer=True)
    if not pairs:
        raise CommandError("a position is required")
    for a, v in pairs:
        if abs(v) > 2**31 - 1:
            raise CommandError("position out of range")

        def load(axis: int, v: float = v) -> None:
            fw.load_position(axis, v, which)

        fw.enqueue([a], cmd.mnemonic, at_once(load), units=2)


def load_position(fw: Firmware, cmd: Command) -> None:
    """Load motor and encoder position [S §2.13]."""
    _load(fw, cmd, "both")


def load_motor(fw: Firmware, cmd: Command) -> None:
    _load(fw, cmd, "motor")


def load_encoder(fw: Firmware, cmd: Command) -> None:
    _load(fw, cmd, "encoder")


# -- homing (queued; the queue waits for the search to end) ------------------------------------
def home_search(fw: Firmware, cmd: Command) -> None:
    """HM/HR search home forward/reverse and ramp to a stop there, KM/KR stop at once; the
    home position becomes the operand (0 without one) [S §4.3, §4.8; spec §5.5]. Queued: the
    queue waits for the search to end."""
    forward = cmd.mnemonic in ("HM", "KM")
    ramp = cmd.mnemonic in ("HM", "HR")
    pairs = fw.per_axis(cmd, integer=True)
    if not cmd.operand:
        pairs = [(a, 0.0) for a in fw.selected()]
    for a, value in pairs:
        if abs(value) > 2**31 - 1:
            raise CommandError("position out of range")

        def make(value: float = value) -> Run:
            started = False

            def run(axis: int) -> bool:
                nonlocal started
                if not started:
                    started = True
                    fw.motion.home(axis, forward, value, ramp)
                    if _refused(fw, axis):
                        return False
                return not fw.motion.moving(axis)

            return run

        fw.enqueue([a], cmd.mnemonic, make, units=2)


def home_mode(fw: Firmware, cmd: Command) -> None:
    """Home mode of the addressed axes: HI "Home Encoder" (home = the AND of phase A, phase B,
    index and switch as the truth table HT/EH sets them, by default `Home = Phase +A * Phase -B
    * Index * Home Switch` [S §4.8]) or HS (the switch alone, the power-up mode); HI needs an
    encoder (PSE, PSM)."""
    _no_operand(cmd)
    axes = fw.selected()
    index = cmd.mnemonic == "HI"
    if index and any(fw.params.ptype[a] == "O" for a in axes):
        raise CommandError("HI needs an encoder (PSE or PSM)")
    for a in axes:
        fw.motion.set_home_mode(a, index)


def home_truth_table(fw: Firmware, cmd: Command) -> str | None:
    """The home logic of HI mode [S §4.3, §4.8] for the addressed axes: `HT a,b,i,s` sets the
    entry of phase A, phase B, index and home switch, `EH a,b,i` the encoder's three only (the
    switch entry stays): 1 active (high), 0 inactive (low), 2 ignored; `1,0,1,1` or `1011`.
    Factory `HT1011`, the manual's default. A table that ignores every term is refused.
    `HT?` -> `=1011`, `EH?` -> `=101` per addressed axis (README)."""
    terms = len(HOME_TERMS) if cmd.mnemonic == "HT" else ENCODER_TERMS
    table, axes = fw.params.home_pattern, fw.selected()
    if cmd.query:
        return ",".join("=" + format_home_pattern(table[a, :terms]) for a in axes)
    pattern = parse_home_pattern(cmd.operand, terms)
    if pattern is None:
        raise CommandError(f"{cmd.mnemonic} takes {terms} entries of 0, 1 or 2")
    if any(not defines_home(pattern + tuple(table[a, terms:])) for a in axes):
        raise CommandError("a home condition needs at least one term")
    for a in axes:
        table[a, :terms] = pattern
    return None


# -- real-time position capture (mnemonics proposed: spec §2.8) ------------------------------------
def _capture_axes(fw: Firmware, pairs: list[tuple[int, int]]) -> None:
    if any(fw.params.ptype[a] == "O" and v for a, v in pairs):
        raise CommandError("capture needs an incremental encoder (PSE or PSM) [S §3.7]")


def capture_home(fw: Firmware, cmd: Command) -> str | None:
    """CPH#: capture the encoder position on home events, the Table 3-6 bits: 1 the home
    switch's rising edge, 2 the encoder index pulse, 4 the falling edge (0 off); `CPH?` ->
    `=#` per addressed axis."""
    cap = fw.capture
    if cmd.query:
        return ",".join(f"={int(cap.home[a])}" for a in fw.selected())
    pairs = [(a, int(v)) for a, v in fw.per_axis(cmd, integer=True)]
    if not pairs or any(not 0 <= v <= 7 for _, v in pairs):
        raise CommandError("CPH takes 0-7 (1 rising, 2 index, 4 falling)")
    _capture_axes(fw, pairs)
    for a, v in pairs:
        cap.home[a] = v
    cap.configure(fw)
    return None


def capture_inputs(fw: Firmware, cmd: Command) -> str | None:
    """CPR/CPF hex: capture the encoder position when these general-purpose input lines rise
    (CPR) or fall (CPF), bit n = IOn, one mask per axis in AA/AM (0 off); `CPR?` -> `=hhhh`."""
    cap = fw.capture
    masks = cap.rising if cmd.mnemonic == "CPR" else cap.falling
    if cmd.query:
        return ",".join(f"={int(masks[a]):04x}" for a in fw.selected())
    words = hex_words(cmd.operand) if cmd.operand else []
    if fw.mode == "single":
        if len(words) != 1 or words[0] is None:
            raise CommandError("one 16-bit hex mask")
        pairs = [(fw.axis, words[0])]
    else:
        if beyond_axes(words, fw.n):
            raise CommandError("more values than axes")
        pairs = [(a, w) for a, w in enumerate(words) if w is not None]
    if not pairs or any(w > 0xFFFF for _, w in pairs):
        raise CommandError("16-bit hex masks")
    _capture_axes(fw, pairs)
    for a, w in pairs:
        masks[a] = w
    cap.configure(fw)
    return None


# -- absolute encoders ------------------------------------------------------------------------
def ssi_encoder(fw: Firmware, cmd: Command) -> str | None:
    """ECA bits,clock: the addressed PSE axis reads an SSI absolute encoder of 1-32 bits at
    one of the §4.9 clock rates [S §4.9.1]; `ECA?` -> `=bits,clock`."""
    a = fw.axis
    if cmd.query:
        return f"={int(fw.ssi.bits[a])},{int(fw.ssi.clock[a])}"
    try:
        bits, clock = (int(x) for x in cmd.operand.split(","))
    except ValueError:
        raise CommandError("ECA bits,clock") from None
    if fw.params.ptype[a] != "E":
        raise CommandError("ECA is for PSE axes")
    if not 1 <= bits <= MAX_BITS or clock not in CLOCKS:
        raise CommandError("ECA: 1-32 bits, a clock of the list in [S §4.9]")
    fw.ssi.configure(a, bits, clock)
    return None
