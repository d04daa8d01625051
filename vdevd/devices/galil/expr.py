"""DMC expressions: evaluated strictly left to right in 32.16 fixed point (spec galil.md §4.1, §4.5
"Programming and flow").

`MG 1+2*3` prints 9: there is no operator precedence, only parentheses force an order [CR-DUMP
"*", "( )"]. Operands are numbers (1000, .5, $FF), `_` operands (_TPX) and TIME, variables (V1,
spx), array elements (POS[C]) and @ functions; the card's state is reached through an `Env`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import Protocol

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.numbers import MAX_VALUE, MIN_VALUE, SCALE, fixed, units


class Env(Protocol):
    """What an expression reads from the card; each raises GalilError with the card's TC code
    for a name it does not know."""

    def operand(self, name: str) -> float:
        """`_TPX` -> operand("TPX"); TIME -> operand("TIME") [M Ch5 §Operands]."""
        ...

    def variable(self, name: str) -> float:
        """A variable's value (names are case-sensitive)."""
        ...

    def array(self, name: str, index: int) -> float:
        """An array element NAME[index] [M Ch6 §Multiple Moves]."""
        ...

    def function(self, name: str, arg: float) -> float:
        """@IN[n], @OUT[n], @AN[n] and any @ function this module does not compute [M Ch3]."""
        ...


def _degrees(fn: Callable[[float], float]) -> Callable[[float], float]:
    return lambda x: fn(math.radians(x))


def _inverse_degrees(fn: Callable[[float], float]) -> Callable[[float], float]:
    def inverse(x: float) -> float:
        if not -1 <= x <= 1:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{x} outside -1..1")
        return math.degrees(fn(x))

    return inverse


def _complement(x: float) -> float:
    return float(~math.trunc(x))  # NOT of the 32-bit integer: @COM[0] = $FFFFFFFF = -1


#: @ functions computed here, angles in degrees [CR-DUMP @ABS ... @TAN]: @INT truncates
#: (@INT[-2.4] = -2), @FRAC keeps the sign (-0.4), @RND rounds halves up (@RND[-5.5] = -5),
#: @SQR takes the absolute value first
MATH_FUNCTIONS: dict[str, Callable[[float], float]] = {
    "ABS": abs,
    "INT": lambda x: float(math.trunc(x)),
    "FRAC": lambda x: x - math.trunc(x),
    "RND": lambda x: float(math.floor(x + 0.5)),
    "SQR": lambda x: math.sqrt(abs(x)),
    "SIN": _degrees(math.sin),
    "COS": _degrees(math.cos),
    "TAN": _degrees(math.tan),
    "ASIN": _inverse_degrees(math.asin),
    "ACOS": _inverse_degrees(math.acos),
    "ATAN": lambda x: math.degrees(math.atan(x)),
    "COM": _complement,
}

TIME = "TIME"  # the free-running clock, an operand without underscore [CR-DUMP special operands]
MAX_NAME_LENGTH = 8
MAX_DEPTH = 32  # nesting of ( and [

_NUMBER = re.compile(r"\d+\.?\d*|\.\d+", re.ASCII)
_HEX = re.compile(r"([0-9A-Fa-f]+)(?:\.([0-9A-Fa-f]{0,4}))?")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9]*")
_OPERAND = re.compile(r"[A-Za-z0-9]+")
_OPERATORS = ("<=", ">=", "<>", "+", "-", "*", "/", "&", "|", "=", "<", ">")


def _checked(value: float) -> float:
    value = fixed(value)
    if not MIN_VALUE <= value <= MAX_VALUE:
        raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"{value} outside the 32.16 range")
    return value


def _bits(op: Callable[[int, int], int]) -> Callable[[float, float], float]:
    """& and | act on the whole 32.16 word [CR-DUMP "( )": var1&(var2/$10) = 0]."""
    return lambda a, b: op(units(a), units(b)) / SCALE


def _divide(a: float, b: float) -> float:
    if b == 0:
        raise GalilError(TC.NUMBER_OUT_OF_RANGE, "division by zero")
    return a / b


_APPLY: dict[str, Callable[[float, float], float]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": _divide,
    "&": _bits(lambda a, b: a & b),
    "|": _bits(lambda a, b: a | b),
    "=": lambda a, b: float(a == b),
    "<": lambda a, b: float(a < b),
    ">": lambda a, b: float(a > b),
    "<=": lambda a, b: float(a <= b),
    ">=": lambda a, b: float(a >= b),
    "<>": lambda a, b: float(a != b),
}


def evaluate(text: str, env: Env) -> float:
    """The value of a DMC expression, left to right, each step rounded to 1/65536.

    Errors (TC): a result outside the 32.16 range or division by zero 6 (the card answers '?'
    to both); a missing or malformed value 83; a character that starts nothing or text after a
    complete expression 1; unbalanced parentheses (or nesting deeper than 32) 59; a missing [
    or ] 55; an @ without a name 57; unknown names are the env's to report.
    """
    parser = _Parser(text, env)
    value = parser.expression(0)
    parser.skip_spaces()
    if parser.pos < len(text):
        if text[parser.pos] == ")":
            raise GalilError(TC.MISMATCHED_PARENTHESES, repr(text))
        if text[parser.pos] == "]":
            raise GalilError(TC.MISSING_BRACKET, repr(text))
        raise GalilError(TC.UNRECOGNIZED_COMMAND, f"{text[parser.pos:]!r} after the expression")
    return value


