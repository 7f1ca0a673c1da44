"""The per-tick glue made cheaper (issue 36) against the formulations it replaced, value for
value on random inputs: ets's index kernels, crpps's one-call path, the object scores without
empty sums, the coverage rows shared by a pair's two sides, `worst`'s test for no value."""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from casewatch.monitor.comfort import (
    MIN_POINTS,
    TIME_EPS,
    _projection,
    _score,
    _uniform_kernel,
    ppcs,
)
from casewatch.monitor.coverage import _rows, _view, _view_rows, common_view
from casewatch.monitor.family import worst
from casewatch.monitor.frames import Coverage, Ego, Objects, box_footprint
from casewatch.monitor.history import (
    _along,
    _along_segs,
    _arc_length,
    _arc_length_segs,
    _segments,
    common_path,
)
from casewatch.monitor.prediction import _ompv_counts, _predict, _standing_counts, ompv
from casewatch.monitor.resample import (
    hold_standing,
    prepare_plan,
    resample_plan,
    smooth_plan,
    with_predictions,
)
from casewatch.monitor.safety_kernel import _stands_still
from casewatch.monitor.safety_score import _upto, prediction_horizon
from casewatch.monitor.similarity import (
    _weights,
    common_range,
    compare_objects,
    crpps_inputs,
    ets,
    pair_objects,
    ranges_from,
)
from casewatch.monitor.situation import _half_extents, ego_half_width
from tests.monitor.test_prediction import GATE, TOL, ompv_case


def _old_ets(plan_a, plan_b, decay, shift=None):
    """ets before issue 36: numpy slices, a shifted copy of B, then the sum."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    a, b = common_range(plan_a, plan_b)
    n = min(len(a), len(b))
    if n == 0:
        return None
    if shift is not None:
        b = b.copy()
        b[:, 1] += shift[0]
        b[:, 2] += shift[1]
    return _old_ets_kernel(a, b, _weights(decay, n))


@njit(error_model="numpy")
def _old_ets_kernel(plan_a, plan_b, w):  # pragma: no cover - compiled
    """The compiled sum ets called before issue 36 (similarity._ets_kernel)."""
    num = 0.0
    den = 0.0
    for p in range(w.shape[0]):
        d = math.hypot(plan_a[p, 1] - plan_b[p, 1], plan_a[p, 2] - plan_b[p, 2])
        num += w[p] * (1.0 / (1.0 + d))
        den += w[p]
    return num / den


def _old_crpps_inputs(plan_a, plan_b):
    """crpps_inputs before issue 36: the cut in its own pass, then `common_path`."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    horizon = min(plan_a[-1, 0], plan_b[-1, 0]) + 1e-9
    begin = max(plan_a[0, 0], plan_b[0, 0]) - 1e-9
    pa = np.array([r[1:3] for r in plan_a if begin <= r[0] <= horizon]).reshape(-1, 2)
    pb = np.array([r[1:3] for r in plan_b if begin <= r[0] <= horizon]).reshape(-1, 2)
    if len(pa) == 0 or len(pb) == 0:
        return None
    x0, y0 = pb[0, 0], pb[0, 1]
    pb = np.column_stack([pb[:, 0] - x0 + pa[0, 0], pb[:, 1] - y0 + pa[0, 1]])
    return common_path(pa, pb)


def _plan(rng, n, start, step=0.1):
    dt = start + step * np.arange(n)
    xy = rng.uniform(-1e3, 1e3, 2) + np.cumsum(rng.normal(0, 2.0, (n, 2)), axis=0)
    return np.column_stack([dt, xy])


