"""DMC expressions: strictly left to right, 32.16 fixed point, operands, arrays, @ functions
(vdevd/devices/galil/expr.py)."""

from __future__ import annotations

import operator
from collections.abc import Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vdevd.devices.galil.errors import TC, GalilError
from vdevd.devices.galil.expr import Env, evaluate
from vdevd.devices.galil.numbers import MAX_VALUE, MIN_VALUE, fixed

RESOLUTION = 1 / 65536


class DictEnv:
    """A card's state as plain dicts; unknown names fail with the codes a card would use."""

    def __init__(
        self,
        operands: dict[str, float] | None = None,
        variables: dict[str, float] | None = None,
        arrays: dict[str, list[float]] | None = None,
        functions: dict[str, dict[int, float]] | None = None,
    ) -> None:
        self.operands = operands or {}
        self.variables = variables or {}
        self.arrays = arrays or {}
        self.functions = functions or {}

    def operand(self, name: str) -> float:
        if name not in self.operands:
            raise GalilError(TC.UNRECOGNIZED_COMMAND, name)
        return self.operands[name]

    def variable(self, name: str) -> float:
        if name not in self.variables:
            raise GalilError(TC.VARIABLE_ERROR, name)
        return self.variables[name]

    def array(self, name: str, index: int) -> float:
        if name not in self.arrays:
            raise GalilError(TC.BAD_FUNCTION, name)
        if not 0 <= index < len(self.arrays[name]):
            raise GalilError(TC.ARRAY_INDEX_INVALID, f"{name}[{index}]")
        return self.arrays[name][index]

    def function(self, name: str, arg: float) -> float:
        if name not in self.functions or int(arg) not in self.functions[name]:
            raise GalilError(TC.BAD_FUNCTION, name)
        return self.functions[name][int(arg)]


ENV = DictEnv(
    operands={"TPX": 1234, "DEX": 9990, "TEX": -8, "TC": 1, "TIME": 5000, "LM": 0},
    variables={"V1": 1000, "V2": 30, "C": 2, "spx": 100, "var1": 0x1F, "var2": 0xF, "COUNT": 749},
    arrays={"POS": [0, 10, 20, 30], "VX": [float(n) for n in range(750)]},
    functions={"IN": {1: 1, 2: 0}, "OUT": {1: 0}, "AN": {1: 1.7883}},
)


def value(text: str) -> float:
    return evaluate(text, ENV)


def error_code(text: str) -> int:
    with pytest.raises(GalilError) as info:
        evaluate(text, ENV)
    return info.value.code


def test_the_env_protocol_is_satisfied_by_a_dict_env() -> None:
    env: Env = ENV
    assert evaluate("1", env) == 1


# -- left to right -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "result"),
    [
        ("1+2*3", 9),  # MG 1+2*3 [spec §4.1, CR-DUMP]
        ("1+(2*3)", 7),
        ("10*30-60/30", 8),
        ("((10*30)-(60/30))", 298),
        ("10*30+60/30", 12),
        ("((10*30)+(60/30))", 302),
        ("(2 + 3) * 2", 10),
        ("10-4-3", 3),
        ("100/10/2", 5),
        (" ( 1 + 2 ) * 3 ", 9),
    ],
)
def test_operators_apply_strictly_left_to_right(text: str, result: float) -> None:
    assert value(text) == result


@given(
    st.integers(min_value=-1000, max_value=1000),
    st.lists(st.tuples(st.sampled_from("+-*"), st.integers(min_value=0, max_value=100_000)), max_size=8),
)
def test_a_chain_of_operators_is_a_left_fold(first: int, steps: list[tuple[str, int]]) -> None:
    ops: dict[str, Callable[[int, int], int]] = {"+": operator.add, "-": operator.sub, "*": operator.mul}
    text, expected, overflow = str(first), first, False
    for op, operand in steps:
        text += f"{op}{operand}"
        expected = ops[op](expected, operand)
        overflow = overflow or not MIN_VALUE <= expected <= MAX_VALUE
    if overflow:
        assert error_code(text) == TC.NUMBER_OUT_OF_RANGE
    else:
        assert value(text) == expected


