"""Running motion programs: one runner per coordinate system, its run control (B R S Q A H K)
and the C.S. status bits it owns [spec pmac.md §2.8; Turbo UM "How PMAC Executes a Motion
Program", "Writing and Executing Motion Programs"; Turbo SRM B, R, S, Q, H, A, DWELL, DELAY].

Calculation and execution are apart, as on the card. The calculator reads program statements
(logic, variables, moves) and hands each move to the move mode's planner (`PLANNERS`: LINEAR,
RAPID here; the other modes register their planner there), whose pieces (pieces.py) queue for
execution. It works ahead only as far as the card does [UM "Calculating Ahead"]: `_ahead` moves
past the one executing (two for blended LINEAR/CIRCLE moves with Isx13 = 0, one with Isx13 > 0
and in PVT, SPLINE1 two, SPLINE2 three: README "Calculation and look-ahead"), one more each time
a move starts executing; so a statement reading a P-variable sees the value written on-line
before the calculation reached it, and Q stops at the end of those moves. It does not
calculate past a DWELL (until the dwell is over), a RAPID move or a HOME (until every motor
has finished) [UM "When No Calculation Ahead"], nor past a second backward jump (ENDWHILE,
GOTO) without a move in between: the move before comes to a stop and calculation goes on at the
next servo cycle ("double-jump-back rule"). DELAY is a move of its own time: calculation goes through it.

Execution samples the queued pieces each servo cycle at the program's time, which runs at %/100
of real time (the feedrate override and the feed hold, which slews the time base to 0 at Isx95
per servo cycle in I10 units and back at R) but for a DWELL, which runs in real time [SRM
DWELL]. The sample (axis positions) gives each motor of the C.S. its commanded position through
the axis definitions (motor = Σ scale·axis + position bias, coord.py), handed to the motor's servo
loop with `MotionCore.track`, so following error, status bits and the fatal following-error
kill behave as for jogs. A motor killed (K, fatal following error, amplifier fault) or reaching
a limit on the way stops the program: the C.S. aborts (each motor stops at Ixx15) and word 2
bit 22 (run-time error) is set until the next R.
"""

from __future__ import annotations

import copy
import math
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from vdevd.devices.pmac import kin_velocity, mode_blend, rollover, stop_commands
from vdevd.devices.pmac.circle import CirclePlanner
from vdevd.devices.pmac.coord import AXES, CS_COUNT
from vdevd.devices.pmac.errors import ERR_DATA, ERR_NO_PROGRAM, CommandError
from vdevd.devices.pmac.expr import ExprError
from vdevd.devices.pmac.jog_profile import jog_accel
from vdevd.devices.pmac.linear import LinearPlanner, RapidPlanner
from vdevd.devices.pmac.lookahead import MAX_OUTPUTS, MAX_SEGMENTS, Segmenter
from vdevd.devices.pmac.mvars import MDefError
from vdevd.devices.pmac.online import PortState
from vdevd.devices.pmac.pieces import NAXES, Move, Piece, Planner
from vdevd.devices.pmac.planerr import CIRCLE_RADIUS_ERROR, PlanError
from vdevd.devices.pmac.plc import CMD_QUEUE, MESSAGE_QUEUE, _true
from vdevd.devices.pmac.prog_trigger import start_trigger_move
from vdevd.devices.pmac.programs import Program, ProgramStore, compile_program
from vdevd.devices.pmac.pvt import PvtPlanner
from vdevd.devices.pmac.spline import Spline1Planner, Spline2Planner, SplinePlanner

if TYPE_CHECKING:
    from vdevd.devices.pmac.firmware import Firmware

#: move mode -> its planner class (other modes add theirs here)
PLANNERS: dict[str, type[Planner]] = {
    "LINEAR": LinearPlanner, "RAPID": RapidPlanner, "PVT": PvtPlanner,
    "SPLINE1": Spline1Planner, "SPLINE2": Spline2Planner,
    "CIRCLE1": CirclePlanner, "CIRCLE2": CirclePlanner}

# R / S refusals [UM "Turbo PMAC will reject a run or step command": ERR010-ERR017]
ERR_RUNNING = 1
ERR_BOTH_LIMITS = 10
ERR_MOVING = 11
ERR_OPEN_LOOP = 12
ERR_NOT_ACTIVATED = 13
ERR_NO_MOTORS = 14
ERR_BAD_PROGRAM = 16
ERR_IN_USE_BUFFER = 7   # a buffer out of the definition order [A L3139]

#: statements the calculator runs in one servo cycle at most (the rest: next cycle)
MAX_STEPS = 4096
#: GOSUB/CALL nesting (deeper: run-time error) (ASSUMPTION)
MAX_STACK = 255
#: the longest DWELL, DELAY, TM, ms [SRM DWELL]
MAX_TIME_MS = 8_388_607.0
#: feedrate axes at power-on: X Y Z [SRM FRAX]
DEFAULT_FRAX = np.array([a in "XYZ" for a in AXES])

# C.S. status bits this module sets [SRM "??", digest §2.6]
W1_RUNNING, W1_SINGLE_STEP, W1_CONTINUOUS, W1_TM_MODE, W1_RUN_REQUEST = 1, 2, 4, 8, 16
W1_RADIUS_INC = 32
W2_RAPID, W2_CIRCLE, W2_PVT_SPLINE, W2_DWELL, W2_IN_POSITION = 2, 1, 16, 1 << 12, 1 << 17
W2_RUNTIME_ERROR = 1 << 22
W2_LOOKAHEAD = 1 << 23
W2_RADIUS_ERROR = 1 << CIRCLE_RADIUS_ERROR
#: word 2 bit 16: the rotary buffer is full (I17/I16) [SRM I17 "Rotary Buffer Full" status bit]
W2_ROTARY_FULL = 1 << 16
_MODE_BITS = {"LINEAR": 0, "RAPID": W2_RAPID, "CIRCLE1": W2_CIRCLE, "CIRCLE2": W2_CIRCLE | W2_RAPID,
              "PVT": W2_PVT_SPLINE, "SPLINE1": W2_PVT_SPLINE | W2_CIRCLE,
              "SPLINE2": W2_PVT_SPLINE | W2_CIRCLE}
#: the kinds of operation that are moves for the look-ahead count
_MOVES = ("move", "dwell", "delay", "trigmove")


@dataclass
class _Frame:
    """A GOSUB/CALL return point and the arguments READ sees."""

    prog: int
    pc: int
    args: dict[str, float] = field(default_factory=dict)


@dataclass
class _Glide:
    """The motors' counts of the next servo cycles inside the executing piece, computed at once
    (the hot path: a piece of a scan spans many cycles at a steady time base)."""

    q: _Queued
    rate: float
    taus: np.ndarray
    counts: np.ndarray
    k: int = 0


#: servo cycles one glide computes at most
GLIDE_MAX = 4096
#: program time a LINEAR or CIRCLE move waiting for the rotary buffer's next line runs on at a time, s
#: (ASSUMPTION: the sources give no calculation step)
ROTARY_CHUNK = 0.010


@dataclass
class _Queued:
    piece: Piece
    scaled: bool = True   # runs at the time base (all but DWELL)
    starts: int = 0       # the move number that begins with this piece (0: none)
    #: PVT in a kinematic C.S.: the `#n->I` motors' cubic in the piece's time (kin_velocity.py)
    motor: np.ndarray | None = None


