"""The commands and operands of the virtual axis N [M Ch6 §Virtual Axis] (virtual.py).

N is addressed by name: `ACN=`, `DCN=`, `SPN=`, `JGN=`, `ITN=`, `PRN=`, `PAN=`, `DPN=` (also
`PR N=`, and `=?` queries), `EMN=` (its ECAM cycle as a master); the action commands take the
letter among the axes (`BG XN`, `ST N`, `AM N`, `MC N`, `RP N`, `TP N`: the interpreter's
`split_n`); operands `_RPN _TPN _DPN _BGN _ACN _DCN _SPN _JGN _ITN _PRN _PAN _EMN`. Another
per-axis command naming N (`KPN=`, the motor's parameters) is TC 4: N has no motor. No I/O.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from vdevd.devices.galil import syntax
from vdevd.devices.galil.ecam import MASTER_CYCLE_LIMIT
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.numbers import POSITION_PARAMS
from vdevd.devices.galil.params import PARAMS
from vdevd.devices.galil.virtual import LETTER, PARAM_NAMES

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware
    from vdevd.devices.galil.interpreter import Interpreter

#: `N=value` after a per-axis command (`PR N=100`, or `PRN=100` split so by syntax.py)
_N_ASSIGN = re.compile(r"N *=(.*)", re.DOTALL)


def split_n(arg: str) -> tuple[str, bool]:
    """The axis letters of an action command without N, and whether N was among them."""
    if LETTER not in arg:
        return arg, False
    return arg.replace(LETTER, ""), True


class VirtualCommands:
    """The `<cmd>N=` forms, over an interpreter (its firmware's `virtual`)."""

    def __init__(self, interp: Interpreter) -> None:
        self.interp = interp

    def route(self, name: str, arg: str) -> bytes | None:
        """The reply of `<name> N=value` when that is the statement, else None."""
        if name not in syntax.AXIS_ASSIGN_COMMANDS:
            return None
        match = _N_ASSIGN.fullmatch(arg)
        return None if match is None else self.assign(name, match.group(1).strip(" "))

    def assign(self, name: str, text: str) -> bytes:
        """`ACN=256000`, `PRN=?` ...; a command N does not take: TC 4."""
        interp = self.interp
        fw = interp.fw
        virtual = fw.virtual
        query = text == "?"
        if name in PARAM_NAMES:
            param = PARAMS[name]
            if query:
                v = virtual.value(name)
                return interp.data(interp.pos(v) if name in POSITION_PARAMS
                                   else interp.fmt(v, param.digits, param.frac))
            coerced = param.coerce(interp.value(text))
            if coerced is None:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name}N {text}")
            virtual.set_param(name, coerced)
            return b":"
        if name == "DP":
            if query:
                return interp.data(interp.pos(virtual.reference()))
            coerced = PARAMS["PA"].coerce(interp.value(text))
            if coerced is None:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"DPN {text}")
            virtual.define(coerced)
            return b":"
        if name == "EM":
            return self._em(fw, text)
        raise GalilError(TC.OPERAND_ERROR, f"the virtual axis N has no {name}")

    def _em(self, fw: Firmware, text: str) -> bytes:
        """EMN=: N's cycle as the ECAM master [M Ch6 §Virtual Axis "EMN=4000"]."""
        ecam, interp = fw.follow.ecam, self.interp
        if text == "?":
            return interp.data(interp.fmt(float(ecam.cycle[fw.n]), 10, 0))
        v = interp.value(text)
        if not abs(v) <= MASTER_CYCLE_LIMIT:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"EMN {v}")
        ecam.check_idle()
        ecam.cycle[fw.n] = float(round(v))
        return b":"


def operand(fw: Firmware, cmd: str) -> float:
    """`_<cmd>N`: N's reference (RP, TP, DP), BG (1 while it moves), its parameters, PA's
    destination, EM its cycle; another: TC 57, as an operand the card does not know."""
    virtual = fw.virtual
    if cmd in ("RP", "TP", "DP"):
        return virtual.reference()
    if cmd == "BG":
        return float(virtual.moving)
    if cmd in PARAM_NAMES:
        return virtual.value(cmd)
    if cmd == "EM":
        return float(fw.follow.ecam.cycle[fw.n])
    raise GalilError(TC.BAD_FUNCTION, f"_{cmd}N")
