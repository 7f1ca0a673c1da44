"""hypothesis strategies for random past-time formulas and traces (shared by spec tests)."""

from __future__ import annotations

from fractions import Fraction

from hypothesis import strategies as st

from casewatch.spec.ast import (
    Abs,
    Arith,
    BoolOp,
    Compare,
    Interval,
    Neg,
    Next,
    Not,
    Num,
    Prev,
    Signal,
    Span,
    Sum,
    Window,
)

SIGNALS = ("x", "y", "z")
PERIOD = 0.1

numbers = st.sampled_from([0.0, 0.5, 1.0, 2.0, 3.25, 10.0]).map(Num)
signals = st.sampled_from(SIGNALS).map(Signal)

terms = st.recursive(
    st.one_of(numbers, signals),
    lambda inner: st.one_of(
        st.builds(Neg, inner),
        st.builds(Abs, inner),
        st.builds(Arith, st.sampled_from(["+", "-", "*"]), inner, inner),
        # division only by a non-zero constant: rtamt raises ZeroDivisionError on x / 0
        st.builds(Arith, st.just("/"), inner, st.sampled_from([0.5, 2.0, 4.0]).map(Num)),
    ),
    max_leaves=4,
)

comparison_ops = st.sampled_from(["<", "<=", ">", ">=", "==", "!="])


@st.composite
def sum_windows(draw: st.DrawFn) -> Interval:
    lo = draw(st.integers(0, 2))
    hi = draw(st.integers(lo, 3))
    return Interval(Fraction(lo, 10), Fraction(hi, 10))


#: Terms with a `sum`. A sum is +inf until its window is complete (rtamt's `prev` of a real at
#: the first sample), so these keep every infinity of one sign: sums of sums, of a sum plus a
#: plain term, absolute values and positive scalings, never `sum - sum` or `sum * 0`, whose
#: `inf - inf` is NaN (NaN is outside the engines' contract; see docs/formulas.md, "sum").
sums = st.recursive(
    st.builds(Sum, sum_windows(), terms),
    lambda inner: st.one_of(
        st.builds(Sum, sum_windows(), inner),
        st.builds(Sum, sum_windows(), st.builds(Arith, st.just("+"), inner, terms)),
        st.builds(Abs, inner),
        st.builds(Arith, st.just("*"), inner, st.sampled_from([0.5, 2.0]).map(Num)),
    ),
    max_leaves=3,
)
sum_terms = st.one_of(
    sums,
    st.builds(Neg, sums),
    st.builds(Arith, st.sampled_from(["+", "-"]), sums, terms),
    st.builds(Arith, st.just("-"), terms, sums),
)

plain_comparisons = st.builds(Compare, comparison_ops, terms, terms)
comparisons = st.one_of(
    plain_comparisons,
    plain_comparisons,  # two in three comparisons without a sum
    st.one_of(
        st.builds(Compare, comparison_ops, sum_terms, terms),
        st.builds(Compare, comparison_ops, terms, sum_terms),
    ),
)


@st.composite
def intervals(draw: st.DrawFn) -> Interval | None:
    if draw(st.booleans()):
        return None
    lo = draw(st.integers(0, 3))
    hi = draw(st.integers(lo, 5))
    return Interval(Fraction(lo, 10), Fraction(hi, 10))


past_formulas = st.recursive(
    comparisons,
    lambda inner: st.one_of(
        st.builds(Not, inner),
        st.builds(BoolOp, st.sampled_from(["and", "or", "implies"]), inner, inner),
        st.builds(Prev, inner),
        st.builds(Window, st.sampled_from(["once", "historically"]), intervals(), inner),
        st.builds(Span, st.just("since"), intervals(), inner, inner),
    ),
    max_leaves=5,
)


@st.composite
def traces(draw: st.DrawFn, min_len: int = 1, max_len: int = 12) -> dict[str, list[float]]:
    n = draw(st.integers(min_len, max_len))
    values = st.floats(-10, 10, allow_nan=False, allow_infinity=False).map(lambda v: round(v, 3))
    return {name: draw(st.lists(values, min_size=n, max_size=n)) for name in SIGNALS}


def _bounded(lo_max: int = 2, hi_max: int = 3) -> st.SearchStrategy[Interval]:
    return st.integers(0, lo_max).flatmap(
        lambda lo: st.integers(lo, hi_max).map(
            lambda hi: Interval(Fraction(lo, 10), Fraction(hi, 10))
        )
    )


#: past and bounded future operators together (for shifts and canonical text round trips)
mixed_formulas = st.recursive(
    comparisons,
    lambda inner: st.one_of(
        st.builds(Not, inner),
        st.builds(BoolOp, st.sampled_from(["and", "or", "implies"]), inner, inner),
        st.builds(Prev, inner),
        st.builds(Next, inner),
        st.builds(Window, st.sampled_from(["once", "historically"]), _bounded(), inner),
        st.builds(Window, st.sampled_from(["eventually", "always"]), _bounded(), inner),
        st.builds(Span, st.just("since"), _bounded(), inner, inner),
    ),
    max_leaves=4,
)
