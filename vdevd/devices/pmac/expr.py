"""Turbo PMAC expressions: operators, functions and variables [A §"Turbo PMAC Mathematical Features",
L944-1404; spec pmac.md §1.4].

`* / % &` bind tighter than `+ - | ^`; equal priorities go left to right [A §"+" L954]. Operands
are constants (10, 2.5, .5, $F0), variables (I123, P1, Q30, M1, P(expr)), function calls
(SIN(expr)) and parenthesised groups; a leading `-` negates, a leading `+` is rejected [A L956].
Letters are case-insensitive and spaces between tokens are skipped. `parse` builds a tree once
(a PLC or motion program line is parsed when it is downloaded); `Expr.eval` reads the card
through an `Env` and computes in IEEE doubles: the caller quantises at storage (numbers.py).
"""

from __future__ import annotations

import math
import re
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from vdevd.devices.pmac.numbers import SATURATION, round_to_int

DATA_ERROR = 3  # ERR003: data error or unrecognized command [spec pmac.md §2.4]
VARIABLE_KINDS = frozenset("IPQM")
#: ASSUMPTION: nesting of parentheses, calls, indices and unary minus; deeper is ERR003
MAX_NESTING = 64
#: ASSUMPTION: bitwise operators see a two's-complement fixed-point value with this many fraction
#: bits (exact for any stored float of magnitude 0.25 or more) [spec pmac.md §1.4]
FRACTION_BITS = 36

_NUMBER = re.compile(r"\d+\.?\d*|\.\d+", re.ASCII)
_HEX = re.compile(r"\$([0-9A-Fa-f]+)", re.ASCII)
_WORD = re.compile(r"ATAN2|[A-Z]+", re.ASCII | re.IGNORECASE)  # the one name with a digit
_DIGITS = re.compile(r"\d+", re.ASCII)
_HIGH = "*/%&"  # multiplication, division, modulo, and [A §"*" L974]
_LOW = "+-|^"  # addition, subtraction, or, exclusive or


class ExprError(Exception):
    """An expression the card rejects; `code` is the PMAC error number (ERRnnn)."""

    def __init__(self, code: int = DATA_ERROR, message: str = "") -> None:
        super().__init__(message or f"ERR{code:03d}")
        self.code = code


class Env(Protocol):
    """What an expression reads from the card."""

    def get(self, kind: str, n: int) -> float:
        """Variable `kind` ("I", "P", "Q" or "M") number n; ExprError(3) if n is out of range."""
        ...

    def q0(self) -> float:
        """Q0 of the addressed coordinate system: ATAN2's "cosine" argument [A §ATAN2 L1203]."""
        ...

    @property
    def radians(self) -> bool:
        """I15 = 1: angles in radians; I15 = 0 (default): degrees [A §ACOS L1134]."""
        ...


class Expr(ABC):
    """A parsed expression."""

    @abstractmethod
    def eval(self, env: Env) -> float:
        """The expression's value (an IEEE double, not yet quantised)."""


@dataclass(frozen=True)
class Constant(Expr):
    value: float

    def eval(self, env: Env) -> float:
        return self.value


@dataclass(frozen=True)
class Variable(Expr):
    """`P1` (index Constant(1)) or `P(expr)`; a computed index is rounded to nearest (ASSUMPTION)."""

    kind: str
    index: Expr

    def eval(self, env: Env) -> float:
        return env.get(self.kind, round_to_int(self.index.eval(env)))


@dataclass(frozen=True)
class Negate(Expr):
    """Unary minus [A §"-" L964]."""

    operand: Expr

    def eval(self, env: Env) -> float:
        return 0.0 - self.operand.eval(env)  # never -0.0: a PMAC float has no negative zero


@dataclass(frozen=True)
class Call(Expr):
    name: str
    arg: Expr

    def eval(self, env: Env) -> float:
        return FUNCTIONS[self.name](self.arg.eval(env), env)


@dataclass(frozen=True)
class Chain(Expr):
    """Operators of one priority applied left to right: first op1 x1 op2 x2 ..."""

    first: Expr
    rest: tuple[tuple[str, Expr], ...]

    def eval(self, env: Env) -> float:
        value = self.first.eval(env)
        for op, operand in self.rest:
            value = OPERATORS[op](value, operand.eval(env))
        return value