class CsProgram:
    """The motion program state of one coordinate system."""

    def __init__(self, fw: Firmware, cs: int) -> None:
        self.fw, self.cs = fw, cs
        self.port = PortState(cs=cs)  # Q-variables and CMD addressing of the program
        self.pos = np.zeros(NAXES)    # programmed axis positions (where calculation stands)
        self.prog = 0                 # the program pointed to (B), 0 none
        self.pc = 0
        self.stack: list[_Frame] = []
        self.args: dict[str, float] = {}
        self._state = "idle"          # idle | run | step | quit (`state`)
        self.stopping = False         # calculation ended (end, Q, S, STOP): stop when drained
        self.hold_target = 1.0
        self.hold = 1.0
        self.error = False
        self.queue: deque[_Queued] = deque()
        self.cur: _Queued | None = None
        self.tau = 0.0
        self.exec_pos = np.zeros(NAXES)
        self.calc = 0      # moves calculated
        self.started = 0   # moves begun executing
        self.wait = ""     # "" | "drain" | "home"
        self.homing: list[int] = []
        self.members = np.zeros(0, dtype=np.intp)
        self.member_mask = np.zeros(0, dtype=bool)
        self.scale = np.zeros((0, NAXES))
        self.planner: Planner | None = None
        self.move_at: dict[int, tuple[int, int]] = {}  # move number -> (prog, op) (PE)
        self.exec_at = (0, 0)                          # (prog, op) executing or last executed
        self.block = False                             # between BLOCKSTART and BLOCKSTOP
        self.lookahead_buffer: tuple[int, int] | None = None  # DEFINE LOOKAHEAD segments, outputs
        self.segmenter: Segmenter | None = None        # Isx13 segments of LINEAR moves
        self.radius_error = False
        self._glide: _Glide | None = None
        self._blocked: tuple[int, int, int] | None = None   # (started, prog, pc) held at
        self.rot = Program([], [], {})   # the rotary buffer's line being run (B0)
        self.rot_flushed = True
        self.inv_rows = np.zeros(0, dtype=np.intp)   # rows of `#n->I` motors (Isx50 = 1)
        self.inv_order: list[int] = []
        self._inv_at: np.ndarray | None = None
        self._inv_counts = np.zeros(0)
        #: where the last move statement was calculated from, and its blend's piece count, for
        #: the `/` stop (stop_commands.py): (move number, prog, pc, stack, ops, start point)
        self.move_from: tuple[int, int, int, list[_Frame], list[Any], np.ndarray] | None = None
        self.move_blend = (0, 0)
        #: the same per move number for the moves calculated ahead (`/` with two of them)
        self.move_recs: dict[int, tuple[int, int, int, list[_Frame], list[Any], np.ndarray]] = {}
        self.blend_at: dict[int, int] = {}
        #: a CIRCLE sequence's planner before each move and that move's blend start (`/`)
        self.circle_before: dict[int, tuple[CirclePlanner, float]] = {}
        #: a SPLINE sequence's planner before the move that began move n, and its move count
        self.spline_before: dict[int, tuple[SplinePlanner, int]] = {}
        self.online = False   # running an on-line `!` move only (altdest.py)
        self.reset_modes()

    def reset_modes(self) -> None:
        """The modal state at power-on and at B: LINEAR, ABS, TA/TS/F from Isx87-Isx89 (ms,
        user units per Isx90 ms) [SRM Isx87-Isx90] (ASSUMPTION: B starts them afresh)."""
        iv, base = self.fw.ivars.values, 5000 + 100 * self.cs
        self.mode = "LINEAR"
        self.mode_arg = 0.0
        self.inc = np.zeros(NAXES, dtype=bool)
        self.frax = DEFAULT_FRAX.copy()
        self.ta, self.ts = float(iv[base + 87]), float(iv[base + 88])
        self.f, self.tm = float(iv[base + 89]), 0.0
        self.tm_mode = False
        self.normal = np.array([0.0, 0.0, -1.0])  # NORMAL K-1: the XY plane [SRM NORMAL]
        self.radius_inc = True                     # INC(R): centres from the move's start

    # -- state -------------------------------------------------------------------------------------
    @property
    def state(self) -> str:
        return self._state

    @state.setter
    def state(self, value: str) -> None:
        """The card's set of running C.S. follows (what its tick looks at)."""
        self._state = value
        if value == "idle":
            self.fw.motion.running.discard(self.cs)
        else:
            self.fw.motion.running.add(self.cs)

    @property
    def running(self) -> bool:
        return self._state != "idle"

    def move_time_left(self) -> float:
        """MOVETIME: program time left in the present move (up to the next move's start), ms."""
        if not self.running or self.cur is None:
            return 0.0
        left = self.cur.piece.dur - self.tau
        for q in self.queue:
            if q.starts:
                break
            left += q.piece.dur
        return left * 1000

    def _ahead(self) -> int:
        """Moves calculated beyond the one executing (README "Calculation and look-ahead"):
        two for blended LINEAR/CIRCLE moves without segmentation (Isx13 = 0), one with it and
        in PVT; SPLINE1 two, SPLINE2 three (the spline's next segment needs the points, and
        SPLINE2's times, that far ahead: spline.py)."""
        iv = self.fw.ivars.values
        if self.mode.startswith("SPLINE"):
            return 2 if self.mode == "SPLINE1" else 3
        blended = self.mode in ("LINEAR", "CIRCLE1", "CIRCLE2")
        return 2 if blended and iv[5000 + 100 * self.cs + 13] == 0 else 1

    # -- run control ---------------------------------------------------------------------------------
    def point(self, n: float | None) -> None:
        """B{n} (n.label: the label n's fraction × 100000) / B alone: back to the top."""
        if self.running:
            raise CommandError(ERR_RUNNING, "a program is running")
        if n is None:
            self.pc, self.stack = 0, []
            return
        prog = int(n)
        if not 0 <= prog <= 32767:
            raise CommandError(ERR_DATA)
        self.prog, self.pc, self.stack, self.args = prog, 0, [], {}
        label = round((n - prog) * 100000)
        program = self.fw.motion.store.runnable(prog)
        if label and program is not None and program.ops is not None:
            self.pc = program.labels.get(label, 0)
        self.exec_at = (self.prog, self.pc)
        self.reset_modes()

    def abort_and_run(self, n: float | None) -> None:
        """ABR[{n}]: abort the program (motors stop at Ixx15), point to PROG n (`n.label` as B;
        without n the program pointed to, from its top) and run it [A L3261]: the calculation
        starts once the motors have stopped, from where they stopped (ASSUMPTION). The R
        checks apply but for ERR011 (moving: the motors are in their abort stop)."""
        if self.running:
            self.abort()
            self.fw.motion.abort_motors(self.cs)
        self.point(n if n is not None else float(self.prog))
        try:
            self._check_start()
        except CommandError as exc:
            if exc.code != ERR_MOVING:
                raise
        self.run(step=False, after_abort=True)

    def run(self, step: bool, after_abort: bool = False) -> None:
        """R / S: start (after the checks of [UM]), resume a held, quitting or stepping run;
        `after_abort` (ABR): checked already, the motors may still be stopping."""
        if self.running:
            if step:
                self.state = "step" if self.state == "run" else self.state
                return
            self.hold_target = 1.0
            if self.state in ("step", "quit"):
                self.state, self.stopping = "run", False
                if self.wait == "" and self.planner is None:
                    self._restart_planner()
            return
        if not after_abort:
            self._check_start()
        self.error = self.radius_error = False
        self._blocked = self._glide = None
        if self.prog == 0:
            self.rot, self.pc, self.rot_flushed = Program([], [], {}), 0, True
        self.hold = self.hold_target = 1.0
        self.state = "step" if step else "run"
        self.stopping = False
        self.calc = self.started = 0
        self.move_at.clear()
        self._forget_calculated()
        self.block = False
        self.wait = ""
        self._map_motors()
        self._read_position()
        try:
            self._forward()
        except CommandError:
            self.state = "idle"
            raise
        self.exec_pos = self.pos.copy()
        self._restart_planner()
        motors = self.fw.motors
        motors.timed[self.members] = True
        if after_abort and motors.core.profile.moving[self.members].any():
            self.wait, self.homing = "home", self.members.tolist()  # until they stop
            self.planner = None
            return
        motors.abort_decel[self.members] = False

    def _forget_calculated(self) -> None:
        """A fresh run: the records `/` keeps of the moves calculated ahead are stale."""
        self.move_recs.clear()
        self.blend_at.clear()
        self.circle_before.clear()
        self.spline_before.clear()

    def _check_start(self) -> None:
        """The program first (ERR015 a PROG buffer open or no program pointed to, ERR016 one
        CLOSE found badly structured), then the motors (ERR014 none, ERR013 not activated,
        ERR012 open loop, ERR010 both limits, ERR011 moving) (ASSUMPTION: this order)."""
        fw = self.fw
        store = fw.motion.store
        if store.owner is not None or fw.kinematics.owner is not None:
            raise CommandError(ERR_NO_PROGRAM, "a PROG or kinematic buffer is open")
        program: Program | None = self.rot   # B0: the rotary buffer [SRM B]
        if self.prog == 0 and not fw.rotary.exists(self.cs):
            raise CommandError(ERR_NO_PROGRAM, "no rotary buffer")
        if self.prog:
            program = store.runnable(self.prog)
        if program is None:
            raise CommandError(ERR_NO_PROGRAM, "not pointing to a program")
        if program.ops is None:
            raise CommandError(ERR_BAD_PROGRAM if program.bad else ERR_NO_PROGRAM, "not runnable")
        self.check_motors()

    def check_motors(self) -> None:
        """R's checks of the C.S.'s motors (ERR014, ERR013, ERR012, ERR010, ERR011)."""
        fw = self.fw
        members = [m - 1 for m in fw.coord.members(self.cs) if m <= fw.ivars.motors]
        if not members:
            raise CommandError(ERR_NO_MOTORS, "no motors in the C.S.")
        idx = np.array(members)
        mo = fw.motors
        if not mo.active[idx].all():
            raise CommandError(ERR_NOT_ACTIVATED, "a motor is not activated")
        if not mo.core.servo_on_mask[idx].all():
            raise CommandError(ERR_OPEN_LOOP, "a motor is open loop")
        if (mo.plim[idx] & mo.mlim[idx]).any():
            raise CommandError(ERR_BOTH_LIMITS, "a motor has both limits")
        if mo.core.profile.moving[idx].any():
            raise CommandError(ERR_MOVING, "a motor is moving")

    def start_online(self) -> None:
        """An idle C.S. set running with nothing to calculate, for the moves an on-line command
        queues (`!`, altdest.py); it stops once they have run, the program pointer unchanged."""
        self.error = self.radius_error = False
        self._blocked = self._glide = None
        self.hold = self.hold_target = 1.0
        self.state, self.stopping, self.wait = "run", True, ""
        self.online = True
        self.calc = self.started = 0
        self.move_at.clear()
        self._forget_calculated()
        self._map_motors()
        self._read_position()
        self._forward()
        self.exec_pos = self.pos.copy()
        self.planner = self.segmenter = None
        self.fw.motors.timed[self.members] = True
        self.fw.motors.abort_decel[self.members] = False

    def rapid_to(self, target: np.ndarray) -> None:
        """`!` (altdest.py): a RAPID move from where the motion calculated so far ends to
        `target`, queued after it; the calculation goes on from `target`."""
        planner = RapidPlanner(self.pos)
        prm: dict[str, Any] = dict(self._rapid_limits())
        self.calc += 1
        self._enqueue(planner.add(Move(target, target != self.pos, prm)), self.calc, scaled=True)
        self.pos = target.astype(float).copy()
        if self.planner is not None:
            self.planner.position = self.pos.copy()

    def rapid_limits(self) -> dict[str, np.ndarray]:
        """The RAPID speed, acceleration and jerk per axis (`_rapid_limits`), for altdest.py."""
        if not len(self.members):
            self._map_motors()
        return self._rapid_limits()

    def break_in(self, delay: float, build: Any, target: np.ndarray) -> bool:
        """`!` into a RAPID move in progress (altdest.py): the motion queued is cut `delay`
        program seconds from now and `build(pos, vel)` gives the pieces from there on; False
        (nothing changed) when the queued motion ends before that."""
        pieces = ([self.cur] if self.cur is not None else []) + list(self.queue)
        left = delay + (self.tau if self.cur is not None else 0.0)
        k = 0
        while k < len(pieces) and left >= pieces[k].piece.dur:
            left -= pieces[k].piece.dur
            k += 1
        if k == len(pieces):
            return False
        q = pieces[k]
        pos, vel = q.piece.at(left)
        cut = _Queued(Piece(left, q.piece.coef), q.scaled, q.starts)
        kept = pieces[:k] + ([cut] if left > 0 else [])
        self._glide = None
        if self.cur is not None:
            self.cur = kept.pop(0) if kept else None
            if self.cur is None:
                self.tau = 0.0
        self.queue = deque(kept)
        self.calc += 1
        for j, piece in enumerate(build(pos, vel)):
            self.queue.append(_Queued(piece, True, self.calc if j == 0 else 0))
        self.pos = target.astype(float).copy()
        if self.planner is not None:
            self.planner.position = self.pos.copy()
        return True

    def quit(self) -> None:
        """Q: no more calculation; the moves already calculated finish, then the program stops
        (R resumes after them) [SRM Q]."""
        if self.running:
            self.state = "quit"

    def feed_hold(self) -> None:
        """H: the time base slews to 0 at Isx95; R resumes [SRM H]."""
        if self.running:
            self.hold_target = 0.0

    def abort(self, error: bool = False) -> None:
        """A (and a fault): calculation stops where it is, the queued motion is dropped and the
        motors stop at Ixx15 (the caller aborts them); R resumes from the next statement."""
        if not self.running:
            return
        self._stop_tracking(hold=False)
        self.error = self.error or error

    def kill(self) -> None:
        """K of the C.S.: the program stops (the caller kills the motors)."""
        self.abort()

    def _stop_tracking(self, hold: bool) -> None:
        mo = self.fw.motors
        if hold and len(self.members):
            counts = self._counts(self.exec_pos)
            closed = mo.core.servo_on_mask[self.members]
            if closed.any():
                mo.core.hold(self.members[closed], (counts + mo.origin[self.members])[closed])
        mo.timed[self.members] = False
        mo.dwell[self.members] = False
        self._glide = None
        self.state, self.stopping, self.wait = "idle", False, ""
        self.online = False
        self.queue.clear()
        self.cur, self.tau = None, 0.0
        self.planner = None
        self.segmenter = None
        self.homing = []

    def _hold_motors(self, idx: np.ndarray) -> None:
        """Motors of the C.S. stop being tracked: they hold where the program left them."""
        mo = self.fw.motors
        rows = np.flatnonzero(np.isin(self.members, idx))
        closed = rows[mo.core.servo_on_mask[self.members[rows]]]
        if len(closed):
            counts = self._counts(self.exec_pos)[closed] + mo.origin[self.members[closed]]
            mo.core.hold(self.members[closed], counts)

    # -- motors <-> axes --------------------------------------------------------------------------
    def _map_motors(self) -> None:
        """The C.S.'s motors and their scale matrix (counts per axis unit); inverse-kinematic
        motors (`#m->I`) are driven by the inverse program with Isx50 = 1 and one defined
        (kinematics.py), else not at all."""
        fw = self.fw
        defs = fw.coord.defs
        kin = fw.kinematics
        inverse = self._kinematic() and kin.has(self.cs, "INVERSE")
        members = [m - 1 for m in fw.coord.members(self.cs) if m <= fw.ivars.motors
                   and (inverse or not getattr(defs[m - 1], "inverse", False))]
        self.members = np.array(members, dtype=np.intp)
        self.member_mask = np.zeros(len(fw.motors.core.servo_on_mask), dtype=bool)
        self.member_mask[self.members] = True
        self.scale = np.zeros((len(members), NAXES))
        self.inv_order = kin.inverse_motors(self.cs) if inverse else []
        self.inv_rows = np.array([r for r, m in enumerate(members) if m + 1 in self.inv_order],
                                 dtype=np.intp)
        self._inv_at = None
        for r, m in enumerate(members):
            d = fw.coord.defs[m]
            if d is not None:
                for s, a in d.terms:
                    self.scale[r, AXES.index(a)] += s

    def _counts(self, pos: np.ndarray, q: _Queued | None = None, tau: float = 0.0) -> np.ndarray:
        counts = self.scale @ pos + self.fw.coord.bias[self.members]
        if len(self.inv_rows):
            if q is not None and q.motor is not None:   # PVT with velocities (kin_velocity.py)
                c = q.motor
                counts[self.inv_rows] = c[0] + tau * (c[1] + tau * (c[2] + tau * c[3]))
            else:
                counts[self.inv_rows] = self._inverse(pos)
        return counts

    def _kinematic(self) -> bool:
        return bool(self.fw.ivars.values[5000 + 100 * self.cs + 50])

    def _inverse(self, pos: np.ndarray) -> np.ndarray:
        """The `#n->I` motors' positions (counts) for axis positions `pos`: the inverse
        kinematic program (kinematics.py), run again only when the axes moved."""
        if self._inv_at is None or not np.array_equal(pos, self._inv_at):
            try:
                motors = self.fw.kinematics.inverse(self.cs, pos)
            except PlanError:
                self.error = True
                return self._inv_counts
            by_motor = dict(zip(self.inv_order, motors.tolist(), strict=True))
            self._inv_counts = np.array([by_motor[int(m) + 1] for m in self.members[self.inv_rows]])
            self._inv_at = pos.copy()
        return self._inv_counts

    def _read_position(self) -> None:
        """The axis positions the motors' commanded positions give back (least squares over the
        axes the definitions use); axes no motor drives keep their programmed value."""
        if not len(self.members):
            return
        used = np.flatnonzero(np.abs(self.scale).sum(axis=0) > 0)
        if not len(used):
            return
        cmd = self.fw.reports.commanded()[self.members] - self.fw.coord.bias[self.members]
        sol, *_ = np.linalg.lstsq(self.scale[:, used], cmd, rcond=None)
        self.pos[used] = sol

    def _forward(self) -> None:
        """Isx50 = 1 with a forward program: the axis positions are what it gives for the
        motors' commanded positions (at R, S) [SRM OPEN FORWARD]."""
        fw = self.fw
        if self._kinematic() and fw.kinematics.has(self.cs, "FORWARD"):
            try:
                self.pos = fw.kinematics.forward(self.cs, fw.reports.commanded())
            except PlanError:
                raise CommandError(ERR_DATA, "forward kinematics did not end") from None

    # -- planners -------------------------------------------------------------------------------------
    def _restart_planner(self) -> None:
        cls = PLANNERS.get(self.mode)
        self.planner = cls(self.pos) if cls is not None else None
        self._release_segments(final=True)
        self.segmenter = self._new_segmenter()

    def _new_segmenter(self) -> Segmenter | None:
        """LINEAR with Isx13 > 0: Isx13 ms segments, through the lookahead's Ixx16/Ixx17 limits
        when the C.S. has a lookahead buffer and Isx20 > 0 (lookahead.py). A C.S. with
        inverse-kinematic motors segments in axis units, without the motor limits (README)."""
        iv, base = self.fw.ivars.values, 5000 + 100 * self.cs
        seg_ms = float(iv[base + 13])
        if self.mode != "LINEAR" or seg_ms <= 0:
            return None
        depth = 0
        motors = 100 * (self.members + 1)
        vmax, amax = np.full(len(self.members), np.inf), np.zeros(len(self.members))
        if self.lookahead_buffer is not None and iv[base + 20] > 0:
            depth = int(min(iv[base + 20], self.lookahead_buffer[0]))
            v = iv[motors + 16] * 1000.0
            vmax = np.where(v > 0, v, np.inf)
            amax = iv[motors + 17] * 1e6
        if len(self.inv_rows):   # `#n->I` motors have no scale row: segment in axis units
            n = self.scale.shape[1]
            return Segmenter(self.pos, seg_ms / 1000, depth, np.eye(n), np.full(n, np.inf),
                             np.zeros(n))
        return Segmenter(self.pos, seg_ms / 1000, depth, self.scale, vmax, amax)

    def define_lookahead(self, segments: int | None, outputs: int) -> None:
        """DEFINE LOOKAHEAD {segments},{outputs} (None: DELETE LOOKAHEAD) of this C.S. [SRM]:
        ERR001 while it runs a program, ERR003 outside 1-65535 / 0-65535, ERR007 while a
        gather buffer exists (the buffer order, README "Compensation tables") (ASSUMPTIONS)."""
        if self.running:
            raise CommandError(ERR_RUNNING, "the C.S. runs a program")
        if segments is None:
            self.lookahead_buffer = None
            return
        if not 1 <= segments <= MAX_SEGMENTS or not 0 <= outputs <= MAX_OUTPUTS:
            raise CommandError(ERR_DATA, "DEFINE LOOKAHEAD segments, outputs")
        if self.fw.gather.defined:
            raise CommandError(ERR_IN_USE_BUFFER, "a gather buffer exists: DELETE GATHER first")
        self.lookahead_buffer = (segments, outputs)

    def _release_segments(self, final: bool) -> None:
        seg = self.segmenter
        if seg is not None:
            for piece, starts in seg.release(final):
                self.queue.append(_Queued(piece, True, starts))

    def _flush(self) -> None:
        planner = self.planner
        if isinstance(planner, SplinePlanner):
            self._enqueue_labelled(planner.flush(), planner.labels)
        elif planner is not None:
            self._enqueue(planner.flush(), starts=0)
        self._release_segments(final=True)

    def _enqueue_labelled(self, pieces: list[Piece], labels: list[tuple[int, int]]) -> None:
        """Pieces of which those at the labels' indices begin move calc − lag (spline.py)."""
        lags = dict(labels)
        for k, piece in enumerate(pieces):
            self._enqueue([piece], self.calc - lags[k] if k in lags else 0)

    def _enqueue(self, pieces: list[Piece], starts: int, scaled: bool = True,
                 begin: int = 0) -> None:
        seg = self.segmenter
        if seg is not None:
            if scaled:
                seg.add(pieces[:begin])
                seg.add(pieces[begin:], starts)
                self._release_segments(final=False)
                return
            self._release_segments(final=True)
        cubics: list[np.ndarray | None] = [None] * len(pieces)
        if len(self.inv_rows) and isinstance(self.planner, PvtPlanner) and scaled and pieces:
            try:   # Q10 = 1 in PVT mode [UM "Velocity Calculation Flag"]
                cubics = list(kin_velocity.motor_cubics(
                    self.fw, self.cs, [int(m) + 1 for m in self.members[self.inv_rows]], pieces,
                    float(self._params()["FEED_PERIOD"])))
            except PlanError:
                self.error = True
        for k, piece in enumerate(pieces):
            self.queue.append(_Queued(piece, scaled, starts if k == begin else 0, cubics[k]))

    def _params(self) -> dict[str, Any]:
        """The move parameters of the present modal state (seconds, units per second)."""
        fw, base = self.fw, 5000 + 100 * self.cs
        iv = fw.ivars.values
        per = float(iv[base + 90]) or 1000.0
        ta = self.ta / 1000
        prm: dict[str, Any] = {
            "TA": ta, "TS": self.ts / 1000, "F": self.f * 1000 / per,
            "TM": self.tm / 1000 if self.tm_mode else None, "FRAX": self.frax.copy(),
            "SEG": float(iv[base + 13]) / 1000, "FEED_PERIOD": per / 1000,
            "MOTOR_SCALE": self.scale,
        }
        motors = 100 * (self.members + 1)
        if iv[base + 13] == 0:
            prm["MOTOR_MAXV"] = iv[motors + 16] * 1000
            prm["MOTOR_MAXA"] = iv[motors + 17] * 1e6
        else:  # segmented: Ixx16/Ixx17 are the lookahead's (lookahead.py) [SRM Ixx16, Ixx17]
            prm["MOTOR_MAXV"] = np.zeros(0)
            prm["MOTOR_MAXA"] = np.zeros(0)
        if self.mode == "RAPID":
            prm.update(self._rapid_limits())
        if self.mode == "PVT":
            prm["PVT"] = self.mode_arg / 1000
        if self.mode.startswith("CIRCLE"):
            prm["CIRCLE"] = int(self.mode[-1])
            prm["Isx96"], prm["Isx97"] = float(iv[base + 96]), float(iv[base + 97])
        prm["NORMAL"] = self.normal.copy()
        prm["IJK_INC"] = self.radius_inc
        return prm

    def _rapid_limits(self) -> dict[str, np.ndarray]:
        """Per axis: the jog-type speed, acceleration and jerk of the first motor driving it
        alone, in axis units [SRM Ixx22, Ixx90] (ASSUMPTION: axes of multi-axis definitions
        take the first motor's numbers over its scale)."""
        iv = self.fw.ivars.values
        vmax, amax, jerk = np.zeros(NAXES), np.zeros(NAXES), np.zeros(NAXES)
        for r, m in enumerate(self.members.tolist()):
            for k in np.flatnonzero(self.scale[r]).tolist():
                if vmax[k]:
                    continue
                s = abs(float(self.scale[r, k]))
                base = 100 * (m + 1)
                speed = float(iv[base + 16] if iv[base + 90] else iv[base + 22])
                acc, jk = jog_accel(iv, m, speed)
                vmax[k], amax[k], jerk[k] = speed * 1000 / s, acc / s, jk / s
        return {"MAXV": vmax, "MAXA": amax, "JERK": jerk}

    # -- the servo cycle -------------------------------------------------------------------------------
    def tick(self, dt: float) -> np.ndarray | None:
        """One servo cycle: the motors' commanded positions (core counts) to track, None when
        nothing is to be tracked this cycle."""
        if not self.running:
            return None
        if not self._motors_ok():
            return None
        self._calculate()
        if not self.running:
            return None
        return self._execute(dt)

    def _motors_ok(self) -> bool:
        """A killed motor or a limit on the way aborts the program with a run-time error."""
        fw, idx = self.fw, self.members
        mo = fw.motors
        lim = mo.core.limits
        # the hot path: one pass over every motor, masked to the C.S.'s (no fancy indexing)
        if not ((~mo.core.servo_on_mask | lim.hard_pos | lim.hard_neg) & self.member_mask).any():
            return True
        if not mo.core.servo_on_mask[idx].all():
            self.abort(error=True)
            fw.motion.abort_motors(self.cs)
            return False
        if self.wait == "home":
            return True
        lim = mo.core.limits  # hardware (unless Ixx24 bit 17) and software limits, as pushed
        pos_hit, neg_hit = lim.hard_pos[idx], lim.hard_neg[idx]
        if pos_hit.any() or neg_hit.any():
            v = mo.core.axes.cmd_vel[idx]
            if (pos_hit & (v > 0)).any() or (neg_hit & (v < 0)).any():
                self.abort(error=True)
                fw.motion.abort_motors(self.cs)
                return False
        return True

    def _execute(self, dt: float) -> np.ndarray | None:
        fw = self.fw
        if self.hold != self.hold_target:
            # the time base itself moves by Isx95 I10-units a cycle, whatever the `%` under it
            iv = fw.ivars.values
            rate = float(iv[5000 + 100 * self.cs + 95]) / max(float(iv[10]), 1.0)
            pct = fw.timebase.present(self.cs - 1) / 100
            step = rate / pct if rate > 0 and pct > 0 else 1.0
            self.hold = min(self.hold + step, 1.0) if self.hold_target > self.hold \
                else max(self.hold - step, 0.0)
        tb = fw.timebase.present(self.cs - 1) / 100 * self.hold  # `%` slewing at Isx94
        g = self._glide
        if g is not None:
            if g.q is self.cur and g.k < len(g.taus) and g.rate == (tb if g.q.scaled else 1.0):
                self.tau = float(g.taus[g.k])
                g.k += 1
                return g.counts[g.k - 1]
            self._glide = None
        real = dt
        while real > 0:
            if self.cur is None:
                if not self.queue:
                    break
                self.cur, self.tau = self.queue.popleft(), 0.0
                if self.cur.starts:
                    self.started = max(self.started, self.cur.starts)
                    self.exec_at = self.move_at.pop(self.cur.starts, self.exec_at)
                    self._calculate()
            q = self.cur
            rate = tb if q.scaled else 1.0
            if rate <= 0:
                break
            need = (q.piece.dur - self.tau) / rate
            if real < need:
                self.tau += real * rate
                real = 0.0
            else:
                real -= need
                self.exec_pos = q.piece.end()[0]
                self.cur = None
                if self.prog == 0 and self.rot_flushed and not self.queue:
                    self.exec_pos = self.pos.copy()   # a dry rotary buffer: on the end exactly
        fw.motors.dwell[self.members] = self.cur is not None and not self.cur.scaled
        if self.cur is not None:
            c, tau = self.cur.piece.coef, self.tau
            pos = c[0] + tau * (c[1] + tau * (c[2] + tau * c[3]))  # Piece.at's position
        else:
            pos = self.exec_pos
        if self.wait == "home":
            return None
        if self.cur is None and not self.queue and self.stopping:
            self._finish()
            return None
        counts = self._counts(pos, self.cur, self.tau) + fw.motors.origin[self.members]
        if self.cur is not None and not len(self.inv_rows):
            self._glide_ahead(tb, dt)
        return counts

    def _glide_ahead(self, tb: float, dt: float) -> None:
        """The counts of the servo cycles still inside the executing piece at this time base,
        vectorised (`_Glide`); the cycle that leaves the piece takes the general path."""
        q = self.cur
        assert q is not None
        rate = tb if q.scaled else 1.0
        if rate <= 0:
            return
        step = rate * dt
        n = min(int((q.piece.dur - self.tau) / step), GLIDE_MAX)
        taus = self.tau + step * np.arange(1, n + 1)
        taus = taus[taus < q.piece.dur]
        if len(taus) < 2:
            return
        c = q.piece.coef
        t = taus[:, None]
        pos = c[0] + t * (c[1] + t * (c[2] + t * c[3]))
        mo = self.fw.motors
        counts = pos @ self.scale.T + (self.fw.coord.bias[self.members] + mo.origin[self.members])
        self._glide = _Glide(q, rate, taus, counts)

    def _finish(self) -> None:
        """Calculation ended and the motion drained: the motors hold the programmed end point
        (exactly, free of the pieces' rounding)."""
        self.exec_pos = self.pos.copy()
        self._stop_tracking(hold=True)

    # -- the calculator ----------------------------------------------------------------------------------
    def _calculate(self) -> None:
        """Statements until the look-ahead rule, a wait or the end stops the calculation."""
        if self._blocked == (self.started, self.prog, self.pc) and not self.wait \
                and not self.stopping and self.state != "quit" and (self.cur is not None or self.queue):
            return   # still held by the look-ahead rule at the same move: nothing to do (hot path)
        self._blocked = None
        if self.wait == "drain":
            if self.cur is not None or self.queue:
                return
            self.wait = ""
            self._read_position_after_wait()
        elif self.wait == "home":
            mo = self.fw.motors
            idx = np.array(self.homing, dtype=np.intp)
            if len(idx) and (mo.homing.searching[idx].any() or mo.core.profile.moving[idx].any()):
                return
            self.wait, self.homing = "", []
            self._read_position()
            self.exec_pos = self.pos.copy()
            self._restart_planner()
        if self.stopping or self.state == "quit":
            if self.planner is not None:
                if self.state == "quit":   # Q in PVT: no velocity step at the stop
                    stop_commands.pvt_quit(self)
                self._flush()
                self.planner = None
            self.stopping = True
            return
        store = self.fw.motion.store
        jumps = 0
        for _ in range(MAX_STEPS):
            program = self.rot if self.prog == 0 else store.runnable(self.prog)
            if program is None or program.ops is None:
                self._runtime_error()
                return
            ops = program.ops
            if self.pc >= len(ops):
                if self.stack:
                    self._return()
                    continue
                if self.prog == 0:   # the rotary buffer: its next line, or wait for one
                    if self._next_rotary_line():
                        continue
                    return
                self._end()
                return
            op = ops[self.pc]
            name = op[0]
            if name in _MOVES:
                busy = self.cur is not None or bool(self.queue)
                seg = self.segmenter
                if seg is not None and seg.lookahead:  # keep Isx20 segments buffered
                    if seg.full() and self.queue:  # (on as the last released piece runs)
                        return
                elif self.calc >= self.started + self._ahead() and busy:
                    self._blocked = (self.started, self.prog, self.pc)
                    return
                if self.state == "step" and self.calc > 0 and not self.block:
                    self._end()
                    return
                if name == "move":
                    self.move_from = (self.calc + 1, self.prog, self.pc, list(self.stack), ops,
                                      self.pos.copy())
                    self.move_recs[self.calc + 1] = self.move_from
                    if len(self.move_recs) > 8:
                        self.move_recs.pop(min(self.move_recs))
            self.pc += 1
            calc = self.calc
            try:
                go = self._statement(op, program)
            except (CommandError, ExprError, MDefError):
                self._runtime_error()
                return
            except PlanError as exc:   # the move is refused: the program stops before it
                if exc.bit == CIRCLE_RADIUS_ERROR:
                    self.radius_error = True
                    self._end()
                else:
                    self._runtime_error()
                return
            if self.calc != calc:  # a move: where it is, for PE
                self.move_at[self.calc] = (self.prog, self.pc - 1)
                if len(self.move_at) > 64:
                    self.move_at.pop(min(self.move_at))
            if self.wait or self.stopping:
                return
            if go == "back":
                jumps += 1
                if jumps >= 2:  # double-jump-back: no blending across it [UM]
                    self._flush()
                    self.wait = "drain"
                    return
            elif go == "move":
                jumps = 0
            elif go == "stop":
                return

    def _next_rotary_line(self) -> bool:
        """The next line the host sent to the rotary buffer, compiled on its own (rotary.py).
        None waiting: the program waits for lines (`_rotary_dry`)."""
        line = self.fw.rotary.take(self.cs)
        if line is None:
            if not self.rot_flushed:
                self._rotary_dry()
            return False
        self.rot_flushed = False
        try:
            ops, labels = compile_program([line])
        except CommandError:
            ops, labels = [], {}
            self._runtime_error()
        self.rot.ops, self.rot.labels, self.pc = ops, labels, 0
        return bool(ops)

    def _rotary_dry(self) -> None:
        """No line waits in the rotary buffer. The buffer is dry only when the card needs the
        next move [UM "Rotary Motion Program Buffers"; SRM I16, I17]: the LINEAR (or CIRCLE)
        move held for its blend runs on (`advance` of its planner, ROTARY_CHUNK at a time as
        the motion needs it, so the blend keeps the room Ixx17 may stretch it into) as far as a
        stop in its TA allows, the lookahead buffer (Isx20) filling from it; once the motion calculated would
        run out in this servo cycle, the last move is completed to a stop (the planner flushed)
        and the next line sent starts from rest. A line that comes before blends."""
        seg = self.segmenter
        hungry = seg is not None and seg.lookahead and not seg.full()
        if not hungry and not self._running_out():
            return
        planner = self.planner
        if isinstance(planner, (LinearPlanner, CirclePlanner)):
            for _ in range(MAX_STEPS):
                more = planner.advance(math.inf if hungry else ROTARY_CHUNK)
                if not more:
                    break
                self._enqueue(more, starts=0)
                if not self._running_out():
                    return
        if self._running_out():
            self._flush()
            self._restart_planner()
            self.rot_flushed = True

    def _running_out(self) -> bool:
        """The motion queued ends within this servo cycle (at the present time base)."""
        rate = self.fw.timebase.present(self.cs - 1) / 100 * self.hold
        step = rate * self.fw.period_ns / 1e9
        if step <= 0:
            return False   # held: nothing runs out
        left = self.cur.piece.dur - self.tau if self.cur is not None else 0.0
        for q in self.queue:
            if left > step:
                break
            left += q.piece.dur
        return left <= step

    def _read_position_after_wait(self) -> None:
        self.exec_pos = self.pos.copy()
        if self.planner is None:
            self._restart_planner()

    def _end(self) -> None:
        self._flush()
        self.planner = None
        self.stopping = True

    def _runtime_error(self) -> None:
        """A statement that cannot run (a missing label or program, a bad value): the program
        stops where it is with the run-time error bit [SRM "??" word 2 bit 22]."""
        self.error = True
        self._end()

    def _return(self) -> None:
        frame = self.stack.pop()
        self.prog, self.pc, self.args = frame.prog, frame.pc, frame.args

    def _statement(self, op: tuple[Any, ...], program: Program) -> str:
        """Run one operation; "move" for a move-kind, "back" for a backward jump, "stop" to end
        this calculation, "" otherwise."""
        fw, env = self.fw, self.fw.env(self.port)
        name = op[0]
        if name == "set":
            try:
                index = int(op[2].eval(env))
                if 0 <= index < 8192:
                    fw.set_variable(self.port, op[1], index, op[3].eval(env))
            except (CommandError, ExprError, MDefError):
                pass  # a value the variable refuses: no effect, as in PLCs (README)
        elif name in ("if", "while"):
            if not _true(op[1], env):
                self.pc = op[2]
        elif name == "jump":
            self.pc = op[1]
        elif name == "endwhile":
            self.pc = op[1]
            return "back"
        elif name == "move":
            self._move(op, env)
            return "move"
        elif name == "mode":
            going_on = op[1] in PLANNERS and mode_blend.carry_on(self, op[1])  # LINEAR <-> CIRCLE
            if not going_on:
                self._flush()
            self.mode = op[1]
            self.mode_arg = float(op[2].eval(env)) if op[2] is not None else 0.0
            if self.mode not in PLANNERS:
                raise CommandError(ERR_DATA, f"{self.mode} is not emulated")
            if not going_on:
                self._restart_planner()
        elif name == "absinc":
            mask = np.ones(NAXES, dtype=bool) if op[2] is None else np.isin(np.arange(NAXES), op[2])
            self.inc[mask] = op[1]
        elif name == "param":
            value = float(op[2].eval(env))
            if op[1] == "TA":
                self.ta = min(max(value, 0.0), MAX_TIME_MS)
            elif op[1] == "TS":
                self.ts = min(max(value, 0.0), MAX_TIME_MS)
            elif op[1] == "TM":
                self.tm, self.tm_mode = min(max(value, 0.0), MAX_TIME_MS), True
            else:
                self.f, self.tm_mode = abs(value), False
        elif name == "normal":
            vec = dict((v, float(e.eval(env))) for v, e in op[1])
            self.normal = np.array([vec.get(c, 0.0) for c in "IJK"])
        elif name == "radius":
            self.radius_inc = bool(op[1])
        elif name == "frax":
            self.frax = np.isin(np.arange(NAXES), op[1])
        elif name in ("dwell", "delay"):
            ms = min(max(float(op[1].eval(env)), 0.0), MAX_TIME_MS)
            self._flush()
            self.calc += 1
            self._enqueue([Piece.hold(self.pos, ms / 1000)], self.calc, scaled=name == "delay")
            if name == "dwell":  # no calculation through a DWELL [SRM DWELL]
                self.wait = "drain"
                return "stop"
            return "move"
        elif name == "home":
            self._flush()
            self.wait = "drain"
            self.pc -= 1  # start the search once the motion before has drained
            if self.cur is None and not self.queue:
                self.pc += 1
                self._home(op[1], op[2])
            return "stop"
        elif name == "label":
            pass
        elif name == "goto":
            target = self._label(program, float(op[1].eval(env)))
            back = target < self.pc
            self.pc = target
            return "back" if back else ""
        elif name in ("gosub", "call"):
            self._call(op, program, env)
        elif name == "return":
            if not self.stack:
                self._end()
                return "stop"
            self._return()
        elif name == "read":
            self._read(op[1])
        elif name == "stop":
            self._end()
            return "stop"
        elif name == "wait":  # the calculation pauses until the next servo cycle [SRM WAIT]
            self._flush()
            self.wait = "drain"
            return "stop"
        elif name in ("pset", "pmatch"):
            self._flush()
            if self.cur is not None or self.queue:  # once the motion before has drained
                self.pc -= 1
                self.wait = "drain"
                return "stop"
            if name == "pset":
                self._pset(op[1], env)
            else:
                self._pmatch()
        elif name == "cmd":
            plc = fw.plc
            if len(plc.queue) >= CMD_QUEUE:
                self.pc -= 1
                return "stop"
            plc.queue.append((PortState(), op[1]))  # &1 #1 unless it says [SRM CMD]
        elif name in ("enable", "disable"):
            fw.plc.enable(op[1], name == "enable")
        elif name in ("pause", "resume"):
            fw.plc.pause(op[1], name == "resume")
        elif name == "send":  # as a PLC's SEND (plc.py); a full queue holds the calculation
            if len(fw.plc.messages) >= MESSAGE_QUEUE:
                self.pc -= 1
                return "stop"
            fw.plc.messages.append((op[1], op[2]))
        elif name == "block":  # a step ends before a BLOCKSTART: the next S runs the block
            if op[1] and self.state == "step" and self.calc > 0 and not self.block:
                self.pc -= 1
                self._end()
                return "stop"
            self.block = bool(op[1])
        elif name == "trigmove":
            self._flush()
            if self.cur is not None or self.queue:  # once the motion before has drained
                self.pc -= 1
                self.wait = "drain"
                return "stop"
            self.calc += 1
            self.started = self.calc
            self.exec_at = (self.prog, self.pc - 1)
            start_trigger_move(self, op[1], env)
            return "stop"
        return ""

    def _pset(self, axes: tuple[tuple[int, Any], ...], env: Any) -> None:
        """PSET: the axes' present positions become the values, through the motors' position
        bias; nothing moves [SRM PSET; A L932]."""
        fw = self.fw
        for k, e in axes:
            value = float(e.eval(env))
            fw.coord.set_axis(self.cs, AXES[k], value, fw.reports.commanded())
            self.pos[k] = value
        self.exec_pos = self.pos.copy()
        self._restart_planner()

    def pmatch_online(self) -> None:
        """On-line PMATCH (online.py): as at R, without running; ERR001 while running."""
        if self.running:
            raise CommandError(ERR_RUNNING, "a program is running")
        self._map_motors()
        self._read_position()
        self._forward()

    def _pmatch(self) -> None:
        """PMATCH: the axis positions computed again from the motors' commanded positions, as
        at R (through the forward kinematic program with Isx50 = 1) [SRM PMATCH; UM
        "Kinematic Calculations"]."""
        self._read_position()
        try:
            self._forward()
        except CommandError:
            self._runtime_error()
            return
        self.exec_pos = self.pos.copy()
        self._restart_planner()

    def _label(self, program: Program, n: float) -> int:
        label = int(n)
        if label not in program.labels:
            raise CommandError(ERR_DATA, f"no label N{label}")
        return program.labels[label]

    def _call(self, op: tuple[Any, ...], program: Program, env: Any) -> None:
        if len(self.stack) >= MAX_STACK:
            raise CommandError(ERR_DATA, "GOSUB/CALL nesting")
        value = float(op[1].eval(env))
        args = {letter: float(e.eval(env)) for letter, e in op[2]}
        frame = _Frame(self.prog, self.pc, self.args)
        if op[0] == "gosub":
            target = self._label(program, value)
            self.stack.append(frame)
            self.pc, self.args = target, args
            return
        prog = int(value)
        called = self.fw.motion.store.runnable(prog)
        if called is None or called.ops is None:
            raise CommandError(ERR_DATA, f"no PROG {prog}")
        label = round((value - prog) * 100000)
        pc = 0
        if label:
            pc = self._label(called, label)
        self.stack.append(frame)
        self.prog, self.pc, self.args = prog, pc, args

    def _read(self, letters: str) -> None:
        """READ(letters): each argument the calling line gave goes into Q(100 + n), n the
        letter's place in the alphabet (A = 1), and Q100 gets bit n − 1 for each found [SRM
        READ; UM G04: P -> Q116, X -> Q124]."""
        mask = 0
        q = self.fw.q[self.cs - 1]
        for letter in letters:
            if letter in self.args:
                n = ord(letter) - 64
                q[100 + n] = self.args[letter]
                mask |= 1 << (n - 1)
        q[100] = float(mask)

    def _move(self, op: tuple[Any, ...], env: Any) -> None:
        target = self.pos.copy()
        named = np.zeros(NAXES, dtype=bool)
        vel = np.zeros(NAXES)
        for k, e, v in op[1]:
            value = float(e.eval(env))
            target[k] = target[k] + value if self.inc[k] else value
            named[k] = True
            if v is not None:
                vel[k] = float(v.eval(env))
        ixx27 = self.fw.ivars.values[100 * (self.members + 1) + 27]
        if ixx27.any():  # rotary-axis rollover of ABS moves (rollover.py) [SRM Ixx27]
            target = rollover.destination(self.pos, target, named & ~self.inc,
                                          rollover.revolutions(ixx27, self.scale))
        prm = self._params()
        per = prm["FEED_PERIOD"]
        prm["V"] = vel / per
        vectors = {letter: float(e.eval(env)) for letter, e in op[2]}
        if any(letter in vectors for letter in "IJK"):
            prm["IJK"] = np.array([vectors.get(c, 0.0) for c in "IJK"])
        if "R" in vectors:
            prm["R"] = vectors["R"]
        if self.mode == "LINEAR" and isinstance(self.planner, CirclePlanner):
            prm["LINE"] = True   # a LINEAR move in a CIRCLE sequence (mode_blend.py)
        move = Move(target, named, prm)
        if self.planner is None:
            self._restart_planner()
        planner = self.planner
        if planner is None:
            raise CommandError(ERR_DATA, f"{self.mode} is not emulated")
        self.calc += 1
        before = copy.deepcopy(planner) if isinstance(planner, CirclePlanner | SplinePlanner) \
            else None
        pieces = planner.add(move)
        begin = int(getattr(planner, "begin", 0))
        if isinstance(planner, CirclePlanner) and isinstance(before, CirclePlanner):   # for `/`
            self.circle_before[self.calc] = (before, planner.t_begin)
            if len(self.circle_before) > 4:
                self.circle_before.pop(min(self.circle_before))
        if isinstance(planner, SplinePlanner):
            if isinstance(before, SplinePlanner):   # for `/`: the planner before a move began
                for _, lag in planner.labels:
                    self.spline_before[self.calc - lag] = (before, self.calc - 1)
                if len(self.spline_before) > 4:
                    self.spline_before.pop(min(self.spline_before))
            self._enqueue_labelled(pieces, planner.labels)
        else:
            self._enqueue(pieces, self.calc, begin=begin)
        self.move_blend = (self.calc, len(pieces) - begin)
        self.blend_at[self.calc] = len(pieces) - begin
        if len(self.blend_at) > 8:
            self.blend_at.pop(min(self.blend_at))
        if not pieces:  # nothing to execute for it: it counts as begun
            self.started = max(self.started, self.calc) if not self.queue and self.cur is None \
                else self.started
        self.pos = target
        if self.mode == "RAPID":  # not blended: no calculation until every motor is done [UM]
            self.wait = "drain"

    def _home(self, zero: bool, motors: tuple[int, ...]) -> None:
        """HOME/HOMEZ n,...: the motors' home searches from the program; calculation waits
        until they finish [UM "When No Calculation Ahead"]."""
        fw = self.fw
        idx = [n - 1 for n in motors if n <= fw.ivars.motors and fw.ivars.values[100 * n]]
        self._hold_motors(np.array(idx, dtype=np.intp))
        for m in idx:
            if zero:
                fw.motors.home_zero(m)
            else:
                fw.motors.home(m)
            fw.coord.rebias(m + 1)
        others = np.setdiff1d(self.members, np.array(idx, dtype=np.intp))
        self._hold_motors(others)
        self.homing = idx
        self.wait = "home"
        self.planner = None


