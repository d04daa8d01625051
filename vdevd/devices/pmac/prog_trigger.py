"""Move until trigger in a motion program, `{axis}{data}^{data}` [Turbo SRM "{axis}{data}^{data}";
UM "Move-Until-Trigger"]: each motor of the named axes makes a RAPID-type move toward the
axis end point (the first value, ABS or INC as the axis is) and, if its trigger (the home
search's: I7mn2/I7mn3 on Ixx25, or Ixx97) comes first, ends at the trigger position plus the
second value (axis units, through the motor's scale). The motors use the jog-until-trigger
machinery of motors.py (`jog_trigger`: jog speed Ixx22 and accelerations Ixx19-Ixx21, word 2
bit 7 trigger move, Mxx73 the trigger position); the calculation waits until every motor has
stopped and goes on from the positions they stopped at, as after a HOME."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from vdevd.devices.pmac.pieces import NAXES

if TYPE_CHECKING:
    from vdevd.devices.pmac.program_runner import CsProgram


def start_trigger_move(r: CsProgram, axes: tuple[tuple[int, Any, Any], ...], env: Any) -> None:
    """Start the motors of `axes` ((axis, end value, post-trigger distance) expressions); the
    C.S.'s other motors hold; the runner waits for them as for a HOME ("home" wait)."""
    target = r.pos.copy()
    post = np.zeros(NAXES)
    named = np.zeros(NAXES, dtype=bool)
    for k, e, d in axes:
        value = float(e.eval(env))
        target[k] = target[k] + value if r.inc[k] else value
        post[k] = float(d.eval(env))
        named[k] = True
    rows = np.flatnonzero(np.abs(r.scale[:, named]).sum(axis=1) > 0)
    counts = r._counts(target)       # motor positions (counts from the motor's zero)
    distance = r.scale @ post        # post-trigger distance per motor, counts
    motors = r.fw.motors
    idx = r.members[rows]
    r._hold_motors(r.members)
    for row, m in zip(rows.tolist(), idx.tolist(), strict=True):
        motors.jog_trigger(m, "=", float(counts[row]), float(distance[row]))
    r.homing = idx.tolist()
    r.wait = "home"
    r.planner = None
    r.pos = target