class _Parser:
    """Recursive descent over the text that evaluates as it reads (no tree: one pass)."""

    def __init__(self, text: str, env: Env) -> None:
        self.text = text
        self.env = env
        self.pos = 0

    def skip_spaces(self) -> None:
        while self.pos < len(self.text) and self.text[self.pos] == " ":
            self.pos += 1

    def expression(self, depth: int) -> float:
        if depth > MAX_DEPTH:
            raise GalilError(TC.MISMATCHED_PARENTHESES, "nested too deep")
        value = self.operand(depth)
        while (op := self.operator()) is not None:
            value = _checked(_APPLY[op](value, self.operand(depth)))
        return value

    def operator(self) -> str | None:
        self.skip_spaces()
        for op in _OPERATORS:
            if self.text.startswith(op, self.pos):
                self.pos += len(op)
                return op
        return None

    def operand(self, depth: int) -> float:
        self.skip_spaces()
        if self.pos >= len(self.text):
            raise GalilError(TC.NOT_A_VALID_NUMBER, f"value expected at the end of {self.text!r}")
        char = self.text[self.pos]
        if char in "-+":
            self.pos += 1
            value = self.operand(depth + 1)
            return _checked(-value) if char == "-" else value
        if char == "(":
            self.pos += 1
            value = self.expression(depth + 1)
            self.expect(")", TC.MISMATCHED_PARENTHESES)
            return value
        if char.isdigit() or char == ".":
            return self.number()
        if char == "$":
            return self.hex_number()
        if char == "_":
            self.pos += 1
            return _checked(self.env.operand(self.take(_OPERAND, TC.UNRECOGNIZED_COMMAND)))
        if char == "@":
            self.pos += 1
            return self.function(depth)
        if char.isalpha():
            return self.name(depth)
        if char == ")":
            raise GalilError(TC.MISMATCHED_PARENTHESES, repr(self.text))
        if char == "]":
            raise GalilError(TC.MISSING_BRACKET, repr(self.text))
        if any(self.text.startswith(op, self.pos) for op in _OPERATORS):
            raise GalilError(TC.NOT_A_VALID_NUMBER, f"value expected at {self.text[self.pos:]!r}")
        raise GalilError(TC.UNRECOGNIZED_COMMAND, f"{char!r} in {self.text!r}")

    def take(self, pattern: re.Pattern[str], code: TC) -> str:
        match = pattern.match(self.text, self.pos)
        if match is None:
            raise GalilError(code, repr(self.text[self.pos:]))
        self.pos = match.end()
        return match.group()

    def expect(self, char: str, code: TC) -> None:
        self.skip_spaces()
        if not self.text.startswith(char, self.pos):
            raise GalilError(code, f"{char!r} expected in {self.text!r}")
        self.pos += 1

    def end_of_token(self) -> None:
        """A number runs into a letter, digit or second point: "1.2.3", "10X" are not numbers."""
        if self.pos < len(self.text) and (self.text[self.pos].isalnum() or self.text[self.pos] in "._$"):
            raise GalilError(TC.NOT_A_VALID_NUMBER, repr(self.text))

    def number(self) -> float:
        value = float(self.take(_NUMBER, TC.NOT_A_VALID_NUMBER))
        self.end_of_token()
        return _checked(value)

    def hex_number(self) -> float:
        """$FF; 32-bit two's complement ($FFFFFFFF = -1), optional hex fraction ($0.F = 0.9375)."""
        self.pos += 1
        match = _HEX.match(self.text, self.pos)
        if match is None:
            raise GalilError(TC.NOT_A_VALID_NUMBER, repr(self.text))
        self.pos = match.end()
        self.end_of_token()
        whole, fraction = match.group(1), match.group(2) or ""
        if len(whole.lstrip("0")) > 8:
            raise GalilError(TC.NUMBER_OUT_OF_RANGE, f"${whole} is wider than 32 bits")
        integer = int(whole, 16)
        integer -= (1 << 32) if integer >= 1 << 31 else 0
        return integer + (int(fraction, 16) / 16 ** len(fraction) if fraction else 0.0)

    def bracketed(self, depth: int) -> float:
        """The [expr] of a function or array element."""
        self.expect("[", TC.MISSING_BRACKET)
        value = self.expression(depth + 1)
        self.expect("]", TC.MISSING_BRACKET)
        return value

    def function(self, depth: int) -> float:
        name = self.take(_NAME, TC.BAD_FUNCTION)
        arg = self.bracketed(depth)
        compute = MATH_FUNCTIONS.get(name)
        return _checked(compute(arg) if compute is not None else self.env.function(name, arg))

    def name(self, depth: int) -> float:
        name = self.take(_NAME, TC.UNRECOGNIZED_COMMAND)
        if name == TIME:
            return _checked(self.env.operand(TIME))
        if len(name) > MAX_NAME_LENGTH:
            raise GalilError(TC.VARIABLE_ERROR, f"{name!r} is longer than {MAX_NAME_LENGTH} characters")
        self.skip_spaces()
        if not self.text.startswith("[", self.pos):
            return _checked(self.env.variable(name))
        index = self.bracketed(depth)
        if index != int(index):
            raise GalilError(TC.ARRAY_INDEX_INVALID, f"{name}[{index}]")
        return _checked(self.env.array(name, int(index)))
