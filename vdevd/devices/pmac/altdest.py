"""`!{axis}{data}...`: the on-line "altered destination" RAPID move of the addressed coordinate
system (V1.936 [A L3232]; Turbo UM "Altered-Destination Moves", "Use of Altered Destination").

The command executes a RAPID-mode move of the named axes to the given destinations (axis user
units, absolute): from an idle C.S. directly, or, while the C.S. is in a RAPID-mode move (a fixed
program's or its rotary buffer's), as the new end point of that move; the program's calculation
goes on from the new destination [UM]. A C.S. running a move of another mode rejects it.

Departure (README "Not emulated"): the firmware extends the running RAPID move by Ixx92 ms and
then blends into the new RAPID move; here the running RAPID move finishes and the new one
starts from its end point, as the UM describes for a command received after the end of the move
("all axes end up in the same location").
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac.coord import AXES
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.pieces import NAXES

if TYPE_CHECKING:
    from vdevd.devices.pmac.expr import Env
    from vdevd.devices.pmac.firmware import Firmware
    from vdevd.devices.pmac.online import Line

#: a move of another mode in progress (ASSUMPTION: the UM says "an error"; ERR001 as for the
#: other commands a running program refuses)
ERR_OTHER_MODE = 1
_AXIS = re.compile(r"\s*([ABCUVWXYZ])\s*")
_CONST = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)(E[-+]?\d+)?", re.IGNORECASE)


def parse(line: Line, env: Env) -> tuple[np.ndarray, np.ndarray]:
    """The `{axis}{data}` pairs after `!`: (destinations, named mask); a constant or a
    parenthesised expression each (ERR003 for anything else, or no axis at all)."""
    dest, named = np.zeros(NAXES), np.zeros(NAXES, dtype=bool)
    while True:
        m = _AXIS.match(line.s, line.i)
        if m is None:
            break
        line.i = m.end()
        k = AXES.index(m.group(1))
        if line.peek() == "(":
            dest[k] = line.expression(env)
        else:
            c = _CONST.match(line.s, line.i)
            if c is None:
                raise CommandError(ERR_DATA, "! needs a value after the axis")
            line.i = c.end()
            dest[k] = float(c.group())
        named[k] = True
    if not named.any():
        raise CommandError(ERR_DATA, "! needs {axis}{data}")
    return dest, named


def altered_destination(fw: Firmware, cs: int, dest: np.ndarray, named: np.ndarray) -> None:
    """Run `!` on C.S. `cs` (see the module docstring)."""
    r = fw.motion.runner(cs)
    if r.running and r.mode != "RAPID":
        raise CommandError(ERR_OTHER_MODE, "a move of another mode is in progress")
    if not r.running:
        r.check_motors()
        r.start_online()
    r.rapid_to(np.where(named, dest, r.pos))