@pytest.mark.parametrize("seed", range(40))
def test_ets_and_crpps_inputs_equal_their_old_formulation(seed):
    rng = np.random.default_rng(seed)
    for _ in range(25):
        n_a, n_b = (int(x) for x in rng.integers(0, 55, 2))
        a = _plan(rng, n_a, float(rng.choice([0.0, 0.1, 0.3, 6.0])))
        b = _plan(rng, n_b, float(rng.choice([0.0, 0.2])), float(rng.choice([0.1, 0.05])))
        decay = float(rng.choice([0.95, 0.5, 1.0, rng.uniform(0.1, 1.0)]))
        shift = tuple(rng.normal(0, 3, 2).tolist()) if rng.random() < 0.5 else None
        assert ets(a, b, decay, shift) == _old_ets(a, b, decay, shift)
        got, want = crpps_inputs(a, b), _old_crpps_inputs(a, b)
        if want is None:
            assert got is None
        else:
            assert got is not None
            for g, w in zip(got, want, strict=True):
                assert g.shape == w.shape
                assert np.array_equal(g, w)


def _objects(rng, k):
    pos = rng.uniform(-60, 60, (k, 2))
    fp = np.broadcast_to(box_footprint(4.5, 2.0), (k, 4, 2)).copy()
    pred = np.zeros((k, 0, 3))
    return Objects(
        ids=[str(i) for i in range(k)],
        cls=["car"] * k,
        pos=pos,
        yaw=rng.uniform(-3, 3, k),
        vel=rng.normal(0, 5, (k, 2)),
        footprints=fp,
        pred=pred,
        pred_len=np.zeros(k, dtype=np.int64),
        convex=np.ones(k, dtype=bool),
        half=np.tile([2.25, 1.0], (k, 1)),
    )


def _old_scores(cmp, keep_a, keep_b):
    """ObjectComparison.scores before issue 36 (numpy sums of possibly empty arrays)."""
    n_lone_a, n_lone_b = int(cmp.lone_a.sum()), int(cmp.lone_b.sum())
    keep = float(np.sum(keep_a)) + float(np.sum(keep_b))
    lone = n_lone_a + n_lone_b
    out = {"ocs": 1.0 / (1.0 + abs(n_lone_a - n_lone_b))}
    counts = (cmp.pairs, cmp.pairs, cmp.pairs, cmp.ots_pairs)
    for name, total, pairs in zip(("ols", "oos", "oas", "ots"), cmp.sums, counts, strict=True):
        mean = total / pairs if pairs else 1.0
        out[name] = (total + keep * mean) / (pairs + lone) if pairs + lone else 1.0
    return out


@pytest.mark.parametrize("seed", range(30))
def test_scores_and_common_view_equal_their_old_formulation(seed):
    rng = np.random.default_rng(seed)
    for _ in range(10):
        a, b = _objects(rng, int(rng.integers(0, 12))), _objects(rng, int(rng.integers(0, 12)))
        b.pos[: min(len(a), len(b))] = a.pos[: min(len(a), len(b))] + rng.normal(0, 1, 2)
        ego_a = Ego(*rng.normal(0, 2, 5).tolist(), footprint=box_footprint(4.6, 1.9))
        ego_b = Ego(*rng.normal(0, 2, 5).tolist(), footprint=box_footprint(4.6, 1.9))
        covs = [Coverage(), Coverage(120.0, 50.0), Coverage(360.0, 30.0), Coverage(60.0)]
        cov_a, cov_b = covs[int(rng.integers(0, 4))], covs[int(rng.integers(0, 4))]
        margin = float(rng.choice([0.0, 2.0, -1.0]))
        views = ((cov_a, ego_a), (cov_b, ego_b))
        oa, core_a, ob, core_b = common_view(a, ego_a, cov_a, b, ego_b, cov_b, margin)
        if not (cov_a.all_round and cov_b.all_round):
            for objs, got_objs, got_core in ((a, oa, core_a), (b, ob, core_b)):
                want_objs, want_core = _view(objs, views, margin)
                assert np.array_equal(got_core, want_core)
                assert got_objs.ids == want_objs.ids
                assert np.array_equal(got_objs.pos, want_objs.pos)
                assert _view_rows(objs, _rows(views, margin))[1].tolist() == want_core.tolist()
        cmp = compare_objects(oa, ob, 3.0, 0.95, core_a, core_b)
        for keep_a, keep_b in (
            (np.zeros(0), np.zeros(0)),
            (rng.random(int(cmp.lone_a.sum())), rng.random(int(cmp.lone_b.sum()))),
        ):
            assert cmp.scores(keep_a, keep_b) == _old_scores(cmp, keep_a, keep_b)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True)), max_size=6),
    st.booleans(),
)
def test_worst_equals_the_generator_test(values, use_max):
    if not values or any(v is None for v in values):
        want = None
    else:
        want = max(values) if use_max else min(values)
    got = worst(values, use_max)
    assert (got is None and want is None) or got is want


