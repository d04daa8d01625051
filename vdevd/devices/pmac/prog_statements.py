"""Motion-program statements: the words a `PROG` buffer takes beyond the PLC language that
buffers.py parses [spec pmac.md §2.8; Turbo SRM "Program Command Specification"; UM "Writing and
Executing Motion Programs"].

A line is parsed statement by statement when it is entered (ERR003 for one the card does not
know: the line is not stored). Keywords are case- and space-insensitive (`Dwell 0`, `TA 100`)
and take their short forms (`LIN`, `RPD`, `DWE`, `DLY`, `HM`, `HMZ`, `RET`, `CIR1`, `SPL1`).
`{data}` is a constant or an expression (`X(P1+2)`, `DWELL(P2)`).

Operations (the tuples buffers.compile_lines strings together), besides buffers.py's:
``("move", ((axis, expr, vel_expr | None), ...), ((vector, expr), ...))`` an axis move
(axis 0-8 in coord.AXES order; `X10:5` gives a PVT end velocity; I J K R vectors, circle data),
``("mode", name, expr | None)`` LINEAR RAPID CIRCLE1 CIRCLE2 SPLINE1 SPLINE2 PVT(time),
``("absinc", inc, axes | None)``, ``("param", "TA"|"TS"|"TM"|"F", expr)``, ``("frax", axes)``,
``("dwell", expr)``, ``("delay", expr)``, ``("home", zero, motors)``, ``("label", n)``,
``("goto", expr)``, ``("gosub", expr, args)``, ``("call", expr, args)``, ``("return",)``,
``("read", letters)``, ``("stop",)``, ``("wait",)``, ``("pset", ((axis, expr), ...))``,
``("normal", ((vector, expr), ...))``, ``("radius", inc)`` (ABS(R)/INC(R)); `args`
are ((letter, expr), ...) after GOSUB/CALL.
"""

from __future__ import annotations

import re

from vdevd.devices.pmac import buffers, expr
from vdevd.devices.pmac.buffers import Statement
from vdevd.devices.pmac.coord import AXES
from vdevd.devices.pmac.errors import ERR_DATA, CommandError

_SP = r"[ ]*"
#: move modes (the first name is the one the runner knows; the rest are short forms)
MODES = {"LINEAR": "LINEAR", "LIN": "LINEAR", "RAPID": "RAPID", "RPD": "RAPID",
         "CIRCLE1": "CIRCLE1", "CIR1": "CIRCLE1", "CIRCLE2": "CIRCLE2", "CIR2": "CIRCLE2",
         "SPLINE1": "SPLINE1", "SPL1": "SPLINE1", "SPLINE2": "SPLINE2", "SPL2": "SPLINE2"}
_MODE = re.compile("(" + "|".join(sorted(MODES, key=len, reverse=True)) + r")(?![A-Z])")
_PVT = re.compile(rf"PVT{_SP}")
_ABSINC = re.compile(rf"(ABS|INC)(?![A-Z]){_SP}")
_FRAX = re.compile(rf"(NOFRAX|FRAX)(?![A-Z]){_SP}")
_PARAM = re.compile(rf"(TA|TS|TM|F)(?=[ 0-9.(\-$PQMI]){_SP}")
_TIMED = re.compile(rf"(DWELL|DWE|DELAY|DLY)(?![A-Z]){_SP}")
_HOME = re.compile(rf"(HOMEZ|HMZ|HOME|HM)(?![A-Y]){_SP}")
_JUMP = re.compile(rf"(GOTO|GOSUB|CALL)(?![A-Z]){_SP}")
_RETURN = re.compile(r"(RETURN|RET)(?![A-Z])")
_READ = re.compile(rf"READ{_SP}\(")
_LABEL = re.compile(rf"([NO]){_SP}(\d+)(?![\d.])")
_STOP = re.compile(r"STOP(?![A-Z])")
_WAIT = re.compile(r"WAIT(?![A-Z])")
_BLOCK = re.compile(rf"BLOCK{_SP}(START|STOP)(?![A-Z])")
_NORMAL = re.compile(rf"NORMAL{_SP}")
_RADIUS_MODE = re.compile(rf"(ABS|INC){_SP}\({_SP}R{_SP}\)")
_PSET = re.compile(rf"PSET{_SP}")
_AXIS = re.compile(rf"([{AXES}]){_SP}(?=[0-9.(\-+$])")
_VECTOR = re.compile(rf"([IJKR]){_SP}(?=[0-9.(\-+$])")
_ARG = re.compile(rf"([A-Z]){_SP}(?=[0-9.(\-$])")
#: a label number [SRM "N{constant}": 0 to 262,143]
MAX_LABEL = 262_143
#: motors HOME may name
MAX_MOTORS = 32


