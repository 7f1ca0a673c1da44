"""The windowed sum `sum[a:b](e)`: parsing, sorts, its rtamt expansion, values by hand, the
warm-up it needs after a reset, and the 100-sample limit (CW049)."""

from __future__ import annotations

import math
from fractions import Fraction

import pytest

from casewatch.spec.ast import Abs, Arith, Compare, Interval, Num, Prev, Signal, Sum, signals_of
from casewatch.spec.compiler import compile_case
from casewatch.spec.emit import build_rtamt_monitor, period_fraction, to_rtamt, to_text
from casewatch.spec.model import CompiledFormula
from casewatch.spec.parser import FormulaError, parse_formula, parse_rtamt, parse_term
from casewatch.spec.reference_eval import reference_robustness
from casewatch.spec.timing import intervals_of, past_horizon, sum_warmup
from tests.spec.cases import hazard_node, make_case, stl_node
from tests.spec.rtamt_helpers import online

INF = math.inf
P = period_fraction(0.1)
x = Signal("x")
X = {"x": [1.0, 2.0, 4.0, 8.0, 16.0]}


def window(lo: str, hi: str) -> Interval:
    return Interval(Fraction(lo), Fraction(hi))


def same(got: list[float], want: list[float]) -> bool:
    return len(got) == len(want) and all(
        g == w if math.isinf(w) else abs(g - w) <= 1e-9 for g, w in zip(got, want, strict=True)
    )


# ---- syntax and sorts --------------------------------------------------------------------


def test_parse_and_canonical_text_round_trip() -> None:
    text = "sum[0:0.4](abs(lead_gap__camera - gt_lead_gap)) <= 5"
    formula = parse_formula(text)
    gap = Arith("-", Signal("lead_gap__camera"), Signal("gt_lead_gap"))
    assert formula == Compare("<=", Sum(window("0", "0.4"), Abs(gap)), Num(5.0))
    assert to_text(formula) == "(sum[0s:0.4s](abs((lead_gap__camera - gt_lead_gap))) <= 5.0)"
    assert parse_formula(to_text(formula)) == formula
    assert parse_term("sum[0s:400ms](x)") == parse_term("sum[0:0.4](x)")
    # a number: arithmetic and comparisons take it, it takes any number
    assert parse_term("2 * sum[0.1:0.2](x + 1) - y") == Arith(
        "-",
        Arith("*", Num(2.0), Sum(window("0.1", "0.2"), Arith("+", x, Num(1.0)))),
        Signal("y"),
    )
    assert parse_term("sum[0:0.1](sum[0:0.2](x))") == Sum(
        window("0", "0.1"), Sum(window("0", "0.2"), x)
    )
    # the keyword and what starts with it
    term = parse_term("summary + sum[0:0](x)")
    assert [s.name for s in signals_of(term)] == ["summary", "x"]
    assert intervals_of(term) == [window("0", "0")]
    assert parse_formula("sum[0:0.4](x) <= 1").left.col == 1


@pytest.mark.parametrize(
    ("text", "col", "fragment"),
    [
        ("sum[0:0.4](x >= 1) <= 5", 12, "expected a number or signal"),  # operand: a number
        ("y > 0 and sum[0:1](prev x >= 1) > 0", 20, "expected a number or signal"),
        ("sum[0:0.4](x)", 1, "expected a condition"),  # a sum is a number, not a condition
        ("prev sum[0:0.4](x)", 6, "expected a condition"),
        ("sum(x) <= 1", 4, "unexpected '('"),  # the window is required
        ("sum[0.4:0](x) <= 1", 4, "empty interval"),
        ("sum[0:0.4] x <= 1", 12, "unexpected 'x'"),  # the operand is parenthesised
    ],
)
def test_sort_and_syntax_errors_point_at_the_column(text: str, col: int, fragment: str) -> None:
    with pytest.raises(FormulaError) as info:
        parse_formula(text)
    assert info.value.col == col, info.value
    assert fragment in info.value.message


# ---- rtamt expansion ---------------------------------------------------------------------


def test_rtamt_text_is_a_nested_chain_of_prev() -> None:
    def emitted(text: str) -> str:
        return to_rtamt(parse_formula(text), P)

    assert emitted("sum[0:0.2](x) <= 10") == "((x + (prev (x + (prev x)))) <= 10.0)"
    assert emitted("sum[0.1:0.2](x) <= 10") == "((prev (x + (prev x))) <= 10.0)"
    assert emitted("sum[0.2:0.2](x) <= 10") == "((prev (prev x)) <= 10.0)"
    assert emitted("sum[0:0](x) <= 10") == "(x <= 10.0)"
    assert emitted("sum[0:0.1](abs(x - y)) > 1") == ("((abs((x - y)) + (prev abs((x - y)))) > 1.0)")
    with pytest.raises(ValueError, match="needs the sampling period"):
        to_rtamt(parse_formula("sum[0:0.2](x) <= 10"))
    assert to_rtamt(parse_formula("x <= 10")) == "(x <= 10.0)"  # no sum: no period needed


