"""plan_lateral's compiled pass against its numpy formulation (spi-reference plan_lat) on
random plans: equal values, bit for bit, and None in the same places (issue 36)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from casewatch.monitor.similarity import common_range, plan_lateral


def _numpy_plan_lateral(plan_a, plan_b, shift, yaws, horizon):
    """The numpy formulation the kernel replaced (np.gradient tangents)."""
    if len(plan_a) == 0 or len(plan_b) == 0:
        return None
    a, b = common_range(plan_a, plan_b)
    n = min(int(np.count_nonzero(a[:, 0] <= horizon + 1e-9)), len(b))
    if n == 0:
        return None
    pa, pb = a[:n, 1:3], b[:n, 1:3] + np.asarray(shift)
    direction = np.zeros((n, 2))
    if n > 1:
        for p in (pa, pb):
            t = np.gradient(p, axis=0)
            norm = np.hypot(t[:, 0], t[:, 1])
            direction += t / np.where(norm > 1e-3, norm, np.inf)[:, None]
    norm = np.hypot(direction[:, 0], direction[:, 1])
    fallback = np.array(
        [math.cos(yaws[0]) + math.cos(yaws[1]), math.sin(yaws[0]) + math.sin(yaws[1])]
    )
    fallback /= max(float(np.hypot(*fallback)), 1e-12)
    moving = norm > 1e-3
    ux = np.where(moving, direction[:, 0] / np.where(moving, norm, 1.0), fallback[0])
    uy = np.where(moving, direction[:, 1] / np.where(moving, norm, 1.0), fallback[1])
    d = pb - pa
    return float(np.max(np.abs(d[:, 1] * ux - d[:, 0] * uy)))


def _plan(rng, n: int, start: float, standing: bool) -> np.ndarray:
    dt = start + 0.1 * np.arange(n)
    if standing:  # a plan that stands still for a while: tangents below 1e-3 m
        steps = np.where(rng.random((n, 2)) < 0.5, 0.0, rng.normal(0, 2.0, (n, 2)))
    else:
        steps = rng.normal(0, 2.0, (n, 2))
    xy = rng.uniform(-1e3, 1e3, 2) + np.cumsum(steps, axis=0)
    return np.column_stack([dt, xy])


@pytest.mark.parametrize("seed", range(60))
def test_kernel_equals_numpy_formulation(seed):
    rng = np.random.default_rng(seed)
    for _ in range(20):
        n_a, n_b = (int(x) for x in rng.integers(0, 55, 2))
        a = _plan(rng, n_a, float(rng.choice([0.0, 0.1, 0.3])), seed % 3 == 0)
        b = _plan(rng, n_b, float(rng.choice([0.0, 0.2])), seed % 4 == 0)
        shift = tuple(rng.normal(0, 3, 2).tolist())
        yaws = tuple(rng.uniform(-4, 4, 2).tolist())
        horizon = float(rng.choice([0.0, 0.05, 2.0, 3.0, 10.0]))
        want = _numpy_plan_lateral(a, b, shift, yaws, horizon)
        got = plan_lateral(a, b, shift, yaws, horizon)
        assert got == want, (n_a, n_b, horizon)


def test_one_common_point_reads_the_egos_heading():
    # one shared time: no tangent, the mean of the two yaws (both +y) is "along"
    a = np.array([[0.0, 0.0, 0.0]])
    b = np.array([[0.0, 0.4, 7.0]])
    assert plan_lateral(a, b, (0.0, 0.0), (math.pi / 2, math.pi / 2), 2.0) == pytest.approx(0.4)