def test_unary_minus_applies_to_the_next_operand() -> None:
    assert value("-V1/2") == -500  # PR -V1/2 [M Ch2 Ex14]
    assert value("V1*-2") == -2000
    assert value("- 1") == -1  # AI - 1 [M Ch6 §ECAM example]
    assert value("--5") == 5
    assert value("+5") == 5
    assert value("-_TEX/4+V1") == 1002  # [M Ch6 §Backlash compensation]


# -- numbers -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "result"),
    [("1000", 1000), ("-0.5", -0.5), (".5", 0.5), ("1.", 1), ("0007", 7), ("-2147483647", -2147483647),
     ("$FF", 255), ("$ff", 255), ("$FFFFFFFF", -1), ("$7FFFFFFF", 2147483647), ("$0.F", 0.9375),
     ("$1F.8", 31.5)],
)
def test_decimal_and_hex_numbers(text: str, result: float) -> None:
    assert value(text) == result


def test_every_step_is_rounded_to_1_over_65536() -> None:
    assert value("1/3") == 21845 * RESOLUTION
    assert value("1/3*3") == 65535 * RESOLUTION  # rounded before the multiplication
    assert value("0.00001") == RESOLUTION
    assert value("0.000001") == 0


@pytest.mark.parametrize(
    "text",
    ["2147483647+1", "2147483647*2", "-2147483647-2", "99999999999", "$123456789", "1/0", "V1/(V2-30)"],
)
def test_out_of_range_and_division_by_zero_are_tc_6(text: str) -> None:
    assert error_code(text) == TC.NUMBER_OUT_OF_RANGE


# -- bitwise and comparisons -------------------------------------------------------------------


def test_bitwise_operators_act_on_the_32_16_word() -> None:
    assert value("$F&$F0") == 0
    assert value("$F|$F0") == 255
    assert value("var1&var2/$10") == 0.9375  # [CR-DUMP "( )"]
    assert value("var1&(var2/$10)") == 0
    assert value("1.5&1.25") == 1.0
    assert value("-1&3") == 3


@pytest.mark.parametrize(
    ("text", "result"),
    [("V1<10001", 1), ("V1=0", 0), ("V1=1000", 1), ("V1<>1000", 0), ("V1<>0", 1), ("V1<=1000", 1),
     ("V1>=1001", 0), ("V1>999", 1), ("_LM=0", 1), ("@ABS[V2]<2", 0), ("COUNT<750", 1),
     ("(V1=1000)&(V2=30)", 1), ("(V1=1)|(V2=30)", 1), ("(V1=1)|(V2=1)", 0), ("1+1=2", 1)],
)
def test_comparisons_give_1_or_0(text: str, result: float) -> None:
    assert value(text) == result


# -- operands, variables, arrays ---------------------------------------------------------------


def test_operands_variables_and_time_come_from_the_env() -> None:
    assert value("_TPX") == 1234
    assert value("10000-_DEX") == 10  # [M Ch6 §Backlash compensation]
    assert value("_TC") == 1
    assert value("TIME") == 5000
    assert value("_TIME") == 5000
    assert value("spx*2") == 200  # lower-case variable [M Ch6 §SPM]
    assert value("V1 + 2") == 1002


def test_array_elements_take_an_expression_index() -> None:
    assert value("POS[C]") == 20
    assert value("POS[C+1]") == 30
    assert value("POS [1]") == 10
    assert value("VX[COUNT]") == 749
    assert value("POS[POS[1]/10]") == 10


def test_array_errors() -> None:
    assert error_code("POS[1.5]") == TC.ARRAY_INDEX_INVALID
    assert error_code("POS[4]") == TC.ARRAY_INDEX_INVALID
    assert error_code("NOPE[1]") == TC.BAD_FUNCTION
    assert error_code("POS[1") == TC.MISSING_BRACKET


def test_unknown_names_are_the_envs_to_report() -> None:
    assert error_code("V9") == TC.VARIABLE_ERROR
    assert error_code("_ZZX") == TC.UNRECOGNIZED_COMMAND
    assert error_code("VERYLONGNAME") == TC.VARIABLE_ERROR


