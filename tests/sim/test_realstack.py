"""The real-stack channel profiles (LIDAR_STACK, CAMERA_STACK) on hand-built truths, no SUMO.

Each property is checked with the profiles' own values: plans every 0.5 s over 3 s and every
metre over 5 s, predictions of 4.0 s and 2.5 s, AR(1) localisation noise with the configured
standard deviation and lag-1 correlation, the forward camera's field of view and range, the
header's `coverage` key.
"""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest

from examples.sim.channels import (
    CAMERA_STACK,
    LAV,
    LIDAR_STACK,
    SAMPLER_FIELDS,
    TFUSE,
    ChannelModel,
    ChannelParams,
    localize,
    resample_by_distance,
)
from examples.sim.frames import header
from examples.sim.scenarios import HIGHWAY_REALSTACK, URBAN_GRID, URBAN_REALSTACK
from examples.sim.simulate import GroundTruth

QUIET = {
    "pos_sigma": 0.0,
    "pos_white": 0.0,
    "yaw_sigma": 0.0,
    "speed_sigma": 0.0,
    "lat_speed_sigma": 0.0,
    "size_sigma": 0.0,
    "p_miss": 0.0,
    "ghost_rate": 0.0,
    "p_id_switch": 0.0,
    "loc_sigma": 0.0,
    "loc_drift": 0.0,
    "loc_yaw_sigma": 0.0,
    "ego_speed_sigma": 0.0,
    "plan_lateral": 0.0,
    "plan_longitudinal": 0.0,
}


def _truth(ego_x: np.ndarray, others: list[tuple[float, float]] | None = None) -> GroundTruth:
    """The ego on the x axis at `ego_x` (one value per 0.1 s tick), heading east; `others` are
    parked cars at fixed (x, y)."""
    others = others or []
    n_t, n_v = len(ego_x), 1 + len(others)
    t = np.round(np.arange(n_t) * 0.1, 1)
    x = np.empty((n_t, n_v))
    y = np.zeros((n_t, n_v))
    x[:, 0] = ego_x
    for j, (ox, oy) in enumerate(others, start=1):
        x[:, j], y[:, j] = ox, oy
    speed = np.zeros((n_t, n_v))
    speed[:, 0] = np.gradient(ego_x, 0.1)
    n = (n_t, n_v)
    return GroundTruth(
        scenario="hand",
        times=t,
        ids=["ego"] + [f"car{j}" for j in range(1, n_v)],
        cls=["car"] * n_v,
        length=np.full(n_v, 4.5),
        width=np.full(n_v, 1.8),
        min_gap=np.full(n, 2.5),
        x=x,
        y=y,
        yaw=np.zeros(n),
        speed=speed,
        lane=np.zeros(n, dtype=int),
        lane_pos=x + 2.25,
        lane_ids=["hw_1"],
        speed_limit=np.full(n_t, 33.3),
        sumo_leader=[None] * n_t,
        sumo_leader_gap=np.full(n_t, np.nan),
        ego_min_gap=np.full(n_t, 2.5),
        ssm_file=Path("unused"),
        ego_index=0,
    )


def test_profiles_report_as_lav_and_tfuse_with_their_profile_names() -> None:
    # the reference case declares channels [lav, tfuse]; the profile name goes into the meta
    assert (LIDAR_STACK.name, LIDAR_STACK.profile) == ("lav", "LIDAR_STACK")
    assert (CAMERA_STACK.name, CAMERA_STACK.profile) == ("tfuse", "CAMERA_STACK")
    assert (LIDAR_STACK.fov_deg, LIDAR_STACK.range_m) == (360.0, 80.0)
    assert (CAMERA_STACK.fov_deg, CAMERA_STACK.range_m) == (120.0, 70.0)


def test_camera_plan_is_sampled_every_half_second_over_three_seconds() -> None:
    gt = _truth(10.0 * np.arange(80) * 0.1)
    plan = ChannelModel(gt, replace(CAMERA_STACK, **QUIET), (), seed=1).plan(0)
    np.testing.assert_allclose(plan[:, 0], [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0], atol=1e-9)
    np.testing.assert_allclose(plan[:, 1], 10.0 * plan[:, 0], atol=1e-9)


