"""Emission to rtamt: the rtamt 0.4.10 bugs exist with naive text and our text avoids them;
hand-written formulas round-trip (our syntax re-parses equal, rtamt parses the emitted text and
its online robustness equals the value computed by hand)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rtamt.exception.exception import RTAMTException

from casewatch.spec.emit import build_rtamt_monitor, period_fraction, to_rtamt, to_text
from casewatch.spec.model import CompiledFormula
from casewatch.spec.parser import parse_formula, parse_term
from casewatch.spec.timing import delay, future_depth
from tests.spec.rtamt_helpers import offline, online
from tests.spec.strategies import PERIOD, past_formulas, traces

INF = math.inf

# ---- the bugs named in the issue -------------------------------------------------------


def test_bug_mixed_division_multiplication_is_right_associative() -> None:
    # naive: rtamt reads x / 2 * 4 as x / (2 * 4) = 8 / 8 = 1.0
    assert online("x / 2 * 4", {"x": [8.0]}) == [1.0]
    # ours: ((x / 2.0) * 4.0) = (8 / 2) * 4 = 16
    ours = to_rtamt(parse_term("x / 2 * 4"))
    assert ours == "((x / 2.0) * 4.0)"
    assert online(ours, {"x": [8.0]}) == [16.0]


def test_bug_subtracting_a_literal_does_not_parse() -> None:
    with pytest.raises(RTAMTException):
        online("x - 1 + 1", {"x": [8.0]})
    with pytest.raises(RTAMTException):
        online("x - 1", {"x": [8.0]})
    ours = to_rtamt(parse_term("x - 1 + 1"))
    assert ours == "((x - (1.0)) + 1.0)"
    assert online(ours, {"x": [8.0]}) == [8.0]  # (8 - 1) + 1


def test_bug_pastify_shifts_a_predicate_twice() -> None:
    import rtamt

    text = "(req >= 1) implies eventually[0:3](gnt >= 2)"
    trace = {"req": [1.0, 0, 0, 1, 0, 0, 0, 0, 0, 0], "gnt": [0.0, 0, 3, 0, 0, 0, 5, 0, 0, 0]}
    # the truth, offline (future visible), at period 1 s so [0:3] is 3 samples:
    #   t0: max(-(1-1), max(gnt[0..3]) - 2) = max(0, 1) = 1;  t3: max(0, 5 - 2) = 3 ...
    formula = parse_formula(text)
    truth = offline(to_rtamt(formula), trace, period=1.0)
    assert truth[:4] == [1.0, 1.0, 1.0, 3.0]

    spec = rtamt.StlDiscreteTimeSpecification()
    for name in ("req", "gnt", "out"):
        spec.declare_var(name, "float")
    spec.spec = f"out = {text}"
    spec.parse()
    spec.pastify()
    # rtamt's own pastified form reads req 6 samples back instead of 3
    assert "once[3,3]((once[3,3](req))" in spec.ast.specs[0].name
    naive = [
        spec.update(i, [("req", trace["req"][i]), ("gnt", trace["gnt"][i])]) for i in range(10)
    ]
    # a delayed-by-3 monitor must report truth[t - 3] at t; rtamt's does not (t = 6: it pairs
    # gnt over samples 3..6 (max 5 - 2 = 3) with req at sample 0, not 3)
    assert [naive[t] for t in range(3, 10)] != truth[:7]

    # ours: online compilation rejects the future operator and proposes a correct past form
    depth = future_depth(formula, period_of(1.0))
    past = delay(formula, depth, period_of(1.0))
    assert past is not None
    assert to_text(past) == "((once[3s:3s] (req >= 1.0)) implies (once[0s:3s] (gnt >= 2.0)))"
    ours = online(to_rtamt(past), trace, period=1.0)
    assert [ours[t] for t in range(3, 10)] == truth[:7]


def period_of(seconds: float):  # type: ignore[no-untyped-def]
    from casewatch.spec.emit import period_fraction

    return period_fraction(seconds)


# ---- further rtamt 0.4.10 behaviour our emitter fences -----------------------------------


def test_fence_mixed_subtraction_addition() -> None:
    trace = {"x": [8.0], "y": [2.0], "z": [4.0]}
    assert online("x - y + z", trace) == [2.0]  # rtamt: 8 - (2 + 4)
    assert online(to_rtamt(parse_term("x - y + z")), trace) == [10.0]  # (8 - 2) + 4


def test_fence_implies_chain_is_right_associative() -> None:
    # at x = 3: a = x >= 1 -> 2, b = x >= 9 -> -6, c = x >= 10.5 -> -7.5
    # a implies (b implies c) = max(-2, max(6, -7.5)) = 6
    # rtamt's (a implies b) implies c = max(-max(-2, -6), -7.5) = 2
    trace = {"x": [3.0]}
    assert online("(x >= 1) implies (x >= 9) implies (x >= 10.5)", trace) == [2.0]
    ours = to_rtamt(parse_formula("x >= 1 implies x >= 9 implies x >= 10.5"))
    assert online(ours, trace) == [6.0]


def test_fence_repeated_stateful_subformula() -> None:
    trace = {"x": [0.0, 1.0, 2.0, 3.0]}
    # prev at the first sample is +inf in rtamt; min(inf, inf) = inf, then x(t-1) - 1
    expected = [INF, -1.0, 0.0, 1.0]
    naive = "((prev (x >= 1)) and (prev (x >= 1)))"
    assert online(naive, trace)[0] == -1.0  # shared state updated twice: reads x(0) at t = 0
    ours = to_rtamt(parse_formula("prev x >= 1 and prev x >= 1"))
    assert ours == "((prev (x >= 1.0)) and (prev (not (not (x >= 1.0)))))"
    assert online(ours, trace) == expected


def test_fence_unary_minus_and_not_equal() -> None:
    with pytest.raises(RTAMTException):
        online("-x >= 1", {"x": [3.0]})
    with pytest.raises(RTAMTException):
        online("x != 1", {"x": [3.0]})
    ours = to_rtamt(parse_formula("-x >= -5 and x != 1"))
    assert ours == "(((0.0 - x) >= (-5.0)) and (x !== 1.0))"
    # min(-3 - -5, |3 - 1|) = min(2, 2) = 2
    assert online(ours, {"x": [3.0]}) == [2.0]


# ---- round trip of hand-written formulas ---------------------------------------------

TRACE = {"a": [1.0, 4.0, 2.0, 0.5, 3.0], "b": [0.0, 1.0, 1.0, 2.0, 5.0]}

# (formula, robustness at every sample, by hand; period 0.1 s)
HAND_WRITTEN: list[tuple[str, list[float]]] = [
    # a - b: 1, 3, 1, -1.5, -2
    ("a >= b", [1.0, 3.0, 1.0, -1.5, -2.0]),
    # 1 - a/2*... : a / 2 * 4 = 2a -> 2a - 5: -3, 3, -1, -4, 1
    ("a / 2 * 4 > 5", [-3.0, 3.0, -1.0, -4.0, 1.0]),
    # (a - 1 + 1) - b = a - b
    ("a - 1 + 1 >= b", [1.0, 3.0, 1.0, -1.5, -2.0]),
    # 2 - |a - b|: 1, -1, 1, 0.5, 0
    ("abs(a - b) <= 2", [1.0, -1.0, 1.0, 0.5, 0.0]),
    # -a - -3 = 3 - a: 2, -1, 1, 2.5, 0
    ("-a >= -3", [2.0, -1.0, 1.0, 2.5, 0.0]),
    # -|a - 2|: -1, -2, 0, -1.5, -1
    ("a == 2", [-1.0, -2.0, 0.0, -1.5, -1.0]),
    # not (a >= 2) = 2 - a; or with b - 1: max(1, -1) = 1; max(-2, 0) = 0; max(0, 0) = 0;
    #   max(1.5, 1) = 1.5; max(-1, 4) = 4
    ("not a >= 2 or b >= 1", [1.0, 0.0, 0.0, 1.5, 4.0]),
    # a >= 2 implies b >= 1 = max(2 - a, b - 1): same as above
    ("a >= 2 implies b >= 1", [1.0, 0.0, 0.0, 1.5, 4.0]),
    # once[0:0.2s] (a >= 2): max of a - 2 over 3 samples: -1, 2, 2, 2, 1
    ("once[0:0.2s] a >= 2", [-1.0, 2.0, 2.0, 2.0, 1.0]),
    # historically[0:200ms] (a >= 1): min of a - 1 over 3 samples: 0, 0, 0, -0.5, -0.5
    ("historically[0:200ms] a >= 1", [0.0, 0.0, 0.0, -0.5, -0.5]),
    # prev (b >= 1): inf, -1, 0, 0, 1
    ("prev b >= 1", [INF, -1.0, 0.0, 0.0, 1.0]),
    # (a >= 1) since[0:0.1] (b >= 1): max over s in {t-1, t} of min(b_s - 1, a over (s, t] - 1)
    #   t0: s=0: min(-1, inf) = -1 -> -1
    #   t1: s=0: min(-1, a1-1=3) = -1; s=1: min(0, inf) = 0 -> 0
    #   t2: s=1: min(0, a2-1=1) = 0; s=2: min(0, inf) = 0 -> 0
    #   t3: s=2: min(0, a3-1=-0.5) = -0.5; s=3: min(1, inf) = 1 -> 1
    #   t4: s=3: min(1, a4-1=2) = 1; s=4: min(4, inf) = 4 -> 4
    ("a >= 1 since[0:0.1] b >= 1", [-1.0, 0.0, 0.0, 1.0, 4.0]),
]


@pytest.mark.parametrize(("text", "expected"), HAND_WRITTEN)
def test_round_trip_hand_written(text: str, expected: list[float]) -> None:
    formula = parse_formula(text)
    assert parse_formula(to_text(formula)) == formula  # our canonical text reads back equal
    emitted = to_rtamt(formula)
    got = online(emitted, TRACE)  # rtamt parses it and evaluates online
    assert len(got) == len(expected)
    for g, e in zip(got, expected, strict=True):
        assert g == e if math.isinf(e) else abs(g - e) <= 1e-9, (text, got, expected)


def test_build_rtamt_monitor_declares_signals_and_period() -> None:
    compiled = CompiledFormula(
        id="Sn1",
        node_id="Sn1",
        node_text="ELS holds",
        kind="spi",
        source="once[0:0.3s] (els >= 0.6)",
        rtamt="(once[0s:0.3s] (els >= 0.6))",
        signals=["els"],
        merge_gap=1.0,
        min_duration=0.0,
    )
    monitor = build_rtamt_monitor(compiled, 0.1)
    els = [0.9, 0.5, 0.4, 0.3, 0.2, 0.7]
    got = [monitor.update(i * 0.1, [("els", v)]) for i, v in enumerate(els)]
    # max(els - 0.6) over 4 samples (0.3 s at 0.1 s): 0.3, 0.3, 0.3, 0.3, max(-.1,-.2,-.3,-.4),
    # then max(-0.2, -0.3, -0.4, 0.1) = 0.1
    expected = [0.3, 0.3, 0.3, 0.3, -0.1, 0.1]
    assert all(abs(g - e) <= 1e-9 for g, e in zip(got, expected, strict=True))


def _compiled(rtamt_text: str, signals: list[str]) -> CompiledFormula:
    return CompiledFormula(
        id="F",
        node_id="F",
        node_text="random",
        kind="spi",
        source=rtamt_text,
        rtamt=rtamt_text,
        signals=signals,
        merge_gap=0.0,
        min_duration=0.0,
    )


@settings(max_examples=120, deadline=None)
@given(formula=past_formulas, trace=traces(), cut=st.integers(min_value=0, max_value=12))
def test_fenced_monitor_equals_plain_rtamt_across_a_reset(formula, trace, cut) -> None:  # type: ignore[no-untyped-def]
    """build_rtamt_monitor's fences (no sampling bookkeeping, direct predicate arithmetic,
    eager operators) change no value: random past-time formulas over every comparison
    operator, fed, reset at `cut`, fed again, equal plain rtamt fed the two parts fresh."""
    text = to_rtamt(formula, period_fraction(PERIOD))
    n = len(next(iter(trace.values())))
    cut = min(cut, n)
    fenced = build_rtamt_monitor(_compiled(text, list(trace)), PERIOD)
    got = []
    for i in range(n):
        if i == cut:
            fenced.reset()
        j = i - cut if i >= cut else i
        got.append(fenced.update(j * PERIOD, [(k, float(v[i])) for k, v in trace.items()]))
    head = {k: v[:cut] for k, v in trace.items()}
    tail = {k: v[cut:] for k, v in trace.items()}
    expected = (online(text, head) if cut else []) + (online(text, tail) if cut < n else [])
    for i, (a, b) in enumerate(zip(got, expected, strict=True)):
        assert a == b or (math.isnan(a) and math.isnan(b)), f"sample {i}: {a} != {b} ({text})"


@pytest.mark.parametrize(
    ("op", "expected"),
    [(">=", -1.0), (">", -1.0), ("<=", 1.0), ("<", 1.0), ("==", -1.0), ("!==", 1.0)],
)
def test_direct_predicate_arithmetic(op: str, expected: float) -> None:
    # x = 2, y = 3: x >= y is x - y = -1; x <= y is y - x = 1; == is -|x - y|; !== is |x - y|
    monitor = build_rtamt_monitor(_compiled(f"(x {op} y)", ["x", "y"]), 0.1)
    assert monitor.update(0.0, [("x", 2.0), ("y", 3.0)]) == expected
