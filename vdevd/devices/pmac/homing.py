"""The home search and position capture of the Turbo PMAC's motors [spec pmac.md §2.7, §1.5;
SRM p.101, p.222-223; UM "Homing"].

HM jogs at |Ixx23| toward sign(Ixx23) until the capture condition of the motor's flag channel
(Ixx25) holds: I7mn2 on the flag I7mn3 selects, and the index pulse. The Servo IC latches the
counter (X:b+3, Mxx73) and sets the position-captured flag; trigger + Ixx26/16 becomes motor
position 0 and the motor moves there (EncoderPos = MotorPos + HomeCapture + Ixx26/16
[A L900-914]). HMZ makes the present commanded position 0 without motion. A search answers what
its motor should do (`Jog`, `Found`) and `Motors` does it: homing moves the motor's origin
(`Motors.origin`), never the encoder count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from vdevd.devices.pmac.ivars import SERVO_IC_BASE, IVars
from vdevd.rt import MotionCore


class MotorView(Protocol):
    """What a home search reads of its motors (never writes): their count, I-variables, motion
    core and raw flag inputs."""

    @property
    def n(self) -> int: ...
    @property
    def ivars(self) -> IVars: ...
    @property
    def core(self) -> MotionCore: ...
    @property
    def hmfl(self) -> np.ndarray: ...
    @property
    def plim(self) -> np.ndarray: ...
    @property
    def mlim(self) -> np.ndarray: ...
    @property
    def user(self) -> np.ndarray: ...


@dataclass(frozen=True, slots=True)
class Jog:
    """Start the search: jog at `velocity` counts/ms with the jog accelerations, limits pushed
    first (software limits are off while searching); then check the trigger at once."""

    velocity: float


@dataclass(frozen=True, slots=True)
class Triggered:
    """A jog-until-trigger found its trigger: the motor moves to `position` (core counts: the
    trigger + the post-trigger distance) with the jog parameters in force now; its zero stays
    [UM "Jog-until-trigger"]."""

    position: float


@dataclass(frozen=True, slots=True)
class Found:
    """Home found: `origin` (core counts) becomes motor position 0; with `speed` (|Ixx23|,
    counts/ms) the motor moves there as a timed jog-type move, without (HMZ) it stays put."""

    origin: float
    speed: float | None = None


#: what `Motors` does after `HomeSearch.start` / `zero`
HomeAction = Jog | Found
#: what a trigger answers: a home search's `Found`, a jog-until-trigger's `Triggered`
TriggerAction = Found | Triggered


def _ic_channel(address: int, motor: int) -> tuple[int, int]:
    """(Servo IC, channel 1-4) of a PMAC2 flag address (Ixx25) [A Ixx25 table]; for any other
    address (MACRO, PMAC(1) style) the motor's own on-board channel."""
    for ic, base in enumerate(SERVO_IC_BASE):
        offset = address - base
        if 0 <= offset < 32 and offset % 8 == 0:
            return ic, offset // 8 + 1
    ic, ch = divmod(motor - 1, 4)
    return ic % len(SERVO_IC_BASE), ch + 1


