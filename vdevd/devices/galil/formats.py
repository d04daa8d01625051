"""PF and VF: the position and variable formats of the card's replies (pure, no state).

`PF m.n` formats what the card prints as a position (TP, TE, TD, RP, RL, the `?` of DP, DE, IP,
PA, PR, BL, FL), `VF m.n` variables, array elements and `MG` numbers: m integer digits (0..10;
negative: hexadecimal, -8..-1), n fraction digits (0..4). Spec galil.md §4.4 names them; the seed
lacks chapter 7, so the form is the Galil command reference family's (README "Assumptions"):

- decimal: `format_number`'s form (LZ pads the integer part to m digits); a number wider than
  the format prints as the largest the format holds with its sign ("999.99", "-999");
- hexadecimal: `$`, then the integer part in m hex digits of two's complement and n hex digits
  of the 16-bit fraction (`VF-2.2` prints 10 as `$0A.00`, `PF-4.2` -5 as `$FFFB.00`); beyond
  m digits the largest positive or negative number ("$7FF", "$8000").
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.numbers import SCALE, format_number, units

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware

MAX_DIGITS = 10  # m of a decimal format
MAX_HEX_DIGITS = 8  # |m| of a hexadecimal format: the 32-bit integer part
MAX_FRACTION = 4  # n


@dataclass(frozen=True, slots=True)
class NumberFormat:
    """A PF or VF format: `digits` (m, negative for hexadecimal) and `frac` (n)."""

    digits: int
    frac: int

    @property
    def hex(self) -> bool:
        return self.digits < 0

    def text(self, value: float, lz: bool = True) -> str:
        """`value` as the card prints it in this format; `lz`: leading zeros (LZ)."""
        if self.hex:
            return _hex(value, -self.digits, self.frac, lz)
        m, n = self.digits, self.frac
        if abs(value) >= 10**m - 0.5 * 10.0**-n:  # rounds to more than m digits
            whole = "9" * m if m else "0"
            text = whole + ("." + "9" * n if n else "")
            return ("-" if value < 0 else "") + text
        return format_number(value, m, n, lz)

    def number(self) -> float:
        """The format as the operand `_PF`/`_VF` and the `?` query give it: m (the reference's
        "n = ? returns the value of m")."""
        return float(self.digits)


def parse_format(text: str) -> NumberFormat | None:
    """The format of `PF m.n` from its argument text (`5.2`, `-2.2`, `1`, `-4`); None when it is
    not of that form or m or n is out of range (TC 6)."""
    match = _FORMAT.fullmatch(text.strip())
    if match is None:
        return None
    sign, whole, frac = match.groups()
    m, n = int(whole), int(frac or 0)
    if sign:
        if not 1 <= m <= MAX_HEX_DIGITS:
            return None
        m = -m
    elif m > MAX_DIGITS:
        return None
    if n > MAX_FRACTION:
        return None
    return NumberFormat(m, n)


_FORMAT = re.compile(r"(-?)\s*(\d{1,2})(?:\.(\d?))?")


def _hex(value: float, m: int, n: int, lz: bool) -> str:
    """`$` and two's complement hex: m integer digits, n fraction digits (the top n hex digits
    of the 16-bit fraction, rounded); saturates at the m-digit signed range."""
    step = SCALE // 16**n  # 1/65536 units per last hex digit
    q = units(value)
    q = (q + step // 2) // step * step if n < 4 else q  # round to n hex digits
    whole, fraction = q // SCALE, q % SCALE  # floor: -5.5 is -6 + 0.5 (FFFA.8)
    lo, hi = -(16**m) // 2, 16**m // 2 - 1
    if whole > hi:
        whole, fraction = hi, SCALE - step
    elif whole < lo:
        whole, fraction = lo, 0
    digits = format(whole % 16**m, f"0{m}X")
    if not lz:
        digits = digits.lstrip("0") or "0"
    text = "$" + digits
    if n:
        text += "." + format(fraction // step, f"0{n}X")
    return text


#: the power-on formats [Galil command reference: PF default 10.0, VF default 10.4]
DEFAULT_PF = NumberFormat(10, 0)
DEFAULT_VF = NumberFormat(10, 4)


class FormatCommands:
    """The PF and VF commands: a base of `Interpreter`, whose firmware (`fw.pf`, `fw.vf`) and
    reply helpers they use."""

    if TYPE_CHECKING:
        fw: Firmware

        def fmt(self, value: float, digits: int, frac: int) -> str: ...

        @staticmethod
        def data(text: str) -> bytes: ...

    def pf(self, arg: str) -> bytes:
        """PF m.n: the position format; `PF ?` answers m [M Ch5 §Interrogation Commands]."""
        return self._format("pf", arg)

    def vf(self, arg: str) -> bytes:
        """VF m.n: the variable format; `VF ?` answers m [M Ch5 §Interrogation Commands]."""
        return self._format("vf", arg)

    def _format(self, name: str, arg: str) -> bytes:
        fw = self.fw
        if arg.strip() == "?":
            return self.data(self.fmt(getattr(fw, name).number(), 2, 0))
        form = parse_format(arg)
        if form is None:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name.upper()} {arg.strip()}")
        setattr(fw, name, form)
        return b":"
