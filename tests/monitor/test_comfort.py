"""hcs and ppcs: hand-computed values, an independent reference, and the noise / manoeuvre
behaviour spi-reference promises (0.12 m of localisation noise reads comfortable, a -6 m/s^2
brake and a swerve do not)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.comfort import STILL_SPEED, hcs, nv, ppcs
from casewatch.monitor.resample import resample_plan

W = 0.2
SPAN = 3.0
DT = 0.1


def test_nv_symmetric_form():
    assert nv(0.0, W) == 0.0
    # 2 / (1 + exp(-0.4)) - 1 = 0.197375
    assert nv(2.0, W) == pytest.approx(0.197375, abs=1e-6)
    assert nv(-2.0, W) == nv(2.0, W)


def window(n: int = 31, step: float = DT) -> np.ndarray:
    return np.arange(n) * step


def test_hcs_constant_speed_and_constant_acceleration():
    t = window()
    u = np.array([math.cos(0.7), math.sin(0.7)])
    assert hcs(t, (5 * t)[:, None] * u, SPAN, W) == pytest.approx(1.0, abs=1e-12)
    # s = 10 t + t^2 along u: a_lon = 2, a_lat = 0, jerk 0 (a cubic fit is exact)
    # score = 1 - ((NV(2) + 0) / 2 + 0) / 2 = 1 - 0.197375 / 4 = 0.950656
    xy = (10 * t + t**2)[:, None] * u
    assert hcs(t, xy, SPAN, W) == pytest.approx(1 - nv(2.0, W) / 4, abs=1e-9)
    assert hcs(t, xy, SPAN, W) == pytest.approx(0.950656, abs=1e-6)


def test_hcs_cubic_motion_hand_computed():
    # x = t^3 on [0, 3], centre 1.5: v = 3 * 2.25 = 6.75, a = 6 * 1.5 = 9 (longitudinal),
    # jerk 6: score = 1 - (NV(9) / 2 + NV(6)) / 2
    t = window()
    xy = np.column_stack([t**3, np.zeros_like(t)])
    assert hcs(t, xy, SPAN, W) == pytest.approx(1 - (nv(9.0, W) / 2 + nv(6.0, W)) / 2, abs=1e-9)


def test_hcs_reads_only_the_last_span_and_warms_up():
    t = window(40)
    xy = np.column_stack([10 * t, np.zeros_like(t)])
    xy[:5] += 3.0  # a jump older than the span is forgotten
    assert hcs(t, xy, SPAN, W) == pytest.approx(1.0, abs=1e-12)
    assert hcs(t[:30], xy[:30], SPAN, W) is None  # 2.9 s of history: not yet a full span
    assert hcs(t[:3], xy[:3], 0.2, W) is None  # three samples cannot fix a cubic


def test_lateral_acceleration_on_a_circle():
    # 10 m/s on a 40 m circle: a_lat = v^2 / R = 2.5, a_lon = 0, and the jerk vector turns with
    # the velocity: |j| = v^3 / R^2 = 0.625. score = 1 - (NV(2.5) / 2 + NV(0.625)) / 2
    # = 1 - (0.244919 / 2 + 0.062418) / 2 = 0.907561; the cubic fit's bias on a 0.75 rad arc
    # stays within 1e-3 of it
    want = 1 - (nv(2.5, W) / 2 + nv(0.625, W)) / 2
    assert want == pytest.approx(0.907561, abs=1e-6)
    t = window()
    ang = 0.25 * t
    xy = np.column_stack([40 * np.cos(ang), 40 * np.sin(ang)])
    assert hcs(t, xy, SPAN, W) == pytest.approx(want, abs=1e-3)
    plan = np.column_stack(
        [np.arange(51) * DT, *(40 * f(0.25 * np.arange(51) * DT) for f in (np.cos, np.sin))]
    )
    assert ppcs(plan, SPAN, W) == pytest.approx(want, abs=1e-3)


def test_standstill_counts_the_whole_acceleration_as_longitudinal():
    # starts from rest: |v| < STILL_SPEED at the centre, so a_lon = |a|, whatever the frame
    t = window()
    s = 0.05 * (t - 1.5) ** 2  # v = 0 at the centre, a = 0.1
    for ang in (0.0, 1.0, 2.5):
        xy = np.column_stack([s * math.cos(ang), s * math.sin(ang)])
        assert hcs(t, xy, SPAN, W) == pytest.approx(1 - nv(0.1, W) / 4, abs=1e-9)
    assert STILL_SPEED > 0


def test_ppcs_short_plans():
    dt = np.arange(5) * 0.2
    plan = np.column_stack([dt, 3 * dt, -dt])
    assert ppcs(plan, SPAN, W) == pytest.approx(1.0)  # shorter than the span: one whole fit
    assert ppcs(plan[:3], SPAN, W) is None  # three points cannot fix a cubic


def numpy_reference(
    times: np.ndarray, xy: np.ndarray, centres: np.ndarray, half: float, steepness: float
) -> float:
    """Independent formulation: np.polyfit per centre, derivatives of the polynomial."""
    peaks = np.zeros(3)
    for c in centres:
        sel = np.abs(times - c) <= half + 1e-9
        px = np.polyfit(times[sel] - c, xy[sel, 0], 3)
        py = np.polyfit(times[sel] - c, xy[sel, 1], 3)
        v = np.array([px[2], py[2]])
        a = 2 * np.array([px[1], py[1]])
        j = 6 * np.array([px[0], py[0]])
        speed = np.hypot(*v)
        if speed >= STILL_SPEED:
            u = v / speed
            lon, lat = a @ u, -a[0] * u[1] + a[1] * u[0]
        else:
            lon, lat = np.hypot(*a), 0.0
        peaks = np.maximum(peaks, [abs(lon), abs(lat), np.hypot(*j)])
    v = [2.0 / (1.0 + math.exp(-steepness * p)) - 1.0 for p in peaks]
    return 1.0 - ((v[0] + v[1]) / 2 + v[2]) / 2


@settings(max_examples=80, deadline=None)
@given(
    st.lists(st.floats(0.02, 0.3), min_size=12, max_size=60),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20)),
    st.tuples(st.floats(-3, 3), st.floats(-3, 3)),
    st.integers(0, 2**32 - 1),
)
def test_kernel_equals_numpy_reference(steps, v0, acc, seed):
    """hcs and ppcs against np.polyfit on random irregular series with noise."""
    times = np.concatenate([[0.0], np.cumsum(steps)])
    rng = np.random.default_rng(seed)
    xy = np.outer(times, v0) + 0.5 * np.outer(times**2, acc) + rng.normal(0.0, 0.1, (len(times), 2))
    span = times[-1] - times[0]
    if span < 0.5 or np.sum(np.abs(times - span / 2) <= span / 2 + 1e-9) < 4:
        return
    want = numpy_reference(times, xy, np.array([times[-1] - span / 2]), span / 2, W)
    assert hcs(times, xy, span, W) == pytest.approx(want, abs=1e-7)


def ar1(rng: np.random.Generator, n: int, sigma: float, phi: float) -> np.ndarray:
    e = np.empty(n)
    e[0] = rng.normal(0.0, sigma)
    w = rng.normal(0.0, sigma * math.sqrt(1 - phi**2), n)
    for k in range(1, n):
        e[k] = phi * e[k - 1] + w[k]
    return e


def rolling_hcs(t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    n = round(SPAN / DT) + 1
    return np.array(
        [hcs(t[i - n + 1 : i + 1], xy[i - n + 1 : i + 1], SPAN, W) for i in range(n - 1, len(t))]
    )


@pytest.mark.parametrize("speed", [0.0, 13.9, 33.3])
@pytest.mark.parametrize("phi", [0.3, 0.6, 0.9])
def test_localisation_noise_reads_comfortable(speed, phi):
    """A stationary or constant-speed ego with 0.12 m of AR(1) noise per axis (more than the
    0.1 m the issue names) stays above the 0.8 threshold on every tick of 60 s."""
    rng = np.random.default_rng(round(speed * 10 + phi * 100))
    t = np.arange(601) * DT
    xy = np.column_stack([speed * t + ar1(rng, len(t), 0.12, phi), ar1(rng, len(t), 0.12, phi)])
    assert rolling_hcs(t, xy).min() > 0.85


def brake(t: np.ndarray, decel: float, ramp: float = 0.5, v0: float = 25.0) -> np.ndarray:
    """Distance along a straight road: cruise, then brake at `decel` (reached in `ramp` s) to
    a stop at t = 10 s."""
    a = np.where(t < 10.0, 0.0, np.maximum(decel, decel * (t - 10.0) / ramp))
    v = np.maximum(v0 + np.cumsum(a) * DT, 0.0)
    return np.cumsum(v) * DT


def test_harsh_brake_reads_uncomfortable_through_noise():
    rng = np.random.default_rng(7)
    t = np.arange(301) * DT
    noise = np.column_stack([ar1(rng, len(t), 0.12, 0.6), ar1(rng, len(t), 0.12, 0.6)])
    scores = rolling_hcs(t, np.column_stack([brake(t, -6.0), np.zeros_like(t)]) + noise)
    assert scores.min() < 0.75
    assert (scores < 0.8).sum() >= 10  # a second or more of violation, not a blip


def lane_change(t: np.ndarray, duration: float, speed: float = 30.0) -> np.ndarray:
    """3.5 m to the left in `duration` s from t = 10 s, lateral acceleration a full sine."""
    s = np.clip((t - 10.0) / duration, 0.0, 1.0)
    y = 3.5 * (s - np.sin(2 * np.pi * s) / (2 * np.pi))
    return np.column_stack([speed * t, y])


def test_swerve_reads_uncomfortable_and_a_lane_change_does_not():
    rng = np.random.default_rng(11)
    t = np.arange(301) * DT
    noise = np.column_stack([ar1(rng, len(t), 0.12, 0.6), ar1(rng, len(t), 0.12, 0.6)])
    swerve = rolling_hcs(t, lane_change(t, 1.5) + noise)
    assert swerve.min() < 0.8
    relaxed = rolling_hcs(t, lane_change(t, 4.0) + noise)
    assert relaxed.min() > 0.8


def path(times: np.ndarray) -> np.ndarray:
    """A braking left turn: speed 15 - 1.5 t, curvature growing with t."""
    s = 15 * times - 0.75 * times**2
    heading = 0.002 * s**1.5
    ds = np.gradient(s)
    x = np.cumsum(np.cos(heading) * ds)
    y = np.cumsum(np.sin(heading) * ds)
    return np.column_stack([times, x - x[0], y - y[0]])


def test_ppcs_is_sampling_invariant():
    """The same planned motion sampled every 0.1 s, every 0.5 s and every metre reads the same
    ppcs within 0.01 once resampled onto the canonical grid."""
    fine = path(np.linspace(0.0, 5.0, 5001))
    by_time = {step: fine[:: round(step / 0.001)] for step in (0.1, 0.5)}
    dist = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(fine[:, 1:], axis=0).T))])
    marks = np.searchsorted(dist, np.arange(0.0, dist[-1], 1.0))
    by_distance = fine[np.unique(np.append(marks, len(fine) - 1))]
    values = [ppcs(resample_plan(p, DT), SPAN, W) for p in (*by_time.values(), by_distance)]
    assert max(values) - min(values) < 0.01
    assert values[0] < 0.95  # the manoeuvre is there to be measured


@settings(max_examples=60, deadline=None)
@given(
    st.integers(31, 60),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20)),
    st.tuples(st.floats(-3, 3), st.floats(-3, 3)),
    st.integers(0, 2**32 - 1),
)
def test_ppcs_on_the_grid_equals_the_general_fit(n, v0, acc, seed):
    """ppcs takes one least-squares projection for every window of a uniformly sampled plan;
    it must give the general per-window fit's value (np.polyfit reference)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    xy = np.outer(t, v0) + 0.5 * np.outer(t**2, acc) + rng.normal(0.0, 0.05, (n, 2))
    plan = np.column_stack([t, xy])
    inside = (t - SPAN / 2 >= -1e-9) & (t + SPAN / 2 <= t[-1] + 1e-9)
    want = numpy_reference(t, xy, t[inside], SPAN / 2, W)
    assert ppcs(plan, SPAN, W) == pytest.approx(want, abs=1e-7)


def test_ppcs_windows_of_three_samples_have_no_value_instead_of_failing():
    """comfort_span 1.0 s on a 0.5 s grid: each fit window holds 3 samples, too few for a
    cubic, so ppcs has no value (it raised LinAlgError from the singular projection)."""
    t = np.arange(0.0, 5.01, 0.5)
    plan = np.column_stack([t, 10.0 * t, 0.1 * t**2])
    assert ppcs(plan, 1.0, 1.0) is None
    assert ppcs(plan, 1.5, 1.0) is None  # [t - 0.75, t + 0.75] still holds 3 samples
    # five samples per window (span 2 s) fit: a straight constant-speed plan is fully comfortable
    straight = np.column_stack([t, 10.0 * t, np.zeros_like(t)])
    assert ppcs(straight, 2.0, 1.0) == pytest.approx(1.0, abs=1e-9)