def divide(a: float, b: float) -> float:
    """Always floating point; a zero divisor saturates to +-2**47 with the dividend's sign, no
    error [A §"/" L982, L988]. ASSUMPTION: 0/0 gives +2**47."""
    if b == 0:
        return -SATURATION if a < 0 else SATURATION
    return a / b


def modulo(x: float, n: float) -> float:
    """Remainder with the quotient floored [A §"%" L1008-1014]: 0 <= r < n for n > 0,
    -|n| <= r < |n| for n < 0 (x - 2|n| floor((x+|n|)/2|n|), spec pmac.md §1.4), 0 for n = 0."""
    if n == 0:
        return 0.0
    if n > 0:
        return x % n
    m = -n
    return (x + m) % (2 * m) - m


def _fixed(x: float) -> int:
    """`x` in two's-complement fixed point; NaN is 0 and magnitudes clamp to 2**47 (ASSUMPTION)."""
    if math.isnan(x):
        return 0
    return round(math.ldexp(max(-SATURATION, min(SATURATION, x)), FRACTION_BITS))


def _bitwise(op: Callable[[int, int], int]) -> Callable[[float, float], float]:
    """& | ^ act on integer and fractional bits [A §"&" L1036]."""
    return lambda a, b: math.ldexp(op(_fixed(a), _fixed(b)), -FRACTION_BITS)


OPERATORS: dict[str, Callable[[float, float], float]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": divide,
    "%": modulo,
    "&": _bitwise(lambda a, b: a & b),
    "|": _bitwise(lambda a, b: a | b),
    "^": _bitwise(lambda a, b: a ^ b),
}


def _angle(x: float, env: Env) -> float:
    """An inverse function's result in the I15 unit."""
    return x if env.radians else math.degrees(x)


def _sin(x: float, env: Env) -> float:
    """In degrees, multiples of 90 give exact results (SIN(180) = 0, not 1.2e-16)."""
    if env.radians:
        return math.sin(x)
    r = x % 360.0
    return {0.0: 0.0, 90.0: 1.0, 180.0: 0.0, 270.0: -1.0}.get(r, math.sin(math.radians(r)))


def _cos(x: float, env: Env) -> float:
    if env.radians:
        return math.cos(x)
    r = x % 360.0
    return {0.0: 1.0, 90.0: 0.0, 180.0: -1.0, 270.0: 0.0}.get(r, math.cos(math.radians(r)))


def _tan(x: float, env: Env) -> float:
    """Exactly at +-(2N-1)*90 degrees the internal sin/cos division by zero saturates at +-2**47
    [A §TAN L1395], with the sign of the sine (TAN(90) = 2**47, TAN(-90) = -2**47). In radians no
    double is exactly a pole: the result is just very large."""
    if env.radians:
        return math.tan(x)
    r = x % 180.0
    if r == 90.0:
        return divide(_sin(x, env), 0.0)
    return 0.0 if r == 0.0 else math.tan(math.radians(r))


def _atan2(sine: float, env: Env) -> float:
    """atan2(expr, Q0) [A §ATAN2 L1203-1207]; both exactly 0 -> 0 (the manual: "arbitrary")."""
    cosine = env.q0()
    if sine == 0 and cosine == 0:
        return 0.0
    return _angle(math.atan2(sine + 0.0, cosine + 0.0), env)  # + 0.0: no -0.0, so no -180


def _clamp_unit(x: float) -> float:
    """ACOS/ASIN outside -1..1 return "an arbitrary value" [A L1138, L1164]: we clamp."""
    return max(-1.0, min(1.0, x))


def _exp(x: float, env: Env) -> float:
    """Beyond a double's range the result saturates at the largest double (the PMAC float
    reaches 2**2047)."""
    try:
        return math.exp(x)
    except OverflowError:
        return sys.float_info.max


#: Functions of one argument [A §"Mathematical Functions" L1096-1404]
FUNCTIONS: dict[str, Callable[[float, Env], float]] = {
    "ABS": lambda x, env: abs(x),
    "ACOS": lambda x, env: _angle(math.acos(_clamp_unit(x)), env),
    "ASIN": lambda x, env: _angle(math.asin(_clamp_unit(x)), env),  # range +-90, not "0 to Pi" [A L1157]
    "ATAN": lambda x, env: _angle(math.atan(x), env),
    "ATAN2": _atan2,
    "COS": _cos,
    "EXP": _exp,
    "INT": lambda x, env: float(math.floor(x)) if math.isfinite(x) else x,  # toward -inf [A L1295]
    "LN": lambda x, env: math.log(x) if x > 0 else 0.0,  # "a 0 value will be returned" [A L1329]
    "SIN": _sin,
    "SQRT": lambda x, env: math.sqrt(abs(x)),  # negative: "arbitrary value" [A L1371]: sqrt(|x|)
    "TAN": _tan,
}


