"""Jog moves [M §4.5; spec adlink.md §2.8]: continuous and step jogging on the JOG-ON signal,
from `APS_jog_start` or from digital inputs.

JOG-ON comes from four sources per axis: the software signal (`APS_jog_start`, direction
PRA_JG_DIR) and, as PRA_JG_MAP_DI_EN's bits enable them (spec ASSUMPTION: bit 0, 1, 2), DI
channel PRA_JG_P_JOG_DI (positive), PRA_JG_N_JOG_DI (negative) and PRA_JG_JOG_DI (direction
PRA_JG_DIR); the DI word (after PRB_DI_LOGIC) is read every cycle. A rising edge on a free axis
starts a jog in its source's direction; that source's falling edge ends it; the other sources'
edges are ignored while it runs, and so is every rising edge while another motion (a home
move) runs (spec ASSUMPTION: the call returns 0). PRA_JG_DIR 0 is negative, 1 positive: the
manual's sense (spec Q6).

Continuous mode (PRA_JG_MODE 0): a velocity move at JG_VM with JG_ACC and JG_SF; the falling
edge decelerates to rest with JG_DEC. Step mode (1): the rising edge moves exactly JG_OFFSET;
if JOG-ON is still on PRA_JG_DELAY microseconds after that step ends (spec Q22: us), the axis
runs on continuously, and the falling edge stops it at the next integer multiple of JG_OFFSET
from where the jog began that JG_DEC can reach (spec ASSUMPTION, Fig 4-18). JOG (bit 15) and
MDN 0 from the rising edge to the final stop [M §4.8.1]; EMG, ALM and the limits end a jog as
every motion [M §4.5 NOTE].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.aps_defs import (
    PRA_JG_ACC,
    PRA_JG_DEC,
    PRA_JG_DELAY,
    PRA_JG_DIR,
    PRA_JG_JOG_DI,
    PRA_JG_MAP_DI_EN,
    PRA_JG_MODE,
    PRA_JG_N_JOG_DI,
    PRA_JG_OFFSET,
    PRA_JG_P_JOG_DI,
    PRA_JG_SF,
    PRA_JG_VM,
    ERR_ParametersInvalid,
)

from vdevd.devices.adlink import moves
from vdevd.devices.adlink.errors import ApsError
from vdevd.devices.adlink.modes import IDLE, JOG
from vdevd.devices.adlink.motion import refused

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

SOFTWARE, P_DI, N_DI, ONE_DI = 0, 1, 2, 3  # the JOG-ON sources of an axis
_DI_PARAMS = ((P_DI, PRA_JG_P_JOG_DI), (N_DI, PRA_JG_N_JOG_DI), (ONE_DI, PRA_JG_JOG_DI))


@dataclass(slots=True)
class _Jog:
    """A jog in progress: its source, direction, mode and where it began (counts)."""

    source: int
    d: int
    step: bool
    origin: float
    phase: str = "run"  # run (continuous), step, wait (JG_DELAY), stopping
    wait_until: float = math.inf


class Jogging:
    """The kernel unit of jog moves: the JOG-ON sources' edges, the step-mode delay."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.runs: dict[int, _Jog] = {}
        self.level = np.zeros((k.n, 4), dtype=bool)  # JOG-ON of each source, last seen

    def reset(self) -> None:
        self.runs.clear()
        self.level[:] = False

    def busy(self) -> bool:
        return bool(self.runs)

    def motion_only(self) -> bool:
        """No jog runs and no DI is mapped to a JOG-ON (watched every cycle; runs.py)."""
        return not self.runs and not (self.k.p(PRA_JG_MAP_DI_EN).any() or self.level[:, 1:].any())

    # -- JOG-ON ------------------------------------------------------------------------------------
    def signal(self, a: int, source: int, on: bool) -> None:
        """A source's JOG-ON level: its edges start and end the jog."""
        was = bool(self.level[a, source])
        self.level[a, source] = on
        if on and not was:
            self.rise(a, source)
        elif was and not on:
            self.fall(a, source)

    def direction(self, a: int, source: int) -> int:
        if source == P_DI:
            return 1
        if source == N_DI:
            return -1
        return 1 if self.k.p(PRA_JG_DIR)[a] else -1  # 0: negative [M §4.5] (Q6)

    def rise(self, a: int, source: int) -> None:
        k = self.k
        if a in self.runs or k.mode[a] != IDLE or k.moving()[a] or k.wait[a] or k.owned[a]:
            return  # another motion runs: ignored [M §4.5 NOTE]
        d = self.direction(a, source)
        if refused(k, a, d):
            return
        p = k.p
        step = bool(p(PRA_JG_MODE)[a])
        origin = float(k.core.axes.cmd_pos[a])
        run = _Jog(source, d, step, origin, "step" if step else "run")
        moves.begin(k, a, JOG)
        k.jog[a] = True
        self.runs[a] = run
        k.sequences[a] = lambda: self.ended(a)
        if step:
            self._step(a, run, origin + d * float(p(PRA_JG_OFFSET)[a]) * k.factor(a))
        else:
            self._run(a, run)

    def fall(self, a: int, source: int) -> None:
        k = self.k
        run = self.runs.get(a)
        if run is None or run.source != source:
            return
        if run.phase == "wait":
            self._end(a)
            k.finish(a)
        elif run.phase == "run":
            run.phase = "stopping"
            if run.step:
                self._stop_on_multiple(a, run)
            else:
                _, _, dec, sf = self._profile(a)
                moves.decelerate(k, a, dec, sf)

    # -- the moves ---------------------------------------------------------------------------------
    def _profile(self, a: int) -> tuple[float, float, float, float]:
        p = self.k.p
        return (float(p(PRA_JG_VM)[a]), float(p(PRA_JG_ACC)[a]), float(p(PRA_JG_DEC)[a]),
                float(p(PRA_JG_SF)[a]))

    def _run(self, a: int, run: _Jog) -> None:
        vm, acc, dec, sf = self._profile(a)
        run.phase = "run"
        moves.run_at(self.k, a, run.d * vm, 0.0, acc, dec, sf)

    def _step(self, a: int, run: _Jog, goal: float) -> None:
        vm, acc, dec, sf = self._profile(a)
        self._target(a, goal)
        moves.go_to(self.k, a, goal, 0.0, vm, acc, dec, sf)

    def _target(self, a: int, counts: float) -> None:
        k = self.k
        k.target[a] = counts / k.factor(a) + float(k.cmd_off[a])

    def _stop_on_multiple(self, a: int, run: _Jog) -> None:
        """Step mode's continuous run ends on a whole number of JG_OFFSET from the origin: the
        first one the deceleration can reach (spec §2.8 ASSUMPTION)."""
        k = self.k
        off = float(k.p(PRA_JG_OFFSET)[a]) * k.factor(a)
        here = float(k.core.axes.cmd_pos[a])
        _, _, dec, sf = self._profile(a)
        reach = run.d * (here - run.origin) + moves.stop_distance(k, a, dec, sf)
        n = max(1, math.ceil(reach / off - 1e-9))
        self._step(a, run, run.origin + run.d * n * off)

    def ended(self, a: int) -> bool:
        """The axis's profile ended: a step done (wait, run on or end), or the final stop."""
        k = self.k
        run = self.runs.get(a)
        if run is None:
            return False
        if run.phase == "wait":
            return True
        if run.phase == "step" and self.level[a, run.source]:
            delay = float(k.p(PRA_JG_DELAY)[a]) / 1e6
            if delay > 0:
                run.phase, run.wait_until = "wait", k.t + delay
            else:
                self._run(a, run)
            return True
        self._end(a)
        return False

    def _end(self, a: int) -> None:
        if self.runs.pop(a, None) is not None:
            self.k.sequences.pop(a, None)

    # -- the cycle -------------------------------------------------------------------------------
    def before_motion(self, t: float) -> None:
        k = self.k
        enabled = k.p(PRA_JG_MAP_DI_EN)
        if enabled.any() or self.level[:, 1:].any():
            di = k.di_word()
            for a in range(k.n):
                mask = int(enabled[a])
                for bit, (source, no) in enumerate(_DI_PARAMS):
                    on = bool(mask >> bit & 1) and bool(di >> int(k.p(no)[a]) & 1)
                    if on != self.level[a, source]:
                        self.signal(a, source, on)
        for a, run in list(self.runs.items()):
            if run.phase == "wait" and k.t >= run.wait_until - 1e-9:
                self._run(a, run)

    def after_motion(self, t: float) -> None:
        """The target tracks the command while the jog runs continuously [M §4.5]."""
        k = self.k
        for a, run in self.runs.items():
            if run.phase == "run" or (run.phase == "stopping" and not run.step):
                k.target[a] = float(k.user_cmd()[a])

    def stop_axis(self, a: int, code: int, immediate: bool) -> None:
        """EMG, ALM, a limit or a stop command ends the jog (the kernel stops the axis)."""
        self._end(a)


def jog_start(k: Kernel, a: int, on: int) -> None:
    """APS_jog_start(Axis_ID, STA_On) (the manual's APS_jog_on) [M §4.5]: the software JOG-ON
    signal, 1 on, 0 off; any other value -10."""
    k.check_axis(a)
    if on not in (0, 1):
        raise ApsError(ERR_ParametersInvalid, f"STA_On {on}: 0 or 1")
    unit = next(u for u in k.units if isinstance(u, Jogging))
    unit.signal(a, SOFTWARE, bool(on))
