"""`LEARN[({axis}[,{axis}...])]`: with a motion-program buffer (PROG or rotary) open on the port,
a line of the addressed C.S.'s present commanded axis positions goes into it, as if the host had
sent `X{pos} Y{pos}...` (only the port that opened the buffer may LEARN into it, V1.936
[A L3234]; README "Motion programs"). Without a buffer open LEARN answers ERR005 (commands.py).

ASSUMPTIONS (the SRM's LEARN page was not retrieved): without a list, every axis a motor of the
C.S. is defined to (A B C U V W X Y Z order); a position is the commanded position of the first
motor defined to the axis alone, through its definition (coord.py `axis_position`), printed as
the card prints values (numbers.py); an axis no motor drives alone is left out.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from vdevd.devices.pmac.coord import AXES
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.numbers import format_value

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

_LEARN = re.compile(r"\s*LEARN\s*(?:\(([A-Z ,]*)\))?\s*$", re.IGNORECASE)


def is_learn(text: str) -> bool:
    return _LEARN.match(text.split(";", 1)[0]) is not None


def learn_line(fw: Firmware, cs: int, text: str) -> str:
    """The program line `LEARN...` stands for in C.S. cs (ERR003 for an axis list that is not
    one); "" when no axis has a motor."""
    m = _LEARN.match(text.split(";", 1)[0])
    assert m is not None
    defs = [fw.coord.defs[n - 1] for n in fw.coord.members(cs)]
    if m.group(1) is None:
        axes = [a for a in AXES if any(d is not None and d.scale_of(a) for d in defs)]
    else:
        axes = [a.strip() for a in m.group(1).upper().split(",")]
        if any(a not in AXES or len(a) != 1 for a in axes):
            raise CommandError(ERR_DATA, "LEARN takes axis letters")
    commanded = fw.reports.commanded()
    single = {d.terms[0][1] for d in defs if d is not None and len(d.terms) == 1}
    return " ".join(f"{a}{format_value(fw.coord.axis_position(cs, a, commanded))}"
                    for a in axes if a in single)