class HomeSearch:
    """The home searches of the motors of one card, with the capture registers and index pulses
    they trigger on. It reads the motors through `MotorView` and answers what they should do
    (`Jog`, `Found`); `Motors` does it. Per-motor Python only at the servo cycle a trigger
    happens."""

    def __init__(self, motors: MotorView) -> None:
        self.motors = motors
        #: index pulses at index_phase + k x index_period encoder counts (period 0: none)
        self.index_period = np.zeros(motors.n)
        self.index_phase = np.zeros(motors.n)
        #: I7mn0's number for the Servo IC channel of each motor's flags (Ixx25)
        self.capture_ivar = np.zeros(motors.n, dtype=np.int64)
        self.clear()

    def clear(self) -> None:
        """Power-up: no search, home complete and position captured cleared, capture register 0."""
        n = self.motors.n
        self.home_complete = np.zeros(n, dtype=bool)
        self.searching = np.zeros(n, dtype=bool)
        self.captured = np.zeros(n, dtype=bool)  # X:b+0 bit 11
        self.capture_counts = np.zeros(n, dtype=np.int64)  # X:b+3 / Mxx73
        self.any_searching = False  # False: no motor searching (True may be stale until `check`)
        self._enc_prev = np.zeros(n, dtype=np.int64)
        self.jog_trigger = np.zeros(n, dtype=bool)  # the search is a jog-until-trigger
        self.trigger_move = np.zeros(n, dtype=bool)  # word 2 bit 7, until the trigger's move ends
        self.post_trigger = np.zeros(n, dtype=bool)  # the trigger was found: moving to it + c
        self.trigger_distance = np.zeros(n)

    def map_channels(self) -> None:
        """Each motor's flag channel from Ixx25 (after an I-variable change)."""
        values = self.motors.ivars.values
        channels = [_ic_channel(int(values[100 * (m + 1) + 25]), m + 1)
                    for m in range(self.motors.n)]
        self.capture_ivar = np.array([7000 + 100 * ic + 10 * ch for ic, ch in channels])

    def end(self, idx: int | np.ndarray) -> None:
        """The search of the motors `idx` ends (killed, open loop, another command)."""
        self.searching[idx] = False
        self.any_searching = bool(self.searching.any())

    def new_move(self, m: int) -> None:
        """A jog, move or home search starts: the trigger-move state of the last one goes."""
        self.trigger_move[m] = self.post_trigger[m] = self.jog_trigger[m] = False

    def trigger_move_bits(self, moving: np.ndarray) -> np.ndarray:
        """Word 2 bit 7 "trigger move": set at the start of a jog-until-trigger, cleared at the
        end of its post-trigger move; left set when the move ended without a trigger [UM
        "Jog-until-trigger"]."""
        return self.trigger_move & ~(self.post_trigger & ~moving)

    def start_trigger(self, m: int, distance: float) -> None:
        """A jog-until-trigger move has started: watch its trigger as a home search's (home
        search in progress set [UM]); at the trigger it ends at trigger + `distance` counts."""
        self.searching[m] = True
        self.any_searching = True
        self.captured[m] = False
        self.jog_trigger[m] = self.trigger_move[m] = True
        self.post_trigger[m] = False
        self.trigger_distance[m] = distance
        self._enc_prev[m] = self.motors.core.axes.encoder[m]

    def stopped(self, moving: np.ndarray) -> None:
        """A limit or a stop ended the motion of the motors not `moving`: their search ends."""
        self.searching &= moving

    # -- HM and HMZ ------------------------------------------------------------------------------
    def start(self, m: int) -> HomeAction:
        """HM, once the motor's loop is closed: home search at |Ixx23| toward sign(Ixx23) with
        the jog accelerations until the capture trigger of I7mn2/I7mn3; then the motor moves to
        trigger + Ixx26/16, which is motor position 0 [SRM p.101, UM "Homing"]. Software limits
        are off during the search. Ixx23 = 0 homes where the motor is (as HMZ)."""
        speed = float(self.motors.ivars.values[100 * (m + 1) + 23])
        self.home_complete[m] = False
        self.new_move(m)
        if speed == 0:
            return self.zero(m)
        self.searching[m] = True
        self.any_searching = True
        self.captured[m] = False
        self._enc_prev[m] = self.motors.core.axes.encoder[m]
        return Jog(speed)

    def zero(self, m: int) -> Found:
        """HMZ: the present commanded position becomes motor position 0, home complete set
        (the actual position then reads minus the following error); no motion."""
        core = self.motors.core
        self.end(m)
        here = core.axes.cmd_pos[m] if core.servo_on_mask[m] else core.axes.fb[m]
        self.home_complete[m] = True
        return Found(float(here))

    # -- the trigger -----------------------------------------------------------------------------
    def check(self, initial: bool = False, edges: np.ndarray | None = None
              ) -> list[tuple[int, TriggerAction]]:
        """Searching motors whose capture condition holds: latch the capture, set home complete;
        for each, trigger + Ixx26/16 becomes motor position 0 and it moves there [§2.7]
        (`Found`, with the motor). `initial`: at the command or an input change, not after a
        servo cycle (no index crossed since the last check). `edges` (4 x motors, encoder
        counts, NaN: unknown): where the HMFL, PLIM, MLIM and USER inputs changed level during
        this cycle; a flag trigger captures there (else the present count)."""
        mo = self.motors
        core, values = mo.core, mo.ivars.values
        self.searching &= core.profile.moving  # a limit or a stop ended the search
        idx = np.flatnonzero(self.searching)
        if not len(idx):
            self.any_searching = False
            return []
        hit = idx[self._capture_level(idx, initial)]
        found: list[tuple[int, TriggerAction]] = []
        for m in hit.tolist():
            capture = self._capture_value(m, initial, edges)
            self.capture_counts[m] = capture
            self.captured[m] = True
            self.searching[m] = False
            if self.jog_trigger[m]:
                self.post_trigger[m] = True
                found.append((m, Triggered(capture + float(self.trigger_distance[m]))))
                continue
            self.home_complete[m] = True
            origin = capture + float(values[100 * (m + 1) + 26]) / 16
            found.append((m, Found(origin, abs(float(values[100 * (m + 1) + 23])))))
        np.copyto(self._enc_prev, core.axes.encoder)
        self.any_searching = bool(self.searching.any())
        return found

    def _capture_level(self, idx: np.ndarray, initial: bool) -> np.ndarray:
        """The capture condition of I7mn2 (bit 0 index, bit 1 flag, bits 2/3 their low-true
        polarity; 0/4/8/12 immediate) on the flag I7mn3 selects (HMFL, PLIM, MLIM, USER), for
        the motors `idx` [SRM p.222-223]; level-triggered as on a PMAC2-style IC. The index is
        high when the encoder crossed (or sits on) a multiple of the index period this cycle."""
        mo = self.motors
        v = mo.ivars.values
        civ = self.capture_ivar[idx]
        ctrl = v[civ + 2].astype(np.int64)
        sel = v[civ + 3].astype(np.int64)
        flag = np.choose(np.clip(sel, 0, 3), [mo.hmfl[idx], mo.plim[idx], mo.mlim[idx],
                                               mo.user[idx]])
        flag = np.where((ctrl & 8) != 0, ~flag, flag)
        i97 = v[100 * (idx + 1) + 97].astype(np.int64)
        period = self.index_period[idx]
        enc = mo.core.axes.encoder[idx] - self.index_phase[idx]
        safe = np.where(period > 0, period, 1)
        prev = enc if initial else self._enc_prev[idx] - self.index_phase[idx]
        crossed = (np.floor_divide(enc, safe) != np.floor_divide(prev, safe)) | (enc % safe == 0)
        index = (period > 0) & crossed
        index = np.where((ctrl & 4) != 0, ~index, index)
        use_index, use_flag = (ctrl & 1) != 0, (ctrl & 2) != 0
        immediate = ~use_index & ~use_flag
        hardware = immediate | ((index | ~use_index) & (flag | ~use_flag))
        if not (i97 & 2).any():
            return hardware
        # Ixx97 bit 1: the trigger is the warning following error (|FE| > Ixx12) [SRM Ixx97]
        axes = mo.core.axes
        warn = v[100 * (idx + 1) + 12] / 16
        error = (warn > 0) & (np.abs(axes.cmd_pos[idx] - axes.fb[idx]) > warn)
        return np.where((i97 & 2) != 0, error, hardware)

    def _capture_value(self, m: int, initial: bool, edges: np.ndarray | None = None) -> int:
        """The counter value latched: the index position crossed; else, on a flag, where the
        flag changed level this cycle (`edges`); else the present count."""
        enc = int(self.motors.core.axes.encoder[m])
        values = self.motors.ivars.values
        if int(values[100 * (m + 1) + 97]) & 3:  # software capture (bit 0; bit 1 needs it) [SRM]
            return enc
        civ = int(self.capture_ivar[m])
        ctrl = int(values[civ + 2])
        period = float(self.index_period[m])
        if ctrl & 1 and not ctrl & 4 and period > 0:
            phase = float(self.index_phase[m])
            prev = enc if initial else int(self._enc_prev[m])
            e, p = enc - phase, prev - phase
            k = max(e // period, p // period) if e % period else e // period
            return math.floor(k * period + phase + 0.5)
        if ctrl & 2 and edges is not None:
            edge = float(edges[int(values[civ + 3]) & 3, m])
            if math.isfinite(edge):
                return math.floor(edge)
        return enc
