"""Home moves [M §4.3; spec adlink.md §2.6]: ORG (mode 0), EL (mode 1) and single-EZ (mode 2)
homing, as the sequences of spec §2.6 (the manual's V-T figures 4-8 to 4-12 are missing, so
their steps are the spec's ASSUMPTION).

A sequence is a chain of steps; each runs the axis at a speed in a direction and watches a
signal edge every cycle (the `Homing` unit), then stops on it: decelerating with PRA_HOME_ACC
(searches at HOME_VM, leaving ORG), at once where the edge was seen (the final ORG or EL edge,
at HOME_VO: within one cycle's travel), or at once on the index mark itself (EZ: the card
latches where the mark is). An EL met on the way is the kernel's ordinary EL stop (PRA_EL_MODE);
where the sequence expects it (a search turning back, spec Q8) the unit takes the stop back: no
ASTP, no stop code, HMV stays on. Where the signal is missing the sequence aborts with ASTP and
STOP_ORG_EL (20), STOP_NO_ORG (21), STOP_NO_EZ (22) or STOP_BOTH_EL (23) [X8].

On success the axis rests at the origin (+ HOME_SHIFT) and its command and feedback positions
are reset to zero (the counters too), then set to PRA_HOME_POS (spec ASSUMPTION: both).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

from vdevmaps.aps_defs import (
    PRA_HOME_ACC,
    PRA_HOME_CURVE,
    PRA_HOME_DIR,
    PRA_HOME_EZA,
    PRA_HOME_MODE,
    PRA_HOME_POS,
    PRA_HOME_SHIFT,
    PRA_HOME_VM,
    PRA_HOME_VO,
    PRA_HOME_VS,
    STOP_BOTH_EL,
    STOP_MEL,
    STOP_NO_EZ,
    STOP_NO_ORG,
    STOP_ORG_EL,
    STOP_PEL,
    ERR_CommandInProcess,
)

from vdevd.devices.adlink import motion, moves
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.modes import HOME

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

MODE_ORG, MODE_EL, MODE_EZ = 0, 1, 2  # PRA_HOME_MODE [M §4.3]
#: what an EL met in a step means when it is not a turn: the abort code, by the ORG level then
_ORG_LOST = -1


class Step(NamedTuple):
    """One step of a home sequence: direction (+1: the home direction s, -1: against it, 0: the
    direction of the step before it, reversed), speed parameter, the edge watched (`rise`/`fall`
    of `signal`), how it stops (`dec`, `halt`, `mark`), the next step, and what an EL met in it
    means (the next step, or an abort code)."""

    sense: int
    speed: int
    signal: str
    edge: str
    stop: str
    then: str
    on_el: str | int


#: the steps of spec §2.6 (`align`: EZ alignment or the shift, as PRA_HOME_EZA says)
STEPS: dict[str, Step] = {
    # mode 0 [M §4.3.1]: B leaves ORG first; A/C search, C turns at the EL and crosses ORG
    "leave_org": Step(-1, PRA_HOME_VO, "org", "fall", "dec", "search", STOP_ORG_EL),
    "search": Step(+1, PRA_HOME_VM, "org", "rise", "dec", "leave", "back"),
    "back": Step(-1, PRA_HOME_VM, "org", "fall", "dec", "approach", _ORG_LOST),
    "leave": Step(-1, PRA_HOME_VO, "org", "fall", "dec", "approach", _ORG_LOST),
    "approach": Step(+1, PRA_HOME_VO, "org", "rise", "halt", "align", _ORG_LOST),
    # mode 1 [M §4.3.2]: the EL found (the kernel stops there), then its edge from inside
    "find_el": Step(+1, PRA_HOME_VM, "", "", "", "leave_el", "leave_el"),
    "leave_el": Step(-1, PRA_HOME_VO, "el", "fall", "halt", "align", STOP_BOTH_EL),
    # mode 2 [M §4.3.3]: the mark found at VM (turning once at an EL), then back to it at VO
    "find_ez": Step(+1, PRA_HOME_VM, "ez", "rise", "dec", "return_ez", "find_ez_back"),
    "find_ez_back": Step(-1, PRA_HOME_VM, "ez", "rise", "dec", "return_ez", STOP_NO_EZ),
    "return_ez": Step(0, PRA_HOME_VO, "ez", "rise", "mark", "shift", STOP_NO_EZ),
    # EZ alignment (modes 0 and 1, PRA_HOME_EZA = 1): on at VO to the first mark
    "ez": Step(+1, PRA_HOME_VO, "ez", "rise", "mark", "shift", STOP_NO_EZ),
}


@dataclass(slots=True)
class _Run:
    """A home sequence in progress on one axis."""

    mode: int
    s: int  # +1 for PRA_HOME_DIR 0 (positive), -1 for 1 [M §4.3.1 tables]
    step: str = ""
    d: int = 0  # the direction of the step's motion
    phase: str = ""  # move (watching), stop (after the edge), el (the kernel's EL stop)
    seen_on: bool = False
    seen_off: bool = False
    then: str = ""


class Homing:
    """The kernel unit of home moves: the edges watched every cycle, the EL stops a search
    expects taken back, the next steps planned when a stop ends (`Kernel.sequences`)."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.runs: dict[int, _Run] = {}
        self.el_hits: dict[int, int] = {}  # axis -> the stop code before the kernel's EL stop

    def reset(self) -> None:
        self.runs.clear()
        self.el_hits.clear()

    def busy(self) -> bool:
        return bool(self.runs)

    def motion_only(self) -> bool:
        """No search runs and no EL stop waits to be taken back (runs.py)."""
        return not self.runs and not self.el_hits

    # -- starting --------------------------------------------------------------------------------
    def start(self, a: int) -> None:
        """APS_home_move on a free axis: the first step for the start condition."""
        k = self.k
        p = k.p
        mode, s = int(p(PRA_HOME_MODE)[a]), -1 if p(PRA_HOME_DIR)[a] else 1
        run = _Run(mode, s)
        if k.pel[a] and k.mel[a]:  # both limits on: no direction is free (Q8)
            k.stop_code[a], k.astp[a], k.mdn[a] = STOP_BOTH_EL, True, True
            return
        at_el = bool(self._el(a, s))
        if mode == MODE_ORG:
            first = "leave_org" if k.org[a] else "back" if at_el else "search"
        elif mode == MODE_EL:
            first = "leave_el" if at_el else "find_el"
        else:
            first = "find_ez_back" if at_el else "find_ez"
        moves.begin(k, a, HOME)
        k.hmv[a] = True
        self.runs[a] = run
        k.sequences[a] = lambda: self.ended(a)
        self.enter(a, run, first)

    def enter(self, a: int, run: _Run, name: str) -> bool:
        """Start step `name`; False when the sequence is complete (the position set)."""
        k = self.k
        if name == "align":
            eza = bool(k.p(PRA_HOME_EZA)[a]) and run.mode != MODE_EZ
            name = "ez" if eza else "shift"
        if name == "shift":
            shift = float(k.p(PRA_HOME_SHIFT)[a])
            if shift == 0 or run.step == "shift":
                return self.complete(a)
            run.step, run.phase = "shift", "stop"
            goal = float(k.core.axes.cmd_pos[a]) + shift * k.factor(a)
            vm, acc = float(k.p(PRA_HOME_VM)[a]), float(k.p(PRA_HOME_ACC)[a])
            moves.go_to(k, a, goal, float(k.p(PRA_HOME_VS)[a]), vm, acc, acc,
                        float(k.p(PRA_HOME_CURVE)[a]))
            return True
        step = STEPS[name]
        if step.sense == 0:
            run.d = -run.d
        elif name == "ez" and run.mode == MODE_EL:
            run.d = -run.s  # mode 1: the axis cannot go on into the limit (spec §2.6)
        else:
            run.d = step.sense * run.s
        run.step, run.phase, run.then = name, "move", step.then
        level = self._signal(a, run, step.signal)
        run.seen_on, run.seen_off = level, not level
        speed = float(k.p(step.speed)[a])
        acc = float(k.p(PRA_HOME_ACC)[a])
        moves.run_at(k, a, run.d * speed, float(k.p(PRA_HOME_VS)[a]), acc, acc,
                     float(k.p(PRA_HOME_CURVE)[a]))
        return True

    def complete(self, a: int) -> bool:
        """Home found: command and feedback (and the counters) zero, then PRA_HOME_POS
        [M §4.3]; the kernel then ends the motion (HMV 0, MDN 1, stop code 0)."""
        k = self.k
        k.core.set_position([a], 0.0)
        home = float(k.p(PRA_HOME_POS)[a])
        k.cmd_off[a] = k.fb_off[a] = home
        k.target[a] = home
        self.runs.pop(a, None)
        k.sequences.pop(a, None)
        return False

    # -- the cycle -------------------------------------------------------------------------------
    def ended(self, a: int) -> bool:
        """The axis's profile ended (a stop on an edge): the next step."""
        run = self.runs.get(a)
        if run is None:
            return False
        if run.phase == "stop":
            return self.enter(a, run, "shift" if run.step == "shift" else run.then)
        return True

    def before_motion(self, t: float) -> None:
        if self.el_hits:
            for a, old_code in list(self.el_hits.items()):
                if a in self.runs:
                    self._el_stop(a, old_code)
            self.el_hits.clear()
        k = self.k
        for a, run in list(self.runs.items()):
            if run.phase != "move":
                continue
            step = STEPS[run.step]
            if not step.signal:
                continue
            level = self._signal(a, run, step.signal)
            if step.edge == "rise":
                hit = level and run.seen_off
                run.seen_off |= not level
            else:
                hit = not level and run.seen_on
                run.seen_on |= level
            if not hit:
                continue
            run.phase = "stop"
            if step.stop == "dec":
                moves.decelerate(k, a, float(k.p(PRA_HOME_ACC)[a]), float(k.p(PRA_HOME_CURVE)[a]))
            elif step.stop == "mark":  # on the index mark itself (physical + the core's zero)
                moves.halt(k, a, run.d, float(k.ez_mark[a] + k.core.zero[a]))
            else:
                moves.halt(k, a, run.d)

    def after_motion(self, t: float) -> None:
        k = self.k
        for a, run in list(self.runs.items()):
            if run.phase == "el" and not k.core.profile.moving[a]:
                k.mode[a], k.hmv[a], k.mdn[a] = HOME, True, False
                self.enter(a, run, run.then)

    def stop_axis(self, a: int, code: int, immediate: bool) -> None:
        """The kernel stops axis a: an EL the sequence may expect (looked at once the kernel
        has stopped it, `before_motion`), else the homing ends with the kernel's stop."""
        run = self.runs.get(a)
        if run is None:
            return
        if code in (STOP_PEL, STOP_MEL) and run.step != "shift":
            self.el_hits.setdefault(a, int(self.k.stop_code[a]))
            return
        del self.runs[a]
        self.el_hits.pop(a, None)
        self.k.sequences.pop(a, None)

    def _el_stop(self, a: int, old_code: int) -> None:
        """The kernel stopped a homing axis at an EL (PRA_EL_MODE): a turn the sequence expects
        (no ASTP, the search goes on, spec Q8), or the abort code for a missing signal."""
        k, run = self.k, self.runs[a]
        outcome = run.then if run.phase == "stop" else STEPS[run.step].on_el
        if isinstance(outcome, int):
            if outcome == _ORG_LOST:
                outcome = STOP_ORG_EL if k.org[a] else STOP_NO_ORG
            k.stop_code[a] = outcome
            del self.runs[a]
            k.sequences.pop(a, None)
            return
        k.stop_code[a], k.astp[a], k.hmv[a], k.mdn[a] = old_code, False, True, False
        run.phase, run.then = "el", outcome

    def _el(self, a: int, d: int) -> bool:
        return bool(self.k.pel[a] if d > 0 else self.k.mel[a])

    def _signal(self, a: int, run: _Run, name: str) -> bool:
        k = self.k
        if name == "org":
            return bool(k.org[a])
        if name == "ez":
            return bool(k.ez[a])
        if name == "el":
            return self._el(a, run.s)
        return False


def home_move(k: Kernel, a: int) -> None:
    """APS_home_move [M §4.3]: start the PRA_HOME_MODE sequence; MDN 0 and HMV 1 until it
    completes or aborts. EMG or ALM on: refused as every motion (code and ASTP, returns 0).
    An axis moving, waiting, jogging or homing: -15 (ASSUMPTION: the manual says nothing)."""
    k.check_axis(a)
    motion.check_free(k, a)
    if k.moving()[a] or k.wait[a]:
        raise ApsError(ERR_CommandInProcess, f"axis {a} is moving")
    if motion.refused(k, a, 0.0):
        return
    unit = next(u for u in k.units if isinstance(u, Homing))
    unit.start(a)