# --- resampling, situation and safety-score glue --------------------------------------------


def _old_hold_standing(plan, radius):
    if radius <= 0.0 or len(plan) < 2:
        return plan
    d = np.hypot(plan[:, 1] - plan[0, 1], plan[:, 2] - plan[0, 2])
    if d.max() >= radius:
        return plan
    out = plan.copy()
    out[:, 1] = plan[0, 1]
    out[:, 2] = plan[0, 2]
    return out


def _old_prediction_horizon(objects):
    lens = objects.pred_len
    if len(lens) == 0 or objects.pred.shape[1] == 0 or not (lens > 0).any():
        return math.inf
    last = objects.pred[np.arange(len(lens)), np.maximum(lens - 1, 0), 0]
    return float(last[lens > 0].max())


def _same(a, b):
    return (math.isnan(a) and math.isnan(b)) or a == b


@pytest.mark.parametrize("seed", range(40))
def test_plan_and_prediction_helpers_equal_their_old_formulation(seed):
    rng = np.random.default_rng(seed)
    for _ in range(25):
        n = int(rng.integers(0, 12))
        plan = np.column_stack(
            [0.1 * np.arange(n), rng.normal(5, 0.3, n).round(1), rng.normal(0, 0.3, n).round(1)]
        )
        if n and rng.random() < 0.3:
            plan[:, 1:] = plan[0, 1:]  # standing exactly
        if n > 1 and rng.random() < 0.1:
            plan[int(rng.integers(0, n)), 1] = np.nan
        radius = float(rng.choice([0.0, 0.5, 1.0, 2.0]))
        assert np.array_equal(
            hold_standing(plan, radius), _old_hold_standing(plan, radius), equal_nan=True
        )
        if n:
            want = bool((plan[:, 1:3] == plan[0, 1:3]).all())
            assert _stands_still(np.ascontiguousarray(plan)) == want
            limit = float(rng.choice([0.0, 0.25, 0.5, 5.0])) + 1e-9
            if rng.random() < 0.2:
                rng.shuffle(plan)  # not increasing: the mask, not a prefix
            assert np.array_equal(_upto(plan, limit), plan[plan[:, 0] <= limit], equal_nan=True)
        k, width = int(rng.integers(0, 6)), int(rng.integers(0, 5))
        objs = _objects(rng, k)
        objs.pred = rng.uniform(0, 5, (k, width, 3))
        objs.pred_len = rng.integers(0, width + 1, k) if width else np.zeros(k, dtype=np.int64)
        if k and width and rng.random() < 0.1:
            objs.pred[0, :, 0] = np.nan
        assert _same(prediction_horizon(objs), _old_prediction_horizon(objs))
        hl, hw = _half_extents(objs)
        assert hl.flags.c_contiguous and hw.flags.c_contiguous
        assert np.array_equal(hl, objs.half[:, 0]) and np.array_equal(hw, objs.half[:, 1])


def test_ego_half_width_is_the_footprints_for_a_box():
    for length, width in ((4.6, 1.9), (3.0, 0.0), (12.0, 2.55)):
        ego = Ego(
            0.0, 0.0, 0.3, 1.0, 0.0, box_footprint(length, width), half=(length / 2, width / 2)
        )
        assert ego_half_width(ego) == float(np.max(np.abs(ego.footprint[:, 1])))
        ego.half = None
        assert ego_half_width(ego) == float(np.max(np.abs(ego.footprint[:, 1])))