def test_hand_computed_through_rtamt() -> None:
    # x = 1, 2, 4, 8, 16; a sample before the first counts +inf (rtamt's prev of a real)
    cases = [
        # x_t + x_t-1 + x_t-2: inf, inf, 7, 14, 28 -> 10 - sum
        ("sum[0:0.2](x) <= 10", [-INF, -INF, 3.0, -4.0, -18.0]),
        # x_t-1 + x_t-2: inf, inf, 3, 6, 12
        ("sum[0.1:0.2](x) <= 10", [-INF, -INF, 7.0, 4.0, -2.0]),
        # -sum is -inf while incomplete: `<=` reads -10 - (-sum) = sum - 10, +inf at first
        ("-sum[0:0.1](x) <= -10", [INF, -7.0, -4.0, 2.0, 14.0]),
        # nested: s = x_t + x_t-1 (inf, 3, 6, 12, 24), then s_t + s_t-1: inf, inf, 9, 18, 36
        ("sum[0:0.1](sum[0:0.1](x)) <= 100", [-INF, -INF, 91.0, 82.0, 64.0]),
        # once over a sum: max over the last 3 samples of 10 - (x_t + x_t-1)
        ("once[0:0.2](sum[0:0.1](x) <= 10)", [-INF, 7.0, 7.0, 7.0, 4.0]),
    ]
    for text, want in cases:
        formula = parse_formula(text)
        assert same(reference_robustness(formula, X, 0.1), want), text
        compiled = CompiledFormula(
            id="F",
            node_id="F",
            node_text="",
            kind="spi",
            source=text,
            rtamt=to_rtamt(formula, P),
            signals=["x"],
            merge_gap=0,
            min_duration=0,
        )
        monitor = build_rtamt_monitor(compiled, 0.1)
        got = [monitor.update(i, [("x", v)]) for i, v in enumerate(X["x"])]
        assert same(got, want), (text, got)


def test_a_reset_empties_the_window() -> None:
    formula = parse_formula("sum[0:0.2](x) <= 10")
    compiled = CompiledFormula(
        id="F",
        node_id="F",
        node_text="",
        kind="spi",
        source="",
        rtamt=to_rtamt(formula, P),
        signals=["x"],
        merge_gap=0,
        min_duration=0,
    )
    monitor = build_rtamt_monitor(compiled, 0.1)
    got = [monitor.update(i, [("x", v)]) for i, v in enumerate([1.0, 2.0, 4.0])]
    monitor.reset()
    got += [monitor.update(i, [("x", v)]) for i, v in enumerate([8.0, 16.0, 32.0, 64.0])]
    # after the reset: inf, inf, 8 + 16 + 32 = 56, 16 + 32 + 64 = 112
    assert same(got, [-INF, -INF, 3.0, -INF, -INF, -46.0, -102.0])


def test_repeated_sums_do_not_share_rtamt_state() -> None:
    # rtamt keys operator state by printed subformula: the naive text updates `prev x` twice
    # per sample and is wrong; the emitter makes the second copy `prev (x * 1.0)`
    naive = "(((x + (prev x)) + (x + (prev x))) <= 100.0)"
    want = [-INF, 94.0, 88.0, 76.0, 52.0]  # 100 - 2 (x_t + x_t-1)
    assert not same(online(naive, X), want)
    formula = parse_formula("sum[0:0.1](x) + sum[0:0.1](x) <= 100")
    ours = to_rtamt(formula, P)
    assert "(prev (x * 1.0))" in ours and "(prev x)" in ours
    assert same(online(ours, X), want)
    # a nested sum is copied once per sample of the outer one: each copy's state its own
    nested = parse_formula("sum[0:0.2](sum[0:0.1](x)) + sum[0:0.1](x) <= 100")
    # inner s: inf, 3, 6, 12, 24; outer s_t + s_t-1 + s_t-2: inf, inf, inf, 21, 42
    want = [-INF, -INF, -INF, 100 - 21 - 12.0, 100 - 42 - 24.0]
    assert same(reference_robustness(nested, X, 0.1), want)
    assert same(online(to_rtamt(nested, P), X), want)


def test_parse_rtamt_reads_the_expansion_back() -> None:
    one = window("0.1", "0.1")
    assert parse_rtamt("((x + (prev x)) <= 3.0)", 0.1) == Compare(
        "<=", Arith("+", x, Sum(one, x)), Num(3.0)
    )
    assert parse_rtamt("(prev (x >= 1.0))", 0.1) == Prev(Compare(">=", x, Num(1.0)))
    assert parse_rtamt("(x !== 1.0)", 0.1) == Compare("!=", x, Num(1.0))
    formula = parse_formula("sum[0.1:0.3](abs(x)) - x < 1 and prev x != 2")
    back = parse_rtamt(to_rtamt(formula, P), 0.1)
    assert same(reference_robustness(back, X, 0.1), reference_robustness(formula, X, 0.1))
    with pytest.raises(FormulaError, match="expected a condition"):
        parse_formula("(prev x) <= 3")  # only the rtamt reader takes `prev` of a number


