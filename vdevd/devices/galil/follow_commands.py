"""The commands of gearing, ECAM, contour mode, SPM and commutation (follow.py), bound beside
the interpreter's own (`COMMANDS.bind(interp, FollowCommands(interp))`), and their operands.

Each handler takes the command's argument text and answers like the interpreter's: `:` (OK),
data then `:`, a `Trippoint` (WC, and CD with the contour buffer full), or raises `GalilError`.
Manual sections: [M Ch6 §Electronic Gearing, §Electronic Cam, §Contour Mode, §SPM], [M Ch2 Step
5, 7b].
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from vdevd.devices.galil import syntax
from vdevd.devices.galil.contour import CD_LIMIT, DT_MAX
from vdevd.devices.galil.ecam import MASTER_CYCLE_LIMIT, SLAVE_CHANGE_LIMIT, TABLE_POINTS
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.follow import Follow
from vdevd.devices.galil.gearing import GR_LIMIT, GR_RESOLUTION, Source
from vdevd.devices.galil.motion import Mode
from vdevd.devices.galil.spm import SPM_PARAMS

if TYPE_CHECKING:
    from vdevd.devices.galil.interpreter import Interpreter, Trippoint

OK = b":"
_LETTERS = "XYZWABCD"
_GR_FORMAT = (3, 4)
_SCALAR_FORMAT = (10, 0)


def _axis(letter: str, n: int) -> int:
    """X..W (A..D) -> 0..3; another letter TC 4, an axis the card lacks TC 90."""
    return syntax.axis_index(letter, n)


class FollowCommands:
    """GA GR GM, EA EM EP ET EB EG EQ EC, CM CD DT WC, YA YB YC YS YR QS, BA BM BI BB BC BZ BS."""

    def __init__(self, interp: Interpreter) -> None:
        self.interp = interp
        self.n = interp.n

    @property
    def follow(self) -> Follow:
        return self.interp.fw.follow

    def _done(self) -> bytes:
        self.follow.refresh()
        return OK

    def _values(self, name: str, arg: str, check: Callable[[int, float], float],
                query: Callable[[], np.ndarray], fmt: tuple[int, int] = _SCALAR_FORMAT
                ) -> tuple[list[int], list[float]] | bytes:
        """Per-axis fields (`GR 1,,2`, `GRY=2`, `GR ?`): (axes, checked values), or the reply of a
        query; none at all is TC 50."""
        interp = self.interp
        pairs = interp.per_axis(arg)
        if not pairs:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, name)
        queries = [a for a, f in pairs if f is syntax.QUERY]
        if queries:
            current = query()
            return interp.data(",".join(interp.fmt(float(current[a]), *fmt) for a in queries))
        axes = [a for a, _ in pairs]
        return axes, [check(a, interp.value(str(f))) for a, f in pairs]

    def _flag(self, name: str, arg: str) -> float:
        """A single value (EB 1, DT 3, EC 5)."""
        if not arg.strip():
            raise GalilError(TC.NOT_ENOUGH_FIELDS, name)
        return self.interp.value(arg)

    # -- electronic gearing [M Ch6 §Electronic Gearing] --------------------------------------------
    def ga(self, arg: str) -> bytes:
        """GA: each follower's master: X (main encoder), CX (commanded), DX (auxiliary); N or
        CN the virtual axis's commanded position (master number n; it has no encoder)
        [M Ch6 §Virtual Axis]; S or T the distance the plane travels along its path (masters
        n+1, n+2) [M Ch6 §Electronic Gearing: "n = S or T for gearing to coordinated
        motion"]."""
        gear = self.follow.gearing
        axes, masters, sources = [], [], []
        for a, field in self.interp.per_axis(arg):
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID, "GA")
            text = str(field).strip().upper()
            source = Source.ENCODER
            if len(text) == 2 and text[0] in "CD":
                source = Source.COMMANDED if text[0] == "C" else Source.AUXILIARY
                text = text[1:]
            if text in ("S", "T") and source == Source.ENCODER:
                # gearing to coordinated motion: the plane's distance along its path
                master, source = self.n + 1 + "ST".index(text), Source.COMMANDED
            elif text == "N" and source != Source.AUXILIARY:
                master, source = self.n, Source.COMMANDED
            else:
                master = _axis(text, self.n)
            if master == a:
                raise GalilError(TC.GEAR_MASTER_AND_FOLLOWER)
            axes.append(a)
            masters.append(master)
            sources.append(int(source))
        if not axes:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, "GA")
        gear.set_master(axes, masters, sources)
        return self._done()

    def gr(self, arg: str) -> bytes:
        """GR: gear ratios +-127.9999, resolution 0.0001; 0 disengages; on the fly."""
        gear = self.follow.gearing

        def check(a: int, v: float) -> float:
            if not abs(v) <= GR_LIMIT + GR_RESOLUTION / 2:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"GR {v}")
            if v and self.follow.ecam.engaged[a]:
                raise GalilError(TC.NOT_VALID_PERFORMING_ECAM)
            return round(v / GR_RESOLUTION) * GR_RESOLUTION

        got = self._values("GR", arg, check, lambda: gear.ratio, _GR_FORMAT)
        if isinstance(got, bytes):
            return got
        gear.set_ratio(*got)
        return self._done()

    def gm(self, arg: str) -> bytes:
        """GM: 1 gantry mode (ST and limit switches keep the gearing), 0 standard."""
        gear = self.follow.gearing
        got = self._values("GM", arg, _zero_or_one, lambda: gear.gantry.astype(float), (1, 0))
        if isinstance(got, bytes):
            return got
        gear.gantry[got[0]] = np.asarray(got[1]) != 0
        return OK

    # -- ECAM [M Ch6 §Electronic Cam] ----------------------------------------------------------------
    def ea(self, arg: str) -> bytes:
        """EA p: the master, by its main encoder (X..W), or the virtual axis N by its commanded
        position (master number n) [M Ch6 §Virtual Axis "EAN"]."""
        ecam = self.follow.ecam
        text = arg.strip().upper()
        if text == "?":
            return self.interp.data((_LETTERS[:self.n] + "N")[ecam.master] if ecam.master >= 0
                                    else "")
        if not text:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, "EA")
        master = self.n if text == "N" else _axis(text, self.n)
        ecam.check_idle()
        ecam.master = master
        return OK

    def em(self, arg: str) -> bytes:
        """EM: the master's cycle (<= 8 388 607) and each slave's change per cycle."""
        ecam = self.follow.ecam

        def check(a: int, v: float) -> float:
            limit = MASTER_CYCLE_LIMIT if a == ecam.master else SLAVE_CHANGE_LIMIT
            if not abs(v) <= limit:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"EM {v}")
            return float(round(v))

        got = self._values("EM", arg, check, lambda: ecam.cycle)
        if isinstance(got, bytes):
            return got
        ecam.check_idle()
        ecam.cycle[got[0]] = got[1]
        return OK

    def ep(self, arg: str) -> bytes:
        """EP m,n: the table's master interval m and its start n."""
        ecam, interp = self.follow.ecam, self.interp
        fields = syntax.parse_fields(arg, 2)
        if fields and fields[0] is syntax.QUERY:
            return interp.data(f"{interp.fmt(ecam.interval, *_SCALAR_FORMAT)},"
                               f"{interp.fmt(ecam.start, *_SCALAR_FORMAT)}")
        if not fields or fields[0] is None or syntax.QUERY in fields:
            raise GalilError(TC.NOT_ENOUGH_FIELDS, "EP")
        m = round(interp.value(str(fields[0])))
        start = round(interp.value(str(fields[1]))) if len(fields) > 1 and fields[1] else 0
        if not 0 < m <= MASTER_CYCLE_LIMIT or abs(start) > MASTER_CYCLE_LIMIT:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"EP {m},{start}")
        ecam.check_idle()
        ecam.interval, ecam.start = float(m), float(start)
        return OK

    def et(self, arg: str) -> bytes:
        """ET[n]=x,y,z,w: the slaves' positions at point n (0-256; TC 101 else); `ET[n]=?`."""
        ecam, interp = self.follow.ecam, self.interp
        text = arg.strip()
        close = text.find("]")
        if not text.startswith("[") or close < 0:
            raise GalilError(TC.MISSING_BRACKET, "ET")
        index = interp.value(text[1:close])
        rest = text[close + 1:].lstrip()
        if not rest.startswith("="):
            raise GalilError(TC.OPERAND_ERROR, "ET")
        if index != int(index) or not 0 <= index < TABLE_POINTS:
            raise GalilError(TC.ECAM_INDEX)
        row = int(index)
        fields = syntax.parse_fields(rest[1:], self.n)
        queries = [a for a, f in enumerate(fields) if f is syntax.QUERY]
        if queries:
            return interp.data(",".join(interp.fmt(float(ecam.table[row, a]), *_SCALAR_FORMAT)
                                        for a in queries))
        pairs = [(a, f) for a, f in enumerate(fields) if f is not None]
        values = [float(round(interp.value(str(f)))) for _, f in pairs]
        if any(abs(v) > SLAVE_CHANGE_LIMIT for v in values):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, "ET")
        ecam.set_table(row, [a for a, _ in pairs], values)
        return OK

    def eb(self, arg: str) -> bytes:
        """EB 1 enables the ECAM mode (a master with its cycle first: TC 102, 103), EB 0 ends it."""
        ecam = self.follow.ecam
        if arg.strip() == "?":
            return self.interp.data(self.interp.fmt(float(ecam.enabled), 1, 0))
        ecam.enable(bool(_zero_or_one(0, self._flag("EB", arg))))
        return self._done()

    def eg(self, arg: str) -> bytes:
        """EG: engage each slave when the master passes its position (outside the cycle: now)."""
        ecam = self.follow.ecam
        got = self._values("EG", arg, lambda a, v: float(round(v)),
                           lambda: ecam.engaged.astype(float), (1, 0))
        if isinstance(got, bytes):
            return got
        ecam.engage(*got)
        return self._done()

    def eq(self, arg: str) -> bytes:
        """EQ: disengage each slave when the master passes its position (outside: now)."""
        ecam = self.follow.ecam
        got = self._values("EQ", arg, lambda a, v: float(round(v)),
                           lambda: np.isfinite(ecam.disengage_at).astype(float), (1, 0))
        if isinstance(got, bytes):
            return got
        ecam.disengage(*got)
        return self._done()

    def ec(self, arg: str) -> bytes:
        """EC n: the ECAM table index counter (0-256, TC 101 else); kept and reported (`_EC`):
        the manual gives no command that reads or advances it."""
        ecam = self.follow.ecam
        if arg.strip() == "?":
            return self.interp.data(self.interp.fmt(ecam.index, 3, 0))
        v = self._flag("EC", arg)
        if v != int(v) or not 0 <= v < TABLE_POINTS:
            raise GalilError(TC.ECAM_INDEX)
        ecam.index = int(v)
        return OK

    # -- contour mode [M Ch6 §Contour Mode] ----------------------------------------------------------
    def cm(self, arg: str) -> bytes:
        """CM axes: contour mode for them (none moving: TC 7; data left: TC 18)."""
        contour, motion = self.follow.contour, self.interp.fw.motion
        if arg.strip() == "?":
            return self.interp.data(self.interp.fmt(float(contour.busy), 1, 0))
        axes_set = syntax.parse_axes(arg, self.n)
        if axes_set.s or axes_set.t:
            raise GalilError(TC.S_OPERAND_NOT_VALID, "CM S/T")
        axes = list(axes_set.axes)
        if contour.on and contour.busy:
            raise GalilError(TC.NOT_VALID_CONTOURING)
        if any(motion.moving(a) for a in axes):
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        if self.follow.ecam.engaged[axes].any():
            raise GalilError(TC.NOT_VALID_PERFORMING_ECAM)
        contour.begin(axes)
        return self._done()

    def cd(self, arg: str) -> bytes | Trippoint:
        """CD: increments (+-32000) over the DT interval; DT 0 and CD 0 end the mode. Outside
        contour mode TC 8 (ASSUMPTION); increments with DT 0: TC 39 "No time specified"."""
        contour, interp = self.follow.contour, self.interp
        if not contour.on:
            raise GalilError(TC.NOT_VALID_WHEN_NOT_RUNNING, "CD without CM")
        inc = np.zeros(self.n)
        for a, field in interp.per_axis(arg):
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID, "CD")
            v = interp.value(str(field))
            if not abs(v) <= CD_LIMIT:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"CD {v}")
            inc[a] = round(v)
        if not contour.dt and inc.any():
            raise GalilError(TC.NO_TIME_SPECIFIED)
        if not contour.full:
            contour.push(inc)
            return self._done()
        from vdevd.devices.galil.interpreter import Trippoint

        def room() -> bool:  # the buffer is full: the command waits for space
            if contour.full:
                return False
            if contour.on:
                contour.push(inc)
            self.follow.refresh()
            return True

        return Trippoint(room)

    def dt(self, arg: str) -> bytes:
        """DT n: the interval of the next CDs, 2^n samples (1-8); 0 with CD 0 ends the mode."""
        contour = self.follow.contour
        if arg.strip() == "?":
            return self.interp.data(self.interp.fmt(contour.dt, 1, 0))
        v = self._flag("DT", arg)
        if v != int(v) or not 0 <= v <= DT_MAX:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"DT {v}")
        contour.dt = int(v)
        return OK

    def wc(self, arg: str) -> Trippoint:
        """WC: wait until the interval before the last one given is complete [M Ch6]."""
        from vdevd.devices.galil.interpreter import Trippoint

        contour = self.follow.contour
        return Trippoint(lambda: not contour.buffer)

    # -- stepper position maintenance [M Ch6 §SPM] ---------------------------------------------------
    def spm_param(self, name: str, arg: str) -> bytes:
        """YA (pulses per full step), YB (full steps per rev), YC (counts per rev)."""
        spm = self.follow.spm
        _, lo, hi = SPM_PARAMS[name]

        def check(a: int, v: float) -> float:
            if not lo <= v <= hi:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name} {v}")
            return float(round(v)) if name != "YA" else v

        got = self._values(name, arg, check, lambda: spm.values[name], (4, 0))
        if isinstance(got, bytes):
            return got
        spm.values[name][got[0]] = got[1]
        return OK

    def ys(self, arg: str) -> bytes:
        """YS 1 enables SPM, 0 disables; it reads 2 after an error [M Ch6 §Error Limit]."""
        spm = self.follow.spm
        got = self._values("YS", arg, _zero_or_one, lambda: spm.ys.astype(float), (1, 0))
        if isinstance(got, bytes):
            return got
        spm.ys[got[0]] = got[1]
        return self._done()

    def yr(self, arg: str) -> bytes:
        """YR n: the correction move of n pulses, given once the axis has stopped (TC 7)."""
        motion = self.interp.fw.motion
        got = self._values("YR", arg, lambda a, v: float(round(v)), lambda: np.zeros(self.n))
        if isinstance(got, bytes):
            return got
        axes, values = got
        if any(motion.moving(a) for a in axes):
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        for a, v in zip(axes, values, strict=True):
            motion.values["PR"][a] = v
            motion.mode[a] = Mode.PR
        motion.begin(axes)
        self.follow.spm.corrected[axes] += values
        return OK

    def qs(self, arg: str) -> bytes:
        """QS ?: the error magnitude in pulses (read only) [M Ch6 §SPM]."""
        spm = self.follow.spm
        got = self._values("QS", arg, _read_only, spm.error, (10, 4))
        assert isinstance(got, bytes)
        return got

    # -- sinusoidal commutation [M Ch2 Step 5, 7b] ---------------------------------------------------
    def ba(self, arg: str) -> bytes:
        """BA axes: sinusoidal commutation on them (BA alone: none)."""
        com = self.follow.commutation
        if arg.strip() == "?":
            return self.interp.data(",".join(str(int(s)) for s in com.sinusoidal))
        axes = list(syntax.parse_axes(arg, self.n).axes) if arg.strip() else []
        com.select(axes)
        return OK

    def b_param(self, name: str, arg: str) -> bytes:
        """BM (magnetic cycle, counts), BI (first Hall input), BB (Hall offset, degrees)."""
        com = self.follow.commutation
        store = {"BM": com.cycle, "BI": com.hall, "BB": com.hall_offset}[name]

        def check(a: int, v: float) -> float:
            ok = {"BM": 0 < abs(v) <= 1_000_000, "BI": v == int(v) and 0 <= v <= 6,
                  "BB": -360 <= v <= 360}[name]
            if not ok:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name} {v}")
            return v

        got = self._values(name, arg, check, lambda: store.astype(float),
                           (7, 3) if name == "BM" else (3, 0))
        if isinstance(got, bytes):
            return got
        com.require(got[0])
        store[got[0]] = got[1]
        return OK

    def bc(self, arg: str) -> bytes:
        """BC axes: calibrate the phase at the next Hall transition (armed only: no Halls)."""
        com = self.follow.commutation
        axes = self.interp.axes(arg)
        com.require(axes)
        com.calibrate[axes] = True
        return OK

    def bz(self, arg: str) -> bytes:
        """BZ v: drive to the zero phase with v volts; v > 0 ends MO, v < 0 SH; `BZ ?` the
        counts to the zero phase."""
        com, motion = self.follow.commutation, self.interp.fw.motion

        def check(a: int, v: float) -> float:
            if v == 0 or abs(v) > 10:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"BZ {v}")
            return v

        got = self._values("BZ", arg, check, com.to_zero)
        if isinstance(got, bytes):
            return got
        axes, volts = got
        com.require(axes)
        if any(motion.moving(a) for a in axes):
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        for a, v in zip(axes, volts, strict=True):
            com.zero_here([a], v)
        return OK

    def bs(self, arg: str) -> bytes:
        """BSx = v,t: the setup test (v volts, t ms per phase): checked and accepted, no result
        (no motor physics; see the README)."""
        assign = syntax.parse_axis_assign(arg, self.n)
        axes, text = assign if assign is not None else ([0], arg)
        fields = syntax.parse_fields(text, 2)
        if len(fields) < 2 or any(f is None or f is syntax.QUERY for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS, "BS")
        v, t = (self.interp.value(str(f)) for f in fields)
        if not (0 < abs(v) <= 10 and 0 < t <= 10_000):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, "BS")
        self.follow.commutation.require(axes)
        return OK