def test_with_predictions_is_replace_over_every_field():
    rng = np.random.default_rng(3)
    objs = _objects(rng, 4)
    _ = objs.areas, objs.radii  # cached fields travel too
    pred, lens = np.ones((4, 2, 3)), np.full(4, 2)
    got, want = with_predictions(objs, pred, lens), replace(objs, pred=pred, pred_len=lens)
    for f in fields(Objects):
        assert getattr(got, f.name) is getattr(want, f.name), f.name


# --- ompv: prediction to counts in one call when the channel tracks -------------------------


def _old_ompv(prev, elapsed, cur, tolerance, gate, standing):
    """ompv before the fused call: ids matched, `_predict`, then the count kernels."""
    n_prev, n_cur = len(prev), len(cur)
    if n_prev == 0 and standing > 0.0:
        return 1.0
    if n_prev == 0:
        return 1.0 if n_cur == 0 else 0.0
    index_cur = {oid: i for i, oid in enumerate(cur.ids)}
    match = np.array([index_cur.get(oid, -1) for oid in prev.ids], dtype=np.int64)
    predicted, reaches = _predict(prev.pos, prev.pred, prev.pred_len, float(elapsed))
    pi = np.flatnonzero(match >= 0)
    if len(pi) or n_cur == 0:
        ci = match.take(pi)
    else:
        cand = np.flatnonzero(reaches)
        pa, ci, _ = pair_objects(predicted.take(cand, axis=0), cur.pos, gate)
        pi = cand.take(pa)
    if standing <= 0.0:
        n1, n2 = _ompv_counts(predicted, reaches, cur.pos, pi, ci, float(tolerance))
        return n1 / n2
    n1, n2 = _standing_counts(
        predicted, reaches, prev.pos, cur.pos, pi, ci, float(tolerance), float(standing)
    )
    return 1.0 if n2 == 0 else n1 / n2


@settings(max_examples=400, deadline=None)
@given(ompv_case(), st.sampled_from([0.05, 0.1, 0.5]), st.sampled_from([0.0, 0.05, 0.5, 1.5]))
def test_ompv_equals_its_old_formulation(case, elapsed, standing):
    prev, cur = case
    want = _old_ompv(prev, elapsed, cur, TOL, GATE, standing)
    assert ompv(prev, elapsed, cur, TOL, GATE, standing) == want


# --- chpps: stored plans' segment lengths computed once -------------------------------------


@pytest.mark.parametrize("seed", range(30))
def test_cached_segments_give_the_arc_lengths_and_points_of_the_direct_ones(seed):
    """`_cut` reads segment lengths pushed with each plan (`_segments`) instead of recomputing
    them: `_arc_length_segs` and `_along_segs` equal `_arc_length` and `_along` bit for bit."""
    rng = np.random.default_rng(seed)
    for _ in range(30):
        n_rows = int(rng.integers(1, 45))
        rows = np.zeros((n_rows + 3, 3))  # padding rows after the plan, as in PlanHistory
        rows[:n_rows, 1:] = rng.uniform(-500, 500, 2) + np.cumsum(
            np.where(rng.random((n_rows, 2)) < 0.2, 0.0, rng.normal(0, 2, (n_rows, 2))), axis=0
        )
        segs = np.zeros(n_rows + 3)
        _segments(rows, n_rows, segs)
        first = int(rng.integers(0, n_rows))
        n = int(rng.integers(1, n_rows - first + 1))
        assert _arc_length_segs(segs, first, n) == _arc_length(rows, first, n)
        length = _arc_length(rows, first, n) * float(rng.choice([1.0, 0.5, 0.0, 1.01]))
        n_out = int(rng.integers(1, 50))
        off = rng.normal(0, 3, 2)
        want = np.zeros((n_out + 2, 2))
        got = np.zeros((n_out + 2, 2))
        _along(rows, first, n, length, n_out, off[0], off[1], want, 1)
        _along_segs(rows, segs, first, n, length, n_out, off[0], off[1], got, 1)
        assert np.array_equal(got, want)


# --- ppcs: the plan's rows read in place ----------------------------------------------------