# ---- time: horizon and warm-up ---------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "warmup", "horizon"),
    [
        ("sum[0:0.4](x) <= 1", 4, 4),
        ("sum[0.2:0.4](x) <= 1", 4, 4),
        ("sum[0:0](x) <= 1", 0, 0),
        ("x <= 1", 0, 0),
        ("prev x <= 1", 0, 1),
        ("sum[0:0.2](sum[0:0.3](x)) <= 1", 5, 5),  # nested sums add
        ("prev (sum[0:0.4](x) <= 1)", 5, 5),
        ("once[0:1](sum[0:0.4](x) <= 1)", 14, 14),
        ("once[0:1](sum[0:0.2](sum[0:0.3](x)) <= 1) and prev prev prev y > 0", 15, 15),
        ("(prev prev prev prev prev prev y > 0) or sum[0:0.4](x) <= 1", 4, 6),  # only sums
        ("x > 0 since[0:0.5] sum[0:0.4](x) <= 1", 9, 9),
        ("historically (sum[0:0.4](x) <= 1)", 4, 4),  # unbounded: adds nothing
        ("eventually[0.2:0.5](sum[0:0.4](x) <= 1)", 2, 4),  # offline: credited
        ("next next next next next (sum[0:0.4](x) <= 1)", 0, 4),
    ],
)
def test_warmup_is_the_deepest_sum_window_end(text: str, warmup: int, horizon: int) -> None:
    formula = parse_formula(text)
    assert sum_warmup(formula, P) == warmup
    assert past_horizon(formula, P) == horizon


def test_compiled_formula_carries_the_warmup() -> None:
    signals = {"gap": "lead gap by camera, m", "gap_gt": "lead gap ground truth, m"}
    case = make_case(
        stl_node("Sn1", "sum[0:0.4](abs(gap - gap_gt)) <= 5"),
        stl_node("Sn2", "once[0:1s](sum[0:0.2](sum[0:0.3](gap)) <= 1)"),
        stl_node("Sn3", "gap >= 1"),
        hazard_node("CSn1", "sum[0:0.2](gap) > 100"),
        signals=signals,
    )
    spec, findings = compile_case(case)
    assert findings == [] and spec is not None
    by_id = {f.id: f for f in spec.formulas}
    assert {i: f.warmup_ticks for i, f in by_id.items()} == {
        "Sn1": 4,
        "Sn2": 15,
        "Sn3": 0,
        "CSn1": 2,
    }
    sn1 = by_id["Sn1"]
    assert math.isclose(sn1.horizon, 0.4) and sn1.signals == ["gap", "gap_gt"]
    assert sn1.rtamt.count("prev") == 4
    gap, truth = [10.0, 11.0, 12.5, 10.0, 9.0, 10.0], [10.0, 10.0, 10.0, 10.0, 10.0, 10.0]
    got = online(sn1.rtamt, {"gap": gap, "gap_gt": truth})
    # |gap - gt| = 0, 1, 2.5, 0, 1, 0; window of 5: 4.5 at t4, 4.5 at t5 -> 5 - 4.5
    assert same(got, [-INF, -INF, -INF, -INF, 0.5, 0.5])


# ---- the 100-sample limit (CW049) ------------------------------------------------------


def _codes(*texts: str) -> list[tuple[str, int, int]]:
    nodes = [stl_node(f"Sn{i + 1}", text, line=20 + i) for i, text in enumerate(texts)]
    _spec, findings = compile_case(make_case(*nodes, signals={"y": "a declared signal"}))
    return [(f.code, f.line, f.col) for f in findings]


def test_a_sum_of_more_than_100_samples_is_cw049() -> None:
    assert _codes("sum[0:7s](y) <= 1") == []  # 71 samples at 0.1 s
    # 100 samples pass CW049, but nest too deeply for rtamt as it receives them (issue 31:
    # RecursionError inside rtamt): CW051 at the formula
    assert _codes("sum[0:9.9s](y) <= 1") == [("CW051", 20, 10)]
    assert _codes("sum[0.1:10s](y) <= 1") == [("CW051", 20, 10)]
    # 101 samples; column: `sum` at 1 of the formula, which starts at column 10 of line 20
    assert _codes("sum[0:10s](y) <= 1") == [("CW049", 20, 10)]
    # nested: 10 x 11 = 110, reported once, at the outer sum (column 12 of the formula)
    assert _codes("y >= 0 and sum[0:0.9](sum[0:1](y)) <= 1") == [("CW049", 20, 21)]
    assert _codes("sum[0:0](sum[0:20s](y)) <= 1") == [("CW049", 20, 10)]
    # not a whole number of periods: CW043 only (no sample count to judge)
    assert [c for c, _l, _c in _codes("sum[0:0.25](y) <= 1")] == ["CW043"]
    _spec, findings = compile_case(
        make_case(stl_node("Sn1", "sum[0:10s](y) <= 1"), signals={"y": "a declared signal"})
    )
    (finding,) = findings
    assert finding.severity == "error"
    assert "adds 101 samples" in finding.message and "at most 100" in finding.message
    assert "sum[0:9.9s]" in finding.hint
