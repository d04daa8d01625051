"""Coordinate systems of the Turbo PMAC: axis definitions, position bias, C.S. status words and
the user countdown timers Isx11/Isx12 [spec pmac.md §2.8, §2.6; A L922-934, L3284].

Sixteen coordinate systems. `#m->{scale}{axis}[{+|-}{scale}{axis}...][{+|-}{offset}]` (issued
with `&s` addressed) puts motor m in C.S. s: motor position = Σ scale·axis + offset, in counts
[A L922]. `#m->I` makes it an inverse-kinematic axis. A motor belongs to at most one C.S.; its
status word 2 shows it (bit 15, bits 16-19 the axis code, bits 20-23 the C.S. − 1) [§2.6].
`UNDEFINE` clears the addressed C.S. only (V1.938 [A L3284]), `UNDEFINE ALL` every one.

The position bias Mxx64 (counts here; the register holds 1/(Ixx08·32) count) is set to the
definition's offset at definition and reset, and changed by the on-line `{axis}={v}` [A L932].
The axis positions (L:$002041-$002049) are what the motors' commanded positions give back through
their definitions; no motion program runs yet, so nothing else moves them.

Isx11/Isx12 count down one per servo cycle [§2.8 X/Y:$002015]: each keeps the value written and
the servo cycle it was written at, so a card at rest does no work for them.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.ivars import IVars
from vdevd.devices.pmac.numbers import format_value

CS_COUNT = 16
MAX_MOTORS = 32
#: axis letters in the order of the C.S. target-position registers L:$002041.. [§2.8]
AXES = "ABCUVWXYZ"
#: motor status word 2 bits 16-19: the axis definition code [Turbo SRM "#n?" word 2; README]
AXIS_CODE = {"A": 1, "B": 2, "C": 3, "U": 4, "V": 4, "W": 4, "X": 7, "Y": 7, "Z": 7}
INVERSE_CODE = 5
#: Isx11, Isx12: 24-bit signed countdown timers
TIMERS = (11, 12)
_TIMER_MOD = 1 << 24
_TIMER_HALF = 1 << 23

_NUM = r"(?:\d+\.?\d*|\.\d+)"
_TERM = re.compile(rf"[ \t]*([+-]?)[ \t]*({_NUM})?([{AXES}])")
_OFFSET = re.compile(rf"[ \t]*([+-])[ \t]*({_NUM})(?![{AXES}\d.])")
_ZERO = re.compile(r"[ \t]*0+(?![\d.A-Z])")


@dataclass(frozen=True)
class AxisDef:
    """One motor's axis definition: (scale, axis) terms and an offset, counts; or inverse
    kinematics (`#m->I`)."""

    terms: tuple[tuple[float, str], ...] = ()
    offset: float = 0.0
    inverse: bool = False

    def text(self) -> str:
        """As `#m->` reports it: `1000X+500Y+10`, `I` (ASSUMPTION: the form it was written in,
        numbers as the card prints them)."""
        if self.inverse:
            return "I"
        out = ""
        for k, (scale, axis) in enumerate(self.terms):
            sign = "-" if scale < 0 else ("+" if k else "")
            out += f"{sign}{format_value(abs(scale))}{axis}"
        if self.offset:
            out += f"{'-' if self.offset < 0 else '+'}{format_value(abs(self.offset))}"
        return out

    def code(self) -> int:
        """Word 2 bits 16-19: the code of the first axis (5 for inverse kinematics)."""
        return INVERSE_CODE if self.inverse else AXIS_CODE[self.terms[0][1]]

    def scale_of(self, axis: str) -> float:
        return sum(s for s, a in self.terms if a == axis)


def parse_axis_def(s: str, i: int) -> tuple[AxisDef | None, int]:
    """The definition at s[i:] (upper case) and where it ends; None for `0` (clear the motor's
    definition). ERR003 for anything else that is not a definition."""
    if s.startswith("I", i) and not s[i + 1:i + 2].isalpha():
        return AxisDef(inverse=True), i + 1
    m = _ZERO.match(s, i)
    if m is not None:
        return None, m.end()
    terms: list[tuple[float, str]] = []
    while True:
        m = _TERM.match(s, i)
        if m is None or (terms and not m.group(1)):
            break
        scale = float(m.group(2)) if m.group(2) else 1.0
        terms.append((-scale if m.group(1) == "-" else scale, m.group(3)))
        i = m.end()
    if not terms or len({a for _, a in terms}) != len(terms):
        raise CommandError(ERR_DATA, "bad axis definition")
    offset = 0.0
    m = _OFFSET.match(s, i)
    if m is not None:
        offset = float(m.group(2)) * (-1 if m.group(1) == "-" else 1)
        i = m.end()
    return AxisDef(tuple(terms), offset), i


class CoordSystems:
    """The axis definitions of motors 1-32 in C.S. 1-16, their position bias and the Isx11/Isx12
    timers; `assigned` and `codes` mirror the definitions into the motors' status words."""

    def __init__(self, ivars: IVars, assigned: np.ndarray, codes: np.ndarray,
                 clock: Callable[[], int]) -> None:
        self.ivars = ivars
        self.assigned, self.codes = assigned, codes  # Motors.cs, Motors.axis_code (card motors)
        self.clock = clock
        self.cs = np.zeros(MAX_MOTORS, dtype=np.int64)  # 1-16, 0 = none
        self.defs: list[AxisDef | None] = [None] * MAX_MOTORS
        self.bias = np.zeros(MAX_MOTORS)  # position bias Mxx64, counts
        self._timer_at = np.zeros(CS_COUNT * 100 + 5100, dtype=np.int64)

    # -- definitions ------------------------------------------------------------------------------
    def define(self, cs: int, motor: int, d: AxisDef | None) -> None:
        """`&cs#motor->{d}` (None: `#m->0` clears it). A motor in another C.S. answers ERR003
        (ASSUMPTION: the card refuses; the digest names no code)."""
        m = motor - 1
        if self.cs[m] and self.cs[m] != cs:
            raise CommandError(ERR_DATA, f"motor {motor} is in C.S. {self.cs[m]}")
        if d is None:
            self._clear(np.array([m]))
            return
        self.cs[m], self.defs[m] = cs, d
        self.bias[m] = d.offset
        self._sync()

    def query(self, cs: int, motor: int) -> str:
        """`&cs#motor->`: the definition in C.S. cs, `0` for none there."""
        d = self.defs[motor - 1]
        return d.text() if d is not None and self.cs[motor - 1] == cs else "0"

    def undefine(self, cs: int | None) -> None:
        """UNDEFINE (cs) / UNDEFINE ALL (None) [A L3284]."""
        self._clear(np.flatnonzero(self.cs if cs is None else self.cs == cs))

    def _clear(self, idx: np.ndarray) -> None:
        for m in idx.tolist():
            self.defs[m] = None
        self.cs[idx] = 0
        self.bias[idx] = 0
        self._sync()

    def _sync(self) -> None:
        n = len(self.assigned)
        self.assigned[:] = self.cs[:n]
        self.codes[:] = [d.code() if d is not None else 0 for d in self.defs[:n]]

    def members(self, cs: int) -> list[int]:
        """The motors (1-based) defined in C.S. cs."""
        return [int(m) + 1 for m in np.flatnonzero(self.cs == cs)]

    def has_members(self, cs: int) -> bool:
        return bool((self.cs == cs).any())

    # -- axis positions and the position bias -----------------------------------------------------
    def axis_position(self, cs: int, axis: str, commanded: np.ndarray) -> float:
        """The axis position the first single-axis motor of it gives back from its commanded
        position, (commanded − bias)/scale; 0 with none (ASSUMPTION, README)."""
        for m in np.flatnonzero(self.cs[:len(commanded)] == cs).tolist():
            d = self.defs[m]
            if d is not None and len(d.terms) == 1 and d.terms[0][1] == axis and d.terms[0][0]:
                return float((commanded[m] - self.bias[m]) / d.terms[0][0])
        return 0.0

    def set_axis(self, cs: int, axis: str, value: float, commanded: np.ndarray) -> None:
        """`{axis}={value}`: the present axis position becomes `value` by changing the position
        bias of each motor the axis drives; nothing moves [A L932]."""
        old = self.axis_position(cs, axis, commanded)
        for m in np.flatnonzero(self.cs == cs).tolist():
            d = self.defs[m]
            if d is not None and not d.inverse:
                self.bias[m] += d.scale_of(axis) * (old - value)

    def rebias(self, motor: int) -> None:
        """Homing: the position bias back to the definition's offset [A L932] (ASSUMPTION: when
        the home command is given, not when the search ends)."""
        d = self.defs[motor - 1]
        self.bias[motor - 1] = d.offset if d is not None else 0.0

    # -- Isx11/Isx12 --------------------------------------------------------------------------------
    @staticmethod
    def is_timer(n: int) -> bool:
        return 5100 <= n < 5100 + 100 * CS_COUNT and n % 100 in TIMERS

    def timer(self, n: int) -> float:
        """Isx11/Isx12 now: the value written minus the servo cycles since, as a 24-bit signed
        count (ASSUMPTION: it counts on through zero and wraps)."""
        v = int(self.ivars.values[n]) - (self.clock() - int(self._timer_at[n]))
        return float((v + _TIMER_HALF) % _TIMER_MOD - _TIMER_HALF)

    def on_ivar(self, n: int) -> None:
        if self.is_timer(n):
            self._timer_at[n] = self.clock()

    # -- status --------------------------------------------------------------------------------------
    def status(self, cs: int, w1: np.ndarray, w2: np.ndarray) -> tuple[int, int, int]:
        """`&cs??` with no program running [§2.6]: word 2 bit 17 in position (AND over the
        motors), 18 warning and 19 fatal following error, 20 amplifier fault (OR); word 3 bit 1
        a motor on a limit (ASSUMPTION: EPICS reads it as the limit flag). Word 1 is 0: no
        program, absolute mode."""
        mask = self.cs[:len(w1)] == cs
        a, b = w1[mask], w2[mask]
        word2 = (int(np.all(b & 1)) << 17) | (int(np.any(b & 2)) << 18) \
            | (int(np.any(b & 4)) << 19) | (int(np.any(b & 8)) << 20)
        word3 = int(np.any(a & (3 << 21))) << 1
        return 0, word2, word3

    # -- reset, SAVE ---------------------------------------------------------------------------------
    def reset(self) -> None:
        """Power-on/reset: the bias back to each definition's offset [A L932]; the timers go on
        from their saved values."""
        self.bias[:] = [d.offset if d is not None else 0.0 for d in self.defs]
        self._timer_at[:] = self.clock()
        self._sync()

    def image(self) -> list[dict[str, object]]:
        return [{"motor": m + 1, "cs": int(self.cs[m]), "def": d.text()}
                for m, d in enumerate(self.defs) if d is not None]

    def restore(self, image: list[dict[str, object]]) -> None:
        self.undefine(None)
        for item in image:
            d, _ = parse_axis_def(str(item["def"]).upper(), 0)
            cs, motor = int(str(item["cs"])), int(str(item["motor"]))
            if 1 <= cs <= CS_COUNT and 1 <= motor <= MAX_MOTORS:
                self.define(cs, motor, d)
