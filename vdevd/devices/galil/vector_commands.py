"""The coordinated-motion commands of the DMC-13X8 (manual ch. 6 "Linear Interpolation Mode",
"Vector Mode: Linear and Circular Interpolation Motion"): LM LI LE, VM VP CR VE, VS VA VD VR VT,
TN, CS, CA, and BGS / STS / AMS through the interpreter's BG, ST, AM.

A mixin of `Interpreter` (the command table binds these methods by name); the planes and the
sampling are `coord.Coordinated`, the path `vector.Sequence`. A refused command changes nothing.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

from vdevd.devices.galil import syntax
from vdevd.devices.galil.coord import VIRTUAL, Coordinated, Plane
from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.params import Param
from vdevd.devices.galil.vector import MAX_LENGTH, Segment, arc, line

if TYPE_CHECKING:
    from vdevd.devices.galil.firmware import Firmware
    from vdevd.devices.galil.interpreter import Trippoint

NO_SEQUENCE = 24  # "Begin not valid because no sequence defined"
SEGMENT_TOO_SHORT = 30  # "Sequence segment too short"
DISTANCE_TOO_LONG = 31  # "Total move distance in a sequence > 2 billion"
BUFFER_FULL = 32  # "More than 511 segments in a sequence"
MIXED_SEGMENTS = 33  # "VP or CR commands cannot be mixed with LI commands"

#: the vector parameters: VS as SP, VA/VD as AC/DC but exact and up to the example's
#: "maximum" 68 000 000 [M Ch6 §Sinusoidal Motion Example; spec §1.3, §8 q5], VR 0-10 in
#: steps of 0.0001 [M Ch6 §Changing Feedrate], VT as IT
VECTOR_PARAMS: dict[str, tuple[str, Param]] = {
    "VS": ("vs", Param(25_000, 0, 12_000_000, 0, 8, 0)),
    "VA": ("va", Param(256_000, 1024, 68_431_360, 0, 8, 0)),
    "VD": ("vd", Param(256_000, 1024, 68_431_360, 0, 8, 0)),
    "VR": ("vr", Param(1, 0, 10, 1e-4, 2, 4)),
    "VT": ("vt", Param(1, 0.004, 1, 1 / 256, 1, 4)),
}
_SPEEDS = re.compile(r"([<>])\s*([^<>]*)")
_COORD = 2_147_483_647.0


class VectorCommands:
    """Handlers of the coordinated-motion commands (mixed into `Interpreter`)."""

    fw: Firmware
    n: int

    if TYPE_CHECKING:
        def value(self, text: str) -> float: ...
        def fmt(self, value: float, digits: int, frac: int) -> str: ...
        @staticmethod
        def data(text: str) -> bytes: ...

    @property
    def coord(self) -> Coordinated:
        return self.fw.coord

    # -- modes ------------------------------------------------------------------------------------
    def _lm(self, arg: str) -> bytes:
        """LM axes: linear interpolation of those axes; LM? the free buffer spaces [M Ch6]."""
        plane = self.coord.plane
        if arg.strip() == "?":
            return self.data(self.fmt(plane.seq.free, 3, 0))
        sel = syntax.parse_axes(arg, self.n)
        if sel.s or sel.t or not sel.axes:
            raise GalilError(TC.OPERAND_ERROR)
        self._idle(plane)
        plane.set_mode("LM", tuple(sel.axes))
        return b":"

    def _vm(self, arg: str) -> bytes:
        """VM m,n[,p]: the pair of the path (N: the virtual axis) and the tangent axis p (N: none);
        the commas are optional [M Ch6 §Vector Mode, §Tangent Motion]."""
        letters = [c for c in arg.upper() if c not in " ,"]
        if len(letters) not in (2, 3):
            raise GalilError(TC.OPERAND_ERROR if len(letters) > 3 else TC.NOT_ENOUGH_FIELDS)
        pair = tuple(VIRTUAL if c == "N" else syntax.axis_index(c, self.n) for c in letters[:2])
        tangent = None
        if len(letters) == 3 and letters[2] != "N":
            tangent = syntax.axis_index(letters[2], self.n)
        if pair[0] == pair[1] or tangent in pair or pair == (VIRTUAL, VIRTUAL):
            raise GalilError(TC.OPERAND_ERROR)
        plane = self.coord.plane
        self._idle(plane)
        plane.set_mode("VM", pair, tangent)
        return b":"

    def _ca(self, arg: str) -> bytes:
        """CA S / CA T: the plane vector commands address [M Ch6 §Specifying the Coordinate
        Plane]; CA? reports it (0 S, 1 T)."""
        text = arg.strip().upper()
        if text == "?":
            return self.data(self.fmt("ST".index(self.coord.current), 1, 0))
        if text not in ("S", "T"):
            raise GalilError(TC.OPERAND_ERROR)
        self.coord.current = text
        return b":"

    def _idle(self, plane: Plane) -> None:
        if plane.running:
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)

    # -- segments ---------------------------------------------------------------------------------
    def _speeds(self, arg: str) -> tuple[str, float | None, float | None]:
        """Split `x,y <n >m` into the fields and the speeds [M Ch6 §Specifying Vector Speed for
        Each Segment]."""
        cut = min((i for i in (arg.find("<"), arg.find(">")) if i >= 0), default=len(arg))
        speed = end_speed = None
        for sign, text in _SPEEDS.findall(arg[cut:]):
            v = self.value(text)
            if not 0 <= v <= 12_000_000:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE)
            if sign == "<":
                speed = v
            else:
                end_speed = v
        return arg[:cut], speed, end_speed

    def _plane_for(self, mode: str) -> Plane:
        """The addressed plane in `mode`: none set is an operand error, the other mode TC 33."""
        plane = self.coord.plane
        if plane.mode is None:
            raise GalilError(TC.OPERAND_ERROR, "no LM or VM")
        if plane.mode != mode:
            raise GalilError(MIXED_SEGMENTS)
        seq = plane.seq
        if plane.running and seq.ended:
            raise GalilError(TC.NOT_VALID_WHILE_RUNNING)
        if not seq.done and seq.free <= 0:
            raise GalilError(BUFFER_FULL)
        return plane

    def _add(self, plane: Plane, seg: Segment) -> bytes:
        if seg.length < 1e-9:
            raise GalilError(SEGMENT_TOO_SHORT)
        if seg.length > MAX_LENGTH:
            raise GalilError(DISTANCE_TOO_LONG)
        plane.fresh().add(seg)
        return b":"

    def _coordinate(self, text: str) -> float:
        v = self.value(text)
        if not -_COORD <= v <= _COORD:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        return float(round(v))

    def _li(self, arg: str) -> bytes:
        """LI x,y,z,w <n >m: a segment of increments of the LM axes [M Ch6 §Specifying Linear
        Segments]; a field for an axis not in LM is an operand error."""
        plane = self._plane_for("LM")
        body, speed, end_speed = self._speeds(arg)
        fields = syntax.parse_fields(body, self.n)
        if not any(f is not None for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        delta = [0.0] * len(plane.axes)
        for a, field in enumerate(fields):
            if field is None:
                continue
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID)
            if a not in plane.axes:
                raise GalilError(TC.OPERAND_ERROR, f"axis {a} is not in LM")
            delta[plane.axes.index(a)] = self._coordinate(str(field))
        start = plane.seq.last_end if not plane.seq.done else (0.0,) * len(plane.axes)
        end = tuple(s + d for s, d in zip(start, delta, strict=True))
        return self._add(plane, line(start, end, speed, end_speed))

    def _vp(self, arg: str) -> bytes:
        """VP m,n <n >m: a line to the point (m, n) of the sequence's local coordinates; a field
        left out keeps that coordinate [M Ch6 §Specifying Vector Segments]."""
        plane = self._plane_for("VM")
        body, speed, end_speed = self._speeds(arg)
        fields = syntax.parse_fields(body, 2)
        if not any(f is not None for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        start = plane.seq.last_end if not plane.seq.done else (0.0, 0.0)
        end = list(start)
        for d, field in enumerate(fields):
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID)
            if field is not None:
                end[d] = self._coordinate(str(field))
        return self._add(plane, line(start, (end[0], end[1]), speed, end_speed))

    def _cr(self, arg: str) -> bytes:
        """CR r,θ,Δθ <n >m: an arc of radius r from the angle θ through Δθ degrees, CCW positive
        [M Ch6 §Specifying Vector Segments]; radius 0 or Δθ 0 is a segment too short (TC 30)."""
        plane = self._plane_for("VM")
        body, speed, end_speed = self._speeds(arg)
        fields = syntax.parse_fields(body, 3)
        if len(fields) < 3 or any(f is None for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        if any(f is syntax.QUERY for f in fields):
            raise GalilError(TC.QUESTION_MARK_NOT_VALID)
        r, theta, dtheta = (self.value(str(f)) for f in fields)
        if not (0 <= r <= _COORD and math.isfinite(theta) and math.isfinite(dtheta)):
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        start = plane.seq.last_end if not plane.seq.done else (0.0, 0.0)
        return self._add(plane, arc((start[0], start[1]), r, theta, dtheta, speed, end_speed))

    def _le(self, arg: str) -> bytes:
        """LE / VE: the end of the sequence (decelerate to a stop after its last segment); `?`
        its length [M Ch6]."""
        plane = self.coord.plane
        if arg.strip() == "?":
            return self.data(self.fmt(self.coord.operand("LE") or 0.0, 10, 0))
        if plane.mode is not None and not plane.seq.done:
            plane.seq.ended = True
        return b":"

    def _cs(self, arg: str) -> bytes:
        """CS [S|T]: clear the segments given before the motion [M Ch6]."""
        sel = syntax.parse_axes(arg, self.n) if arg.strip() else None
        planes = [self.coord.plane] if sel is None else self.coord.planes_named(sel.s, sel.t)
        if sel is not None and (sel.axes and not (sel.s or sel.t)):
            raise GalilError(TC.OPERAND_ERROR)
        for plane in planes:
            self._idle(plane)
        for plane in planes:
            if plane.mode is not None:
                plane.set_mode(plane.mode, plane.axes, plane.tangent)
        return b":"

    # -- parameters -------------------------------------------------------------------------------
    def _vector_param(self, name: str, arg: str) -> bytes:
        """VS VA VD VR VT s,t: the S and T planes' values (`?` reports them) [M Ch6]."""
        attr, param = VECTOR_PARAMS[name]
        fields = syntax.parse_fields(arg, 2)
        if not fields:
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        planes = (self.coord.planes["S"], self.coord.planes["T"])
        if any(f is syntax.QUERY for f in fields):
            return self.data(",".join(self.fmt(getattr(planes[i], attr), param.digits, param.frac)
                                      for i, f in enumerate(fields) if f is syntax.QUERY))
        values: list[tuple[Plane, float]] = []
        for plane, field in zip(planes, fields, strict=False):
            if field is None:
                continue
            v = param.coerce(self.value(str(field)))
            if v is None:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{name} {field}")
            values.append((plane, v))
        for plane, v in values:
            setattr(plane, attr, v)
            if attr == "vs":
                plane.seq.speed = None  # VS replaces a segment's `<n` in force
        return b":"

    def _es(self, arg: str) -> bytes:
        """ES m,n: the counts of VM's first and second axis for the same distance; the path is
        then in the lower resolution's counts and the higher-resolution axis moves by the ratio
        [M Ch6 §Compensating for Differences in Encoder Resolution]. Taken at the next BG S;
        `ES ?` reports them. 1..65535 each (TC 6 outside)."""
        plane = self.coord.plane
        fields = syntax.parse_fields(arg, 2)
        if not fields:
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        if any(f is syntax.QUERY for f in fields):
            return self.data(",".join(self.fmt(v, 5, 0) for v in plane.es))
        self._idle(plane)
        es = list(plane.es)
        for k, f in enumerate(fields):
            if f is None:
                continue
            v = self.value(str(f))
            if v != int(v) or not 1 <= v <= 65535:
                raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"ES {v}")
            es[k] = float(v)
        plane.es = (es[0], es[1])
        return b":"

    def _tn(self, arg: str) -> bytes:
        """TN m,n: the tangent axis's scale (counts per degree) and its position at 0 degrees
        [M Ch6 §Tangent Motion]."""
        fields = syntax.parse_fields(arg, 2)
        if not fields or any(f is syntax.QUERY for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS if not fields else TC.QUESTION_MARK_NOT_VALID)
        plane = self.coord.plane
        self._idle(plane)
        values = [None if f is None else self._coordinate_float(str(f)) for f in fields]
        if values[0] is not None:
            plane.tn_scale = values[0]
        if len(values) > 1 and values[1] is not None:
            plane.tn_offset = values[1]
        return b":"

    def _coordinate_float(self, text: str) -> float:
        v = self.value(text)
        if not -_COORD <= v <= _COORD:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE)
        return v

    def _av(self, arg: str) -> Trippoint:
        """AV s,t: wait until the S (T) plane's path has travelled s (t) counts from its start,
        or its sequence has ended [M Ch6 §Linear Interpolation Mode, #LMOVE; §Trippoints]."""
        from vdevd.devices.galil.interpreter import Trippoint

        fields = syntax.parse_fields(arg, 2)
        if not fields or all(f is None for f in fields):
            raise GalilError(TC.NOT_ENOUGH_FIELDS)
        waits: list[tuple[Plane, float]] = []
        for plane, field in zip((self.coord.planes["S"], self.coord.planes["T"]), fields,
                                strict=False):
            if field is syntax.QUERY:
                raise GalilError(TC.QUESTION_MARK_NOT_VALID)
            if field is not None:
                v = self.value(str(field))
                if not 0 <= v <= MAX_LENGTH:
                    raise GalilError(TC.NUMBER_OUT_OF_RANGE)
                waits.append((plane, v))
        return Trippoint(lambda: all(not p.running or p.seq.out >= d - 1e-9 for p, d in waits))

    # -- begin (BG S / BG T) ----------------------------------------------------------------------
    def _check_sequences(self, s: bool, t: bool, axes: tuple[int, ...]) -> list[Plane]:
        """BGS, BGT (with the independent `axes` of the same BG): the planes to begin, checked
        [M Ch6]: no sequence TC 24, running or an axis moving (or also begun on its own) TC 21,
        a motor off TC 20, an axis heading into a limit TC 22."""
        coord, motion = self.coord, self.fw.motion
        planes = coord.planes_named(s, t)
        independent = set(axes)
        for plane in planes:
            seq = plane.seq
            if plane.running:
                raise GalilError(TC.BEGIN_WHILE_RUNNING)
            if plane.mode is None or seq.done or seq.started or not seq.waiting:
                raise GalilError(NO_SEQUENCE)
            used = [a for a in (*plane.axes, plane.tangent) if a is not None and a != VIRTUAL]
            if any(not motion.core.servo_on_mask[a] for a in used):
                raise GalilError(TC.BEGIN_WITH_MOTOR_OFF)
            if any(motion.moving(a) or a in independent for a in used):
                raise GalilError(TC.BEGIN_WHILE_RUNNING)
            if coord.blocked(plane):
                raise GalilError(TC.BEGIN_LIMIT_SWITCH)
        return planes
