"""The discrete Fréchet kernel against its definition: hand-computed cases, brute force over
every monotone coupling, and GEOS wherever GEOS finds the minimum."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.frechet import (
    _full_pair_distances,
    _pair_distances,
    frechet_distance,
    frechet_pairs,
)


def _point_distance(p: np.ndarray, q: np.ndarray) -> float:
    dx, dy = float(p[0] - q[0]), float(p[1] - q[1])
    return math.sqrt(dx * dx + dy * dy)


def brute_force(p: np.ndarray, q: np.ndarray) -> float:
    """min over every monotone coupling of the largest coupled distance (exponential: small
    inputs only). A coupling walks from (0, 0) to (n-1, m-1) by steps (1, 0), (0, 1), (1, 1)."""
    n, m = len(p), len(q)

    @cache
    def walks(i: int, j: int) -> list[float]:
        here = _point_distance(p[i], q[j])
        if (i, j) == (n - 1, m - 1):
            return [here]
        costs = []
        for di, dj in ((1, 0), (0, 1), (1, 1)):
            if i + di < n and j + dj < m:
                costs += [max(here, c) for c in walks(i + di, j + dj)]
        return costs

    return min(walks(0, 0))


def test_parallel_lines_are_their_offset_apart():
    p = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    q = p + np.array([0.0, 1.0])
    assert frechet_distance(p, q) == 1.0


def test_a_detour_costs_its_farthest_point():
    # Q's middle point (1, 1) must be coupled with (0, 0) or (2, 0): sqrt(2) either way
    p = np.array([[0.0, 0.0], [2.0, 0.0]])
    q = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    assert frechet_distance(p, q) == math.sqrt(2.0)


def test_one_point_is_its_farthest_distance_to_the_other_line():
    p = np.array([[0.0, 0.0]])
    q = np.array([[3.0, 4.0], [0.0, 1.0], [6.0, 8.0]])
    assert frechet_distance(p, q) == 10.0
    assert frechet_distance(q, p) == 10.0


def test_the_case_geos_gets_wrong():
    """GEOS 3.14 returns 3.0504 for this pair; the best coupling costs 2.2308."""
    p = np.array(
        [
            [-0.12597918998664273, -0.07249854561981205],
            [-0.017241806508524055, -0.10252635884924693],
            [0.15672413238767935, -1.7733764194643595],
            [0.9863530884277222, -2.3481156883853918],
            [-0.18680560801930246, -1.710364528743956],
            [1.1305203993667794, -1.2173363792445133],
        ]
    )
    q = np.array(
        [
            [0.16115931384552032, -0.9322203053719521],
            [3.032726651659019, -0.051961684710443934],
            [1.8934319813160432, -0.8315996009501885],
        ]
    )
    assert frechet_distance(p, q) == brute_force(p, q)
    assert frechet_distance(p, q) == pytest.approx(2.2308040713877277, abs=1e-12)


coordinates = st.floats(-50.0, 50.0, allow_nan=False, allow_infinity=False)
polylines = st.integers(1, 6).flatmap(
    lambda n: st.lists(st.tuples(coordinates, coordinates), min_size=n, max_size=n)
)


@settings(max_examples=300, deadline=None)
@given(polylines, polylines)
def test_equals_brute_force_over_couplings(p, q):
    p, q = np.array(p), np.array(q)
    assert frechet_distance(p, q) == brute_force(p, q)
    assert frechet_distance(p, q) == frechet_distance(q, p)


def _random_walk(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.cumsum(rng.normal(size=(n, 2)), axis=0)


def test_agrees_with_geos_bit_for_bit_where_geos_finds_the_minimum():
    rng = np.random.default_rng(7)
    for _ in range(2000):
        n, m = rng.integers(2, 40, size=2)
        p, q = _random_walk(rng, n), _random_walk(rng, m)
        geos = shapely.frechet_distance(shapely.linestrings(p), shapely.linestrings(q))
        ours = frechet_distance(p, q)
        assert ours <= geos  # the minimum over couplings is never above any coupling's cost
        if n <= 7 and m <= 7 and geos == brute_force(p, q):
            assert ours == geos
        # the value is one of the point distances, computed as GEOS computes them
        dx = p[:, None, 0] - q[None, :, 0]
        dy = p[:, None, 1] - q[None, :, 1]
        assert ours in np.sqrt(dx * dx + dy * dy)


def test_pairs_in_one_call_equal_each_pair_alone():
    rng = np.random.default_rng(3)
    lines = [_random_walk(rng, int(k)) for k in rng.integers(1, 30, size=12)]
    coords = np.concatenate(lines)
    index = np.repeat(np.arange(len(lines)), [len(x) for x in lines])
    together = frechet_pairs(coords, index)
    alone = [frechet_distance(lines[k], lines[k + 1]) for k in range(0, len(lines), 2)]
    assert together.tolist() == alone


def test_no_pairs_and_bad_layouts():
    assert frechet_pairs(np.zeros((0, 2)), np.zeros(0, dtype=np.int64)).shape == (0,)
    with pytest.raises(ValueError, match="pairs of lines"):
        frechet_pairs(np.zeros((3, 2)), np.array([0, 1, 2]))
    with pytest.raises(ValueError, match="at least one point"):
        frechet_distance(np.zeros((0, 2)), np.zeros((2, 2)))


# The shortcuts (`_bounds`, `_greedy_bound`, `_banded_cost`) against the full programme they
# skip cells of, value for value: the reference is `_full_pair_distances`, the recurrence over
# every cell.


def _batch(lines: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, int]:
    coords = np.ascontiguousarray(np.concatenate(lines), dtype=np.float64)
    index = np.repeat(np.arange(len(lines), dtype=np.int64), [len(x) for x in lines])
    return coords, index, len(lines)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.tobytes() == b.tobytes()  # bit for bit, NaN included


def _near(p: np.ndarray, wobble: np.ndarray) -> np.ndarray:
    """A path like p: what chpps compares (the same number of points, a little off)."""
    return p + wobble


@settings(max_examples=400, deadline=None)
@given(
    st.integers(1, 40),
    st.integers(1, 40),
    st.floats(0.0, 3.0),
    st.integers(0, 2**32 - 1),
)
def test_shortcuts_equal_the_full_programme(n, m, scale, seed):
    rng = np.random.default_rng(seed)
    p = _random_walk(rng, n)
    same_length = _near(p, scale * rng.normal(size=p.shape))  # the diagonal bound's case
    other = _random_walk(rng, m)  # lengths differ: the greedy bound
    shifted = p[::-1].copy()  # the diagonal is a poor coupling: the band is wide
    coords, index, n_lines = _batch([p, same_length, p, other, p, shifted])
    assert _same(
        _pair_distances(coords, index, n_lines), _full_pair_distances(coords, index, n_lines)
    )


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 6), st.integers(0, 6)), min_size=2, max_size=12))
def test_shortcuts_on_a_coarse_grid_with_ties(points):
    """Integer points: many equal distances, so the bounds meet and tie often."""
    half = len(points) // 2
    p = np.array(points[:half], dtype=float)
    q = np.array(points[half : 2 * half], dtype=float)
    coords, index, n_lines = _batch([p, q, q, p])
    got = _pair_distances(coords, index, n_lines)
    assert _same(got, _full_pair_distances(coords, index, n_lines))
    assert got[0] == brute_force(p, q)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e308])
def test_a_coordinate_that_is_not_finite_takes_the_full_programme(bad):
    rng = np.random.default_rng(11)
    p = _random_walk(rng, 9)
    q = p + 0.1
    for k in (0, 4, 8):
        for side in (p, q):
            broken = side.copy()
            broken[k, k % 2] = bad
            lines = [broken, q] if side is p else [p, broken]
            coords, index, n_lines = _batch([*lines, p[:5], broken[:7]])
            assert _same(
                _pair_distances(coords, index, n_lines),
                _full_pair_distances(coords, index, n_lines),
            )


def test_the_band_when_the_diagonal_bound_is_not_the_distance():
    # Q lags P by one point: the diagonal coupling pays 1.0, the best one (Q's first point
    # twice, then P's last twice) pays nothing; both ends coincide, so L = 0 < U = 1 and the
    # banded programme runs
    p = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0], [3.0, 0.0]])
    q = np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    coords, index, n_lines = _batch([p, q])
    assert _pair_distances(coords, index, n_lines).tolist() == [0.0]
    assert _full_pair_distances(coords, index, n_lines).tolist() == [0.0]
    assert frechet_distance(p, q) == brute_force(p, q) == 0.0