def _zero_or_one(a: int, v: float) -> float:
    if v not in (0, 1):
        raise GalilError(TC.NUMBER_OUT_OF_RANGE)
    return v


def _read_only(a: int, v: float) -> float:
    raise GalilError(TC.UNRECOGNIZED_COMMAND, "read only")


def operand(follow: Follow, name: str) -> float | None:
    """The operands of these modes (`_GRX`, `_EB`, `_CM`, `_QSX` ...), None for another name."""
    scalars: dict[str, Callable[[], float]] = {
        "EB": lambda: float(follow.ecam.enabled), "EC": lambda: float(follow.ecam.index),
        "EP": lambda: follow.ecam.interval, "CM": lambda: float(follow.contour.busy),
    }
    if name in scalars:
        return scalars[name]()
    cmd, letter = name[:2], name[2:]
    if len(letter) != 1 or letter not in _LETTERS:
        return None
    per_axis: dict[str, Callable[[], np.ndarray]] = {
        "GR": lambda: follow.gearing.ratio, "GM": lambda: follow.gearing.gantry,
        "EG": lambda: follow.ecam.engaged, "EQ": lambda: np.isfinite(follow.ecam.disengage_at),
        "EM": lambda: follow.ecam.cycle, "QS": follow.spm.error, "YS": lambda: follow.spm.ys,
        "YA": lambda: follow.spm.values["YA"], "YB": lambda: follow.spm.values["YB"],
        "YC": lambda: follow.spm.values["YC"], "BZ": follow.commutation.to_zero,
        "BM": lambda: follow.commutation.cycle, "BA": lambda: follow.commutation.sinusoidal,
    }
    if cmd not in per_axis:
        return None
    a = _LETTERS.index(letter) % 4
    if a >= follow.motion.n:
        raise GalilError(TC.ONLY_ABCD_VALID, name)
    return float(per_axis[cmd]()[a])
