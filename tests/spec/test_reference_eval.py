"""The reference evaluator (spec/reference_eval.py) against hand-computed values and rtamt."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings

from casewatch.spec.emit import new_rtamt_spec, period_fraction, to_rtamt
from casewatch.spec.parser import parse_formula
from casewatch.spec.reference_eval import reference_robustness
from casewatch.spec.timing import future_reach
from tests.spec.rtamt_helpers import offline
from tests.spec.strategies import PERIOD, SIGNALS, mixed_formulas, past_formulas, traces

INF = math.inf
P = period_fraction(PERIOD)


def rtamt_online(formula_text: str, trace: dict[str, list[float]], period: float) -> list[float]:
    monitor = new_rtamt_spec(formula_text, list(trace), period)
    n = len(next(iter(trace.values())))
    return [
        monitor.update(i * period, [(name, float(values[i])) for name, values in trace.items()])
        for i in range(n)
    ]


def close(a: float, b: float) -> bool:
    if math.isinf(a) or math.isinf(b):
        return a == b
    return abs(a - b) <= 1e-9


def test_hand_computed_past_operators() -> None:
    trace = {"x": [5.0, 4.0, 3.0, 2.0, 1.0], "y": [0.0, 2.0, 0.0, 0.0, 3.0]}
    # once[0:0.2s] (x >= 2) at period 0.1: max of x - 2 over the last 3 samples
    #   t0: 3; t1: max(3, 2) = 3; t2: 3; t3: max(2, 1, 0) = 2; t4: max(1, 0, -1) = 1
    assert reference_robustness(parse_formula("once[0:0.2s] x >= 2"), trace, 0.1) == [3, 3, 3, 2, 1]
    # historically[100ms:200ms] (x >= 2): min over samples t-2..t-1, +inf when none exist
    #   t0: inf; t1: 3; t2: min(3, 2) = 2; t3: min(2, 1) = 1; t4: min(1, 0) = 0
    got = reference_robustness(parse_formula("historically[100ms:200ms] x >= 2"), trace, 0.1)
    assert got == [INF, 3, 2, 1, 0]
    # prev (y >= 1): +inf at the first sample (rtamt), then y(t-1) - 1
    assert reference_robustness(parse_formula("prev y >= 1"), trace, 0.1) == [INF, -1, 1, -1, -1]
    # (x >= 2) since (y >= 1), unbounded: out_t = max(y_t - 1, min(x_t - 2, out_{t-1})), out_-1=-inf
    #   t0: max(-1, min(3, -inf)) = -1; t1: max(1, min(2, -1)) = 1; t2: max(-1, min(1, 1)) = 1
    #   t3: max(-1, min(0, 1)) = 0; t4: max(2, min(-1, 0)) = 2
    got = reference_robustness(parse_formula("x >= 2 since y >= 1"), trace, 0.1)
    assert got == [-1, 1, 1, 0, 2]


def test_hand_computed_matches_rtamt() -> None:
    trace = {"x": [5.0, 4.0, 3.0, 2.0, 1.0], "y": [0.0, 2.0, 0.0, 0.0, 3.0]}
    for text in (
        "once[0:0.2s] x >= 2",
        "historically[100ms:200ms] x >= 2",
        "prev y >= 1",
        "x >= 2 since y >= 1",
        "x >= 2 since[0.1:0.3] y >= 1",
    ):
        formula = parse_formula(text)
        ours = reference_robustness(formula, trace, 0.1)
        theirs = rtamt_online(to_rtamt(formula), trace, 0.1)
        assert all(close(a, b) for a, b in zip(ours, theirs, strict=True)), (text, ours, theirs)


@settings(max_examples=150, deadline=None)
@given(formula=past_formulas, trace=traces())
def test_reference_agrees_with_rtamt_online(formula, trace) -> None:  # type: ignore[no-untyped-def]
    """Random past-time formulas on random traces: every sample within 1e-9 (or equal infs)."""
    ours = reference_robustness(formula, trace, PERIOD)
    theirs = rtamt_online(to_rtamt(formula, P), trace, PERIOD)
    assert set(trace) == set(SIGNALS)
    for t, (a, b) in enumerate(zip(ours, theirs, strict=True)):
        assert close(a, b), f"sample {t}: reference {a} != rtamt {b} for {to_rtamt(formula, P)}"


@settings(max_examples=100, deadline=None)
@given(formula=mixed_formulas, trace=traces(min_len=2, max_len=12))
def test_reference_agrees_with_rtamt_offline_where_the_future_is_known(formula, trace) -> None:  # type: ignore[no-untyped-def]
    """Offline (bounded future allowed): equal on every sample whose look-ahead lies inside the
    trace. Near the end rtamt fills missing future samples its own way (`next` at the last
    sample is +inf there, -inf here); those verdicts are incomplete either way."""
    ours = reference_robustness(formula, trace, PERIOD)
    theirs = offline(to_rtamt(formula, P), trace, PERIOD)
    reach = future_reach(formula, period_fraction(PERIOD))
    for t in range(len(ours) - reach):
        assert close(ours[t], theirs[t]), f"sample {t}: {ours[t]} != {theirs[t]}"


def test_rtamt_offline_cannot_evaluate_a_single_sample() -> None:
    # rtamt 0.4.10 offline evaluate raises on a one-sample trace (an unbound local variable in
    # its sampling check); the online monitor handles it (0.7 - 0.6 = 0.1).
    with pytest.raises(UnboundLocalError):
        offline("(els >= 0.6)", {"els": [0.7]})
    assert abs(rtamt_online("(els >= 0.6)", {"els": [0.7]}, PERIOD)[0] - 0.1) <= 1e-9
