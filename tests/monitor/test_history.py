"""els_var and chpps, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.history import chpps, chpps_pairs, chpps_score, els_var, frechet_many

K = 0.95


def test_els_var_sample_variance_of_the_last_window():
    # [1, .5, .5, .25, .5]: mean .55, squared deviations .2025 .0025 .0025 .09 .0025 = .3,
    # divided by n - 1 = 4 -> 0.075
    assert els_var([9.0, 1, 0.5, 0.5, 0.25, 0.5], 5) == pytest.approx(0.075)


def test_els_var_warm_up_and_constant():
    assert els_var([1.0, 1.0, 1.0, 1.0], 5) is None
    assert els_var([0.3] * 5, 5) == 0.0


CURRENT = np.array([[0, 0, 0], [0.1, 1, 0], [0.2, 2, 0]], dtype=float)


def test_chpps_hand_computed():
    # age 0.1: dt shifted to -0.1, 0, 0.1, 0.2 -> common range [0, 0.2]; kept points
    # (0,.5),(1,.5),(2,.5) vs (0,0),(1,0),(2,0): Frechet 0.5 -> f1 = 1/1.5 = 2/3
    older1 = np.array([[0, -1, 0], [0.1, 0, 0.5], [0.2, 1, 0.5], [0.3, 2, 0.5]], dtype=float)
    # age 0.2: dt -0.2 .. 0.2 -> kept (0,0),(1,0),(2,0): Frechet 0 -> f2 = 1
    older2 = np.array(
        [[0, -2, 0], [0.1, -1, 0], [0.2, 0, 0], [0.3, 1, 0], [0.4, 2, 0]], dtype=float
    )
    # (1 * 2/3 + 0.95 * 1) / (1 + 0.95) = 1.616667 / 1.95 = 0.829060
    got = chpps(CURRENT, [(0.1, older1), (0.2, older2)], K)
    assert got == pytest.approx((2 / 3 + 0.95) / 1.95)
    assert got == pytest.approx(0.829060, abs=1e-6)


def test_chpps_no_overlap_is_no_value():
    old = np.array([[0, 0, 0], [0.5, 5, 0]], dtype=float)
    # age 1.0: shifted dt -1.0 .. -0.5, before the current plan starts
    assert chpps(CURRENT, [(1.0, old)], K) is None
    assert chpps(CURRENT, [], K) is None
    assert chpps(np.zeros((0, 3)), [(0.1, old)], K) is None


def test_chpps_weights_use_rank_including_skipped():
    same = CURRENT.copy()
    same[:, 0] += 0.1  # a plan from 0.1 s ago whose points line up with the current dt
    far = np.array([[0, 0, 0], [0.05, 0, 0]], dtype=float)  # no overlap at age 0.2
    # rank 1 overlaps with f = 1 (identical path), rank 2 skipped -> 1.0
    assert chpps(CURRENT, [(0.1, same), (0.2, far)], K) == pytest.approx(1.0)


def test_frechet_many_matches_pairs():
    p = np.array([[0.0, 0.0], [1.0, 0.0]])
    q = np.array([[0.0, 1.0], [1.0, 1.0]])
    single = np.array([[0.0, 3.0]])
    # parallel 1 m apart -> 1; one point at (0,3) vs p -> max(3, sqrt(10))
    assert frechet_many([(p, q), (single, p)]).tolist() == pytest.approx([1.0, np.sqrt(10)])


def sequences(max_len=6):
    """(n, 2) point sequences of 1 to `max_len` points on a coarse grid (ties and repeats)."""
    pt = st.tuples(st.integers(-5, 5), st.integers(-5, 5))
    return st.lists(pt, min_size=1, max_size=max_len).map(lambda v: np.array(v, dtype=float) / 2)


def reference_frechet(p, q):
    """One pair at a time: GEOS on two line strings, or for a one-point sequence the largest
    distance from that point to the other sequence's points."""
    if len(p) == 1 or len(q) == 1:
        one, other = (p, q) if len(p) == 1 else (q, p)
        return max(float(np.hypot(*(o - one[0]))) for o in other)
    return float(shapely.frechet_distance(shapely.LineString(p), shapely.LineString(q)))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(sequences(), sequences()), min_size=1, max_size=6))
def test_frechet_many_equals_pair_by_pair(pairs):
    got = frechet_many(pairs)
    assert got.tolist() == pytest.approx([reference_frechet(p, q) for p, q in pairs], abs=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(0, 100), st.floats(0.01, 1)), min_size=1, max_size=10),
)
def test_chpps_score_is_the_weighted_mean_of_inv(items):
    d = np.array([x for x, _ in items])
    w = [x for _, x in items]
    want = sum(wj / (1 + dj) for dj, wj in zip(d.tolist(), w, strict=True)) / sum(w)
    assert chpps_score(d, w) == pytest.approx(want, rel=1e-12)


@st.composite
def plan_history(draw):
    """A current plan and a few stored ones on 0.1 s grids with random starts and lengths, and
    ages that are multiples of 0.1 s (decimal noise in `dt - age`, as in real streams)."""

    def plan():
        n = draw(st.integers(1, 8))
        start = draw(st.integers(0, 3)) / 10
        return np.array([[start + i / 10, draw(st.floats(-9, 9)), i] for i in range(n)])

    stored = [(draw(st.integers(1, 12)) / 10, plan()) for _ in range(draw(st.integers(0, 5)))]
    stored.sort(key=lambda x: x[0])
    return plan(), stored


@settings(max_examples=100, deadline=None)
@given(plan_history())
def test_chpps_pairs_equal_a_mask_formulation(case):
    current, stored = case
    want_pairs, want_w = [], []
    for rank, (age, plan) in enumerate(stored):
        # common range of current dt and stored dt - age, inclusive with 1e-9 s tolerance
        lo = max(current[0, 0], plan[0, 0] - age) - 1e-9
        hi = min(current[-1, 0], plan[-1, 0] - age) + 1e-9
        cm = (current[:, 0] >= lo) & (current[:, 0] <= hi)
        sm = (plan[:, 0] >= lo + age) & (plan[:, 0] <= hi + age)
        if lo <= hi and cm.any() and sm.any():
            want_pairs.append((current[cm, 1:3], plan[sm, 1:3]))
            want_w.append(K**rank)
    pairs, weights = chpps_pairs(current, stored, K)
    assert weights == pytest.approx(want_w)
    assert [(p.tolist(), q.tolist()) for p, q in pairs] == [
        (p.tolist(), q.tolist()) for p, q in want_pairs
    ]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=2, max_size=12), st.integers(2, 12))
def test_els_var_equals_numpy_sample_variance(window, size):
    got = els_var(window, size)
    if len(window) < size:
        assert got is None
    else:
        assert got == pytest.approx(float(np.var(window[-size:], ddof=1)), rel=1e-9, abs=1e-15)
