"""Coordinated straight-line moves (`MT`) and vector contours (`VV VA VP VC VE VIO VID VO VOA
VG VH`) [S App C L1356-1374, §4.5.1; spec oms.md §4.3 "Vector / contouring", §5.7, §8.14], as
the EPICS MAXv trajectory scan drives them: one task per axis, loaded, then started together
by `VG` [E-traj L572-585, L1284-1437]."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vdevd.devices.oms.contour import Contour, ContourState, Point, Turn
from vdevd.devices.oms.queue import Group, Run
from vdevd.devices.oms.syntax import Command, CommandError, beyond_axes, hex_words, numbers

if TYPE_CHECKING:
    from vdevd.devices.oms.firmware import Firmware

_POSITION = 2**31 - 1
_VELOCITY = 4_194_303  # the largest VL/VV [spec §1.3]


def _multi(fw: Firmware, cmd: Command) -> None:
    if fw.mode == "single":
        raise CommandError(f"{cmd.mnemonic} needs AA or AM mode")


# -- MT: all axes arrive together ------------------------------------------------------------------
def move_together(fw: Firmware, cmd: Command) -> None:
    """A straight line to absolute targets: every axis's velocity and acceleration scaled so
    that all arrive at once [S App C L1356]. The move starts when every axis's queue reaches
    it, that is at the GO that follows (README)."""
    _multi(fw, cmd)
    pairs = fw.per_axis(cmd, integer=True)
    if not pairs or any(abs(v) > _POSITION for _, v in pairs):
        raise CommandError("MT needs absolute positions")
    targets = dict(pairs)
    group = Group(frozenset(targets))
    fw.aa_members = group.members
    fw.armed.update(targets)  # the GO that follows starts them (together, here)

    def make() -> Run:
        def run(axis: int) -> bool:
            if group.act_once():
                fw.motion_together(targets)
            return not fw.motion.moving(axis)

        return run

    fw.enqueue(sorted(targets), "MT", make, units=1 + len(targets), group=group)


# -- contours ------------------------------------------------------------------------------------
def _task(fw: Firmware, cmd: Command) -> int:
    task = cmd.index if cmd.index is not None else 1
    if not 1 <= task <= 8:
        raise CommandError("vector task is 1-8")
    return task


def _contour(fw: Firmware, cmd: Command) -> Contour:
    """The contour being defined in the task, started at the present positions."""
    _multi(fw, cmd)
    task = _task(fw, cmd)
    c = fw.contours.get(task)
    if c is None:
        here = tuple(float(p) for p in fw.motor_position())
        v = fw.params.values
        c = Contour(tuple(range(fw.n)), here, float(v["VL"][0]), float(v["AC"][0]), task=task)
        if task in fw.vector_velocity:
            c.velocity = fw.vector_velocity[task]
        c.end_velocity = fw.vector_end_velocity.get(task)
        if task in fw.vector_acceleration:
            c.acceleration = fw.vector_acceleration[task]
        fw.contours[task] = c
    return c


def _values(cmd: Command, text: str | None = None) -> list[float | None]:
    """The numbers of the operand (or of `text`, a part of it); a malformed one is an error."""
    text = cmd.operand if text is None else text
    try:
        return numbers(text) if text else []
    except ValueError:
        raise CommandError("malformed number") from None


def vector_velocity(fw: Firmware, cmd: Command) -> None:
    """VV[n]v[,vend]: the velocity of the segments defined from now and the speed each ends
    at, counts/s (`VV1000,0` ends at rest, `VV v` runs on) [S App C; spec §4.3]. `VV[n]0`,
    how [E-traj L1355] sends a point at rest, keeps the velocity and ends them at rest."""
    values = _values(cmd)
    if values == [0.0]:
        task = _task(fw, cmd)
        fw.vector_end_velocity[task] = 0.0
        if task in fw.contours:
            fw.contours[task].end_velocity = 0.0
        return
    if not values or len(values) > 2 or values[0] is None or not 1 <= values[0] <= _VELOCITY:
        raise CommandError("vector velocity 1-4194303")
    end = values[1] if len(values) == 2 else None
    if end is not None and not 0 <= end <= _VELOCITY:
        raise CommandError("end velocity 0-4194303")
    task = _task(fw, cmd)
    fw.vector_velocity[task] = values[0]
    fw.vector_end_velocity[task] = end
    if task in fw.contours:
        fw.contours[task].velocity = values[0]
        fw.contours[task].end_velocity = end


def vector_acceleration(fw: Firmware, cmd: Command) -> None:
    """VA[n]a: the acceleration of the segments defined from now, counts/s^2, for the ramps
    within them [E-traj L1422: `VA[n]` before each point]; before the first VP it is the
    contour's own (the halt of VH1 uses it)."""
    values = _values(cmd)
    if len(values) != 1 or values[0] is None or not 1 <= values[0] <= 8_000_000:
        raise CommandError("vector acceleration 1-8000000")
    task = _task(fw, cmd)
    fw.vector_acceleration[task] = values[0]
    if task in fw.contours:
        fw.contours[task].acceleration = values[0]


