"""hcs and ppcs, hand-computed."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from monitor.comfort import comfort_score, comfort_scores, hcs, nv, ppcs

W = 0.2


def test_nv_symmetric_form():
    assert nv(0.0, W) == 0.0
    # 2 / (1 + exp(-0.4)) - 1 = 0.197375
    assert nv(2.0, W) == pytest.approx(0.197375, abs=1e-6)
    assert nv(-2.0, W) == nv(2.0, W)


def test_hcs_constant_speed_is_one_and_constant_acceleration():
    t = np.arange(10) * 0.1
    yaw = np.full(10, 0.7)
    u = np.array([math.cos(0.7), math.sin(0.7)])
    xy = (5 * t)[:, None] * u
    assert hcs(t, xy, yaw, 10, W) == pytest.approx(1.0)
    # s = t^2 along the heading: a_lon = 2, a_lat = 0, jerk 0
    # score = 1 - ((NV(2) + 0) / 2 + 0) / 2 = 1 - 0.197375 / 4 = 0.950656
    xy = (t**2)[:, None] * u
    assert hcs(t, xy, yaw, 10, W) == pytest.approx(1 - nv(2.0, W) / 4, abs=1e-9)
    assert hcs(t, xy, yaw, 10, W) == pytest.approx(0.950656, abs=1e-6)


def test_hcs_uses_the_channel_yaw_not_the_path():
    t = np.arange(10) * 0.1
    xy = np.column_stack([t**2, np.zeros(10)])  # a = 2 along +x
    # heading +y: the acceleration is all lateral: 1 - ((0 + NV(2)) / 2 + NV(0)) / 2
    # (a_lon = 0 everywhere, so j_lon = 0 too)
    assert hcs(t, xy, np.full(10, math.pi / 2), 10, W) == pytest.approx(1 - nv(2.0, W) / 4)


def test_hcs_warm_up():
    t = np.arange(9) * 0.1
    assert hcs(t, np.zeros((9, 2)), np.zeros(9), 10, W) is None


def test_ppcs_circle_lateral_acceleration():
    # 5 m/s on a 10 m radius circle: a_lat = v^2 / R = 2.5, a_lon = 0, jerk 0
    # score = 1 - NV(2.5) / 4 = 1 - 0.244919 / 4 = 0.938770 (finite differences within 1e-4)
    dt = np.arange(30) * 0.1
    ang = 0.5 * dt
    plan = np.column_stack([dt, 10 * np.cos(ang), 10 * np.sin(ang)])
    assert ppcs(plan, W) == pytest.approx(1 - nv(2.5, W) / 4, abs=1e-4)
    assert ppcs(plan, W) == pytest.approx(0.938770, abs=1e-4)


def test_ppcs_straight_and_too_short():
    dt = np.arange(5) * 0.2
    plan = np.column_stack([dt, 3 * dt, -dt])
    assert ppcs(plan, W) == pytest.approx(1.0)
    assert ppcs(plan[:3], W) is None


def test_jerk_counts():
    # x = t^3: v = 3t^2, a = 6t, jerk 6 (finite differences on a uniform grid: exact jerk 6)
    t = np.arange(6) * 0.1
    xy = np.column_stack([t**3, np.zeros(6)])
    got = comfort_score(t, xy, np.zeros(6), W)
    # peak |a_lon| = 6 * t at the last acceleration sample (t = 0.4) -> 2.4
    a_peak = 6 * 0.4
    assert got == pytest.approx(1 - (nv(a_peak, W) / 2 + nv(6.0, W)) / 2, abs=1e-6)


@st.composite
def comfort_series(draw):
    """A (times, xy, yaw or None) series: 2 to 12 samples on an irregular increasing grid,
    sometimes standing still (an undefined plan tangent)."""
    n = draw(st.integers(2, 12))
    t0 = draw(st.floats(-5, 100))
    steps = draw(st.lists(st.floats(0.05, 0.3), min_size=n - 1, max_size=n - 1))
    times = t0 + np.concatenate([[0.0], np.cumsum(steps)])
    # smooth motion: a velocity that changes by up to 3 m/s per step
    v0 = np.array([draw(st.floats(-20, 20)), draw(st.floats(-20, 20))])
    dv = st.tuples(st.floats(-3, 3), st.floats(-3, 3))
    vel = v0 + np.cumsum(np.array(draw(st.lists(dv, min_size=n, max_size=n))), axis=0)
    xy = draw(st.floats(-100, 100)) + np.cumsum(vel * np.append(steps, 0.1)[:, None], axis=0)
    if draw(st.booleans()):
        xy[: n // 2] = xy[0]  # stands still first
    yaw = np.array(draw(st.lists(st.floats(-4, 4), min_size=n, max_size=n)))
    return times, xy, yaw if draw(st.booleans()) else None


@settings(max_examples=80, deadline=None)
@given(st.lists(comfort_series(), min_size=1, max_size=5))
def test_batched_scores_equal_one_at_a_time(series):
    """The engine scores every hcs and ppcs series of a frame in one call; each value must be
    the single-series score (None below four samples)."""
    w = 0.02  # a gentle steepness keeps NV away from saturation: peaks stay distinguishable
    got = comfort_scores(series, w)
    for (times, xy, yaw), value in zip(series, got, strict=True):
        want = comfort_score(times, xy, yaw, w)
        if want is None:
            assert value is None
        else:
            assert value == pytest.approx(want, abs=1e-12)


def reference_score(
    times: np.ndarray, xy: np.ndarray, yaw: np.ndarray | None, steepness: float
) -> float | None:
    """Independent numpy formulation of spi-reference comfort (the pre-kernel code): world-frame
    differences, acceleration rotated onto the heading (yaw, else the chord tangent; no tangent:
    all longitudinal), jerk of a_lon, peaks through NV."""
    if len(times) < 4:
        return None
    vel = np.diff(xy, axis=0) / np.diff(times)[:, None]
    tm = 0.5 * (times[1:] + times[:-1])
    acc = np.diff(vel, axis=0) / np.diff(tm)[:, None]
    if yaw is not None:
        ux, uy = np.cos(yaw[1:-1]), np.sin(yaw[1:-1])
        ok = np.ones(len(acc), dtype=bool)
    else:
        chord = xy[2:] - xy[:-2]
        norm = np.hypot(chord[:, 0], chord[:, 1])
        ok = norm > 1e-12
        safe = np.where(ok, norm, 1.0)
        ux, uy = chord[:, 0] / safe, chord[:, 1] / safe
    a_lon = np.where(ok, acc[:, 0] * ux + acc[:, 1] * uy, np.hypot(acc[:, 0], acc[:, 1]))
    a_lat = np.where(ok, -acc[:, 0] * uy + acc[:, 1] * ux, 0.0)
    j_lon = np.diff(a_lon) / np.diff(times[1:-1])
    peaks = [np.max(np.abs(a_lon)), np.max(np.abs(a_lat)), np.max(np.abs(j_lon))]
    v = [2.0 / (1.0 + math.exp(-steepness * p)) - 1.0 for p in peaks]
    return 1.0 - ((v[0] + v[1]) / 2 + v[2]) / 2


@settings(max_examples=120, deadline=None)
@given(comfort_series(), st.sampled_from([0.02, 0.3, 1.0]))
def test_kernel_equals_numpy_reference(series, steepness):
    """The compiled kernel against the numpy formulation, on random irregular series."""
    times, xy, yaw = series
    want = reference_score(times, xy, yaw, steepness)
    got = comfort_score(times, xy, yaw, steepness)
    if want is None:
        assert got is None
    else:
        assert got == pytest.approx(want, abs=1e-9)


def test_kernel_accepts_strided_engine_views():
    """The engine passes column views of one (n, 4) history array: non-contiguous inputs."""
    t = np.arange(6) * 0.1
    arr = np.column_stack([t, t**3, 0.5 * t**2, np.full(6, 0.3)])
    got = comfort_scores([(arr[:, 0], arr[:, 1:3], arr[:, 3]), (arr[:, 0], arr[:, 1:3], None)], W)
    assert got[0] == pytest.approx(reference_score(t, arr[:, 1:3].copy(), arr[:, 3].copy(), W))
    assert got[1] == pytest.approx(reference_score(t, arr[:, 1:3].copy(), None, W))
