"""The virtual axis N of the DMC-13X8 [M Ch6 §Virtual Axis]: "no encoder and no DAC. However, it
can be commanded by the commands: AC, DC, JG, SP, PR, PA, BG, IT, GA, VM, VP, CR, ST, DP, RP".

`VirtualAxis` is N's own profile: a one-axis `MotionCore` with an ideal plant (the commanded
position is all there is: TP N reads RP N), its parameters `AC DC SP JG IT PR PA`, the mode the
next `BG N` starts (PR, PA, JG) and the commands on it (begin, stop, abort, define). The firmware
ticks it at the start of a sample, before the axes' motion, only while it moves (a moving N keeps
the card out of rest, decision 0008), so an ECAM slave or a gear follower of N sees N's position
of the same sample. A vector plane with N (VM) drives N's commanded position along its path
(`track`, `hold`). No I/O.
"""

from __future__ import annotations

import numpy as np

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.motion import Mode
from vdevd.devices.galil.params import PARAMS
from vdevd.rt import MotionCore, PlantKind, ProfileMode

LETTER = "N"
#: the parameters N has of its own (`ACN=`, `_ACN`) [M Ch6 §Virtual Axis]
PARAM_NAMES = ("AC", "DC", "SP", "JG", "IT", "PR", "PA")
_MOVES = (int(ProfileMode.TRAPEZOID), int(ProfileMode.SCURVE))  # a PR/PA move, not a stop


class VirtualAxis:
    """The N axis: one ideal axis of its own motion core."""

    def __init__(self, period_ns: int) -> None:
        self.dt = period_ns / 1e9
        self.core = MotionCore(1, period_ns, PlantKind.IDEAL)
        self.core.servo_on(0)  # always on: it has no DAC to turn off
        self.values = {name: float(PARAMS[name].default) for name in PARAM_NAMES}
        self.mode = Mode.PR
        self.moving_flag = self.core.profile.moving  # a view: [0] is N's
        self.path = False  # a vector plane drives N now (coord.py)
        self.shifted = 0.0  # the redefinitions of `shift` so far (a path adds them to its own)

    @property
    def moving(self) -> bool:
        return bool(self.moving_flag[0])

    # -- parameters --------------------------------------------------------------------------------
    def set_param(self, name: str, value: float) -> None:
        """A checked value (`Param.coerce`): PR/PA/JG choose what BG starts; JG during a jog,
        SP and AC during a move apply on the fly, as on the real axes [M Ch6]."""
        if name == "JG" and self.moving and self.mode != Mode.JG:
            raise GalilError(TC.JG_ONLY_IN_JOG_MODE)
        self.values[name] = value
        if name in ("PR", "PA", "JG"):
            self.mode = Mode[name]
        if not self.moving:
            return
        v, core, shape = self.values, self.core, int(self.core.profile.mode[0])
        if self.path:  # a vector plane drives N: the values wait for the next BG N
            return
        if name == "JG" and shape == ProfileMode.JOG:
            core.jog(0, v["JG"], v["AC"], v["DC"], self._jerk())
        elif name in ("SP", "AC") and shape in _MOVES and self.mode != Mode.JG:
            core.move_one(0, float(core.target[0]), max(v["SP"], 1.0), v["AC"], v["DC"],
                          self._jerk())

    def _jerk(self) -> float:
        """IT as on the real axes: a moving average of 1/IT samples (motion.py `_jerk`)."""
        it = self.values["IT"]
        samples = round(1.0 / it) if it > 0 else 1
        return 0.0 if samples <= 1 else self.values["AC"] / (samples * self.dt)

    # -- commands ----------------------------------------------------------------------------------
    def begin(self) -> None:
        """BG N: the PR, PA or JG move; TC 21 while N moves (on its own or along a path)."""
        if self.moving:
            raise GalilError(TC.BEGIN_WHILE_RUNNING)
        v, core = self.values, self.core
        sp, ac, dc, jerk = max(v["SP"], 1.0), v["AC"], v["DC"], self._jerk()
        if self.mode == Mode.JG:
            core.jog(0, v["JG"], ac, dc, jerk)
            return
        here = float(np.rint(core.axes.cmd_pos[0]))
        target = here + v["PR"] if self.mode == Mode.PR else v["PA"]
        if target != here:
            core.move_one(0, target, sp, ac, dc, jerk)

    def stop(self) -> None:
        """ST N: decelerate with DC."""
        if self.moving:
            self.core.stop(0, self.values["DC"])

    def abort(self) -> None:
        """AB, the abort input: N stops at once."""
        self.path = False
        if self.moving:
            self.core.abort(0)

    def define(self, value: float) -> None:
        """DP N: N's position becomes `value` (TC 7 while it moves)."""
        if self.moving:
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        self.core.set_position(0, value)
        self.values["PA"] = value

    def shift(self, counts: float) -> None:
        """A redefinition by `counts` that keeps the motion (the ECAM master's cycle end)."""
        self.shifted += counts
        self.core.shift_position(0, counts)

    # -- the path of a vector plane (coord.py) ------------------------------------------------------
    def track(self, position: float) -> None:
        """N's commanded position at the next tick, on the plane's path."""
        self.path = True
        self.core.track([0], [position])

    def hold(self, position: float | None = None) -> None:
        """The path ended: N holds `position` (or where it is)."""
        self.path = False
        self.core.hold([0], None if position is None else [position])

    # -- the sample --------------------------------------------------------------------------------
    def tick(self) -> None:
        """One sample of N's profile (the firmware calls it while N moves)."""
        self.core.tick()

    # -- what the card reports ---------------------------------------------------------------------
    def reference(self) -> float:
        """RP N (and TP N: N has no encoder): the commanded position, whole counts."""
        return float(np.rint(self.core.axes.cmd_pos[0]))

    def position(self) -> float:
        """N's commanded position as a master reads it (not rounded, as `CX` reads an axis)."""
        return float(self.core.axes.cmd_pos[0])

    def destination(self) -> float:
        """_PA N: the target while a move runs, else the commanded position."""
        core = self.core
        if self.moving and core.target_valid[0]:
            return float(core.target[0])
        return self.reference()

    def value(self, name: str) -> float:
        """A parameter of N, or PA's destination (`PAN=?`, `_PAN`)."""
        return self.destination() if name == "PA" else self.values[name]
