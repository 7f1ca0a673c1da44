"""els_var and chpps, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest

from monitor.history import chpps, els_var, frechet_many

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
