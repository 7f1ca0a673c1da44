"""els_var and chpps, hand-computed, and the packed plan history against independent oracles."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.history import (
    GEOM,
    SLOT,
    WEIGHT,
    PlanHistory,
    chpps,
    chpps_frame,
    els_var,
    frame_inputs,
)
from tests.monitor.test_frechet import brute_force

K = 0.95


def test_els_var_sample_variance_of_the_last_window():
    # [1, .5, .5, .25, .5]: mean .55, squared deviations .2025 .0025 .0025 .09 .0025 = .3,
    # divided by n - 1 = 4 -> 0.075
    assert els_var([9.0, 1, 0.5, 0.5, 0.25, 0.5], 5) == pytest.approx(0.075)


def test_els_var_warm_up_and_constant():
    assert els_var([1.0, 1.0, 1.0, 1.0], 5) is None
    assert els_var([0.3] * 5, 5) == 0.0


CURRENT = np.array([[0, 0, 0], [0.1, 1, 0], [0.2, 2, 0]], dtype=float)
#: The distance between the points 1 m along +x and 1 m along (2, 1) / sqrt(5): two paths from
#: one start, resampled by arc length, the tilted one 26.57 degrees off (0.459506 m).
FD_TILT = float(np.hypot(1 - 2 / np.sqrt(5), 1 / np.sqrt(5)))
# age 0.1: dt shifted to -0.1, 0, 0.1, 0.2 -> common range [0, 0.2]; kept points
# (0,0),(1,.5),(2,1) (already on the current plan's first point (0,0)) vs (0,0),(1,0),(2,0).
# Paths: lengths 2.236 and 2, common 2, three points each at 0, 1, 2 m along: the tilted one
# (0,0),(.894,.447),(1.789,.894). Frechet = the end points' distance, 2 * FD_TILT = 0.919012
# -> f1 = 1 / 1.919012
OLDER1 = np.array([[0, -1, 0], [0.1, 0, 0], [0.2, 1, 0.5], [0.3, 2, 1.0]], dtype=float)
# age 0.2: dt -0.2 .. 0.2 -> kept (0,0),(1,0),(2,0): Frechet 0 -> f2 = 1
OLDER2 = np.array([[0, -2, 0], [0.1, -1, 0], [0.2, 0, 0], [0.3, 1, 0], [0.4, 2, 0]], dtype=float)


def test_chpps_hand_computed():
    # (1 * 0.521102 + 0.95 * 1) / (1 + 0.95) = 1.471102 / 1.95 = 0.754411
    got = chpps(CURRENT, [(0.1, OLDER1), (0.2, OLDER2)], K)
    assert got == pytest.approx((1 / (1 + 2 * FD_TILT) + 0.95) / 1.95)
    assert got == pytest.approx(0.754411, abs=1e-6)


def test_chpps_compares_paths_not_speed_profiles():
    # The same straight path driven at 10 m/s, then planned to stop within 1 m (a red light):
    # a time-wise comparison puts the plans 19 m apart at 2 s; their paths are one: chpps 1.
    cruise = np.array([[0.1 * n, 1.0 * n, 0.0] for n in range(21)])
    stopping = np.array([[0.1 * n, min(1.0 * n, 1.0) * (1 - 0.5**n), 0.0] for n in range(21)])
    assert chpps(stopping, [(0.1, cruise)], K) == pytest.approx(1.0)
    assert chpps(cruise, [(0.1, stopping)], K) == pytest.approx(1.0)
    # the path itself swerving: a stored plan along +x, the current one 1 m to the left from
    # 10 m on (a lane change that was not planned before): fd 1 m -> 0.5
    swerve = cruise.copy()
    swerve[10:, 2] = 1.0
    stored = np.vstack([[-0.1, -1.0, 0.0], cruise])
    assert chpps(swerve, [(0.1, stored)], K) == pytest.approx(1 / (1 + 1.0), abs=0.02)


def test_chpps_moves_the_stored_plan_onto_the_current_start():
    # the same path, every point 0.3 m to the left (a localisation jump between two cycles):
    # not instability, chpps 1; the study's untranslated reading would give 1 / 1.3
    shifted = OLDER2 + np.array([0.0, 0.0, 0.3])
    assert chpps(CURRENT, [(0.2, shifted)], K) == pytest.approx(1.0)


def test_chpps_no_overlap_is_no_value():
    old = np.array([[0, 0, 0], [0.5, 5, 0]], dtype=float)
    # age 1.0: shifted dt -1.0 .. -0.5, before the current plan starts
    assert chpps(CURRENT, [(1.0, old)], K) is None
    # age 0.1: shifted dt 0.05 .. 0.06 lies inside the current plan's range but holds none of
    # its samples (0, 0.1, 0.2): no overlap
    between = np.array([[0.15, 5, 0], [0.16, 5, 0]], dtype=float)
    assert chpps(CURRENT, [(0.1, between)], K) is None
    assert chpps(CURRENT, [], K) is None
    assert chpps(np.zeros((0, 3)), [(0.1, old)], K) is None


def test_chpps_weights_use_rank_including_skipped():
    same = CURRENT.copy()
    same[:, 0] += 0.1  # a plan from 0.1 s ago whose points line up with the current dt
    far = np.array([[0, 0, 0], [0.05, 0, 0]], dtype=float)  # no overlap at age 0.2
    # rank 1 overlaps with f = 1 (identical path), rank 2 skipped -> 1.0
    assert chpps(CURRENT, [(0.1, same), (0.2, far)], K) == pytest.approx(1.0)
    # rank 1 skipped, rank 2 = OLDER2 (f = 1) keeps weight 0.95: 0.95 * 1 / 0.95 = 1.0; with
    # OLDER1 at rank 3 (age 0.1 -> same cut as above, f = 0.521102, weight 0.95^2 = 0.9025):
    # (0.95 * 1 + 0.9025 * 0.521102) / (0.95 + 0.9025) = 1.420295 / 1.8525 = 0.766691
    got = chpps(CURRENT, [(0.2, far), (0.2, OLDER2), (0.1, OLDER1)], K)
    assert got == pytest.approx((0.95 + 0.9025 / (1 + 2 * FD_TILT)) / 1.8525)
    assert got == pytest.approx(0.766691, abs=1e-6)


def test_short_common_paths():
    # current dt 0, 0.4; stored (age 0.1) dt 0.1 .. 0.4 -> shifted 0 .. 0.3: common range
    # [0, 0.3] holds one current point (0,0) and four stored points, which move onto it:
    # (0,0),(1,.5),(2,1),(3,1.5). The current cut has no length, so the path both cover is
    # the start point alone: fd 0, chpps 1 (the time-wise reading gave 1 / (1 + 3.354))
    current = np.array([[0.0, 0.0, 0.0], [0.4, 4.0, 0.0]])
    stored = np.array([[0.1, 10, 10], [0.2, 11, 10.5], [0.3, 12, 11], [0.4, 13, 11.5]])
    assert chpps(current, [(0.1, stored)], K) == pytest.approx(1.0)
    # two-point cuts: current keeps (0,0),(1,0), OLDER1 at age 0.2 keeps (1,.5),(2,1) moved to
    # (0,0),(1,.5); common length 1: (1,0) against (.894,.447), fd FD_TILT
    assert chpps(CURRENT[:2], [(0.2, OLDER1)], K) == pytest.approx(1 / (1 + FD_TILT))


def test_history_restarts_after_max_gap_and_keeps_plan_history_plans():
    hist = PlanHistory(2, 2, 0.5, width=2)  # width 2: the 3-point plans widen the buffer
    hist.push(0, 0.0, OLDER2[:3] + np.array([0.2, 0, 0]))  # dt .2 .3 .4, x -2 -1 0
    hist.push(0, 0.1, OLDER1[:3])
    hist.push(0, 0.2, CURRENT)
    # channel 0 at t 0.2: rank 1 = OLDER1[:3] at age 0.1 -> dt -0.1, 0, 0.1: kept (0,0),(1,.5)
    # vs (0,0),(1,0): common length 1, fd FD_TILT; rank 2 = the t 0 plan at age 0.2: dt 0 ..
    # 0.2, points (-2,0),(-1,0),(0,0) moved onto (0,0): (0,0),(1,0),(2,0), the current path:
    # fd 0, f = 1. (0.685163 + 0.95) / 1.95 = 0.838545; channel 1 has no plan from t 0.2: None
    values, fds = chpps_frame(hist, 0.2, K)
    assert values[0] == pytest.approx((1 / (1 + FD_TILT) + 0.95) / 1.95)
    assert values[1] is None and fds == []
    # The ring keeps plan_history = 2 stored plans: at t 0.3 the t 0 plan (age 0.3: dt -0.1 ..
    # 0.1, would overlap, and its x -2, -1, 0 would not line up) is gone; CURRENT at age 0.1 ->
    # dt -0.1 .. 0.1: kept (1,0),(2,0) moved onto (0,0): the current path, fd 0; OLDER1[:3] at
    # age 0.2: dt -0.2 .. 0: one point each, moved together: fd 0. chpps 1.
    hist.push(0, 0.3, CURRENT)
    assert chpps_frame(hist, 0.3, K)[0][0] == pytest.approx(1.0)
    # 1.1 - 0.6 = 0.5000000000000001 s is within max_gap + 1e-9: no restart. The t 0.6 plan at
    # that age lines up with CURRENT point for point: fd 0, chpps 1.
    hist.push(1, 0.6, CURRENT + np.array([0.5, 0, 0]))
    hist.push(1, 1.1, CURRENT)
    assert chpps_frame(hist, 1.1, K)[0] == [None, pytest.approx(1.0)]
    hist.push(1, 1.6000001, CURRENT)  # a gap: history restarts, nothing stored
    assert chpps_frame(hist, 1.6000001, K)[0] == [None, None]
    assert hist.plans.shape[2] >= 3


def test_given_pairs_go_in_the_same_batch():
    p = np.array([[0.0, 0.0], [1.0, 0.0]])
    q = np.array([[0.0, 1.0], [1.0, 1.0]])
    single = np.array([[0.0, 3.0]])
    hist = PlanHistory(1, 1, 0.5)
    # parallel 1 m apart -> 1; one point at (0,3) vs p -> max(3, sqrt(10)); None stays None
    values, fds = chpps_frame(hist, 0.0, K, [(p, q), None, (single, p)])
    assert values == [None]
    assert fds[1] is None
    assert fds[0] == pytest.approx(1.0) and fds[2] == pytest.approx(np.sqrt(10))


def sequences(max_len=6):
    """(n, 2) point sequences of 1 to `max_len` points on a coarse grid (ties and repeats)."""
    pt = st.tuples(st.integers(-5, 5), st.integers(-5, 5))
    return st.lists(pt, min_size=1, max_size=max_len).map(lambda v: np.array(v, dtype=float) / 2)


def reference_frechet(p, q):
    """One pair at a time: the best of every monotone coupling (the definition, brute force),
    or for a one-point sequence the largest distance from that point to the other sequence's
    points."""
    if len(p) == 1 or len(q) == 1:
        one, other = (p, q) if len(p) == 1 else (q, p)
        return max(float(np.hypot(*(o - one[0]))) for o in other)
    return brute_force(p, q)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.none(), st.tuples(sequences(), sequences())), max_size=6))
def test_given_pair_distances_equal_pair_by_pair(pairs):
    _, got = chpps_frame(PlanHistory(1, 1, 0.5), 0.0, K, pairs)
    want = [None if x is None else pytest.approx(reference_frechet(*x), abs=1e-12) for x in pairs]
    assert got == want


def mask_pairs(current, stored, k):
    """chpps's cut as boolean masks: for each stored (age, plan), most recent first, the
    points of both plans within their common range (inclusive, 1e-9 s tolerance) when both
    keep one, with weight k^rank."""
    pairs, weights = [], []
    for rank, (age, plan) in enumerate(stored):
        if len(plan) == 0:
            continue
        lo = max(current[0, 0], plan[0, 0] - age) - 1e-9
        hi = min(current[-1, 0], plan[-1, 0] - age) + 1e-9
        cm = (current[:, 0] >= lo) & (current[:, 0] <= hi)
        sm = (plan[:, 0] >= lo + age) & (plan[:, 0] <= hi + age)
        if lo <= hi and cm.any() and sm.any():
            # the stored cut moves onto the current cut's first point (spi-reference chpps)
            p = current[cm, 1:3]
            q = plan[sm, 1:3]
            q = q + (p[0] - q[0])
            # both paths resampled by arc length over the length both cover (shapely's)
            n = max(len(p), len(q))
            length = min(path_length(p), path_length(q))
            pairs.append((along(p, length, n), along(q, length, n)))
            weights.append(k**rank)
    return pairs, weights


def path_length(points):
    return 0.0 if len(points) < 2 else float(shapely.LineString(points).length)


def along(points, length, n):
    """n points evenly spaced by arc length over the first `length` metres of the path."""
    if len(points) < 2 or length == 0:
        return np.repeat(points[:1], n, axis=0)
    line = shapely.LineString(points)
    return shapely.get_coordinates(line.interpolate(np.linspace(0.0, length, n)))


def reference_chpps(current, stored, k):
    if len(current) == 0:
        return None
    pairs, w = mask_pairs(current, stored, k)
    if not pairs:
        return None
    f = [wj / (1 + reference_frechet(p, q)) for (p, q), wj in zip(pairs, w, strict=True)]
    return sum(f) / sum(w)


def random_plan(draw, max_len=8):
    """A plan on a 0.1 s grid with a random start (on a 0.05 s grid: common ranges that hold
    no sample of one plan), random x, y = index."""
    n = draw(st.integers(1, max_len))
    start = draw(st.integers(0, 6)) / 20
    return np.array([[start + i / 10, draw(st.floats(-9, 9)), i] for i in range(n)])


@st.composite
def plan_history(draw):
    """A current plan and a few stored ones with ages that are multiples of 0.1 s (decimal
    noise in `dt - age`, as in real streams)."""
    stored = [
        (draw(st.integers(1, 12)) / 10, random_plan(draw)) for _ in range(draw(st.integers(0, 5)))
    ]
    stored.sort(key=lambda x: x[0])
    return random_plan(draw), stored


def split_pairs(coords, index, table):
    """The (P, Q) sequences of each table row, from the packed coordinates."""
    return [
        (coords[index == g], coords[index == g + 1]) for g in table[:, GEOM].astype(int).tolist()
    ]


@settings(max_examples=100, deadline=None)
@given(plan_history(), st.lists(st.tuples(sequences(), sequences()), max_size=3))
def test_cut_pairs_equal_a_mask_formulation(case, given_pairs):
    current, stored = case
    hist = PlanHistory(1, max(len(stored), 1), float("inf"), width=3)
    t = 0.0
    for age, plan in reversed(stored):
        hist.push(0, t - age, plan)
    hist.push(0, t, current)
    coords, index, table, n_points, n_geos = frame_inputs(hist, t, K, given_pairs)
    want_pairs, want_w = mask_pairs(current, stored, K)
    want_pairs = given_pairs + want_pairs
    got = split_pairs(coords, index, table)
    assert len(got) == len(want_pairs)
    for (p, q), (wp, wq) in zip(got, want_pairs, strict=True):
        assert p.shape == wp.shape and q.shape == wq.shape
        np.testing.assert_allclose(p, wp, atol=1e-9)
        np.testing.assert_allclose(q, wq, atol=1e-9)
    assert table[:, WEIGHT].tolist() == pytest.approx([1.0] * len(given_pairs) + want_w)
    # GEOS gets exactly the pairs whose sequences both have two points or more, pair by pair.
    multi = [len(p) > 1 and len(q) > 1 for p, q in got]
    assert table[:, SLOT].tolist() == [
        float(sum(multi[:i])) if m else -1.0 for i, m in enumerate(multi)
    ]
    assert n_geos == sum(multi)
    assert index[:n_points].tolist() == sorted(index[:n_points].tolist())
    assert set(index[:n_points].tolist()) == set(range(2 * n_geos))


@settings(max_examples=100, deadline=None)
@given(plan_history())
def test_chpps_equals_the_reference(case):
    current, stored = case
    got = chpps(current, stored, K)
    want = reference_chpps(current, stored, K)
    assert (got is None) == (want is None)
    if want is not None:
        assert got == pytest.approx(want, rel=1e-12, abs=1e-12)


@st.composite
def streams(draw):
    """Frames of two channels: each absent, with an empty plan, or with a random plan; frame
    times on a 0.1 s grid with gaps, some beyond max_gap = 0.25 s."""
    frames = []
    tick = 0
    for _ in range(draw(st.integers(1, 12))):
        tick += draw(st.integers(1, 4))
        row = []
        for _ in range(2):
            kind = draw(st.sampled_from(["absent", "empty", "plan", "plan"]))
            row.append(None if kind == "absent" else np.zeros((0, 3)) if kind == "empty" else 0)
            if kind == "plan":
                row[-1] = random_plan(draw, max_len=10)
        frames.append((tick / 10, row))
    return draw(st.integers(1, 4)), frames


@settings(max_examples=60, deadline=None)
@given(streams())
def test_chpps_over_a_stream_equals_a_deque_model(case):
    """The packed ring against the straightforward model: per channel a deque of the last
    `size` non-empty plans with their times, cleared after more than max_gap without a plan."""
    size, frames = case
    max_gap = 0.25
    hist = PlanHistory(2, size, max_gap, width=4)
    model = [deque(maxlen=size), deque(maxlen=size)]
    for t, row in frames:
        want = []
        for c, plan in enumerate(row):
            if plan is None or len(plan) == 0:
                want.append(None)
                continue
            store = model[c]
            if store and t - store[-1][0] > max_gap + 1e-9:
                store.clear()
            want.append(reference_chpps(plan, [(t - ts, p) for ts, p in reversed(store)], K))
            store.append((t, plan))
            hist.push(c, t, plan)
        got, _ = chpps_frame(hist, t, K)
        assert [g is None for g in got] == [w is None for w in want]
        assert [g for g in got if g is not None] == pytest.approx(
            [w for w in want if w is not None], rel=1e-12, abs=1e-12
        )


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=2, max_size=12), st.integers(2, 12))
def test_els_var_equals_numpy_sample_variance(window, size):
    got = els_var(window, size)
    if len(window) < size:
        assert got is None
    else:
        assert got == pytest.approx(float(np.var(window[-size:], ddof=1)), rel=1e-9, abs=1e-15)