def parse_statement(s: str, i: int) -> tuple[Statement, int]:
    """The statement at s[i] (i past spaces) and the index after it: a motion-program word, else
    one of buffers.py's (IF, WHILE, CMD, assignments ...); CommandError(3) if none."""
    if m := _MODE.match(s, i):
        return _op("mode", MODES[m.group(1)], None), m.end()
    if m := _PVT.match(s, i):
        e, j = _data(s, m.end())
        return _op("mode", "PVT", e), j
    if m := _RADIUS_MODE.match(s, i):  # ABS(R)/INC(R): circle centre vectors [SRM]
        return _op("radius", m.group(1) == "INC"), m.end()
    if m := _NORMAL.match(s, i):
        vectors: list[tuple[str, expr.Expr]] = []
        j = m.end()
        while v := _VECTOR.match(s, j):
            if v.group(1) == "R" or any(n == v.group(1) for n, _ in vectors):
                raise CommandError(ERR_DATA, "NORMAL takes I, J, K once each")
            e, j = _data(s, v.end())
            vectors.append((v.group(1), e))
            j = buffers.skip(s, j)
        if not vectors:
            raise CommandError(ERR_DATA, "NORMAL needs a vector")
        return _op("normal", tuple(vectors)), j
    if m := _ABSINC.match(s, i):
        axes, j = _axis_list(s, m.end(), optional=True)
        return _op("absinc", m.group(1) == "INC", axes), j
    if m := _FRAX.match(s, i):
        if m.group(1) == "NOFRAX":
            return _op("frax", ()), m.end()
        axes, j = _axis_list(s, m.end(), optional=True)
        return _op("frax", tuple(range(len(AXES))) if axes is None else axes), j
    if m := _TIMED.match(s, i):
        e, j = _data(s, m.end())
        return _op("dwell" if m.group(1).startswith("DW") else "delay", e), j
    if m := _HOME.match(s, i):
        motors, j = _motor_list(s, m.end())
        return _op("home", m.group(1).endswith("Z"), motors), j
    if m := _JUMP.match(s, i):
        e, j = _data(s, m.end())
        if m.group(1) == "GOTO":
            return _op("goto", e), j
        args, j = _arguments(s, j)
        return _op(m.group(1).lower(), e, args), j
    if m := _RETURN.match(s, i):
        return _op("return"), m.end()
    if m := _READ.match(s, i):
        letters, j = _letters(s, m.end())
        return _op("read", letters), j
    if m := _STOP.match(s, i):
        return _op("stop"), m.end()
    if m := _WAIT.match(s, i):
        return _op("wait"), m.end()
    if m := _BLOCK.match(s, i):  # BLOCKSTART/BLOCKSTOP: one S runs the block [SRM]
        return _op("block", m.group(1) == "START"), m.end()
    if m := _PSET.match(s, i):
        st, j = _move(s, m.end())
        assert st.op is not None
        if not st.op[1] or st.op[2] or any(v is not None for _, _, v in st.op[1]):
            raise CommandError(ERR_DATA, "PSET takes axes and values")
        return _op("pset", tuple((k, e) for k, e, _ in st.op[1])), j
    if m := _LABEL.match(s, i):
        n = int(m.group(2))
        if n > MAX_LABEL:
            raise CommandError(ERR_DATA, "label above 262143")
        return _op("label", n), m.end()
    if _AXIS.match(s, i) and not _is_keyword(s, i):
        return _move(s, i)
    if m := _PARAM.match(s, i):
        e, j = _data(s, m.end())
        return _op("param", m.group(1), e), j
    return buffers.parse_statement(s, i)


def parse_line(text: str) -> list[Statement]:
    """Every statement of a normalised program line; CommandError(3) at the first that is not
    one."""
    out: list[Statement] = []
    i = buffers.skip(text, 0)
    while i < len(text):
        st, i = parse_statement(text, i)
        out.append(st)
        i = buffers.skip(text, i)
    return out


def _op(*op: object) -> Statement:
    return Statement("OP", tuple(op))


def _is_keyword(s: str, i: int) -> bool:
    """`A`/`C`/`W` starting a word buffers.py knows (ADDRESS, AND, CMD, WHILE ...)."""
    return bool(re.match(r"(ADDRESS|ADR|AND|CMD|COMMAND|WHILE)(?![A-Z])", s[i:]))


def _data(s: str, i: int) -> tuple[expr.Expr, int]:
    try:
        return expr.parse(s, buffers.skip(s, i))
    except expr.ExprError as exc:
        raise CommandError(exc.code) from None