def parse(text: str, pos: int = 0) -> tuple[Expr, int]:
    """Parse one expression starting at text[pos]; return it and the index of the first
    character after it that is not a space (len(text) at the end of the text).

    The expression ends at the first token that cannot continue it: after an operand, anything
    but a binary operator or the `)` of an open group (`P1=5 P2=6`, `P1=5 M2`, the `)` of
    `X(Q80*COS(Q81))`). Note `P1=5 &1` and `P1=5 %50` continue the expression (5&1, 5%50).
    ExprError(3) for a missing operand, an unbalanced `(`, an unknown function or a unary `+`.
    """
    parser = _Parser(text, pos)
    expr = parser.expression()
    return expr, parser.skip_spaces()


def evaluate(text: str, env: Env) -> float:
    """The value of the whole of `text` (spaces around it allowed); ExprError(3) if anything is
    left over after the expression."""
    expr, end = parse(text)
    if end != len(text):
        raise ExprError(DATA_ERROR, f"{text[end:]!r} after the expression")
    return expr.eval(env)


class _Parser:
    """Recursive descent: expression = term {low-op term}; term = unary {high-op unary};
    unary = "-" unary | operand."""

    def __init__(self, text: str, pos: int) -> None:
        self.text = text
        self.pos = pos
        self.depth = 0

    def skip_spaces(self) -> int:
        while self.pos < len(self.text) and self.text[self.pos] == " ":
            self.pos += 1
        return self.pos

    def peek(self) -> str:
        """The next character that is not a space ("" at the end); moves past the spaces."""
        i = self.skip_spaces()
        return self.text[i] if i < len(self.text) else ""

    def error(self, what: str) -> ExprError:
        return ExprError(DATA_ERROR, f"{what} at column {self.pos} of {self.text!r}")

    def expression(self) -> Expr:
        return self.chain(_LOW, self.term)

    def term(self) -> Expr:
        return self.chain(_HIGH, self.unary)

    def chain(self, ops: str, operand: Callable[[], Expr]) -> Expr:
        first = operand()
        rest: list[tuple[str, Expr]] = []
        while (op := self.peek()) and op in ops:
            self.pos += 1
            rest.append((op, operand()))
        return Chain(first, tuple(rest)) if rest else first

    def unary(self) -> Expr:
        char = self.peek()
        if char == "+":
            raise self.error("unary +")  # "This syntax will be rejected with an error" [A L956]
        if char != "-":
            return self.operand()
        self.pos += 1
        return Negate(self.nested(self.unary))

    def nested(self, parse_inner: Callable[[], Expr]) -> Expr:
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise self.error("nesting too deep")
        inner = parse_inner()
        self.depth -= 1
        return inner

    def group(self) -> Expr:
        """`( expression )`, the `(` already consumed."""
        inner = self.nested(self.expression)
        if self.peek() != ")":
            raise self.error("missing )")
        self.pos += 1
        return inner

    def operand(self) -> Expr:
        char = self.peek()
        if char == "(":
            self.pos += 1
            return self.group()
        if match := _NUMBER.match(self.text, self.pos):
            self.pos = match.end()
            return Constant(float(match[0]))
        if match := _HEX.match(self.text, self.pos):
            self.pos = match.end()
            return Constant(float(int(match[1], 16)))
        if match := _WORD.match(self.text, self.pos):
            self.pos = match.end()
            return self.named(match[0].upper())
        raise self.error("missing operand")

    def named(self, word: str) -> Expr:
        """A function call, `I123`-style variable or indexed `P(expr)`; letters already consumed."""
        if word in VARIABLE_KINDS and (digits := _DIGITS.match(self.text, self.pos)):
            self.pos = digits.end()
            return Variable(word, Constant(float(digits[0])))
        if (word in VARIABLE_KINDS or word in FUNCTIONS) and self.peek() == "(":
            self.pos += 1
            arg = self.group()
            return Variable(word, arg) if word in VARIABLE_KINDS else Call(word, arg)
        raise self.error(f"unknown name {word}")
