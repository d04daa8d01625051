"""The MAXk firmware: the command interpreter, the axis queues and the status the host sees.

The card (card.py) feeds it the bytes of the command ring and runs `cycle()` every update
period; the firmware answers through `replies` (posted one at a time by the card, spec oms.md
§2.5) and raises doorbell bits through `ring(bits)`. The command table (commands.py) names the
handlers, functions of the `cmd_*` modules; it is bound to them once, here.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import numpy as np
from vdevmaps.oms import AXES, AxisFlags, MaxkDoorbell

from vdevd.devices.oms import cmd_io, cmd_motion, cmd_servo, cmd_system, cmd_vector
from vdevd.devices.oms.capture import Capture
from vdevd.devices.oms.commands import COMMANDS, OPERANDS
from vdevd.devices.oms.contour import Contour, ContourState
from vdevd.devices.oms.defaults import image as defaults_image
from vdevd.devices.oms.defaults import load_io
from vdevd.devices.oms.faults import FAULT_EVENTS, react_to_faults
from vdevd.devices.oms.layout import limit_word as pack_limit_word
from vdevd.devices.oms.motion import HARD_STOP, OmsMotion
from vdevd.devices.oms.params import UNIT_OPERANDS, Params
from vdevd.devices.oms.queue import AxisQueue, Group, Item, Run
from vdevd.devices.oms.ssi import Ssi
from vdevd.devices.oms.syntax import Command, CommandError, Lexer, beyond_axes, numbers

#: mnemonic -> handler(firmware, command) -> reply text or None
_HANDLERS = COMMANDS.bind(cmd_system, cmd_motion, cmd_servo, cmd_io, cmd_vector)


class Firmware:
    """One card's firmware state; `ring(bits)` rings the outbound doorbell."""

    def __init__(self, n: int, types: list[str], period_ns: float, *, update_hz: int, ideal: bool,
                 ring: Callable[[int], None], version: str, serial: int,
                 save: Callable[[dict[str, Any]], None], saved: dict[str, Any] | None,
                 profiles: list[str] | None = None, servo_outputs: list[str] | None = None,
                 travel_limits: list[tuple[float, float] | None] | None = None,
                 retime: Callable[[Fraction], None] | None = None) -> None:
        """`period_ns`: the update period the card starts at; `retime(period)`: the card's
        clock takes a new update period (`#UR`), exact in ns, from its next cycle."""
        self.n = n
        self.retime = retime
        #: per axis: the velocity profile of moves from rest (card option `profiles`, spec §5.2)
        self.profiles = ["linear"] * n if profiles is None else list(profiles)
        #: per axis: bipolar or unipolar servo output (card option `servo_output`, spec §5.3)
        self.servo_outputs = ["bipolar"] * n if servo_outputs is None else list(servo_outputs)
        #: per axis: software travel limits (low, high) or None (card option `travel_limits`)
        self.travel_limits = [None] * n if travel_limits is None else list(travel_limits)
        self.period_ns = period_ns
        self.ideal = ideal
        self.ring_doorbell = ring
        self.version = version
        self.serial = serial
        self.factory_types = list(types)
        self.params = Params(n, types)
        self.lexer = Lexer(OPERANDS)
        self.replies: deque[bytes] = deque()
        self.last_error = ""
        self.errors = 0
        self.factory_hz = update_hz  # the card's update rate, what RDF makes #UR report
        self.update_hz = update_hz  # what #UR reports
        self.gpio_dir = 0  # 1 = output (load_io: factory IO0-7 in, IO8-15 out [spec §8.18])
        self.gpio_out = 0
        self.gpio_in = 0xFFFF  # input levels (open inputs pulled high)
        self.analog_channels = 4 if n > 5 else 2  # [S Table 6-2]
        self.analog_in = np.zeros(4)
        self.now_ns = 0
        self.save = save
        #: run after each cycle's motion (card.py: the axis world's switches and probes)
        self.sense: Callable[[], None] | None = None
        #: run when PS changes an axis's type (card.py: faults that act on some types only)
        self.on_type_change: Callable[[], None] | None = None
        self.saved = saved  # the power-up defaults APP stored, if any
        self.loaded = "factory"  # which parameter set is in working memory [S Table 3-4]
        if saved is not None:
            self.params.restore(saved)
            self.loaded = "power_up"
        self.power_on()
        self.configure_axes()
        load_io(self, saved)

    def power_on(self) -> None:
        """Positions 0, queues empty, the working parameters as they are."""
        n = self.n
        self.motion = OmsMotion(self.params, self.period_ns, self.ideal, self.profiles)
        self.motion.servo.set_output_modes(self.servo_outputs)
        self.motion.set_travel_limits(self.travel_limits)
        self.queues = [AxisQueue() for _ in range(n)]
        self._queued = [q.items for q in self.queues]  # the cycle looks whether any holds one
        self.mode = "single"  # "single" | "AA" | "AM"
        self.axis = 0
        self.done = np.zeros(n, dtype=bool)  # the D of QA/RA [spec §3.4]
        self.slip = np.zeros(n, dtype=bool)
        self.pending = np.full(n, math.nan)  # MA/MR targets waiting for GO
        self.step_direction = np.ones(n)  # MP (+1) / MM (-1): the direction MO steps in
        # VL and VB as the queued commands will leave them (nan: the working value)
        self.queued = {"VL": np.full(n, math.nan), "VB": np.full(n, math.nan)}
        self.aa_members: frozenset[int] = frozenset(range(n))
        self.wk_flags = [0, 0]  # the W and K status words (0x0CC, 0x0D0)
        self.armed: set[int] = set()  # axes given MA/MR since the last GO (AA/AM)
        self.enc_offset = np.zeros(n)  # LO/LPE on axes whose loop does not use the encoder
        self.reset_requested = False
        self.contours: dict[int, Contour] = {}  # vector tasks being defined
        self.defined_contours: dict[int, Contour] = {}  # each task's last VE, until it ends
        self.waiting_contours: dict[int, Contour] = {}  # at their start, waiting for VG
        self.running_contours: dict[int, Contour] = {}
        self.live_contours: list[Contour] = []  # every contour after its VE, until it ends
        self.vector_velocity: dict[int, float] = {}
        self.vector_end_velocity: dict[int, float | None] = {}  # VV v,vend (None: run on)
        self.vector_acceleration: dict[int, float] = {}
        self.override: dict[int, float] = {}  # VO per task, 1.0 = 100 %
        self.override_analog: dict[int, tuple[int, float]] = {}  # VOA: (input, volts at 100 %)
        self.vector_held: set[int] = set()  # VH1: halted until VG
        self.vector_gated: set[int] = set()  # VH0: the next contour waits for VG
        self.vector_released: set[int] = set()  # VG before that contour reached its start
        self.aux = np.zeros(n, dtype=bool)  # AN/AF auxiliary outputs [S §4.6]
        self.capture = Capture(n)  # real-time position capture [S §3.7]
        self.ssi = Ssi(n)  # absolute encoders (ECA) [S §4.9]
        self.lexer.reset()
        self.replies.clear()

    # -- input --------------------------------------------------------------------------------------
    def feed(self, data: bytes) -> None:
        """Bytes from the command ring: run every complete command."""
        for cmd in self.lexer.feed(data):
            self.execute(cmd)

    def execute(self, cmd: Command) -> None:
        try:
            if cmd.error:
                raise CommandError(cmd.error)
            reply = _HANDLERS[cmd.mnemonic](self, cmd)
        except CommandError as exc:
            self.command_error(f"{cmd.mnemonic}{cmd.operand}: {exc}")
            return
        if reply is not None:
            self.replies.append(reply.encode("latin-1") + b"\n")

    def command_error(self, why: str) -> None:
        self.last_error = why
        self.errors += 1
        self.ring_doorbell(_COMMAND_ERROR)

    # -- the update cycle ---------------------------------------------------------------------------
    def cycle(self) -> None:
        """One update period: queues, then the motion core, then the events it reported."""
        if any(self._queued):  # most cycles no queue holds a command
            for a, q in enumerate(self.queues):
                if q.items:
                    q.advance(a)
        if self.running_contours:
            self.advance_contours()
        self.after_motion(self.motion.tick())

    def after_motion(self, events: int) -> None:
        """The rest of a cycle after its motion, which reported `events`: the world sensed, the
        events, position capture."""
        if self.sense is not None:
            self.sense()
        if events:
            self.motion.core.update_in_position()
            self.on_motion_events(events)
        if self.capture.armed:
            self.capture.cycle(self)

    def motion_only(self) -> bool:
        """Whether a cycle whose motion reports no event is the motion core's tick alone: no
        queued command, no running contour, no sensing, no armed capture, nothing after the
        core's tick (OmsMotion.core_only); kept in step with `cycle` and `after_motion`."""
        return (not any(self._queued) and not self.running_contours and self.sense is None
                and not self.capture.armed and self.motion.core_only())

    def on_motion_events(self, events: int) -> None:
        """Over-travel: a limit stopped or refused a motion [spec §3.4, §5.6]."""
        for a in self.motion.new_limit_stops().tolist():
            self.flush(a)
            self.flag(a, AxisFlags.OVERTRAVEL)
        if events & FAULT_EVENTS:
            react_to_faults(self, events)

    # -- events to the host -------------------------------------------------------------------------
    def flag(self, a: int, event: int) -> None:
        """A done, over-travel or slip event (`AxisFlags`) of axis a: ODBR bit `event` << a for
        X..S [S §3.4.1-3.4.3]; for W and K the W/K status word bit `event` and ODBR bit 25/26
        [S §3.4.5]."""
        if a < 8:
            self.ring_doorbell(int(event) << a)
        else:
            self.wk_flags[a - 8] |= int(event)
            self.ring_doorbell(_WK_NOTIFICATION[a - 8])

    # -- helpers for handlers -----------------------------------------------------------------------
    def selected(self) -> list[int]:
        """The axes a command without operands addresses: the axis, or all in AA/AM."""
        return [self.axis] if self.mode == "single" else list(range(self.n))

    def per_axis(self, cmd: Command, *, integer: bool = False) -> list[tuple[int, float]]:
        """(axis, value) pairs of a numeric operand: one value in single-axis mode, one per axis
        in canonical order in AA/AM, empty fields skipped [S App C]."""
        try:
            values = numbers(cmd.operand) if cmd.operand else []
        except ValueError:
            raise CommandError("malformed number") from None
        if self.mode == "single":
            if len(values) > 1 or (values and values[0] is None):
                raise CommandError("one value in single-axis mode")
            pairs = [(self.axis, values[0])] if values else []
        else:
            if beyond_axes(values, self.n):
                raise CommandError("more values than axes")
            pairs = [(a, v) for a, v in enumerate(values) if v is not None]
        kind = UNIT_OPERANDS.get(cmd.mnemonic)  # user units, encoder ratio [spec §4.1, §4.3]
        out = []
        for a, v in pairs:
            assert v is not None
            scale = 1.0 if kind is None else self.params.scale(a, kind)
            if scale != 1.0:
                v = float(round(v * scale))
            out.append((a, float(math.trunc(v)) if integer else v))
        return out

    def report(self, values: np.ndarray, axes: list[int], kind: str = "motor") -> str:
        """RP/RE/RV/PP/PE: the values of `axes`, comma separated, in counts, or in user units
        (fixed point) when UU is on [spec §4.1, §4.2]."""
        fmt, listed = self.params.format, values.tolist()
        return ",".join([fmt(a, float(listed[a]), kind) for a in axes])

    def enqueue(self, axes: list[int], label: str, make: Callable[[], Run],
                units: int = 1, group: Group | None = None, kind: str = "",
                count: int = 0) -> None:
        """Queue a command on each of `axes` (`make()` builds its runner when it reaches the
        head); all-or-nothing: a queue without room makes it a command error."""
        if any(self.queues[a].free < units for a in axes):
            raise CommandError("command queue full")
        for a in axes:
            self.queues[a].push(Item(label, make, units, group, kind, count))

    def flush(self, a: int, ramp: bool = False) -> None:
        """Empty axis a's queue. A contour on the axis ends: at once where the path took it
        (KS, FL, a hard limit), or, with `ramp` (ST, SA, SI, a soft limit), a running one after
        slowing to rest on its path at its VA, the axis's queue waiting for that (README)."""
        q = self.queues[a]
        q.flush()
        if ramp:
            for task, c in self.running_contours.items():
                if a in c.axes:  # ramps down; its task's VH0 and early VG go now
                    c.stopping = True
                    q.push(Item("VE", _until_ended(c)))
                    self.vector_gated.discard(task)
                    self.vector_released.discard(task)
        self.drop_contours(a, keep_stopping=ramp)
        self.pending[a] = math.nan
        for name in self.queued:
            self.queued[name][a] = math.nan

    def queued_speed(self, a: int) -> tuple[float, float]:
        """(VL, VB) of axis a once the commands in its queue have run: the last queued value,
        else the working one (VB must stay below VL, spec §4.4)."""
        v = self.params.values
        vl, vb = float(self.queued["VL"][a]), float(self.queued["VB"][a])
        if self.queues[a].idle or math.isnan(vl):
            vl = float(v["VL"][a])
        if self.queues[a].idle or math.isnan(vb):
            vb = float(v["VB"][a])
        return vl, vb

    # -- coordinated motion ---------------------------------------------------------------------------
    def motion_together(self, targets: dict[int, float]) -> None:
        """MT: straight-line move, every axis's VL and AC scaled by its share of the distance
        so that all arrive together; the slowest axis's own VL and AC set the pace."""
        m, v = self.motion, self.params.values
        here = {a: float(m.core.axes.cmd_pos[a]) for a in targets}
        dist = {a: abs(targets[a] - here[a]) for a in targets}
        total = max(dist.values())
        if total == 0:
            return
        # the time each axis would need on its own; the longest sets the common profile
        def alone(a: int) -> float:
            d, vl, ac = dist[a], float(v["VL"][a]), float(v["AC"][a])
            return d / vl + vl / ac if d > vl * vl / ac else 2 * math.sqrt(d / ac)

        lead = max((a for a in targets if dist[a] > 0), key=alone)
        vl, ac = float(v["VL"][lead]), float(v["AC"][lead])
        for a, target in targets.items():
            share = dist[a] / dist[lead]
            if share == 0:
                continue
            m.limit_seen[a] = False
            m.direction[a] = 1.0 if target > here[a] else -1.0
            m.core.move_absolute(a, target, vl * share, ac * share, ac * share)

    def start_contour(self, task: int, contour: Contour) -> None:
        """Its VE has reached the head of every axis queue (after any SW): it runs from this
        update cycle on, unless VH[n]0 made it wait for VG[n] and none came yet [E-traj L1300,
        L579-585]; the VG that starts it consumes the VH0. A task runs one contour at a time:
        while the one before still runs or waits, this one is READY and starts when that one
        ends (README). It runs from where its axes are now, not where they were at its
        definition. One that a flush ended never starts."""
        if contour.state in (ContourState.RUNNING, ContourState.ENDED):
            return
        busy = self.running_contours.get(task) or self.waiting_contours.get(task)
        if busy is not None and busy is not contour:
            contour.state = ContourState.READY
            return
        self.defined_contours.setdefault(task, contour)  # a repeat of LS/LE re-registers it
        if task in self.vector_gated and task not in self.vector_released:
            contour.state = ContourState.WAITING
            self.waiting_contours[task] = contour
            return
        self.vector_gated.discard(task)
        self.vector_released.discard(task)
        here = self.motion.core.axes.cmd_pos
        contour.rebase(tuple(float(here[a]) if a in contour.axes else p
                             for a, p in enumerate(contour.start)))
        contour.begin()
        self.running_contours[task] = contour
        self.motion.path_begins(contour.axes, contour.start, contour.here)

    def advance_contours(self) -> None:
        """One update cycle of each running contour: the path coordinate at the override-
        stretched time, the axes held there, VIO outputs at segment starts. At its end the axes
        hold the nearest whole counts (an arc ends between counts; see hold_whole_counts) and,
        after VID, their done flags are set."""
        dt = self.period_ns / 1e9
        profile = self.motion.core.profile
        limits = self.motion.core.limits
        here, direction = self.motion.core.axes.cmd_pos, self.motion.direction
        servo_on = self.motion.core.servo_on_mask
        switch_on = self.motion.travel_limited or bool(limits.hard_pos.any()
                                                       or limits.hard_neg.any())
        for task, c in list(self.running_contours.items()):
            s = c.s_at(c.t)
            pos, seg = c.position(s)
            if switch_on and self._into_limit(c, pos) and c.state is ContourState.ENDED:
                continue  # a hard limit ended it where it was
            ended = c.t >= c.duration
            if ended:  # segments of no length at the end begin there too
                seg = len(c.segments) - 1
            for io in c.segments[c.entered + 1:seg + 1]:  # VIO once, as a segment begins
                self.gpio_out = (self.gpio_out | io.io_on) & ~io.io_off
            c.entered = max(c.entered, seg)
            stopped = c.stopping and c.rate == 0
            if ended or stopped:
                rest = [round(pos[a]) for a in c.axes]
                for a, p in zip(c.axes, rest, strict=True):
                    profile.hold(a, float(p))
                self.end_contour(task, c, None if c.stopping else rest)
                if c.notify and ended and not c.stopping:
                    for a in c.axes:
                        self.set_done(a)
            else:
                for a in c.axes:  # the commanded velocity is the path's (RV, KV)
                    step = pos[a] - here[a]
                    if step > _NOISE or step < -_NOISE:  # QA's direction: its last motion
                        direction[a] = 1.0 if step > 0 else -1.0
                    if servo_on[a]:
                        profile.reach(a, pos[a])
                    else:  # loop open (CL0): the command follows the axis, not the path
                        profile.hold(a, pos[a])
                held = c.stopping or task in self.vector_held
                c.t += dt * c.pace(self.vector_override(task), held, dt)
        profile.commit()

    def _into_limit(self, c: Contour, pos: tuple[float, ...]) -> bool:
        """Over-travel of a contour [spec §5.6]: an axis whose path this cycle heads into its
        active limit switch, or past its software travel limit, flags over-travel (once per
        contour) and flushes its queue; a hard-mode switch or a travel limit ends the contour
        where it is (inside the limit), a soft-mode switch ramps it down on its path (as ST).
        True if it hit."""
        m = self.motion
        limits, here = m.core.limits, m.core.axes.cmd_pos
        up = [a for a in c.axes if pos[a] > here[a] + _NOISE]
        down = [a for a in c.axes if pos[a] < here[a] - _NOISE]
        hits = [a for a in up if limits.hard_pos[a]] + [a for a in down if limits.hard_neg[a]]
        past = ([a for a in up if pos[a] > limits.soft_hi[a] + _NOISE]
                + [a for a in down if pos[a] < limits.soft_lo[a] - _NOISE])
        hard = past + [a for a in hits if limits.limit_dec[a] >= HARD_STOP and a not in past]
        new = [a for a in dict.fromkeys(past + hits) if a not in c.over_travel]
        if not hard and not new:
            return False  # ramping down through a switch it already flagged
        for a in new:
            c.over_travel.add(a)
            m.direction[a] = 1.0 if pos[a] > here[a] else -1.0
            if a in past:
                m.travel_stop(a, pos[a] > here[a])
            self.flag(a, AxisFlags.OVERTRAVEL)
            self.flush(a, ramp=a not in hard)
        if hard and c.state is not ContourState.ENDED:
            self.drop_contours(hard[0])
        return True

    def end_contour(self, task: int, c: Contour, rest: list[int] | None = None) -> None:
        """The task's contour is over: its halt ends with it, and the task's next contour that
        is READY starts. One that ran to its end leaves its axes' targets at `rest`."""
        active = self.running_contours.get(task) is c or self.waiting_contours.get(task) is c
        if c.state is ContourState.RUNNING:
            self.motion.path_ends(c.axes, rest)
        c.state = ContourState.ENDED
        for where in (self.running_contours, self.waiting_contours, self.defined_contours):
            if where.get(task) is c:
                del where[task]
        if c in self.live_contours:
            self.live_contours.remove(c)
        if active:
            self.vector_held.discard(task)
            following = next((d for d in self.live_contours
                              if d.task == task and d.state is ContourState.READY), None)
            if following is not None:
                self.start_contour(task, following)

    def drop_contours(self, a: int, keep_stopping: bool = False) -> None:
        """A flush of axis a (KS, SI, ST, FL, a limit) ends the contours on it, queued,
        waiting or running, without done flags; the axes stay where the path took them [E-traj
        L812-824: VH[n]1, then KS to "kill selected axes and flush queues"], on the nearest
        whole counts, and the task's VH0, halt and early VG go with the task's running or
        waiting one (then its next READY one starts as if VG had come). `keep_stopping`
        spares those ramping down (ST)."""
        on_a = [c for c in self.live_contours
                if a in c.axes and not (keep_stopping and c.stopping)]
        profile, here = self.motion.core.profile, self.motion.core.axes.cmd_pos
        for c in on_a:
            task = c.task
            active = self.running_contours.get(task) or self.waiting_contours.get(task)
            if active is None or active is c:  # a READY one leaves the task's holds alone
                for hold in (self.vector_gated, self.vector_released, self.vector_held):
                    hold.discard(task)
            if c.state is ContourState.RUNNING:  # it rests on the whole counts it is at
                for b in c.axes:
                    profile.hold(b, float(round(here[b])))
            self.end_contour(task, c)
        if on_a:
            profile.commit()

    def vector_override(self, task: int) -> float:
        """The task's override now (1.0 = 100 %): from its VOA input, 100 % at the full-scale
        volts, clamped to 0-200 % [S §4.5.1, App C], else VO's."""
        analog = self.override_analog.get(task)
        if analog is None:
            return self.override.get(task, 1.0)
        ch, full = analog
        return min(2.0, max(0.0, float(self.analog_in[ch]) / full))

    def identity(self) -> str:
        """The WY string: model (MAXk-n000, A for 10 axes), version, serial, FPGA [S §2.6]."""
        model = "A" if self.n == 10 else str(self.n)
        return f"MAXk-{model}000, Ver: {self.version}, S/N: {self.serial:06d}, FPGA:20"

    def set_done(self, a: int) -> None:
        """ID reached: the axis's done flag and its doorbell bit."""
        self.done[a] = True
        self.flag(a, AxisFlags.DONE)

    def kill(self, axes: list[int]) -> None:
        """Stop at once, without deceleration, and flush the queues [spec §2.6]."""
        for a in axes:
            self.flush(a)
            self.motion.kill(a)

    def load_position(self, a: int, value: float, which: str) -> None:
        """LP (motor and encoder), LO (motor only), LPE (encoder only). A servo axis closes its
        loop on the encoder, so on it each of them loads both (README)."""
        enc = float(self.encoder_position()[a])
        servo = self.params.ptype[a] == "M"
        if which == "encoder" and not servo:  # the slip detection starts again from here
            self.enc_offset[a] += value - enc - self.motion.forget_slip(a)
            return
        core = self.motion.core
        before = float(core.axes.pos[a])
        core.set_position(a, value)
        self.motion.renumbered(a, float(core.axes.pos[a]) - before)
        self.enc_offset[a] = 0.0 if which == "both" or servo else enc - value

    def motor_position(self) -> np.ndarray:
        return self.motion.motor_position()

    def encoder_position(self) -> np.ndarray:
        enc = self.motion.encoder_position() + self.enc_offset
        return np.where(self.params.encoder_inverted, -enc, enc)

    def gpio_levels(self) -> int:
        """The 16 I/O lines: outputs as driven, inputs as the outside drives them."""
        return (self.gpio_out & self.gpio_dir) | (self.gpio_in & ~self.gpio_dir & 0xFFFF)

    def limit_word(self) -> int:
        m = self.motion
        return pack_limit_word(m.limit_neg_level, m.limit_pos_level)

    def set_update_rate(self, hz: int) -> None:
        """#UR: the update cycle runs `hz` times a second from the next cycle on [S §2.13]: the
        card's clock takes the new period (`retime`) and calls `set_period` when that cycle
        begins (without a card, at once)."""
        if hz == self.update_hz:
            return
        self.update_hz = hz
        if self.retime is not None:
            self.retime(Fraction(10**9, hz))
        else:
            self.set_period(10**9 / hz)

    def set_period(self, period_ns: float) -> None:
        """A cycle of the new length begins: motion integrates over it, and the KV/KA
        feed-forward, scaled by the cycle time, is recomputed; the gains act per cycle."""
        self.period_ns = period_ns
        self.motion.core.set_period(period_ns)
        self.apply_gains()

    def set_axis_type(self, a: int, ptype: str) -> None:
        self.params.ptype[a] = ptype
        if self.on_type_change is not None:  # the faults the new type has, before it starts
            self.on_type_change()
        self.motion.set_kind(a, ptype)

    def set_closed_loop(self, a: int, on: bool) -> None:
        self.params.closed_loop[a] = on
        self.motion.set_closed_loop(a, on)

    def apply_gains(self) -> None:
        self.motion.apply_gains()

    def in_deadband(self, a: int) -> bool:
        """EA char 4: the encoder within HD of the target (encoder.py)."""
        return self.motion.in_deadband(a)

    # -- stored defaults [S §2.13-2.14; spec §1.4, §2.3] -------------------------------------------
    def store_defaults(self) -> None:
        """APP: the working parameters and I/O configuration become the power-up defaults
        (written to the card's flash, the NVRAM file, at once; defaults.py); which set is
        loaded does not change until a restart."""
        image = defaults_image(self)
        self.save(image)
        self.saved = image

    def restore_defaults(self, factory: bool) -> None:
        """RDF (factory) / RDP (the stored power-up set) into working memory, parameters and
        I/O configuration (what the stored set lacks: factory); RDP without a stored set is
        refused."""
        if not factory and self.saved is None:
            raise CommandError("no power-up defaults stored")
        params = Params(self.n, self.factory_types)
        if not factory:
            assert self.saved is not None
            params.restore(self.saved)
        self.params.__dict__.update(params.__dict__)
        self.loaded = "factory" if factory else "power_up"
        self.configure_axes()
        load_io(self, None if factory else self.saved)

    def configure_axes(self) -> None:
        """Make the axes what the working parameters say: type, loop, encoder ratio, gains,
        limits."""
        m, p = self.motion, self.params
        if self.on_type_change is not None:  # the faults the types have, before they start
            self.on_type_change()
        for a, t in enumerate(p.ptype):
            m.set_kind(a, t)
            m.set_closed_loop(a, bool(p.closed_loop[a]))
            m.core.set_encoder_scale(a, float(p.ratio[a]) if t == "E" else 1.0)
        m.apply_gains()
        m.apply_limits()

    def letter(self, a: int) -> str:
        return AXES[a]

    def check_axis(self, a: int) -> int:
        if not 0 <= a < self.n:
            raise CommandError(f"no axis {AXES[a]} on this card")
        return a


_NOISE = 1e-6  # counts: an arc's cos/sin rounding is no motion
_COMMAND_ERROR = int(MaxkDoorbell.COMMAND_ERROR)
_WK_NOTIFICATION = (int(MaxkDoorbell.W_NOTIFICATION), int(MaxkDoorbell.K_NOTIFICATION))


def _until_ended(c: Contour) -> Callable[[], Run]:
    """A queue entry that holds its axis until contour `c` has ended."""
    return lambda: lambda axis: c.state is ContourState.ENDED