class Motion:
    """The card's motion programs: the PROG buffers and one runner per coordinate system."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.store = ProgramStore(fw)
        self.running: set[int] = set()  # the C.S. whose program runs (CsProgram.state)
        self.cs = [CsProgram(fw, s) for s in range(1, CS_COUNT + 1)]
        fw.rotary.running = lambda cs: self.cs[cs - 1].running and self.cs[cs - 1].prog == 0
        self._dt = fw.period_ns / 1e9

    def runner(self, cs: int) -> CsProgram:
        return self.cs[cs - 1]

    @property
    def active(self) -> bool:
        """A program running in any C.S.: the card is not at rest (decision 0008)."""
        return bool(self.running)

    def any_running(self) -> bool:
        return bool(self.running)

    def motor_in_running_cs(self, motor: int) -> bool:
        return bool(self.running) and int(self.fw.coord.cs[motor - 1]) in self.running

    def tick(self) -> None:
        """Each running C.S. one servo cycle; their motors tracked in one call."""
        idx: list[np.ndarray] = []
        counts: list[np.ndarray] = []
        for cs in sorted(self.running):
            r = self.cs[cs - 1]
            out = r.tick(self._dt)
            if out is not None and len(r.members):
                idx.append(r.members)
                counts.append(out)
        if len(idx) == 1:
            self.fw.motors.core.track(idx[0], counts[0])
        elif idx:
            self.fw.motors.core.track(np.concatenate(idx), np.concatenate(counts))

    def abort_motors(self, cs: int) -> None:
        """The C.S.'s closed-loop motors stop at Ixx15."""
        fw = self.fw
        for motor in fw.coord.members(cs):
            if motor <= fw.ivars.motors and fw.motors.core.servo_on_mask[motor - 1]:
                fw.motors.abort(motor - 1)

    def abort_all(self) -> None:
        for r in self.cs:
            r.abort()

    def hold_all(self) -> None:
        """^O: feed hold of every C.S. [SRM <CONTROL-O>]."""
        for r in self.cs:
            r.feed_hold()

    def status(self, cs: int) -> tuple[int, int, bool]:
        """(word 1 bits, word 2 bits, running) of C.S. cs's program state."""
        r = self.cs[cs - 1]
        w1 = 0
        for k in range(NAXES):
            if r.inc[k]:
                w1 |= 1 << (6 + 2 * k)
            if r.frax[k]:
                w1 |= 1 << (7 + 2 * k)
        if r.tm_mode:
            w1 |= W1_TM_MODE
        if r.radius_inc:
            w1 |= W1_RADIUS_INC
        w2 = _MODE_BITS.get(r.mode, 0) | (W2_RUNTIME_ERROR if r.error else 0) \
            | (W2_RADIUS_ERROR if r.radius_error else 0) \
            | (W2_ROTARY_FULL if self.fw.rotary.full(cs) else 0)
        if r.running and r.segmenter is not None and r.segmenter.lookahead:
            w2 |= W2_LOOKAHEAD
        if r.running:
            w1 |= W1_RUNNING
            if r.state == "step":
                w1 |= W1_SINGLE_STEP
            elif r.state == "run" and r.hold_target > 0:
                w1 |= W1_RUN_REQUEST
            if r.mode == "LINEAR" and (r.cur is not None or r.queue):
                w1 |= W1_CONTINUOUS
            if r.cur is not None and not r.cur.scaled:
                w2 |= W2_DWELL
        return w1, w2, r.running

    def power_on(self) -> None:
        self.store.power_on()
        for r in self.cs:
            r._stop_tracking(hold=False)
            r.error = False
            r.prog, r.pc, r.stack = 0, 0, []
            r.pos[:] = 0.0
            r.reset_modes()

