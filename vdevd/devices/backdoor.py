"""The backdoor vocabulary every card speaks (DESIGN.md "The axis world").

`set_limit`, `set_home`, `set_home_window`, `set_index`, `set_input`, `set_analog`,
`set_amp_fault`, `set_encoder_loss`, `set_estop`, `jam` and `push` have the same names and
parameters on every card; each card maps them to its own signals (its README has the table). The axis actions
change the card's `AxisWorld` and ask the card to apply it (`apply_world`); the input, analog and
emergency-stop actions go to the card's `drive_input`, `drive_analog` and `drive_estop`. Axes are
named as the card names them: a letter of `axis_letters` (any case) or a number counted from
`axis_base`.

A parameter declared `bool` (`active`, `level`) or `bool | None` takes only true or false (or 0
and 1, as JSON and msgpack clients send them); `Card.control` checks them (`flag_params`,
`flag`) before the action runs, so the string "False" never engages an input.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

from vdevd.rt.world import AxisWorld

SIDES = ("positive", "negative")
#: the largest voltage `set_analog` drives onto an input (the cards' ranges are +-10 V or less)
MAX_VOLTS = 100.0
#: the largest distance `push` moves an axis by, in counts (either way)
MAX_PUSH = 2**31


def flag(name: str, value: Any, optional: bool = False) -> bool | None:
    """A backdoor flag: a boolean, or 0 or 1; None only when `optional`. ValueError naming
    `name` otherwise (`bool("false")` would be True)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if value is None and optional:
        return None
    raise ValueError(f"{name}: expected true or false, got {value!r}")


@functools.cache
def _flags_of(fn: Callable[..., Any]) -> Mapping[str, bool]:
    found = {}
    for p in inspect.signature(fn).parameters.values():
        ann = p.annotation if isinstance(p.annotation, str) else inspect.formatannotation(
            p.annotation)
        if ann in ("bool", "bool | None"):
            found[p.name] = ann != "bool"
    return found


def flag_params(action: Callable[..., Any]) -> Mapping[str, bool]:
    """The parameters of a backdoor action declared `bool` or `bool | None`, each with whether
    None is allowed."""
    return _flags_of(getattr(action, "__func__", action))


