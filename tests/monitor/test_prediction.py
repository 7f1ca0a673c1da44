"""ompv and the track interpolation, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.prediction import interpolate_tracks, ompv, positions_at
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
    """ompv moves the previous objects to one time with `positions_at`, on Python scalars when
    the objects share a grid; it must give `interpolate_tracks`' values (before the first
    point, inside, after the end)."""
    objs, _ = data
    want = interpolate_tracks(objs.pos, objs.pred, objs.pred_len, np.array([t]))[:, 0]
    got = positions_at(objs.pos, objs.pred, objs.pred_len, t)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
