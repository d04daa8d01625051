"""PMAC expressions: the addendum's examples, priorities, functions, where an expression ends
(vdevd/devices/pmac/expr.py)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vdevd.devices.pmac.expr import ExprError, evaluate, parse
from vdevd.devices.pmac.numbers import SATURATION, format_hex, format_value, round_to_int

LIMITS = {"I": 8191, "P": 8191, "Q": 8191, "M": 8191}


@dataclass
class DictEnv:
    """Variables as a dict keyed "P1"; unset ones read 0, numbers past 8191 are ERR003."""

    values: dict[str, float] = field(default_factory=dict)
    radians: bool = False

    def get(self, kind: str, n: int) -> float:
        if not 0 <= n <= LIMITS[kind]:
            raise ExprError(3, f"{kind}{n}")
        return self.values.get(f"{kind}{n}", 0.0)

    def q0(self) -> float:
        return self.values.get("Q0", 0.0)


def value(text: str, **values: float) -> float:
    return evaluate(text, DictEnv(values))


def shown(text: str, **values: float) -> str:
    return format_value(value(text, **values))


def test_division_is_floating_point() -> None:
    assert shown("10*2/3") == "6.666666667"  # P1=10*2/3 [A L997]
    assert shown("10*(2/3)") == "6.666666667"


def test_division_stored_to_an_integer_rounds() -> None:
    assert round_to_int(value("10*2/3")) == 7  # M1=10*2/3 [A L999]
    assert round_to_int(value("10*(2/3)")) == 7


def test_divide_by_zero_saturates_with_the_dividends_sign() -> None:
    assert value("5/0") == SATURATION
    assert value("-5/0") == -SATURATION
    assert value("P1/P2", P1=-1) == -SATURATION


def test_zero_divided_by_zero_is_positive_saturation() -> None:
    assert value("0/0") == SATURATION


@pytest.mark.parametrize(
    ("text", "result"),
    [("11%4", 3), ("-11%4", 1), ("11%-4", 3), ("-11%-4", -3),
     ("3%2.5", 0.5), ("-3%2.5", 2), ("3%-2.5", -2), ("-3%-2.5", 2)],
)
def test_modulo_examples(text: str, result: float) -> None:
    assert value(text) == result  # [A L1018-1028]


def test_modulo_by_zero_is_zero() -> None:
    assert value("7%0") == 0
    assert value("-7.5%0") == 0


def test_modulo_negative_divisor_range_includes_minus_n() -> None:
    assert value("4%-4") == -4
    assert value("-4%-4") == -4


@pytest.mark.parametrize(
    ("text", "result"),
    [("3&1", 1), ("3&2", 2), ("3&3", 3), ("3&4", 0), ("3&-3", 1),
     ("0.875&1.75", 0.75), ("0.875&-1.75", 0.25)],
)
def test_and_examples(text: str, result: float) -> None:
    assert value(text) == result  # [A L1042-1051]


@pytest.mark.parametrize(
    ("text", "result"),
    [("4|3", 7), ("3|2", 3), ("3|3", 3), ("$F0|$4", 0xF4), ("3|-3", -1), ("0.5|0.375", 0.875)],
)
def test_or_examples(text: str, result: float) -> None:
    assert value(text) == result  # [A L1065-1073]


def test_or_hex_example_prints_f4() -> None:
    assert format_hex(value("$F0|$4")) == "$F4"


def test_or_of_0_875_and_minus_1_75_deviates_from_printed_example_minus_0_375() -> None:
    # [A L1074] prints -0.375; two's complement (and a|b = a+b-(a&b) with 0.875&-1.75 = 0.25)
    # gives -1.125: spec pmac.md §1.4 CONFLICT / §6 question 1
    assert value("0.875|-1.75") == -1.125


@pytest.mark.parametrize(
    ("text", "result"),
    [("2^1", 3), ("2^2", 0), ("5^7", 2), ("$AA^$55", 0xFF), ("3^-3", -2), ("0.5^0.875", 0.375)],
)
def test_xor_examples(text: str, result: float) -> None:
    assert value(text) == result  # [A L1086-1094]


def test_xor_hex_example_prints_ff() -> None:
    assert format_hex(value("$AA^$55")) == "$FF"


@given(st.integers(-(2**40), 2**40), st.integers(-(2**40), 2**40))
def test_or_is_sum_minus_and_on_fixed_point_values(a: int, b: int) -> None:
    x, y = a / 1024, b / 1024
    env = DictEnv({"P1": x, "P2": y})
    assert evaluate("P1|P2", env) == x + y - evaluate("P1&P2", env)


@pytest.mark.parametrize(
    ("text", "result"),
    [("2+3*4", 14), ("10-2-3", 5), ("1|2&3", 3), ("4|1&2", 4), ("2*3+4*5", 26), ("12/2/3", 2),
     ("7-2*3", 1), ("1+2^3", 0), ("(2+3)*4", 20), ("2*(3+4)*5", 70), ("8/2*4", 16), ("1-(2-3)", 2)],
)
def test_priorities_and_left_to_right(text: str, result: float) -> None:
    assert value(text) == result  # [A §"+" L954]


@pytest.mark.parametrize(
    ("text", "result"),
    [("-P2", -7), ("3&-3", 1), ("2*-1", -2), ("--3", 3), ("-(1+2)", -3), ("-2*3", -6), ("5- -2", 7)],
)
def test_unary_minus(text: str, result: float) -> None:
    assert value(text, P2=7) == result  # [A §"-" L964]


def test_negating_zero_gives_plus_zero() -> None:
    assert math.copysign(1, value("-0")) == 1


@pytest.mark.parametrize("text", ["+P2", "1*+2", "2-+1", "(+1)", "ABS(+1)"])
def test_unary_plus_is_rejected(text: str) -> None:
    with pytest.raises(ExprError) as err:
        value(text, P2=7)  # P1=+P2 "will be rejected with an error" [A L956]
    assert err.value.code == 3


@pytest.mark.parametrize(
    "text",
    ["", " ", "5+", "5+*3", "(1+2", "()", "FOO(1)", "P", "P(", "P()", "$", "ABS 5", "ABS(1",
     ")", "1 2", "5)", ".", "PP1", "PQ1", "IP(1)", "P1.5", "SIN", "*3", "P(1", "1+(2*(3)"],
)
def test_bad_syntax_is_err003(text: str) -> None:
    with pytest.raises(ExprError) as err:
        value(text)
    assert err.value.code == 3


def test_deep_nesting_is_rejected_not_a_crash() -> None:
    with pytest.raises(ExprError):
        value("(" * 500 + "1" + ")" * 500)
    with pytest.raises(ExprError):
        value("-" * 500 + "1")
    assert value("(" * 20 + "1" + ")" * 20) == 1


def test_long_chains_do_not_recurse() -> None:
    assert value("+".join(["1"] * 5000)) == 5000


@pytest.mark.parametrize(
    ("text", "result"),
    [("10", 10), ("2.5", 2.5), (".5", 0.5), ("1.", 1), ("$F0", 0xF0), ("$ff", 255), ("$78400", 0x78400)],
)
def test_constants(text: str, result: float) -> None:
    assert value(text) == result


def test_variables_and_indexed_variables() -> None:
    env = DictEnv({"I123": 4, "P1": 2, "Q30": -0.5, "M1": 9, "P3": 33, "M4": 44})
    assert evaluate("I123+P1*Q30+M1", env) == 12
    assert evaluate("P(P1+1)", env) == 33
    assert evaluate("m(p1*2)", env) == 44
    assert evaluate("P (2.6)", env) == 33  # a computed index rounds to nearest


def test_out_of_range_variable_is_the_envs_err003() -> None:
    with pytest.raises(ExprError) as err:
        value("P9000")
    assert err.value.code == 3


def test_case_insensitive_and_spaces_between_tokens() -> None:
    assert value(" abs ( - p1 ) * 2 + $a ", P1=3) == 16
    assert value("Sin (30)") == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("line", "start", "result", "end"),
    [
        ("P1=5 P2=6", 3, 5, 5),  # points at P2
        ("P1=5 M2", 3, 5, 5),
        ("P1=5M2", 3, 5, 4),
        ("P1=10*2/3", 3, 6.666666666666667, 9),
        ("P1=ABS(-2) Q1=3", 3, 2, 11),
        ("X(Q80*COS(Q81))", 2, 10, 14),  # stops at the ) it did not open [A §COS L1255]
        ("IF (P1>5)", 4, 0, 6),  # comparisons belong to conditions, not expressions
        ("P1=3&1", 3, 1, 6),
        ("P1=2.5 J+", 3, 2.5, 7),
        ("P1=$F0F P2=1", 3, 0xF0F, 8),
        ("P1=5 ", 3, 5, 5),
    ],
)
def test_where_the_expression_ends(line: str, start: int, result: float, end: int) -> None:
    expr, stop = parse(line, start)
    assert expr.eval(DictEnv({"Q80": 10})) == pytest.approx(result)
    assert stop == end


def test_ampersand_after_a_value_is_an_and_not_a_coordinate_system_address() -> None:
    expr, stop = parse("P1=5 &1", 3)
    assert expr.eval(DictEnv()) == 1 and stop == 7


def test_a_parsed_expression_reads_the_variables_at_each_eval() -> None:
    expr, _ = parse("P1+1")
    env = DictEnv({"P1": 1})
    assert expr.eval(env) == 2
    env.values["P1"] = 41
    assert expr.eval(env) == 42


def test_int_truncates_toward_minus_infinity() -> None:
    assert shown("INT(P50)", P50=2.5) == "2"  # [A L1301-1313]
    assert shown("INT(-P50)", P50=2.5) == "-3"
    assert value("INT(-3)") == -3


def test_atan_and_atan2_example() -> None:
    env = DictEnv({"Q30": -0.707, "Q31": -0.707})
    assert format_value(evaluate("ATAN(Q31/Q30)", env)) == "45"  # [A L1216-1227]
    env.values["Q0"] = env.values["Q30"]
    assert format_value(evaluate("ATAN2(Q31)", env)) == "-135"


def test_atan2_quadrants_and_both_zero() -> None:
    assert value("ATAN2(1)", Q0=0) == 90
    assert value("ATAN2(0)", Q0=-1) == 180
    assert value("ATAN2(-0)", Q0=-1) == 180
    assert value("ATAN2(0)", Q0=0) == 0


def test_atan2_in_radians() -> None:
    env = DictEnv({"Q0": -1, "Q1": -1}, radians=True)
    assert evaluate("ATAN2(Q1)", env) == pytest.approx(-3 * math.pi / 4)


@pytest.mark.parametrize(
    ("text", "degrees", "radians"),
    [
        ("COS(30)", math.sqrt(3) / 2, math.cos(30)),  # P60=COS(30) [A L1253]
        ("SIN(30)", 0.5, math.sin(30)),  # P60=SIN(30) [A L1353]
        ("TAN(30)", 1 / math.sqrt(3), math.tan(30)),  # P60=TAN(30) [A L1399]
        ("ACOS(0.5)", 60, math.pi / 3),
        ("ASIN(-0.5)", -30, -math.pi / 6),
        ("ATAN(1)", 45, math.pi / 4),
    ],
)
def test_angle_unit_follows_i15(text: str, degrees: float, radians: float) -> None:
    assert evaluate(text, DictEnv()) == pytest.approx(degrees, rel=1e-12)
    assert evaluate(text, DictEnv(radians=True)) == pytest.approx(radians, rel=1e-12)


def test_sin_cos_of_multiples_of_90_degrees_are_exact() -> None:
    assert [value(f"SIN({a})") for a in (0, 90, 180, 270, 360, -90)] == [0, 1, 0, -1, 0, -1]
    assert [value(f"COS({a})") for a in (0, 90, 180, 270, 450)] == [1, 0, -1, 0, 0]
    assert shown("SIN(30)") == "0.5"


def test_tan_exactly_at_a_pole_saturates() -> None:
    assert value("TAN(90)") == SATURATION  # [A L1395]
    assert value("TAN(-90)") == -SATURATION
    assert value("TAN(270)") == -SATURATION
    assert value("TAN(450)") == SATURATION
    assert value("TAN(180)") == 0
    assert value("TAN(89.99)") > 5000


def test_trig_examples_with_variables() -> None:
    env = DictEnv({"Q80": 2, "Q81": 60, "Q70": 5})
    assert evaluate("Q80*COS(Q81)", env) == pytest.approx(1)  # X(Q80*COS(Q81)) [A L1255]
    assert evaluate("ACOS(Q70/10)", env) == pytest.approx(60)  # C(ACOS(Q70/10)) [A L1146]
    assert evaluate("ASIN (Q70/10)", env) == pytest.approx(30)


def test_acos_asin_clamp_out_of_domain_arguments() -> None:
    assert value("ACOS(2)") == 0
    assert value("ACOS(-2)") == 180
    assert value("ASIN(-7)") == -90


def test_ln_exp_examples() -> None:
    assert shown("LN(10)").startswith("2.302585")  # "The natural logarithm of 10 is equal to 2.302585"
    assert value("LN(P5)/LN(10)", P5=1000) == pytest.approx(3)  # P6=LN(P5)/LN(10) [A L1336]
    assert value("EXP(P2*LN(P1))", P1=2, P2=10) == pytest.approx(1024)  # P3=EXP(P2*LN(P1)) [A L1284]
    assert value("EXP(P19)", P19=1) == pytest.approx(math.e)
    assert value("EXP(0)") == 1


def test_ln_of_non_positive_is_zero() -> None:
    assert value("LN(0)") == 0  # "a 0 value will be returned" [A L1329]
    assert value("LN(-5)") == 0


def test_exp_beyond_a_double_saturates() -> None:
    assert value("EXP(1000)") > 1e308


def test_sqrt_and_abs_examples() -> None:
    assert value("SQRT(P8*P8+P9*P9)", P8=3, P9=4) == 5  # P50=SQRT(P8*P8+P9*P9) [A L1379]
    assert value("SQRT(-4)") == 2
    assert value("ABS(P7)", P7=-2.5) == 2.5  # P8=ABS(P7) [A L1115]
    assert value("ABS(Q200)/Q200", Q200=-8) == -1  # Q240=ABS(Q200)/Q200 [A L1119]


def test_bitwise_on_huge_values_does_not_crash() -> None:
    assert value("EXP(1000)&1") == 0
    assert value("(EXP(1000)-EXP(1000))|3") == 3
