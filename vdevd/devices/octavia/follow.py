"""Cam and gear slaves, sample by sample [Ch5 CAM family, GEAR family, REL_AXMOVE_SLAVE; spec
octavia.md §5.6, §5.7]: the firmware's side of the pure follower laws of cam.py.

Every sample (before the motion core's tick) each engaged slave gets its commanded position for
the next sample (`MotionCore.track`): the cam or gear target from its master's position, plus the
offset of a REL_AXMOVE_SLAVE. Assumptions (README "Cam and gearing"):

* The master position is its actual (encoder) position, or its command (card option
  `follow_master`) [spec Q-21, Q-22b].
* MAXACC limits the engagement transient only (spec §5.6): a slave engaged while its master moves
  catches up with the cam/gear position at no more than its MAXACC (a time-optimal approach in
  the slave's error), then follows exactly; the first sample of exact following whose demanded
  acceleration exceeds MAXACC (by more than the 2 counts of integer rounding) is logged. MAXACC 0:
  no limit ("must be programmed before cam operation").
* An axis that leaves cam or gear mode (STOP, DDAC, AXMOVE, VELMODE, POS_PRESET, an EN_ERRHLT
  halt, an encoder fault, RESET) stops following (spec Q-21). *ESTOP does not halt engaged
  slaves: the master halts and they follow it, engaged [Ch5 CAM Note].
* A redefinition of position (POS_PRESET, POS_SHIFT) of a master or a slave keeps the pair's
  relation: no jump of the slave ("without losing position integrity").
* A slave whose target stands still holds (the core at rest costs nothing); it tracks again
  when the target moves.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np
from vdevmaps.octavia import MAX_AXES, DspStat1, Window, acc_from_raw

from vdevd.devices.octavia.cam import CamFollowers, Follow, Gears
from vdevd.devices.octavia.state import Mode, axes_bits

if TYPE_CHECKING:
    from vdevd.devices.octavia.firmware import Firmware

log = logging.getLogger(__name__)

TS = 200e-6
_CAMCOUNT = 0x484  # CAMCOUNT1..8, u16 each, under 480h/481h (spec Q-24) [Table 6-10]
#: a demanded acceleration this much over MAXACC is integer rounding of the targets, not the table
_ROUNDING = 2.0
FOLLOWING = (Mode.CAM, Mode.GEAR)


def approach(err: np.ndarray, vel: np.ndarray, acc: np.ndarray, vmax: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """One sample of a time-optimal approach to an error `err` (counts) from the relative
    velocity `vel` (counts/sample), with acceleration `acc` and speed `vmax`: the new relative
    velocity, and whether it closes the error exactly this sample (it then equals `err`)."""
    dist = np.abs(err)
    with np.errstate(divide="ignore", invalid="ignore"):
        # the fastest speed from which braking at acc stops within dist, sample by sample
        brake = np.where(acc > 0, acc * (np.sqrt(0.25 + 2.0 * dist / np.where(acc > 0, acc, 1.0))
                                         - 0.5), np.inf)
    speed = np.minimum(np.minimum(brake, vmax), dist)
    want = np.sign(err) * speed
    closes = (speed >= dist) & (np.abs(want - vel) <= acc)
    new = np.where(closes, err, vel + np.clip(want - vel, -acc, acc))
    return new, closes


class Following:
    """The cam and gear slaves of a card and their superimposed moves (one slot per axis)."""

    def __init__(self, fw: Firmware, gear_ratio_bits: int = 7, master: str = "actual") -> None:
        if master not in ("actual", "command"):
            raise ValueError(f"follow_master {master!r} (actual or command)")
        self.fw = fw
        self._counts = np.zeros(MAX_AXES, dtype="<u2")  # CAMCOUNT1..8 as published
        self.gear_ratio_bits = gear_ratio_bits
        self.from_command = master == "command"
        self._clear()

    def _clear(self) -> None:
        n = self.fw.n
        self.cam = CamFollowers(n, self.fw.ram)
        self.gears = Gears(n, self.gear_ratio_bits)
        z = np.zeros
        self.active = False  # any slave armed, engaged or moving an offset
        self.seen = z(n, dtype=bool)  # engaged at the last sample (new ones start a transient)
        self.locked = z(n, dtype=bool)  # following exactly (the engagement transient is over)
        self.pos = z(n)  # the command position given for the next sample
        self.vel = z(n)  # its velocity, counts/sample
        self.goal = z(n)  # the last target (its velocity is the target's)
        self.acc = z(n)  # MAXACC of the transient, counts/sample^2
        self.warned = z(n, dtype=bool)  # a demand over MAXACC was logged for this engagement
        self.zero = self.fw.core.zero.copy()  # the position redefinitions seen so far
        # REL_AXMOVE_SLAVE: an offset added to the target, moved by a trapezoid
        self.offset = z(n)
        self.off_vel = z(n)
        self.off_goal = z(n)
        self.off_acc = z(n)
        self.off_vmax = z(n)
        self.off_moving = z(n, dtype=bool)

    def reset(self) -> None:
        """RESET: every slave disengaged (the cam table stays in the board RAM)."""
        self._clear()

    # -- positions ----------------------------------------------------------------------------
    def masters(self) -> np.ndarray:
        """Every axis's position as a master: its encoder, or its rounded command."""
        ax = self.fw.core.axes
        if self.from_command:
            return np.rint(ax.cmd_pos).astype(np.int64)
        return np.asarray(ax.encoder, dtype=np.int64)

    def commands(self) -> np.ndarray:
        return np.rint(self.fw.core.axes.cmd_pos).astype(np.int64)

    # -- engaging (the handlers of cmd_cam, cmd_gear) -------------------------------------------
    def _take(self, axis: int, mode: Mode) -> None:
        """`axis` becomes a slave (armed or engaged) in `mode`: the loop closes if DDAC opened
        it, another engagement of the axis ends, and its transient starts afresh."""
        fw = self.fw
        if not self.active:  # the redefinitions made while nothing followed are no travel
            self.zero = fw.core.zero.copy()
        fw.close_loop([axis])
        if mode == Mode.CAM:
            self.gears.disengage(axis)
        else:
            self.cam.disengage(axis)
        fw.mode[axis] = mode
        self.seen[axis] = False
        self.off_moving[axis] = False
        self.offset[axis] = self.off_vel[axis] = 0.0
        self.active = True

    def cam_engage(self, axis: int, master: int, start: int, size: int, how: str,
                   arg: int = 0) -> None:
        """CAM (`how` "now"), CAM_POS ("at" master position `arg`), CAM_PROBE ("probe" on the
        EXT code `arg`); ValueError for a table or an axis pair the card cannot run, with the
        slave's present engagement untouched."""
        if axis == master:
            raise ValueError("a slave cannot follow itself")
        cam = self.cam
        if how == "probe":
            cam.engage_on_probe(axis, master, start, size, arg)
        elif how == "at":
            cam.engage_at(axis, master, start, size, arg, int(self.masters()[master]))
        else:
            cam.engage(axis, master, start, size, int(self.masters()[master]),
                       int(self.commands()[axis]))
        self._take(axis, Mode.CAM)

    def gear_engage(self, axis: int, leader: int, ratio: int, how: str, arg: int = 0) -> None:
        """GEAR, GEAR_POS (tp `arg`), GEAR_PROBE (EXT code `arg`), as `cam_engage`."""
        if axis == leader:
            raise ValueError("a follower cannot follow itself")
        gears = self.gears
        if how == "probe":
            gears.engage_on_probe(axis, leader, ratio, arg)
        elif how == "at":
            gears.engage_at(axis, leader, ratio, arg, int(self.masters()[leader]))
        else:
            gears.engage(axis, leader, ratio, int(self.masters()[leader]),
                         int(self.commands()[axis]))
        self._take(axis, Mode.GEAR)

    def disengage(self, axes: list[int], mode: Mode, acc: bool) -> None:
        """CAM_OFF / GEAR_OFF (`acc` False): the slaves in `mode` among `axes` stop following
        at once and hold; CAM_OFF_ACC / GEAR_OFF_ACC: they decelerate to rest at MAXACC (at once
        when it is 0), then report motion complete [Ch5 CAM_OFF_ACC]. Armed slaves disarm."""
        fw = self.fw
        core = fw.core
        followers = self.cam if mode == Mode.CAM else self.gears
        for a in axes:
            if fw.mode[a] != mode:
                continue
            engaged = followers.mode[a] == Follow.ENGAGED
            here = float(self.pos[a] if self.seen[a] else core.axes.cmd_pos[a])
            self._drop(a)
            if not engaged:
                fw.mode[a] = Mode.HOLD
            elif not acc:
                core.hold(a, here)
                fw.mode[a] = Mode.HOLD
            else:
                raw = int(fw.params.maxacc[a])
                if raw and core.profile.moving[a]:
                    core.stop(a, acc_from_raw(raw) / (TS * TS))
                else:
                    core.hold(a, here)  # at rest already, or no MAXACC: done (DONE next sample)
                fw.mode[a] = Mode.STOP
                fw._prev_flags[a] = 0

    def _drop(self, a: int) -> None:
        self.cam.disengage(a)
        self.gears.disengage(a)
        self.seen[a] = self.off_moving[a] = False
        self.offset[a] = self.off_vel[a] = 0.0

    def superimpose(self, axis: int, acc: float, distance: int, vmax: float) -> bool:
        """REL_AXMOVE_SLAVE: a trapezoid of `distance` counts (acc counts/sample^2, slew vmax
        counts/sample) added to an engaged slave's target, from the offset it has now (its
        rounded value: the relative move's origin, as REL_AXMOVE's); False if the axis is not
        an engaged slave."""
        if not (self.cam.mode[axis] == Follow.ENGAGED or self.gears.mode[axis] == Follow.ENGAGED):
            return False
        self.off_goal[axis] = float(np.rint(self.offset[axis])) + distance
        self.off_acc[axis], self.off_vmax[axis] = acc, vmax
        self.off_moving[axis] = True
        self.active = True
        return True

    def engaged(self) -> np.ndarray:
        """The axes following now (cam or gear)."""
        return self.cam.engaged | self.gears.engaged

    def unfollowed(self, axes: np.ndarray) -> np.ndarray:
        """Of `axes`, those *ESTOP and STOP_DSPL halt: not the engaged slaves (they follow
        their halting masters), nor the armed ones at rest (they stay armed)."""
        armed = (self.cam.mode != Follow.OFF) | (self.gears.mode != Follow.OFF)
        keep = self.engaged() | armed & ~self.fw.core.profile.moving
        return axes[~keep[axes]]

    # -- the probe inputs [Ch5 CAM_PROBE, GEAR_PROBE] ---------------------------------------------
    def probe(self, inputs: int) -> int:
        """*EXT inputs (bit codes) went active: slaves armed on one engage there, m0 = their
        master's position at the edge, and that edge raises no interrupt; the bits left."""
        if not self.active:
            return inputs
        consumed = 0
        for code in (1, 2, 4, 8):
            if not inputs & code:
                continue
            hit = (self.cam.probe(code, self.masters(), self.commands())
                   | self.gears.probe(code, self.masters(), self.commands()))
            if hit.any():
                consumed |= code
                self.seen[hit] = False
        return inputs & ~consumed

    # -- the sample ---------------------------------------------------------------------------------
    def step(self) -> None:
        """Before the core's tick: every engaged slave's command for the next sample."""
        fw = self.fw
        core = fw.core
        cam, gears = self.cam, self.gears
        gone = ((cam.mode != Follow.OFF) & (fw.mode != Mode.CAM)
                | (gears.mode != Follow.OFF) & (fw.mode != Mode.GEAR))
        for a in np.flatnonzero(gone).tolist():
            self._drop(a)
        if not np.array_equal(core.zero, self.zero):
            self._redefined(core.zero - self.zero)
        masters, commands = self.masters(), self.commands()
        target = commands.astype(float)
        if cam.active:
            t, _ = cam.targets(masters, commands)
            np.copyto(target, t, where=cam.engaged)
        if gears.active:
            np.copyto(target, gears.targets(masters, commands), where=gears.engaged)
        engaged = cam.engaged | gears.engaged
        new = engaged & ~self.seen
        if new.any():
            self._begin(new)
        if self.off_moving.any():
            self._offsets(engaged)
        target += np.where(engaged, self.offset, 0.0)
        self._move(engaged, target)
        self.seen = engaged
        self.active = bool(cam.active or gears.active or self.off_moving.any())

    def _begin(self, new: np.ndarray) -> None:
        """Slaves engaged since the last sample start their transient from where they are."""
        ax = self.fw.core.axes
        self.pos[new] = ax.cmd_pos[new]
        self.vel[new] = ax.cmd_vel[new] * TS
        self.acc[new] = [acc_from_raw(int(r)) for r in self.fw.params.maxacc[:self.fw.n][new]]
        self.locked[new] = self.acc[new] == 0
        self.warned[new] = False
        self.goal[new] = np.nan  # no target velocity known yet

    def _redefined(self, shift: np.ndarray) -> None:
        """POS_PRESET / POS_SHIFT moved the zero of some axes by `shift` counts: a master's new
        frame is not travel, a slave's anchors move with it."""
        self.zero = self.fw.core.zero.copy()
        d = np.rint(shift).astype(np.int64)
        for f in (self.cam, self.gears):
            armed = f.mode != Follow.OFF
            f.last[armed] += d[f.master[armed]]
            f.s0[armed] += d[armed]
        self.pos += d
        self.goal += d

    def _offsets(self, engaged: np.ndarray) -> None:
        """Advance the REL_AXMOVE_SLAVE trapezoids one sample; motion complete where one ends
        [Ch5 REL_AXMOVE_SLAVE: "similar to AXMOVE"]."""
        fw = self.fw
        on = self.off_moving & engaged
        if fw.estop:  # *ESTOP: the superimposed move stops too, at ESTOP_ACC (else its own)
            self._halt_offsets(on)
        new, closes = approach(self.off_goal - self.offset, self.off_vel, self.off_acc,
                               self.off_vmax)
        self.offset = np.where(on, self.offset + new, self.offset)
        self.off_vel = np.where(on & ~closes, new, np.where(on, 0.0, self.off_vel))
        done = on & closes
        if done.any():
            self.offset[done] = self.off_goal[done]
            self.off_moving[done] = False
            hit = done & fw.params.motcp_on[:fw.n]
            if hit.any():
                fw.post_stat1(DspStat1.MOTCP, axes_bits(hit))

    def _halt_offsets(self, on: np.ndarray) -> None:
        p = self.fw.params
        for a in np.flatnonzero(on).tolist():
            raw = int(p.estop_acc[a])
            acc = acc_from_raw(raw) if raw else float(self.off_acc[a])
            v = float(self.off_vel[a])
            stop = self.offset[a] + np.sign(v) * (v * v / (2 * acc) + abs(v) / 2)
            self.off_goal[a], self.off_acc[a] = np.rint(stop), acc

    def _move(self, engaged: np.ndarray, target: np.ndarray) -> None:
        """The command of each engaged slave for the next sample: the target itself once
        locked, else the MAXACC-limited approach to it; tracked, or held when it stands still."""
        known = ~np.isnan(self.goal)  # the target's velocity is known from the second sample
        goal_vel = np.where(known, target - self.goal, 0.0)
        free = engaged & ~self.locked
        vel = np.where(engaged, target - self.pos, 0.0)
        if free.any():
            # in the target's frame: the gap now and the slave's velocity relative to it
            rel, closes = approach(target - goal_vel - self.pos, self.vel - goal_vel, self.acc,
                                   np.full(len(target), np.inf))
            vel = np.where(free, goal_vel + rel, vel)
            self.locked |= free & closes & known
        tight = engaged & self.locked & ~free & ~self.warned
        if tight.any():
            over = tight & (np.abs(vel - self.vel) > self.acc + _ROUNDING) & (self.acc > 0)
            for a in np.flatnonzero(over).tolist():
                self.warned[a] = True
                log.warning("octavia: axis %d's cam/gear path demands %.3f counts/sample^2, "
                            "more than its MAXACC %.3f (followed anyway)", a + 1,
                            abs(vel[a] - self.vel[a]), self.acc[a])
        still = engaged & (vel == 0) & (self.vel == 0)
        self.pos = np.where(engaged, self.pos + vel, self.pos)
        self.vel = np.where(engaged, vel, self.vel)
        self.goal = np.where(engaged, target, self.goal)
        core = self.fw.core
        track = np.flatnonzero(engaged & ~still)
        if len(track):
            core.track(track, self.pos[track])
        hold = np.flatnonzero(still & core.profile.moving)
        if len(hold):
            core.hold(hold, self.pos[hold])  # on the target itself, free of time's rounding

    # -- the DPR ------------------------------------------------------------------------------------
    def publish(self) -> None:
        """CAMCOUNT1..8 (484h..493h): each slave's absolute cam table index, under 480h/481h
        (spec Q-24) [Table 6-10]; deferred while the host holds the window."""
        counts = self._counts
        counts[:self.fw.n] = self.cam.camcount & 0xFFFF
        data = counts.tobytes()
        if self.fw.buf[_CAMCOUNT:_CAMCOUNT + len(data)] != data:  # (the same: nothing to do)
            self.fw.windows.put_bytes(Window.COUNTERS, _CAMCOUNT, data)