def _old_ppcs(plan, span, steepness):
    """ppcs before issue 36: contiguous copies of the columns, numpy scalars."""
    if len(plan) < MIN_POINTS:
        return None
    times = np.ascontiguousarray(plan[:, 0])
    xy = np.ascontiguousarray(plan[:, 1:3])
    half = 0.5 * span
    first, last = times[0], times[-1]
    if last - first < span - TIME_EPS:
        return _score(times, xy, np.array([0.5 * (first + last)]), 0.5 * (last - first), steepness)
    step = (last - first) / (len(times) - 1)
    h = round(half / step)
    if abs(h * step - half) <= TIME_EPS and all(
        abs(times[i + 1] - times[i] - step) <= TIME_EPS for i in range(len(times) - 1)
    ):
        return _uniform_kernel(
            xy, h, len(times) - 1 - h, _projection(h), float(half), float(steepness)
        )
    inside = (times - half >= first - TIME_EPS) & (times + half <= last + TIME_EPS)
    return _score(times, xy, times[inside], half, steepness)


@pytest.mark.parametrize("seed", range(30))
def test_ppcs_equals_its_old_formulation(seed):
    rng = np.random.default_rng(seed)
    for _ in range(20):
        n = int(rng.integers(0, 60))
        step = float(rng.choice([0.1, 0.2, 0.5, 0.13]))
        dt = float(rng.choice([0.0, 0.1])) + step * np.arange(n)
        if n > 2 and rng.random() < 0.2:
            dt[1:] += rng.uniform(0, 0.05, n - 1).cumsum()  # not uniform
        xy = rng.uniform(-100, 100, 2) + np.cumsum(rng.normal(0, 1.5, (n, 2)), axis=0)
        plan = np.column_stack([dt, xy])
        span = float(rng.choice([3.0, 2.0, 1.0, 10.0]))
        steep = float(rng.choice([0.2, 1.0]))
        try:
            want = _old_ppcs(plan, span, steep)
        except np.linalg.LinAlgError:
            # windows of 3 samples (h = 1): no cubic; the old code raised, ppcs has no value
            assert ppcs(plan, span, steep) is None
            continue
        got = ppcs(plan, span, steep)
        assert (got is None and want is None) or got == want


# --- a plan prepared in one call -------------------------------------------------------------


@pytest.mark.parametrize("seed", range(40))
def test_prepare_plan_is_the_three_steps_in_turn(seed):
    rng = np.random.default_rng(seed)
    for _ in range(25):
        n = int(rng.integers(0, 40))
        step = float(rng.choice([0.1, 0.5, 0.25, 0.07]))
        dt = float(rng.choice([0.0, 0.1, 0.03])) + step * np.arange(n)
        xy = rng.uniform(-100, 100, 2) + np.cumsum(rng.normal(0, 1.0, (n, 2)), axis=0)
        if n and rng.random() < 0.3:
            xy = xy[:1] + rng.normal(0, 0.1, (n, 2))  # standing with sample noise
        plan = np.column_stack([dt, xy])
        span = float(rng.choice([0.0, 2.0, 1.0]))
        grid = float(rng.choice([0.1, 0.2]))
        radius = float(rng.choice([0.0, 1.0, 0.3]))
        want = hold_standing(resample_plan(smooth_plan(plan, span), grid), radius)
        got = prepare_plan(plan, span, grid, radius)
        assert got.shape == want.shape
        assert np.array_equal(got, want)
        # a plan that is not C-contiguous float takes the three functions
        assert np.array_equal(prepare_plan(np.asfortranarray(plan), span, grid, radius), want)


@pytest.mark.parametrize("seed", range(20))
def test_ranges_are_numpys_hypot(seed):
    rng = np.random.default_rng(seed)
    for _ in range(50):
        k = int(rng.integers(0, 50))
        scale = float(rng.choice([1.0, 1e3, 1e-3, 1e6]))
        pos = rng.normal(0, scale, (k, 2))
        x, y = rng.normal(0, scale, 2).tolist()
        want = np.hypot(pos[:, 0] - x, pos[:, 1] - y)
        assert np.array_equal(ranges_from(pos, x, y), want)
