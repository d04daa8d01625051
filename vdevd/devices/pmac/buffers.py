"""Program-buffer statements: parsing one line of a PLC (later: motion-program) buffer into
statements, and compiling a buffer into a flat list of operations [spec pmac.md §2.8, §2.9].

A line is checked when it is entered, as the card checks it: a statement the card does not know
answers ERR003 and the line is not stored. Structure (IF/ELSE/ENDIF, WHILE/ENDWHILE) is checked at
CLOSE: an unmatched one is ERR009 [A L3235]. Keywords are case- and space-insensitive (`End
While`, `ENDWHILE`, `ENDW`, `Endif`, `ENDI`).

Compiled operations (`Op`) are tuples whose first element names them:
``("set", kind, index, value)``, ``("if", cond, target)`` (jump to `target` when false),
``("jump", target)``, ``("while", cond, target)``, ``("endwhile", target)`` (back to the WHILE;
the scan ends there), ``("cmd", text)``, ``("send", port, text)`` (port "", "S" or "P"),
``("enable", plcs)``, ``("disable", plcs)``, ``("pause", plcs)``, ``("resume", plcs)``,
``("address", motor, cs)``.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from vdevd.devices.pmac import expr
from vdevd.devices.pmac.errors import ERR_DATA, CommandError
from vdevd.devices.pmac.reply import Reply

#: lines one buffer holds, characters a line holds, lines all buffers hold (ERR006 beyond)
MAX_LINES = 4096
MAX_LINE = 256
MAX_TOTAL = 32768
#: IF/WHILE nesting depth accepted at CLOSE (deeper: ERR009)
MAX_NESTING = 32
ERR_NO_ROOM = 6
ERR_STRUCTURE = 9

_SP = r"[ ]*"
_END_WHILE = re.compile(rf"END{_SP}(?:WHILE|W)(?![A-Z])")
_END_IF = re.compile(rf"END{_SP}(?:IF|I)(?![A-Z])")
_IF = re.compile(rf"IF{_SP}\(")
_WHILE = re.compile(rf"WHILE{_SP}\(")
_ELSE = re.compile(r"ELSE")
_CONTINUE = re.compile(rf"(AND|OR){_SP}\(")
_CMD = re.compile(rf"(?:COMMAND|CMD){_SP}\"([^\"]*)\"")
#: CMD^{c}: the control character CTRL-{c} as if from the host [SRM p.424 "CMD^D", "CMD^K"]
_CMD_CTRL = re.compile(rf"(?:COMMAND|CMD){_SP}\^{_SP}([A-Z])")
_SEND = re.compile(rf"SEND{_SP}([SP]?){_SP}\"([^\"]*)\"")
_PLC_CONTROL = re.compile(
    rf"(ENABLE|ENA|DISABLE|DIS|PAUSE|RESUME){_SP}PLC(C?){_SP}(\d+(?:{_SP},{_SP}\d+)*)")
#: compiled PLC n is program PLCC_BASE + n (plc.py)
PLCC_BASE = 32
_ADDRESS = re.compile(rf"(?:ADDRESS|ADR){_SP}(?:#{_SP}(\d+))?{_SP}(?:&{_SP}(\d+))?")
_VARIABLE = re.compile(rf"([IPQM]){_SP}(\d+|\()")
_ASSIGN = re.compile(rf"{_SP}==?{_SP}")
_COMPARE = re.compile(rf"{_SP}(!=|!>|!<|=|>|<)")
_LOGIC = re.compile(rf"{_SP}(AND|OR)(?![A-Z])")

#: a condition: OR of ANDs of (lhs, comparator, rhs) or nested conditions
Cond = tuple[tuple[Any, ...], ...]
Op = tuple[Any, ...]


@dataclass(frozen=True)
class Statement:
    """One statement of a line: `kind` is IF, WHILE, ELSE, ENDIF, ENDWHILE, AND, OR (a
    condition continued on its own line) or OP."""

    kind: str
    op: Op | None = None
    cond: Cond | None = None


def normalise(text: str) -> str:
    """The line as the card keeps it: comment removed, upper case, tabs as spaces, trimmed."""
    return text.split(";", 1)[0].upper().replace("\t", " ").strip()


def skip(s: str, i: int) -> int:
    while i < len(s) and s[i] == " ":
        i += 1
    return i


def parse_statement(s: str, i: int) -> tuple[Statement, int]:
    """The statement at s[i] (i past spaces) and the index after it; CommandError(3) if none."""
    if m := _END_WHILE.match(s, i):
        return Statement("ENDWHILE"), m.end()
    if m := _END_IF.match(s, i):
        return Statement("ENDIF"), m.end()
    for kind, pattern in (("IF", _IF), ("WHILE", _WHILE)):
        if m := pattern.match(s, i):
            cond, j = parse_condition(s, m.end())
            return Statement(kind, cond=cond), j
    if m := _ELSE.match(s, i):
        return Statement("ELSE"), m.end()
    if m := _CONTINUE.match(s, i):  # `AND (cond)` / `OR (cond)`: the condition goes on
        cond, j = parse_condition(s, m.end())
        return Statement(m.group(1), cond=cond), j
    if m := _CMD.match(s, i):
        return Statement("OP", ("cmd", m.group(1))), m.end()
    if m := _CMD_CTRL.match(s, i):  # the control character's text, run by plc.py's queue
        return Statement("OP", ("cmd", chr(ord(m.group(1)) - 64))), m.end()
    if m := _SEND.match(s, i):  # SEND / SENDS / SENDP "message" (plc.py)
        return Statement("OP", ("send", m.group(1), m.group(2))), m.end()
    if m := _PLC_CONTROL.match(s, i):
        plcs = tuple(int(n) for n in re.findall(r"\d+", m.group(3)))
        if any(n > 31 for n in plcs):
            raise CommandError(ERR_DATA, "PLC number above 31")
        if m.group(2):  # ENABLE/DISABLE PLCC n
            plcs = tuple(PLCC_BASE + n for n in plcs)
        name = {"E": "enable", "D": "disable", "P": "pause", "R": "resume"}[m.group(1)[0]]
        return Statement("OP", (name, plcs)), m.end()
    if (m := _ADDRESS.match(s, i)) and (m.group(1) or m.group(2)):
        motor = int(m.group(1)) if m.group(1) else 0
        cs = int(m.group(2)) if m.group(2) else 0
        if not 0 <= motor <= 32 or not 0 <= cs <= 16:
            raise CommandError(ERR_DATA)
        return Statement("OP", ("address", motor, cs)), m.end()
    if m := _VARIABLE.match(s, i):
        kind = m.group(1)
        if m.group(2) == "(":
            index, j = _expression(s, m.end())
            if not s.startswith(")", j):
                raise CommandError(ERR_DATA, "missing )")
            j += 1
        else:
            index, j = expr.Constant(float(m.group(2))), m.end()
        a = _ASSIGN.match(s, j)
        if a is None:
            raise CommandError(ERR_DATA, "a variable alone is not a PLC statement")
        value, j = _expression(s, a.end())
        return Statement("OP", ("set", kind, index, value)), j
    raise CommandError(ERR_DATA, f"not a PLC statement: {s[i:]!r}")


def _expression(s: str, i: int) -> tuple[expr.Expr, int]:
    try:
        return expr.parse(s, i)
    except expr.ExprError as exc:
        raise CommandError(exc.code) from None


def parse_condition(s: str, i: int) -> tuple[Cond, int]:
    """`cond )` with the opening `(` consumed: simple conditions `a op b` or nested `( cond )`
    joined by AND and OR (AND binds first: README assumption); the index after the `)`."""
    groups: list[tuple[Any, ...]] = []
    terms: list[Any] = []
    while True:
        i = skip(s, i)
        term, i = _simple(s, i)
        terms.append(term)
        i = skip(s, i)
        if s.startswith(")", i):
            groups.append(tuple(terms))
            return tuple(groups), i + 1
        m = _LOGIC.match(s, i)
        if m is None:
            raise CommandError(ERR_DATA, "condition: expected AND, OR or )")
        if m.group(1) == "OR":
            groups.append(tuple(terms))
            terms = []
        i = m.end()


def _simple(s: str, i: int) -> tuple[Any, int]:
    if s.startswith("(", i):  # a nested condition, else a parenthesised expression
        try:
            cond, j = parse_condition(s, i + 1)
            return ("nested", cond), j
        except CommandError:
            pass
    lhs, j = _expression(s, i)
    m = _COMPARE.match(s, j)
    if m is None:
        raise CommandError(ERR_DATA, "condition: expected a comparator")
    rhs, j = _expression(s, m.end())
    return (m.group(1), lhs, rhs), j


def parse_line(text: str) -> list[Statement]:
    """Every statement of a normalised line; CommandError(3) at the first that is not one."""
    out: list[Statement] = []
    i = skip(text, 0)
    while i < len(text):
        st, i = parse_statement(text, i)
        out.append(st)
        i = skip(text, i)
    return out


def compile_lines(lines: list[str],
                  parse: Callable[[str], list[Statement]] | None = None,
                  line_of: list[int] | None = None) -> list[Op]:
    """The buffer's operations; CommandError(9) for an unmatched IF/ELSE/ENDIF/WHILE/ENDWHILE.
    `parse` parses one line (motion programs: prog_statements.parse_line; default PLC lines).

    A line `IF (c) stmts` or `WHILE (c) stmts` with statements after the condition is a
    single-line IF or WHILE: it needs no ENDIF/ENDWHILE and takes no ELSE (README assumption).
    `line_of`, when given, receives the line number of each operation (PC/PE reports)."""
    ops: list[Op] = []
    stack: list[tuple[str, int]] = []  # ("IF"|"ELSE"|"WHILE", index of the op to patch)

    def error() -> CommandError:
        return CommandError(ERR_STRUCTURE, "unmatched IF/ELSE/ENDIF/WHILE/ENDWHILE")

    for number, line in enumerate(lines):
        sts = (parse or parse_line)(line)
        single = bool(sts) and sts[0].kind in ("IF", "WHILE") and len(sts) > 1
        if single and any(st.kind != "OP" for st in sts[1:]):
            raise error()
        for k, st in enumerate(sts):
            if st.kind in ("IF", "WHILE"):
                if len(stack) >= MAX_NESTING:
                    raise error()
                stack.append((st.kind, len(ops)))
                ops.append((st.kind.lower(), st.cond, -1))
            elif st.kind == "ELSE":
                if not stack or stack[-1][0] != "IF":
                    raise error()
                _, at = stack.pop()
                stack.append(("ELSE", len(ops)))
                ops.append(("jump", -1))
                ops[at] = (*ops[at][:2], len(ops))
            elif st.kind in ("AND", "OR"):  # only on the line after an IF or WHILE line
                if k or not stack or stack[-1][1] != len(ops) - 1 or len(sts) > 1:
                    raise error()
                name, cond, target = ops[-1]
                a, b = ("nested", cond), ("nested", st.cond)
                joined = ((a, b),) if st.kind == "AND" else ((a,), (b,))
                ops[-1] = (name, joined, target)
            elif st.kind == "ENDIF":
                _close(ops, stack, ("IF", "ELSE"), error)
            elif st.kind == "ENDWHILE":
                _close(ops, stack, ("WHILE",), error)
            else:
                assert st.op is not None
                ops.append(st.op)
            if single and k == len(sts) - 1:
                _close(ops, stack, (sts[0].kind, ), error)
        if line_of is not None:
            line_of.extend([number] * (len(ops) - len(line_of)))
    if stack:
        raise error()
    return ops


def _close(ops: list[Op], stack: list[tuple[str, int]], kinds: tuple[str, ...], error: Any) -> None:
    if not stack or stack[-1][0] not in kinds:
        raise error()
    kind, at = stack.pop()
    if kind == "WHILE":
        ops.append(("endwhile", at))
        ops[at] = (*ops[at][:2], len(ops))
    elif kind == "ELSE":
        ops[at] = ("jump", len(ops))
    else:
        ops[at] = (*ops[at][:2], len(ops))


_CONTROL_WORDS = ("CLOSE", "CLEAR", "LIST", "OPEN")


def enter_line(text: str, lines: list[str], list_words: tuple[str, ...], *,
               parse: Callable[[str, int], tuple[Any, int]], append: Callable[[str], None],
               close: Callable[[], None], execute: Callable[[str], Reply]) -> Reply:
    """A line from the port that has a PLC or PROG buffer open [spec §2.8, §2.9; A L3234]:
    CLOSE, CLEAR, LIST and OPEN act (CLOSE/OPEN end the line's buffer part, the rest of the line
    runs on-line through `execute`; `LIST` alone or with one of `list_words` lists the open
    buffer `lines`, another LIST runs on-line); the statements between them are checked with
    `parse` and go to `append` as one line (ERR003: none of the line is kept)."""
    reply = Reply()
    s = normalise(text)
    if len(s) > MAX_LINE:
        reply.error = ERR_DATA
        return reply
    i, start, end = skip(s, 0), -1, -1
    try:
        while i < len(s):
            word = next((w for w in _CONTROL_WORDS if s.startswith(w, i)), "")
            if word:
                append(s[start:end] if start >= 0 else "")
                start = -1
                if word in ("CLOSE", "OPEN"):
                    if word == "CLOSE":
                        close()
                        i += len(word)
                    rest = execute(s[i:])
                    reply.lines.extend(rest.lines)
                    reply.error = rest.error
                    return reply
                i += len(word)
                if word == "CLEAR":
                    lines.clear()
                elif s[i:].strip() in ("", *list_words):  # LIST: the open buffer
                    reply.lines.extend(lines)
                    i = len(s)
                else:  # LIST PLC n, LIST GATHER ...: on-line
                    rest = execute(s[i - 4:])
                    reply.lines.extend(rest.lines)
                    reply.error = rest.error
                    return reply
            else:
                _, j = parse(s, i)
                start = i if start < 0 else start
                end = j
                i = j
            i = skip(s, i)
        append(s[start:end] if start >= 0 else "")
    except CommandError as exc:
        reply.error = exc.code
    return reply

