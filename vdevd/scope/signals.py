"""The scope's signal names and how a card maps them (issue 23 §1; docs/card-pattern.md "Scope").

The names are the same on every card: `position` (actual), `command` (commanded position),
`velocity` (actual), `command_velocity`, `error` (following error), `output` (DAC or pulse
rate), `status`, `inputs`, `outputs`. The first six are rows of the motion core's state block
(`Axes.state`, one `np.take` a sample for any set of them); the last three are the card's own
per-axis words (ints), read by a function of the card's `Signals` class.

A card package says how in its `scope.py`: a `Signals` subclass (`SIGNALS_CLASS`) overriding
`core`, `rows` and the word functions. Only classes and plain functions: a recorder holds the
class, never a closure, so a rack with a recorder pickles (snapshots).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from vdevd.rt.axes import Axes, AxisFlag

if TYPE_CHECKING:
    from vdevd.rt.core import MotionCore

#: the rows of the motion core's state (floats, in the card's counts and counts/s)
CORE_SIGNALS = ("position", "command", "velocity", "command_velocity", "error", "output")
#: the card's own words (ints, per axis)
WORD_SIGNALS = ("status", "inputs", "outputs")
SIGNALS = CORE_SIGNALS + WORD_SIGNALS

#: default `inputs` bits from the core's flags: bit 0 forward (+) limit, 1 reverse (-) limit,
#: 2 home switch, 3 amplifier fault
_INPUT_BITS = ((AxisFlag.HARD_LIMIT_POS, 0), (AxisFlag.HARD_LIMIT_NEG, 1),
               (AxisFlag.HOME_SWITCH, 2), (AxisFlag.AMP_FAULT, 3))


class Signals:
    """How the scope reads a card: defaults that fit any card with one `MotionCore`.

    `rows`: signal -> row of `Axes.state` (`position` is the loop's feedback, the encoder in
    position counts, as a card's actual position register reads it). `status`: the core's
    `AxisFlag` bits; `inputs`: the switches (`_INPUT_BITS`); `outputs`: bit 0 the amplifier
    enable (servo on). A card overrides what its manual reports otherwise.
    """

    rows: ClassVar[dict[str, int]] = {
        "position": Axes.FB, "command": Axes.CMD_POS, "velocity": Axes.VEL,
        "command_velocity": Axes.CMD_VEL, "error": Axes.FERR, "output": Axes.OUT,
    }

    @staticmethod
    def core(card: Any) -> MotionCore:
        """The card's motion core (override: where the card keeps it)."""
        return card.core

    @classmethod
    def axis_names(cls, card: Any) -> list[str]:
        """The axes as the card's backdoor names them: its letters, else numbers from its
        `axis_base`."""
        n = cls.core(card).n
        letters = card.axis_letters[:n]
        if len(letters) == n:
            return list(letters)
        return [str(card.axis_base + a) for a in range(n)]

    @classmethod
    def status(cls, card: Any) -> np.ndarray:
        return cls.core(card).axes.flags

    @classmethod
    def inputs(cls, card: Any) -> np.ndarray:
        flags = cls.core(card).axes.flags
        out = np.zeros(len(flags), dtype=np.int64)
        for flag, bit in _INPUT_BITS:
            out |= ((flags & int(flag)) != 0) << bit
        return out

    @classmethod
    def outputs(cls, card: Any) -> np.ndarray:
        return cls.core(card).servo_on_mask.astype(np.int64)

    @classmethod
    def word(cls, card: Any, name: str) -> np.ndarray:
        """The per-axis int array of word signal `name` now."""
        fn = {"status": cls.status, "inputs": cls.inputs, "outputs": cls.outputs}[name]
        return np.asarray(fn(card), dtype=np.int64)


def broadcast(value: int, n: int) -> np.ndarray:
    """A card-wide word (a general-purpose output port) as the value of each of n axes."""
    return np.full(n, value, dtype=np.int64)
