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

from casewatch.monitor.frechet import frechet_distance, frechet_pairs


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
