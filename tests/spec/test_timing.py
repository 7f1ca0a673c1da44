"""Time: bounds in samples, horizons, and the past-time shift the online check suggests.

The shift (`spec.timing.delay`) is what rtamt's `pastify()` gets wrong; here it is checked
against the reference evaluator of the original future formula on random formulas and traces.
"""

from __future__ import annotations

import math
from fractions import Fraction

from hypothesis import given, settings

from casewatch.spec.emit import period_fraction, to_rtamt, to_text
from casewatch.spec.parser import parse_formula
from casewatch.spec.reference_eval import reference_robustness
from casewatch.spec.timing import bound_ticks, delay, future_depth, past_form, past_horizon
from tests.spec.rtamt_helpers import online
from tests.spec.strategies import PERIOD, mixed_formulas, traces

P = period_fraction(PERIOD)


def test_bound_ticks() -> None:
    assert bound_ticks(Fraction(3, 10), P) == 3  # 0.3 s / 0.1 s, exact (no 2.9999...)
    assert bound_ticks(Fraction(7, 10), P) == 7
    assert bound_ticks(Fraction(1, 4), P) is None


def test_horizons() -> None:
    formula = parse_formula("once[0:0.5s] (prev x >= 1) and historically[0.1:0.2] y > 0")
    assert past_horizon(formula, P) == 6  # once: 5 + prev: 1; historically: 2
    assert future_depth(formula, P) == 0
    future = parse_formula("eventually[0:0.3] (x >= 1 until[0:0.2] next y > 0)")
    assert future_depth(future, P) == 3 + 2 + 1


def test_delay_of_the_issue_example() -> None:
    formula = parse_formula("eventually[0:1s] x >= 1")
    shifted = delay(formula, future_depth(formula, P), P)
    assert shifted is not None and to_text(shifted) == "(once[0s:1s] (x >= 1.0))"


@settings(max_examples=60, deadline=None)
@given(formula=mixed_formulas, trace=traces(min_len=16, max_len=24))
def test_delay_is_the_future_formula_judged_late(formula, trace) -> None:  # type: ignore[no-untyped-def]
    found = past_form(formula, P)
    assert found is not None
    shifted, depth = found
    assert depth >= future_depth(formula, P)
    assert future_depth(shifted, P) == 0  # causal: rtamt's online monitor accepts it
    truth = reference_robustness(formula, trace, PERIOD)
    judged = online(to_rtamt(shifted, P), trace)
    n = len(truth)
    # after the warm-up (shift + look-back) every late verdict equals the truth d samples back
    warm_up = depth + past_horizon(formula, P) + depth
    for t in range(warm_up, n):
        a, b = judged[t], truth[t - depth]
        assert (a == b) if math.isinf(b) or math.isinf(a) else abs(a - b) <= 1e-9, (t, a, b)


def test_a_window_over_a_since_whose_lower_bound_credits_a_next() -> None:
    """`since[0.1:0.1]` looks one sample back, so `next` on its right has depth 0 there, yet
    the `since` itself needs a delay of 1 (found by hypothesis): the window takes the reach."""
    formula = parse_formula("once[0:0] ((x < 0) since[0.1:0.1] next (y < 0))")
    found = past_form(formula, P)
    assert found is not None
    shifted, depth = found
    trace = {"x": [1.0, -1.0, -2.0, 3.0, -1.0, -1.0], "y": [-1.0, 2.0, -3.0, -1.0, 1.0, -2.0]}
    late = reference_robustness(shifted, trace, 0.1)
    now = reference_robustness(formula, trace, 0.1)
    warm_up = depth + past_horizon(formula, P) + depth  # as in the property test above
    assert depth == 1 and late[warm_up:] == now[warm_up - depth : len(now) - depth]
