"""`!{axis}{data}...`: the on-line "altered destination" RAPID move of the addressed coordinate
system (V1.936 [A L3232]; Turbo UM "Altered-Destination Moves", "Use of Altered Destination").

The command executes a RAPID-mode move of the named axes to the given destinations (axis user
units, absolute): from an idle C.S. directly, or, while the C.S. is in a RAPID-mode move (a fixed
program's or its rotary buffer's), as the new end point of that move; the program's calculation
goes on from the new destination [UM]. A C.S. running a move of another mode rejects it.

A RAPID move in progress is extended by Ixx92 ms (the first motor's of the C.S.), then each axis
blends from its position and velocity there into a RAPID-type move to the new destination
(`blend_profile`: at the RAPID speed and acceleration, turning back after a stop where it would
overshoot) [UM]. A command that comes after the end of the move (or within Ixx92 ms of it)
starts the new move from rest at the end point: a momentary pause, the same end [UM].
ASSUMPTION: the blend accelerates at the axis's constant RAPID acceleration (no S-curve).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.pmac.coord import AXES
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.linear import Phase, _axis_profile, cut_pieces
from vdevd.devices.pmac.pieces import NAXES, Piece

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
    if r.running and r.mode != "RAPID" and not r.online:
        raise CommandError(ERR_OTHER_MODE, "a move of another mode is in progress")
    if not r.running:
        r.check_motors()
        r.start_online()
    target = np.where(named, dest, r.pos)
    if r.running and len(r.members):
        delay = float(fw.ivars.values[100 * (int(r.members[0]) + 1) + 92]) / 1000
        lim = r.rapid_limits()
        if r.break_in(delay, lambda p, v: blend_pieces(p, v, target, lim["MAXV"], lim["MAXA"]),
                      target):
            return
    r.rapid_to(target)


def blend_profile(p0: float, v0: float, d: float, vmax: float, amax: float) -> list[Phase]:
    """One axis from position p0 moving at v0 to rest at d, as constant-acceleration phases
    (seconds, acceleration, jerk 0): on towards d at up to vmax, or, where it cannot stop in
    time, a stop first and a rest-to-rest move back."""
    if amax <= 0 or vmax <= 0:
        return []
    dist = d - p0
    s = 1.0 if dist > 0 or (dist == 0 and v0 > 0) else -1.0
    u, big_d = s * v0, s * dist
    if u > 0 and big_d < u * u / (2 * amax):   # would overshoot: stop, then come back
        stop = [(u / amax, -s * amax, 0.0)]
        p1 = p0 + s * u * u / (2 * amax)
        back = [(dur, acc, jerk) for dur, acc, jerk in _axis_profile(d - p1, vmax, amax, 0.0)] \
            if abs(d - p1) > 1e-12 else []
        return stop + back
    vp = min(vmax, float(np.sqrt(max((2 * amax * big_d + u * u) / 2, 0.0))))
    if u > vmax:  # faster than the RAPID speed: slow to it
        vp = vmax
    t1 = abs(vp - u) / amax
    a1 = s * amax if vp >= u else -s * amax
    d1 = (vp * vp - u * u) / (2 * amax) if vp >= u else (u * u - vp * vp) / (2 * amax)
    t3 = vp / amax
    cruise = (big_d - d1 - vp * vp / (2 * amax)) / vp if vp > 0 else 0.0
    phases = [(t1, a1, 0.0), (max(cruise, 0.0), 0.0, 0.0), (t3, -s * amax, 0.0)]
    return [ph for ph in phases if ph[0] > 1e-12]


def blend_pieces(p0: np.ndarray, v0: np.ndarray, target: np.ndarray, vmax: np.ndarray,
                 amax: np.ndarray) -> list[Piece]:
    """Every axis's `blend_profile` at once, cut where any axis changes phase; an axis whose
    profile has ended holds at its end (exactly the target)."""
    profiles = []
    for k in range(NAXES):  # nine axes, once per `!`
        if target[k] != p0[k] or v0[k] != 0:
            prof = blend_profile(float(p0[k]), float(v0[k]), float(target[k]), float(vmax[k]),
                                 float(amax[k]))
            if prof:
                profiles.append((k, prof))
    base = np.where(v0 == 0, p0, target)
    return cut_pieces(profiles, base, lambda k, prof, t0: _state(
        prof, t0, float(p0[k]), float(v0[k]), float(target[k])), target)


def _state(prof: list[Phase], t0: float, p: float, v: float, end: float) -> np.ndarray:
    """The cubic coefficients of an axis's profile from t0 on, integrated from (p, v)."""
    t = 0.0
    for dur, a, _ in prof:
        if t + dur > t0 + 1e-12:
            tau = t0 - t
            return np.array([p + v * tau + a * tau * tau / 2, v + a * tau, a / 2, 0.0])
        p += v * dur + a * dur * dur / 2
        v += a * dur
        t += dur
    return np.array([end, 0.0, 0.0, 0.0])