# -- functions ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "result"),
    [  # the values of [CR-DUMP @ABS ... @TAN]
        ("@ABS[-2147483647]", 2147483647),
        ("@INT[1.2]", 1),
        ("@INT[-2.4]", -2),
        ("@RND[1.2]", 1),
        ("@RND[1.6]", 2),
        ("@RND[-1.2]", -1),
        ("@RND[5.5]", 6),
        ("@RND[-5.5]", -5),
        ("@RND[-5.7]", -6),
        ("@SIN[0]", 0),
        ("@SIN[90]", 1),
        ("@SIN[180]", 0),
        ("@SIN[270]", -1),
        ("@COS[90]", 0),
        ("@COS[180]", -1),
        ("@ASIN[-1]", -90),
        ("@ACOS[0]", 90),
        ("@ATAN[0]", 0),
        ("@COM[0]", -1),
        ("@COM[$FFFFFFFF]", 0),
        ("@IN[1]", 1),
        ("@OUT[1]", 0),
        ("@AN[1]", fixed(1.7883)),
    ],
)
def test_functions(text: str, result: float) -> None:
    assert value(text) == result


@pytest.mark.parametrize(
    ("text", "result"),
    [("@FRAC[1.2]", 0.2), ("@FRAC[-2.4]", -0.4), ("@SQR[2]", 1.4142), ("@SQR[-2]", 1.4142),
     ("@TAN[23]", 0.4245), ("@ATAN[10]", 84.2894), ("@ATAN[-10]", -84.2894)],
)
def test_functions_to_four_decimals(text: str, result: float) -> None:
    assert value(text) == pytest.approx(result, abs=0.0001)


def test_functions_nest_and_mix_with_operators() -> None:
    assert value("-955*@SIN[V2]+V1") == 522.5  # V3=-955*@SIN[V2]+V1 [M Ch6 §Contour example]
    assert value("@INT[@ABS[-2.5]*2]") == 5
    assert value("@COM[@OUT[1]]&1") == 1  # toggle output 1 [CR-DUMP @COM]


def test_function_errors() -> None:
    assert error_code("@FOO[1]") == TC.BAD_FUNCTION
    assert error_code("@IN[9]") == TC.BAD_FUNCTION
    assert error_code("@[1]") == TC.BAD_FUNCTION
    assert error_code("@ABS 5") == TC.MISSING_BRACKET
    assert error_code("@ABS[5") == TC.MISSING_BRACKET
    assert error_code("@ASIN[2]") == TC.NUMBER_OUT_OF_RANGE
    assert error_code("@TAN[90]") == TC.NUMBER_OUT_OF_RANGE


# -- syntax errors -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "code"),
    [
        ("(1+2", TC.MISMATCHED_PARENTHESES),
        ("1+2)", TC.MISMATCHED_PARENTHESES),
        ("()", TC.MISMATCHED_PARENTHESES),
        ("(" * 40 + "1" + ")" * 40, TC.MISMATCHED_PARENTHESES),
        ("1]", TC.MISSING_BRACKET),
        ("", TC.NOT_A_VALID_NUMBER),
        ("1+", TC.NOT_A_VALID_NUMBER),
        ("*2", TC.NOT_A_VALID_NUMBER),
        ("1.2.3", TC.NOT_A_VALID_NUMBER),
        ("10X", TC.NOT_A_VALID_NUMBER),
        ("$", TC.NOT_A_VALID_NUMBER),
        ("$G", TC.NOT_A_VALID_NUMBER),
        (".", TC.NOT_A_VALID_NUMBER),
        ("1 2", TC.UNRECOGNIZED_COMMAND),
        ("#A", TC.UNRECOGNIZED_COMMAND),
        ("_", TC.UNRECOGNIZED_COMMAND),
        ('"AB"', TC.UNRECOGNIZED_COMMAND),
    ],
)
def test_malformed_expressions_give_their_tc_code(text: str, code: int) -> None:
    assert error_code(text) == code


def test_nesting_up_to_the_limit_is_fine() -> None:
    assert value("(" * 30 + "1" + ")" * 30) == 1
