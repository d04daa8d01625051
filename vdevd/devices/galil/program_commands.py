"""The commands of application programs and program trippoints, as the interpreter runs them
(spec galil.md §4.5 "Programming and flow", §5.7; [M Ch2 Ex11-13]).

`ProgramCommands` is bound into the command table next to the interpreter (commands.py names its
methods): DL UL LS XQ HX II TR BP BV BN, the flow commands the host may not give (TC 2), and the
trippoints AD AP AR AS AI MF MR and TW. A trippoint returns an interpreter `Trippoint`: on the
command line it holds the interpreter, in a program it blocks only its thread (threads.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.galil import syntax
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.interpreter import OK, Trippoint
from vdevd.devices.galil.motion import StopCode
from vdevd.devices.galil.program import ProgramDownload
from vdevd.devices.galil.threads import MCTIME, Threads

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware


class ProgramCommands:
    """Handlers of the program commands over one firmware."""

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw

    @property
    def _threads(self) -> Threads:
        return self.fw.threads

    def _value(self, text: str) -> float:
        return self.fw.interp.value(text)

    # -- program buffer --------------------------------------------------------------------------
    def _dl(self, arg: str) -> ProgramDownload:
        """DL: the lines that follow, up to `\\`, are the program; DL# appends, DL#LABEL replaces
        from the label on [DMCLIB DMCDownloadFile]. TC 17 while a program runs."""
        if self._threads.active:
            raise GalilError(TC.NOT_VALID_WHILE_PROGRAM_RUNS)
        text = arg.strip()
        start: str | None = None
        if text:
            if not text.startswith("#"):
                raise GalilError(TC.INVALID_LABEL, text)
            start = text[1:]
            if start and start not in self._threads.program.labels:
                raise GalilError(TC.EMPTY_PROGRAM_LINE, text)
        return ProgramDownload(self._threads.program, start)

    def _ul(self, arg: str) -> bytes:
        """UL: the program, each line ending CR LF, then ^Z [DMCLIB DMCUploadFile]."""
        self._unlocked()
        return self._threads.program.upload() + OK

    def _unlocked(self) -> None:
        """UL, LS, ED and TR while `^L^K` locks the program: TC 106 "Privilege violation"."""
        if self._threads.program.locked:
            raise GalilError(TC.PRIVILEGE_VIOLATION, "the program is locked (^L^K)")

    def _pw(self, arg: str) -> bytes:
        """PW password,password: the password `^L^K` asks for, given twice, up to 8
        characters; only while unlocked (TC 106), the two must match (TC 6)."""
        self._unlocked()
        fields = [f.strip() for f in arg.split(",")]
        if len(fields) != 2 or fields[0] != fields[1] or len(fields[0]) > 8:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, "PW password,password")
        self._threads.program.password = fields[0]
        return OK

    def _lock(self, arg: str) -> bytes:
        """^L^K password,n: n 1 locks the program against UL, LS, ED and TR, 0 unlocks; a wrong
        password is TC 106. `_LK` reads 1 while locked."""
        program = self._threads.program
        text, _, n = arg.rpartition(",")
        if not _ or n.strip() not in ("0", "1"):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, "^L^K password,n")
        if text.strip() != program.password:
            raise GalilError(TC.PRIVILEGE_VIOLATION, "wrong password")
        program.locked = n.strip() == "1"
        return OK

    def _ls(self, arg: str) -> bytes:
        """LS [first[,last]]: the lines with their numbers; `first` may be a #label [M Ch2 Ex11]."""
        self._unlocked()
        program = self._threads.program
        fields = [f.strip() for f in arg.split(",")] if arg.strip() else []
        if len(fields) > 2:
            raise GalilError(TC.OPERAND_ERROR)
        bounds: list[int | None] = [0, None]
        for k, f in enumerate(fields):
            if not f:
                continue
            if f.startswith("#"):
                bounds[k] = program.line_of(f[1:])
                continue
            v = self._value(f)
            if v != int(v) or not 0 <= v < max(len(program.lines), 1):
                raise GalilError(TC.INVALID_LABEL, f)
            bounds[k] = int(v)
        return program.listing(bounds[0] or 0, bounds[1]) + OK

    # -- threads -----------------------------------------------------------------------------------
    def _xq(self, arg: str) -> bytes:
        """XQ #label,n: thread n (0-7, default 0) runs from the label [M Ch2 Ex11]."""
        self._threads.execute_label(arg, None)
        return OK

    def _hx(self, arg: str) -> bytes:
        """HX n: halt thread n; HX halts every thread."""
        self._threads.halt(arg)
        return OK

    def _ii(self, arg: str) -> bytes:
        self._threads.input_interrupts(arg)
        return OK

    def _tr(self, arg: str) -> bytes:
        self._unlocked()
        self._threads.set_trace(arg)
        return OK

    def _cw(self, arg: str) -> bytes:
        """CW 1: a program's messages reach the host with bit 7 set (the default), so that a
        library tells them from replies; CW 2: as they are."""
        v = self._value(arg) if arg.strip() else 0
        if v not in (1, 2):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        self.fw.mark_unsolicited = v == 1
        return OK

    def _program_only(self, arg: str) -> bytes:
        """JP JS EN RE RI IF ELSE ZS IN from the host: TC 2 "Command only valid from program"."""
        raise GalilError(TC.ONLY_VALID_FROM_PROGRAM)

    # -- flash [spec §1.5] -------------------------------------------------------------------------
    def _burn(self, what: str, arg: str) -> bytes:
        """BP (programs), BV (variables), BN (parameters): into the card's flash file; BN while
        a program runs is TC 17 "ED, BN and DL not valid while program running"."""
        if what == "parameters" and self._threads.active:
            raise GalilError(TC.NOT_VALID_WHILE_PROGRAM_RUNS)
        self.fw.flash.burn(what)
        return OK

    def _master_reset(self, arg: str) -> bytes:
        """^R^S: programs, arrays, variables and parameters in flash are erased, then the power-on
        state [M Ch2 §Master Reset and Upgrade Jumpers]."""
        fw = self.fw
        fw.flash.erase()
        fw.threads.halt_all()
        fw.threads.program.erase()
        fw.reset()
        return OK

    # -- trippoints [M Ch2 Ex13; spec §5.7] ----------------------------------------------------------
    def _fields(self, arg: str) -> list[tuple[int, float]]:
        pairs = self.fw.interp.per_axis(arg)
        if not pairs:
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        out = []
        for a, f in pairs:
            if f is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID)
            out.append((a, self._value(str(f))))
        return out

    def _ad(self, arg: str) -> Trippoint:
        """AD: until each axis has moved the distance from the start of its move [M Ch2 Ex13]."""
        motion, pairs = self.fw.motion, self._fields(arg)

        def ready() -> bool:
            ref = motion.reference()
            return all(abs(ref[a] - motion.move_start[a]) >= abs(d) for a, d in pairs)

        return Trippoint(ready)

    def _ap(self, arg: str) -> Trippoint:
        """AP: until each axis's commanded position passes the absolute position [M Ch2 Ex13]."""
        motion, pairs = self.fw.motion, self._fields(arg)
        ref = motion.reference()
        sides = [(a, p, 1.0 if p >= ref[a] else -1.0) for a, p in pairs]

        def ready() -> bool:
            now = motion.reference()
            return all((now[a] - p) * s >= 0 for a, p, s in sides)

        return Trippoint(ready)

    def _ar(self, arg: str) -> Trippoint:
        """AR: until each axis has moved the distance from the last AR (or from here)."""
        motion, pairs = self.fw.motion, self._fields(arg)
        last = self.fw.ar_base
        ref = motion.reference()
        goals = []
        for a, d in pairs:
            base = last.get(a, float(ref[a]))
            last[a] = base + d
            goals.append((a, base + d, 1.0 if d >= 0 else -1.0))

        def ready() -> bool:
            now = motion.reference()
            return all((now[a] - g) * s >= 0 for a, g, s in goals)

        return Trippoint(ready)

    def _as(self, arg: str) -> Trippoint:
        """AS axes: until the profiles have stopped accelerating (at slew speed, or decelerating
        already in a short move), or ended [M Ch6 §Example - Jog in X only]."""
        axes = self.fw.interp.axes(arg)
        core = self.fw.motion.core

        def ready() -> bool:
            acc, vel = core.axes.cmd_acc[axes], core.axes.cmd_vel[axes]
            at_speed = (acc * vel <= 0) & (vel != 0)
            return bool((at_speed | ~core.profile.moving[axes]).all())

        return Trippoint(ready)

    def _ai(self, arg: str) -> Trippoint:
        """AI ±n: until input n reads high (+n) or low (-n) [M Ch6 §Electronic Cam]."""
        n = self._value(arg)
        if n != int(n) or not 1 <= abs(n) <= 8:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        fw, bit, want = self.fw, 1 << (abs(int(n)) - 1), n > 0
        return Trippoint(lambda: bool(fw.inputs & bit) == want)

    def _at(self, arg: str) -> bytes | Trippoint:
        """AT n: AT 0 makes now the time reference; AT n waits until n ms after it; AT -n waits
        as long, then moves the reference to that time, so a loop of AT -n runs every n ms
        without drift (the Galil command reference; the seed names AT among the trippoints,
        spec §5.7). One reference per thread, the command line being one; before an AT 0 it is
        the power-up (or RS)."""
        n = self._value(arg)
        if n != int(n) or abs(n) > 2_147_483_647:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"AT {n}")
        fw, key = self.fw, self.fw.interp.thread
        refs = fw.at_reference
        if n == 0:
            refs[key] = fw.now_ns
            return OK
        reset_ns = fw.now_ns - (fw.ticks - fw.time_origin) * fw.period_ns  # TIME's zero
        end = refs.get(key, reset_ns) + int(abs(n)) * 1_000_000

        def ready() -> bool:
            if fw.now_ns < end:
                return False
            if n < 0:
                refs[key] = end
            return True
        return Trippoint(ready)

    def _mf(self, arg: str) -> Trippoint:
        """MF: until the encoder (TP) has passed the position going forward [M Ch6 ECAM Ex]."""
        return self._passing(arg, 1.0)

    def _mr(self, arg: str) -> Trippoint:
        """MR: until the encoder has passed the position going in reverse."""
        return self._passing(arg, -1.0)

    def _passing(self, arg: str, sign: float) -> Trippoint:
        motion, pairs = self.fw.motion, self._fields(arg)

        def ready() -> bool:
            now = motion.position()
            return all((now[a] - p) * sign >= 0 for a, p in pairs)

        return Trippoint(ready)

    def _tw(self, arg: str) -> bytes:
        """TW n: MC waits n ms at most; then SC 99 and #MCTIME (thread 0) [spec §4.4 SC]."""
        tw = self._threads.tw_ms
        pairs = self.fw.interp.per_axis(arg)
        if not pairs:
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        queries = [a for a, f in pairs if f is syntax.QUERY]
        if queries:
            return self.fw.interp.data(",".join(self.fw.interp.fmt(tw[a] or 0, 5, 0) for a in queries))
        for a, f in pairs:
            v = self._value(str(f))
            if not 0 <= v <= 32767:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE)
            tw[a] = v or None
        return OK

    def with_timeout(self, trip: Trippoint, axes: list[int], program: bool) -> Trippoint:
        """MC with TW: after TW ms the axes still out of position get SC 99 and, in a program,
        thread 0 runs #MCTIME; the trippoint is then over."""
        ms = self._threads.mc_timeout(axes)
        if ms is None:
            return trip
        fw = self.fw
        end = fw.now_ns + int(ms * 1e6)
        fired = [False]

        def ready() -> bool:
            if fired[0] or trip.ready():
                return True
            if fw.now_ns < end:
                return False
            fired[0] = True
            fw.motion.stop_code[np.asarray(axes)] = StopCode.MC_TIMEOUT
            if program:
                fw.threads.automatic(MCTIME)
            return True

        return Trippoint(ready)
