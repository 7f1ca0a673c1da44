"""The vectorised robustness of `evaluator.vector_eval` against the plain-Python reference
evaluator (rtamt's semantics), gaps and restarts included."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from casewatch.evaluator.vector_eval import Unsupported, robustness
from casewatch.spec.ast import Compare, Num, Signal, Window, signals_of
from casewatch.spec.parser import parse_formula
from casewatch.spec.reference_eval import ReferenceEvaluator
from tests.spec.strategies import PERIOD, SIGNALS, mixed_formulas, past_formulas


def reference(formula, trace, t, max_gap):
    """Per segment of evaluated ticks (every input finite, no time jump over max_gap), the
    reference evaluator from the segment's first tick: what the online evaluator's restarts do."""
    names = sorted({s.name for s in signals_of(formula)})
    ok = np.all([np.isfinite(trace[n]) for n in names], axis=0)
    out = np.full(len(t), np.nan)
    start = None
    for i in range(len(t) + 1):
        breaks = (
            i == len(t)
            or not ok[i]
            or (start is not None and i > 0 and (not ok[i - 1] or t[i] - t[i - 1] > max_gap + 1e-9))
        )
        if breaks and start is not None:
            seg = {n: [float(v) for v in trace[n][start:i]] for n in SIGNALS}
            ev = ReferenceEvaluator(seg, PERIOD)
            for k in range(i - start):
                out[start + k] = ev.robustness(formula, k)
            start = None
        if i < len(t) and ok[i] and start is None:
            start = i
    return out


@st.composite
def gappy_traces(draw):
    n = draw(st.integers(1, 14))
    values = st.one_of(
        st.floats(-10, 10, allow_nan=False, allow_infinity=False).map(lambda v: round(v, 3)),
        st.just(math.nan),
    )
    trace = {name: np.array(draw(st.lists(values, min_size=n, max_size=n))) for name in SIGNALS}
    steps = draw(st.lists(st.sampled_from([0.1, 0.1, 0.1, 0.3, 0.7]), min_size=n, max_size=n))
    return trace, np.round(np.cumsum(steps), 6)


def assert_matches_reference(formula, data):
    """Same gaps and, elsewhere, the reference's values (to 1e-12) on one random trace."""
    assume(signals_of(formula))
    trace, t = data
    got = robustness(formula, trace, t, PERIOD, max_gap=0.5)
    want = reference(formula, trace, t, max_gap=0.5)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    both = ~np.isnan(want)
    np.testing.assert_allclose(got[both], want[both], rtol=1e-12, atol=1e-12)


@settings(max_examples=300, deadline=None)
@given(past_formulas, gappy_traces())
def test_vectorised_equals_the_reference_per_segment(formula, data):
    assert_matches_reference(formula, data)


def test_for_window_and_restart_hand_computed():
    # once[0:0.2] (x >= 1): the best of the last three samples since the restart; x has no
    # value at tick 3, so tick 4 starts again from itself
    f = Window(
        "once", parse_formula("once[0:0.2] (x >= 1)").interval, Compare(">=", Signal("x"), Num(1.0))
    )
    x = np.array([0.0, 2.0, 0.5, np.nan, 0.2, 0.4, 0.1, 0.0])
    t = np.round(np.arange(8) * 0.1, 6)
    got = robustness(f, {"x": x}, t, 0.1, 0.5)
    want = [-1.0, 1.0, 1.0, np.nan, -0.8, -0.6, -0.6, -0.6]
    np.testing.assert_allclose(got, want, equal_nan=True)


@settings(max_examples=200, deadline=None)
@given(mixed_formulas, gappy_traces())
def test_offline_formulas_equal_the_reference_per_segment(formula, data):
    """Future operators (offline formulas): each segment's end reads as missing samples."""
    assert_matches_reference(formula, data)


def test_future_and_since_hand_computed():
    x = np.array([0.0, 2.0, 0.5, np.nan, 0.2, 3.0, 0.1])
    t = np.round(np.arange(7) * 0.1, 6)
    # eventually[0:0.2] (x >= 1): the best of this and the next two samples of the segment;
    # segments: ticks 0-2 and 4-6 (x has no value at 3); past a segment's end: missing
    got = robustness(parse_formula("eventually[0:0.2] (x >= 1)"), {"x": x}, t, 0.1, 0.5)
    np.testing.assert_allclose(got, [1.0, 1.0, -0.5, np.nan, 2.0, 2.0, -0.9], equal_nan=True)
    # (x >= 0) since (x >= 1), unbounded: S = max(x - 1, min(x, S before)), -inf at a restart
    got = robustness(parse_formula("(x >= 0) since (x >= 1)"), {"x": x}, t, 0.1, 0.5)
    np.testing.assert_allclose(got, [-1.0, 1.0, 0.5, np.nan, -0.8, 2.0, 0.1], equal_nan=True)


def test_unbounded_future_is_refused():
    from casewatch.spec.ast import Window as W

    with pytest.raises(Unsupported, match="unbounded eventually"):
        robustness(
            W("eventually", None, parse_formula("x > 0")),
            {"x": np.zeros(3)},
            np.arange(3) * 0.1,
            0.1,
            0.5,
        )