def test_lidar_plan_is_sampled_every_metre_with_the_time_the_ego_reaches_each_point() -> None:
    # accelerating ego: x = 5 t + 0.5 t^2, planned from t = 2 s (7 m/s) to 7 s (12 m/s); the
    # points lie 1 m apart and their dt is when the (smoothed) ego path reaches them, so dt
    # shrinks from point to point
    t = np.arange(120) * 0.1
    gt = _truth(5.0 * t + 0.5 * t**2)
    model = ChannelModel(gt, replace(LIDAR_STACK, **QUIET), (), seed=1)
    plan = model.plan(20)
    step = np.hypot(*np.diff(plan[:, 1:], axis=0).T)
    np.testing.assert_allclose(step, 1.0, atol=1e-9)
    # over 5 s the path covers 7 * 5 + 0.5 * 25 = 47.5 m -> 48 points (0 .. 47 m)
    covered = model.motion.x[70] - model.motion.x[20]
    assert covered == pytest.approx(47.5, abs=0.01)
    assert len(plan) == 48
    dt = np.diff(plan[:, 0])
    assert np.all(dt > 0) and np.all(np.diff(dt) < 1e-9)  # non-uniform, faster and faster
    # 7 tau + tau^2 / 2 = s: tau(s) = sqrt(49 + 2 s) - 7 (the smoothing shifts the path by a
    # constant a sigma^2 / 2 under constant acceleration, which leaves the differences alone)
    tau = np.sqrt(49.0 + 2.0 * np.arange(48)) - 7.0
    np.testing.assert_allclose(plan[:, 0], tau, atol=2e-3)
    # each dt is the time at which the smoothed path passes the point
    reach = np.interp(plan[:, 1], model.motion.x[20:71], gt.times[:51])
    np.testing.assert_allclose(plan[:, 0], reach, atol=1e-6)
    assert plan[-1, 0] <= LIDAR_STACK.plan_horizon


def test_lidar_plan_at_standstill_has_two_points_over_the_horizon() -> None:
    gt = _truth(np.full(80, 12.0))
    plan = ChannelModel(gt, replace(LIDAR_STACK, **QUIET), (), seed=1).plan(10)
    np.testing.assert_allclose(plan, [[0.0, 12.0, 0.0], [5.0, 12.0, 0.0]], atol=1e-9)
    # creeping less than one spacing: still two points, the first and the last of the horizon
    creep = np.column_stack([np.arange(51) * 0.1, np.arange(51) * 0.015, np.zeros(51)])
    np.testing.assert_allclose(resample_by_distance(creep, 1.0), creep[[0, -1]])


def test_predictions_cover_four_and_two_and_a_half_seconds() -> None:
    gt = _truth(10.0 * np.arange(80) * 0.1, [(30.0, 0.0)])
    for params, step, horizon in ((LIDAR_STACK, 0.5, 4.0), (CAMERA_STACK, 0.1, 2.5)):
        (obj,) = ChannelModel(gt, replace(params, **QUIET), (), seed=1).objects(0)
        pred = np.array(obj["prediction"])
        np.testing.assert_allclose(pred[:, 0], step * np.arange(1, round(horizon / step) + 1))
        assert pred[-1, 0] == pytest.approx(horizon)
        np.testing.assert_allclose(pred[:, 1], 30.0, atol=1e-9)  # a parked car stays


def test_real_stack_plans_may_outlast_their_predictions() -> None:
    # real stacks do not align the horizons: 5 s plan / 4 s predictions, 3 s / 2.5 s
    gt = _truth(10.0 * np.arange(80) * 0.1)
    for params in (LIDAR_STACK, CAMERA_STACK):
        assert params.plan_horizon > params.prediction_points * params.prediction_step
        ChannelModel(gt, params, (), seed=1)  # accepted
    with pytest.raises(ValueError, match="longer than its predictions"):
        ChannelModel(gt, replace(CAMERA_STACK, plan_beyond_prediction=False), (), seed=1)


@pytest.mark.parametrize("params", [LIDAR_STACK, CAMERA_STACK], ids=lambda p: p.profile)
def test_localisation_noise_is_ar1_with_the_configured_std_and_lag1_correlation(
    params: ChannelParams,
) -> None:
    """10 minutes at 0.1 s: the offset series' std per axis is loc_sigma (0.06 / 0.12 m), its
    lag-1 correlation loc_phi (0.7 / 0.6); the heading error likewise (loc_yaw_sigma)."""
    gt = _truth(np.zeros(6000))
    loc = localize(gt, params, (), seed=7)
    off = loc.offset
    assert off.std(axis=0) == pytest.approx([params.loc_sigma] * 2, rel=0.08)
    for axis in (0, 1):
        r1 = np.corrcoef(off[:-1, axis], off[1:, axis])[0, 1]
        assert r1 == pytest.approx(params.loc_phi, abs=0.04)
    # unsmoothed: the tick-to-tick step is sigma * sqrt(2 (1 - phi)), not a few % of sigma
    step = np.diff(off, axis=0).std()
    assert step == pytest.approx(params.loc_sigma * np.sqrt(2 * (1 - params.loc_phi)), rel=0.08)
    yaw_err = loc.yaw - 0.0
    assert yaw_err.std() == pytest.approx(params.loc_yaw_sigma, rel=0.08)
    assert np.corrcoef(yaw_err[:-1], yaw_err[1:])[0, 1] == pytest.approx(params.loc_phi, abs=0.04)


