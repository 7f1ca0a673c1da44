"""Parsing: precedence, associativity, units, sorts, and error columns."""

from __future__ import annotations

from fractions import Fraction

import pytest
from hypothesis import given, settings

from casewatch.safety_case.model import Mark
from casewatch.spec.ast import (
    Abs,
    Arith,
    BoolOp,
    Compare,
    Formula,
    Interval,
    Neg,
    Not,
    Num,
    Prev,
    Signal,
    Span,
    Window,
)
from casewatch.spec.emit import to_text
from casewatch.spec.parser import FormulaError, parse_formula, parse_term, yaml_position
from tests.spec.strategies import mixed_formulas

x, y, z = Signal("x"), Signal("y"), Signal("z")


def ge(left: Signal) -> Compare:
    return Compare(">=", left, Num(0.0))


def test_arithmetic_precedence_and_left_associativity() -> None:
    assert parse_term("x / 2 * 4") == Arith("*", Arith("/", x, Num(2.0)), Num(4.0))
    assert parse_term("x - 1 + 1") == Arith("+", Arith("-", x, Num(1.0)), Num(1.0))
    assert parse_term("x + y * z") == Arith("+", x, Arith("*", y, z))
    assert parse_term("-x * 2") == Arith("*", Neg(x), Num(2.0))
    assert parse_term("x - -1") == Arith("-", x, Neg(Num(1.0)))
    assert parse_term("abs(x - y)") == Abs(Arith("-", x, y))
    assert parse_term("(x + y) * z") == Arith("*", Arith("+", x, y), z)


def test_boolean_precedence() -> None:
    a, b, c = ge(x), ge(y), ge(z)
    assert parse_formula("x >= 0 or y >= 0 and z >= 0") == BoolOp("or", a, BoolOp("and", b, c))
    assert parse_formula("not x >= 0 and y >= 0") == BoolOp("and", Not(a), b)
    # implies is loosest and right-associative
    assert parse_formula("x >= 0 implies y >= 0 implies z >= 0") == BoolOp(
        "implies", a, BoolOp("implies", b, c)
    )
    assert parse_formula("x >= 0 or y >= 0 implies z >= 0") == BoolOp(
        "implies", BoolOp("or", a, b), c
    )


def test_temporal_operators_and_units() -> None:
    half = Interval(Fraction(0), Fraction(1, 2))
    assert parse_formula("once[0:0.5s] x >= 0") == Window("once", half, ge(x))
    assert parse_formula("once[0:500ms] x >= 0") == Window("once", half, ge(x))
    assert parse_formula("once[0:0.5] x >= 0") == Window("once", half, ge(x))
    assert parse_formula("historically x >= 0") == Window("historically", None, ge(x))
    assert parse_formula("prev prev x >= 0") == Prev(Prev(ge(x)))
    # since binds tighter than and, looser than prefix operators
    assert parse_formula("x >= 0 and not y >= 0 since[0:1s] z >= 0") == BoolOp(
        "and", ge(x), Span("since", Interval(Fraction(0), Fraction(1)), Not(ge(y)), ge(z))
    )
    assert parse_formula("x >= 0 until[0.1:0.2] y >= 0") == Span(
        "until", Interval(Fraction(1, 10), Fraction(1, 5)), ge(x), ge(y)
    )
    assert parse_formula("eventually[0:1s] (always[0:100ms] x >= 0)") == Window(
        "eventually",
        Interval(Fraction(0), Fraction(1)),
        Window("always", Interval(Fraction(0), Fraction(1, 10)), ge(x)),
    )


def test_signal_names_with_double_underscores_and_keywords_as_prefixes() -> None:
    formula = parse_formula("els__lav__tfuse >= 0.6 and notable < 1 and android > 2")
    names = [s.name for s in (formula.left.left.left, formula.left.right.left, formula.right.left)]
    assert names == ["els__lav__tfuse", "notable", "android"]


@pytest.mark.parametrize(
    ("text", "col", "fragment"),
    [
        ("x >= ", 5, "ends too early"),  # after '>='
        ("x >= 1 and", 11, "ends too early"),
        ("x >= 1 $ 2", 8, "unexpected character '$'"),
        ("x < y < z", 7, "unexpected '<'"),  # comparisons do not chain
        ("x >= 1 2", 8, "unexpected '2'"),
        ("x", 1, "expected a condition"),
        ("x + (y >= 1)", 6, "expected a number or signal"),
        ("once[2:1] x > 0", 5, "empty interval"),
        ("eventually x > 1", 1, "needs a bound"),
        ("x >= 1 until y > 0", 8, "needs a bound"),
        ("once[0:1h] x > 0", 9, "unexpected 'h'"),
        ("", 1, "empty formula"),
    ],
)
def test_parse_error_columns(text: str, col: int, fragment: str) -> None:
    with pytest.raises(FormulaError) as info:
        parse_formula(text)
    assert info.value.col == col, info.value
    assert fragment in info.value.message


def test_signal_columns_are_recorded() -> None:
    formula = parse_formula("abs(ocs - ols) > 0.5")
    assert (formula.left.operand.left.col, formula.left.operand.right.col) == (5, 11)


def test_yaml_position_single_and_multi_line() -> None:
    # `when: "x >= $"` with the text starting at column 12 of line 40: '$' at formula col 6
    assert yaml_position(Mark(line=40, col=12), 1, 6) == (40, 17)
    # second line of a block scalar: the line moves, the column is the formula's
    assert yaml_position(Mark(line=40, col=12), 2, 3) == (41, 3)


@settings(max_examples=100, deadline=None)
@given(formula=mixed_formulas)
def test_canonical_text_reads_back_equal(formula: Formula) -> None:
    """to_text is fully parenthesised, so re-parsing must give the same tree."""
    assert parse_formula(to_text(formula)) == formula


def test_error_maps_to_yaml() -> None:
    with pytest.raises(FormulaError) as info:
        parse_formula("els >= 0.6 and $")
    assert info.value.yaml_position(Mark(line=7, col=11)) == (7, 11 + 16 - 1)