def _move(s: str, i: int) -> tuple[Statement, int]:
    """`X10 Y(P1) Z5:20 I3 J4`: the axes (each once), their PVT velocities, then the circle
    vector and radius."""
    axes: list[tuple[int, expr.Expr, expr.Expr | None]] = []
    triggers: dict[int, expr.Expr] = {}
    seen: set[int] = set()
    while (m := _AXIS.match(s, i)) and not _is_keyword(s, i):
        k = AXES.index(m.group(1))
        if k in seen:
            raise CommandError(ERR_DATA, "an axis twice in one move")
        seen.add(k)
        value, j = _data(s, m.end())
        caret = _top_level_caret(s, m.end(), j)
        if caret >= 0:  # `X10^2`: the trigger's `^`, not XOR (XOR in parentheses: `X(10^2)`)
            value, j = _data(s[:caret], m.end())
        vel = None
        j2 = buffers.skip(s, j)
        if s.startswith(":", j2):
            vel, j = _data(s, j2 + 1)
        elif s.startswith("^", j2):  # move until trigger [SRM "{axis}{data}^{data}"]
            trigger, j = _data(s, j2 + 1)
            triggers[k] = trigger
        axes.append((k, value, vel))
        i = buffers.skip(s, j)
    vectors: list[tuple[str, expr.Expr]] = []
    while m := _VECTOR.match(s, i):
        if any(v == m.group(1) for v, _ in vectors):
            raise CommandError(ERR_DATA, "a vector twice in one move")
        value, j = _data(s, m.end())
        vectors.append((m.group(1), value))
        i = buffers.skip(s, j)
    if triggers:  # every axis with its post-trigger distance, nothing else (ASSUMPTION)
        if vectors or len(triggers) != len(axes):
            raise CommandError(ERR_DATA, "a move until trigger gives ^ for each axis")
        return _op("trigmove", tuple((k, e, triggers[k]) for k, e, _ in axes)), i
    return _op("move", tuple(axes), tuple(vectors)), i


def _top_level_caret(s: str, i: int, j: int) -> int:
    """Where the first `^` outside parentheses is in s[i:j], else -1."""
    depth = 0
    for k in range(i, j):
        c = s[k]
        depth += (c == "(") - (c == ")")
        if c == "^" and depth == 0:
            return k
    return -1


def _axis_list(s: str, i: int, optional: bool) -> tuple[tuple[int, ...] | None, int]:
    """`(X,Y,Z)` after ABS/INC/FRAX; None when absent (every axis)."""
    if not s.startswith("(", i):
        if optional:
            return None, i
        raise CommandError(ERR_DATA)
    m = re.compile(rf"\({_SP}([{AXES}](?:{_SP},{_SP}[{AXES}])*){_SP}\)").match(s, i)
    if m is None:
        raise CommandError(ERR_DATA, "bad axis list")
    return tuple(sorted({AXES.index(a) for a in re.findall(r"[A-Z]", m.group(1))})), m.end()


def _motor_list(s: str, i: int) -> tuple[tuple[int, ...], int]:
    """`1`, `1,3`, `1..4` (HOME/HOMEZ): the motors, each 1-32."""
    m = re.compile(rf"(\d+)(?:{_SP}\.\.{_SP}(\d+)|(?:{_SP},{_SP}\d+)*)").match(s, i)
    if m is None:
        raise CommandError(ERR_DATA, "HOME needs motors")
    if m.group(2):
        motors = tuple(range(int(m.group(1)), int(m.group(2)) + 1))
    else:
        motors = tuple(int(n) for n in re.findall(r"\d+", m.group(0)))
    if not motors or any(not 1 <= n <= MAX_MOTORS for n in motors):
        raise CommandError(ERR_DATA, "motor 1-32")
    return motors, m.end()


def _letters(s: str, i: int) -> tuple[str, int]:
    """`A,B,X)` after `READ(`."""
    m = re.compile(rf"{_SP}([A-Z](?:{_SP},{_SP}[A-Z])*){_SP}\)").match(s, i)
    if m is None:
        raise CommandError(ERR_DATA, "bad READ list")
    return "".join(re.findall(r"[A-Z]", m.group(1))), m.end()


def _arguments(s: str, i: int) -> tuple[tuple[tuple[str, expr.Expr], ...], int]:
    """The `{letter}{data}` pairs after GOSUB/CALL on the same line: what READ reads [SRM
    READ] (ASSUMPTION: every such pair that follows is an argument)."""
    args: list[tuple[str, expr.Expr]] = []
    j = buffers.skip(s, i)
    while (m := _ARG.match(s, j)) and not s.startswith("=", buffers.skip(s, m.end())):
        value, k = _data(s, m.end())
        if s.startswith("=", buffers.skip(s, k)):
            break
        args.append((m.group(1), value))
        i = k
        j = buffers.skip(s, k)
    return tuple(args), i
