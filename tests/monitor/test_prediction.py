"""ompv and the track interpolation, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.prediction import interpolate_tracks, ompv, positions_at
from tests.monitor.builders import channel, ego, frame, obj

TOL = 1.0
GATE = 3.0


def objects(*items):
    return frame(0.0, {"a": channel(ego(), objects=list(items))}).channels["a"].objects


def test_ompv_hand_computed():
    prev = objects(
        obj(1, 0, 0, prediction=[[0, 0, 0], [0.2, 2, 0]]),  # at 0.1 s: (1, 0)
        obj(2, 10, 0, prediction=[[0, 10, 0], [0.05, 10.5, 0]]),  # ends before 0.1 s: miss
        obj(3, 20, 0),  # no prediction: stays at (20, 0)
    )
    cur = objects(obj(1, 1.5, 0), obj(2, 10.5, 0), obj(3, 22, 0), obj(4, 30, 0))
    # 1: |(1,0)-(1.5,0)| = 0.5 <= 1 followed; 2: miss; 3: 2 m off, miss; 4 is new: miss
    # N1 = 1, N2 = 3 previous + 1 new = 4 -> 0.25
    assert ompv(prev, 0.1, cur, TOL, GATE) == pytest.approx(0.25)


def test_ompv_untracked_uses_nearest_within_gate():
    prev = objects(obj("a", 0, 0, prediction=[[0, 0, 0], [0.1, 1, 0]]), obj("b", 10, 0))
    cur = objects(obj("x", 1.2, 0), obj("y", 12.5, 0))
    # no id carries over -> nearest to predicted positions (1,0) and (10,0):
    # x 0.2 m (followed), y 2.5 m (matched within the gate, but > 1 m: miss), no new
    # N1 = 1, N2 = 2 -> 0.5
    assert ompv(prev, 0.1, cur, TOL, GATE) == pytest.approx(0.5)


def test_ompv_no_objects_edges():
    empty = objects()
    assert ompv(empty, 0.1, empty, TOL, GATE) == 1.0  # N2 = 0
    assert ompv(empty, 0.1, objects(obj(1, 0, 0)), TOL, GATE) == 0.0  # only a new object
    # an object that disappeared: N1 = 0, N2 = 1
    assert ompv(objects(obj(1, 0, 0)), 0.1, empty, TOL, GATE) == 0.0


def test_interpolate_tracks_inside_before_after_and_without():
    prev = objects(
        obj(1, 0, 0, prediction=[[0.2, 2, 0], [0.4, 2, 2]]),
        obj(2, 5, 5),
        obj(3, 0, 0, prediction=[[0, 0, 0], [0.1, 1, 0], [0.3, 1, 2]]),
    )
    times = np.array([0.1, 0.3, 1.0])
    got = interpolate_tracks(prev.pos, prev.pred, prev.pred_len, times)
    # object 1: before its first point (dt 0.2) it moves from (0,0) towards (2,0): (1,0) at
    # 0.1; inside at 0.3: (2,1); after the end: (2,2)
    np.testing.assert_allclose(got[0], [[1, 0], [2, 1], [2, 2]], atol=1e-12)
    assert got[1].tolist() == [[5, 5]] * 3  # no prediction: stays
    # object 3: at 0.1 -> (1,0); at 0.3 -> (1,2); after -> (1,2)
    np.testing.assert_allclose(got[2], [[1, 0], [1, 2], [1, 2]], atol=1e-12)


def test_interpolate_shared_grid_fast_path_matches_general():
    pred = [[0, 0, 0], [0.1, 1, 0], [0.2, 3, 1]]
    same = objects(obj(1, 0, 0, prediction=pred), obj(2, 0, 0, prediction=pred))
    mixed = objects(obj(1, 0, 0, prediction=pred), obj(2, 0, 0, prediction=pred[:2]))
    times = np.array([0.0, 0.05, 0.15, 0.5])
    a = interpolate_tracks(same.pos, same.pred, same.pred_len, times)
    b = interpolate_tracks(mixed.pos, mixed.pred, mixed.pred_len, times)
    # (0.5, 0) at 0.05; (2, 0.5) at 0.15; (3, 1) after the end
    np.testing.assert_allclose(a[0], [[0, 0], [0.5, 0], [2, 0.5], [3, 1]], atol=1e-12)
    np.testing.assert_allclose(b[0], a[0].tolist(), atol=1e-12)
    np.testing.assert_allclose(b[1], [[0, 0], [0.5, 0], [1, 0], [1, 0]], atol=1e-12)


@st.composite
def predicted_objects(draw):
    """1 to 4 objects sharing one prediction grid (ompv's scalar fast path) or not (general
    path): grid start 0 or later, steps 0.05 .. 0.3 s, random points."""
    k = draw(st.integers(1, 4))
    n = draw(st.integers(2, 8))
    start = draw(st.sampled_from([0.0, 0.1, 0.25]))
    steps = draw(st.lists(st.floats(0.05, 0.3), min_size=n - 1, max_size=n - 1))
    grid = [start, *(start + np.cumsum(steps)).tolist()]
    shared = draw(st.booleans())
    items = []
    for i in range(k):
        c = st.floats(-50, 50)
        x, y = draw(c), draw(c)
        pts = [[t, draw(c), draw(c)] for t in grid]
        items.append(obj(i, x, y, prediction=pts if shared or i == 0 else pts[:-1]))
    return objects(*items), grid


@settings(max_examples=80, deadline=None)
@given(predicted_objects(), st.floats(0.0, 3.0))
def test_positions_at_one_time_equal_the_track_interpolation(data, t):
    """ompv moves the previous objects to one time (`positions_at`, the positions its kernel
    predicts); it must give `interpolate_tracks`' values (before the first point, inside,
    after the end)."""
    objs, _ = data
    want = interpolate_tracks(objs.pos, objs.pred, objs.pred_len, np.array([t]))[:, 0]
    got = positions_at(objs.pos, objs.pred, objs.pred_len, t)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_ompv_untracked_ties_within_1e9_break_by_index():
    # No id carries over; no predictions, so the predicted positions are the positions.
    # a at (2 + 5e-13, 0) is 1 + 5e-13 m from x at (1, 0); b at (0, 0) is 1 m from it. The two
    # distances are equal to within 1e-9 m: a tie, broken by index, so x pairs with a (not the
    # strictly nearer b). a is 1 + 5e-13 > 1 m off: miss; b unmatched: miss; x not new.
    # N1 = 0, N2 = 2 -> 0.0 (with b paired it would be 1 / 2).
    prev = objects(obj("a", 2 + 5e-13, 0), obj("b", 0, 0))
    cur = objects(obj("x", 1, 0))
    assert ompv(prev, 0.1, cur, TOL, GATE) == 0.0


def test_ompv_untracked_outside_gate_and_unreached_prediction():
    # a's prediction ends at 0.05 s < 0.1 s: it takes no part in the nearest matching, so x
    # (next to a's predicted end point) is new; b at (10, 0) is 3.5 m from y: beyond the 3 m
    # gate, so y is new too. N1 = 0, N2 = 2 previous + 2 new = 4 -> 0.0
    prev = objects(obj("a", 0, 0, prediction=[[0, 0, 0], [0.05, 0.5, 0]]), obj("b", 10, 0))
    cur = objects(obj("x", 0.5, 0), obj("y", 13.5, 0))
    assert ompv(prev, 0.1, cur, TOL, GATE) == 0.0
    # the same with the gate widened to 4 m: y pairs with b, 3.5 m > 1 m tolerance -> still 0
    assert ompv(prev, 0.1, cur, TOL, 4.0) == 0.0
    # and with the tolerance at 4 m too, b followed: N1 = 1, N2 = 2 + 1 new (x) = 3
    assert ompv(prev, 0.1, cur, 4.0, 4.0) == pytest.approx(1 / 3)


def reference_ompv(prev, elapsed, cur, tolerance, gate):
    """ompv straight from spi-reference, in plain Python over `interpolate_tracks`."""
    n_prev, n_cur = len(prev), len(cur)
    if n_prev == 0:
        return 1.0 if n_cur == 0 else 0.0
    moved = interpolate_tracks(prev.pos, prev.pred, prev.pred_len, np.array([elapsed]))[:, 0]
    reaches = [
        n == 0 or prev.pred[i, n - 1, 0] >= elapsed - 1e-9
        for i, n in enumerate(prev.pred_len.tolist())
    ]
    if n_cur == 0 or any(oid in cur.ids for oid in prev.ids):
        pairs = [(i, cur.ids.index(oid)) for i, oid in enumerate(prev.ids) if oid in cur.ids]
    else:
        cands = []
        for i in range(n_prev):
            for j in range(n_cur):
                d = float(np.sqrt(((moved[i] - cur.pos[j]) ** 2).sum()))
                if reaches[i] and d <= gate + 1e-9:
                    cands.append((round(d / 1e-9), i, j))
        pairs, used_i, used_j = [], set(), set()
        for _, i, j in sorted(cands):
            if i not in used_i and j not in used_j:
                used_i.add(i)
                used_j.add(j)
                pairs.append((i, j))
    n1 = sum(
        1 for i, j in pairs if reaches[i] and float(np.hypot(*(moved[i] - cur.pos[j]))) <= tolerance
    )
    n_new = n_cur - len({j for _, j in pairs})
    return n1 / (n_prev + n_new)


@st.composite
def ompv_case(draw):
    """Two ticks of a few objects close together (so the 3 m gate and 1 m tolerance matter),
    ids from a small pool (tracked or not), predictions absent, short or long."""

    def one_tick(n, ids):
        items = []
        for i in range(n):
            x, y = draw(st.floats(-4, 4)), draw(st.floats(-4, 4))
            m = draw(st.integers(0, 4))
            start = draw(st.sampled_from([0.0, 0.05]))
            pts = [[start + 0.04 * s, x + draw(st.floats(-2, 2)), y] for s in range(m)]
            items.append(obj(ids[i], x, y, prediction=pts or None))
        return objects(*items)

    pool = ["a", "b", "c", "d", "e", "f", "g", "h"]
    n_prev, n_cur = draw(st.integers(0, 4)), draw(st.integers(0, 4))
    prev = one_tick(n_prev, draw(st.permutations(pool))[:n_prev])
    cur = one_tick(n_cur, draw(st.permutations(pool))[:n_cur])
    return prev, cur


@settings(max_examples=150, deadline=None)
@given(ompv_case(), st.sampled_from([0.05, 0.1, 0.12]))
def test_ompv_equals_the_reference(case, elapsed):
    prev, cur = case
    assert ompv(prev, elapsed, cur, TOL, GATE) == reference_ompv(prev, elapsed, cur, TOL, GATE)