def _point(cmd: Command) -> tuple[bool, list[float | None]]:
    """A VP/VC operand: relative (R flag) or absolute (A flag or none) [E-traj L1428], and
    the numbers."""
    flag, text = (cmd.operand[:1], cmd.operand[1:]) if cmd.operand[:1] in ("A", "R") else (
        "", cmd.operand)
    return flag == "R", _values(cmd, text)


def vector_point(fw: Firmware, cmd: Command) -> None:
    """VP[n][A|R]p,p...: a straight segment to absolute positions (A, or no flag), or by
    distances from the end of the segment before (R); an empty field keeps the axis where it
    is [E-traj L1428-1432: `VP[n]A` and a field for axis j only]."""
    relative, values = _point(cmd)
    c = _contour(fw, cmd)
    if not values or beyond_axes(values, len(c.start)):
        raise CommandError("VP needs one position per axis")
    c.add(Point(tuple(values), relative))


def vector_circle(fw: Firmware, cmd: Command) -> None:
    """VC[n][A|R]cx,cy,degrees: an arc of the first two axes around (cx, cy), absolute (A, or
    no flag) or from where the arc starts (R); negative degrees run clockwise (spec §8.14)."""
    relative, values = _point(cmd)
    if len(values) != 3 or any(v is None for v in values):
        raise CommandError("VC centre-x,centre-y,angle")
    cx, cy, deg = (float(v) for v in values if v is not None)
    _contour(fw, cmd).add(Turn((cx, cy), relative, deg))


def vector_io(fw: Firmware, cmd: Command) -> None:
    """VIO on,off,mask: at the start of the next segment the outputs in `mask` take the
    levels of `on` (README)."""
    try:
        words = hex_words(cmd.operand) if cmd.operand else []
    except ValueError:
        raise CommandError("hex words") from None
    if not words or len(words) > 3:
        raise CommandError("VIO on,off,mask")
    on = words[0] or 0
    mask = words[2] if len(words) > 2 and words[2] is not None else 0xFFFF
    c = _contour(fw, cmd)
    c.io_on, c.io_off = on & mask, ~on & mask & 0xFFFF


def vector_end(fw: Firmware, cmd: Command) -> None:
    """The end of the contour definition: the contour starts once every axis of it has reached
    this point of its queue (and, after VH[n]0, VG[n] has come), decelerating to rest at its
    end (README)."""
    task = _task(fw, cmd)
    c = fw.contours.get(task)
    if c is None or not c.segments:
        raise CommandError("no contour defined")
    c.plan()
    c.axes = c.path_axes()
    group = Group(frozenset(c.axes))

    def make() -> Run:
        if c.state is ContourState.ENDED:  # LS/LE runs it again
            c.state = ContourState.QUEUED
            fw.live_contours.append(c)

        def run(axis: int) -> bool:
            if c.state is ContourState.QUEUED and any(fw.motion.moving(a) for a in c.axes):
                return False  # it starts from rest: after an ST's ramp, a JG's stop
            if group.act_once():
                fw.start_contour(task, c)
            return c.state is ContourState.ENDED

        return run

    fw.enqueue(sorted(c.axes), "VE", make, units=1 + len(c.segments), group=group)
    del fw.contours[task]  # not before: a VE the queues have no room for keeps the definition
    fw.aa_members = group.members
    fw.defined_contours[task] = c
    fw.live_contours.append(c)