def control(name: str | None = None, *, deprecated: str | None = None
            ) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Mark a method as a backdoor action (`rack.control(card, action, **params)`);
    `deprecated` names the action of the shared vocabulary that replaces it."""

    def mark(fn: Callable[..., Any]) -> Callable[..., Any]:
        fn.__vdev_control__ = name or fn.__name__  # type: ignore[attr-defined]
        fn.__vdev_deprecated__ = deprecated  # type: ignore[attr-defined]
        return fn

    return mark


class WorldBackdoor:
    """The shared backdoor actions; a card provides `world`, `apply_world` and the drives."""

    #: letters that name the axes (in axis order), accepted in any case; "" for numbers only
    axis_letters: ClassVar[str] = ""
    #: the number of the first axis (0 or 1, as the manual counts)
    axis_base: ClassVar[int] = 0
    world: AxisWorld

    def axis_index(self, axis: str | int) -> int:
        """The index of the axis a backdoor call names; ValueError naming the card's axes."""
        n = self.world.n
        letters = self.axis_letters[:n]
        if isinstance(axis, str) and len(axis) == 1 and axis.upper() in letters:
            return letters.index(axis.upper())
        if isinstance(axis, int) and not isinstance(axis, bool):
            a = axis - self.axis_base
            if 0 <= a < n:
                return a
        names = [*letters] if letters else []
        numbers = f"{self.axis_base}..{self.axis_base + n - 1}"
        raise ValueError(f"no axis {axis!r} (axes: {', '.join(names) + ' or ' if names else ''}"
                         f"{numbers})")

    def apply_world(self) -> None:
        """Put the world's levels and faults on the card's inputs now (override)."""

    def drive_input(self, line: int, level: bool) -> None:
        """Drive general input `line` (override)."""
        raise ValueError("this card has no general inputs")

    def drive_analog(self, channel: int, volts: float) -> None:
        """Drive analog input `channel` (override)."""
        raise ValueError("this card has no analog inputs")

    def drive_estop(self, active: bool) -> None:
        """Drive the card's emergency-stop or abort input (override)."""
        raise ValueError("this card has no emergency-stop input")

    def push_axis(self, a: int, counts: float) -> None:
        """Move the mechanics of axis index `a` by hand by `counts` (override: usually
        `MotionCore.push`)."""
        raise ValueError("this card has no mechanics to push")

    def physical_positions(self) -> Any:
        """The stage's physical positions of the card's axes, in counts (override: usually
        `MotionCore.physical()`)."""
        raise NotImplementedError

    def sense_world(self) -> None:
        """Every tick: the switch levels from the stage's physical positions, applied when one
        changed (nothing to do for a world without mechanics)."""
        world = self.world
        if world.mechanical and world.sense(self.physical_positions()):
            self.apply_world()

    def _world_changed(self) -> None:
        """A backdoor change: the levels sensed again (or from the forces alone) and applied."""
        if self.world.mechanical:
            self.world.sense(self.physical_positions())
        else:
            self.world.forced()
        self.apply_world()

    @control()
    def set_limit(self, axis: str | int, side: str = "positive", active: bool = True) -> None:
        """Hold a hard-limit switch active (or release it to the mechanics): side is positive
        or negative."""
        if side not in SIDES:
            raise ValueError(f"side {side!r} is not one of {', '.join(SIDES)}")
        self.world.force_limit(self.axis_index(axis), side == "positive", bool(active))
        self._world_changed()

    @control()
    def set_home(self, axis: str | int, active: bool = True) -> None:
        """Hold the home switch active (or release it to the mechanics)."""
        self.world.force_home_switch(self.axis_index(axis), bool(active))
        self._world_changed()

    @control()
    def set_home_window(self, axis: str | int, low: float, high: float) -> None:
        """Move the home switch: active while low <= physical position <= high (counts)."""
        self.world.set_home_window(self.axis_index(axis), float(low), float(high))
        self._world_changed()

    @control()
    def set_index(self, axis: str | int, period: float = 4096, phase: float = 0) -> None:
        """Encoder index pulses every `period` counts at `phase` (physical counts; 0: none)."""
        self.world.set_index(self.axis_index(axis), float(period), float(phase))
        self._world_changed()

    @control()
    def set_input(self, line: int, level: bool) -> None:
        """Drive a general-purpose input line (numbered as the card's manual numbers them)."""
        self.drive_input(line, level)

    @control()
    def set_analog(self, channel: int, volts: float) -> None:
        """Drive an analog input channel, in volts."""
        value = float(volts)
        if not -MAX_VOLTS <= value <= MAX_VOLTS:  # also NaN; a card saturates at its own range
            raise ValueError(f"volts {volts!r} outside -{MAX_VOLTS:g}..{MAX_VOLTS:g}")
        self.drive_analog(channel, value)

    @control()
    def set_amp_fault(self, axis: str | int, active: bool = True) -> None:
        """Assert or clear the amplifier fault of an axis."""
        self.world.set_fault("amp_fault", self.axis_index(axis), bool(active))
        self._world_changed()

    @control()
    def set_encoder_loss(self, axis: str | int, active: bool = True) -> None:
        """Lose (freeze) or restore the encoder of an axis."""
        self.world.set_fault("encoder_loss", self.axis_index(axis), bool(active))
        self._world_changed()

    @control()
    def set_estop(self, active: bool = True) -> None:
        """Drive the card's emergency-stop (abort) input."""
        self.drive_estop(bool(active))

    @control()
    def jam(self, axis: str | int, active: bool = True) -> None:
        """Block the motor of an axis: the stage stays put while the command goes on, so the
        following error grows."""
        self.world.set_fault("jammed", self.axis_index(axis), bool(active))
        self._world_changed()

    @control()
    def push(self, axis: str | int, counts: float) -> None:
        """Move the mechanics of an axis by hand by `counts` (whole counts, |counts| <= 2**31):
        the stage and the actual position move, the command does not. Servo off, the axis stays
        there and its encoder reads it; servo on, its loop pulls it back; a stepper's step count
        does not change (MotionCore.push)."""
        if isinstance(counts, bool) or not isinstance(counts, int | float):
            raise ValueError(f"counts: expected a number, got {counts!r}")
        if not -MAX_PUSH <= counts <= MAX_PUSH:  # also NaN
            raise ValueError(f"counts {counts!r} outside -{MAX_PUSH}..{MAX_PUSH}")
        self.push_axis(self.axis_index(axis), float(counts))
        self._world_changed()