def test_original_profiles_keep_the_smooth_localisation() -> None:
    gt = _truth(np.zeros(600))
    off = localize(gt, LAV, (), seed=7).offset
    # smooth: the tick-to-tick step is a few % of the std (AR(1) with phi 0.7: about 77 %)
    assert np.diff(off, axis=0).std() < 0.05 * off.std()


def test_forward_camera_sees_only_within_sixty_degrees_and_seventy_metres() -> None:
    # parked cars around the ego at x = 0 (heading east): bearing (deg) and range (m)
    spots = {
        (0, 30): True,
        (50, 30): True,
        (-50, 30): True,
        (59, 30): True,
        (61, 30): False,
        (-70, 30): False,
        (90, 20): False,
        (135, 20): False,
        (180, 15): False,
        (0, 65): True,
        (0, 72): False,
        (20, 69): True,
        (180, 75): False,
    }
    others = [(r * np.cos(np.radians(b)), r * np.sin(np.radians(b))) for b, r in spots]
    gt = _truth(np.zeros(80), others)
    seen = {
        (round(o["x"], 3), round(o["y"], 3))
        for o in ChannelModel(gt, replace(CAMERA_STACK, **QUIET), (), seed=1).objects(0)
    }
    expect = {
        (round(x, 3), round(y, 3)) for (x, y), v in zip(others, spots.values(), strict=True) if v
    }
    assert seen == expect
    # the LiDAR stack sees all round to 80 m: everything here
    lidar = ChannelModel(gt, replace(LIDAR_STACK, **QUIET), (), seed=1).objects(0)
    assert len(lidar) == len(spots)


def test_forward_camera_ghosts_stay_inside_its_field_of_view() -> None:
    gt = _truth(np.zeros(3000))
    model = ChannelModel(gt, replace(CAMERA_STACK, ghost_rate=5.0, p_miss=0.0), (), seed=3)
    n = 0
    for k in range(0, 3000, 3):
        for o in model.objects(k):
            x, y = o["x"] - model.loc.offset[k, 0], o["y"] - model.loc.offset[k, 1]
            assert abs(np.degrees(np.arctan2(y, x))) <= 60.0 + 1e-6
            assert np.hypot(x, y) <= 70.0
            n += 1
    assert n > 100


def test_header_coverage_matches_the_profiles_for_every_drive() -> None:
    cov = {"lav": {"fov_deg": 360.0, "range_m": 80.0}, "tfuse": {"fov_deg": 120.0, "range_m": 70.0}}
    for sc in (HIGHWAY_REALSTACK, URBAN_REALSTACK):
        head = header(sc)["header"]
        assert head["coverage"] == cov
        assert list(head) == ["format", "version", "channels", "period", "coverage", "meta"]
        params = head["meta"]["channel_params"]
        assert params["lav"]["profile"] == "LIDAR_STACK"
        assert params["tfuse"]["profile"] == "CAMERA_STACK"
        # every parameter is documented (the stack sampler's only when set)
        assert set(params["lav"]) == {f.name for f in fields(ChannelParams)} - set(SAMPLER_FIELDS)
        assert params["lav"]["plan_sampling"] == "distance"
        assert params["tfuse"]["plan_step"] == 0.5
    # the original profiles carry it too (360 deg / 60 m, 200 deg / 50 m), and every parameter
    old = header(URBAN_GRID)["header"]
    assert old["coverage"] == {
        "lav": {"fov_deg": 360.0, "range_m": 60.0},
        "tfuse": {"fov_deg": 200.0, "range_m": 50.0},
    }
    for p in (LAV, TFUSE):
        assert set(p.meta()) == {f.name for f in fields(ChannelParams)} - set(SAMPLER_FIELDS)
        assert p.meta()["plan_standstill_gap"] == 2.0