def vector_done(fw: Firmware, cmd: Command) -> None:
    """VID[n]1 (or a bare VID[n]): when the task's contour ends, set the done flags of its
    axes and ring their doorbell bits; VID[n]0: do not [E-traj L1296: "done flag and
    interrupt", sent before the first VP]. It applies to the contour being defined, else to
    the one defined last if it has not ended, else to the next one (it opens a definition)."""
    values = _values(cmd)
    if len(values) > 1 or (values and values[0] not in (0.0, 1.0)):
        raise CommandError("VID, VID0 or VID1")
    task = _task(fw, cmd)
    c = fw.contours.get(task) or fw.defined_contours.get(task) or _contour(fw, cmd)
    c.notify = not values or values[0] == 1.0


def vector_override(fw: Firmware, cmd: Command) -> None:
    """VO[n]=pct: a fixed velocity override 0-200 %, at once, in place of a VOA input [S App
    C]; a bare `VO` goes back to the fixed override in force (100 % unless VO set one)."""
    values = _values(cmd)
    task = _task(fw, cmd)
    if values:
        if len(values) != 1 or values[0] is None or not 0 <= values[0] <= 200:
            raise CommandError("override 0-200 %")
        fw.override[task] = values[0] / 100
    fw.override_analog.pop(task, None)


def vector_override_analog(fw: Firmware, cmd: Command) -> None:
    """VOA[n]ch[,full]: the override follows analog input `ch`, 100 % at `full` volts (5 V
    unless given), clamped to 0-200 %, sampled every update cycle [S §4.5.1, App C `VOA0,5`];
    a bare `VOA` goes back to the fixed override (README)."""
    values = _values(cmd)
    task = _task(fw, cmd)
    if not values:
        fw.override_analog.pop(task, None)
        return
    ch = values[0]
    if len(values) > 2 or ch is None or ch != int(ch) or not 0 <= ch < fw.analog_channels:
        raise CommandError("no such analog input")
    full = values[1] if len(values) == 2 and values[1] is not None else 5.0
    if not 0 < full <= 10:
        raise CommandError("full-scale volts 0-10")
    fw.override_analog[task] = (int(ch), full)


def vector_hold(fw: Firmware, cmd: Command) -> None:
    """VH[n]0: "don't start until I tell you to start" [E-traj L1300-1301]: the task's next
    contour waits at its start for VG[n]. VH[n]1: halt [E-traj L812-816]: the running contour
    decelerates to rest on its path, whatever its override (VO or VOA), until VG[n]."""
    values = _values(cmd)
    if len(values) != 1 or values[0] not in (0.0, 1.0):
        raise CommandError("VH0 or VH1")
    task = _task(fw, cmd)
    if values[0]:
        fw.vector_held.add(task)
    else:
        fw.vector_gated.add(task)
        fw.vector_released.discard(task)


def vector_go(fw: Firmware, cmd: Command) -> None:
    """VG[n] ("GO!" [E-traj L579-585]): resume a halted contour; start the contour VH[n]0
    holds at its start, or, if it has not reached its start yet, let it start when it does."""
    task = _task(fw, cmd)
    fw.vector_held.discard(task)
    if task in fw.vector_gated:
        fw.vector_released.add(task)
        waiting = fw.waiting_contours.pop(task, None)
        if waiting is not None:
            fw.start_contour(task, waiting)
