"""ompv with standing objects (`standing` > 0): the compiled count against the numpy
formulation it replaced, on random ticks (issue 36): equal values, bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.prediction import TOLERANCE_EPS, _predict, ompv
from casewatch.monitor.similarity import pair_objects
from tests.monitor.test_prediction import GATE, TOL, ompv_case


def numpy_standing_ompv(prev, elapsed, cur, tolerance, gate, standing):
    """ompv's standing branch as numpy array calls (the formulation before the kernel)."""
    n_prev, n_cur = len(prev), len(cur)
    if n_prev == 0:
        return 1.0
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
    partner = np.full(n_prev, -1, dtype=np.int64)
    partner[pi] = ci
    has = partner >= 0
    seen_at = cur.pos[np.where(has, partner, 0)] if n_cur else prev.pos.copy()
    err = np.hypot(*(predicted - seen_at).T)
    moved = np.where(has, np.hypot(*(seen_at - prev.pos).T), 0.0)
    counted = has & ((np.hypot(*(predicted - prev.pos).T) > standing) | (moved > standing))
    followed = counted & reaches & (err <= tolerance + TOLERANCE_EPS)
    n2 = int(counted.sum())
    return 1.0 if n2 == 0 else int(followed.sum()) / n2


@settings(max_examples=300, deadline=None)
@given(ompv_case(), st.sampled_from([0.05, 0.1, 0.12]), st.sampled_from([0.05, 0.5, 1.5]))
def test_standing_ompv_equals_the_numpy_formulation(case, elapsed, standing):
    prev, cur = case
    want = numpy_standing_ompv(prev, elapsed, cur, TOL, GATE, standing)
    assert ompv(prev, elapsed, cur, TOL, GATE, standing) == want


def test_an_object_that_moved_exactly_the_standing_distance_is_standing():
    """Counted only beyond `standing` (strictly): a car 1.5 m on, with standing 1.5 m and no
    prediction, is a standing object (not a missed prediction), 1.6 m is a moving one."""
    from tests.monitor.builders import obj
    from tests.monitor.test_prediction import objects

    prev = objects(obj("a", 0.0, 0.0))
    for x, want in ((1.5, 1.0), (1.6, 0.0)):
        cur = objects(obj("a", x, 0.0))
        assert ompv(prev, 0.1, cur, TOL, GATE, 1.5) == want
        assert numpy_standing_ompv(prev, 0.1, cur, TOL, GATE, 1.5) == want
