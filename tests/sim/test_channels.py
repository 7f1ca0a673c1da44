"""Channel models (examples/sim/channels.py) on a hand-built ground truth, no SUMO needed."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from examples.sim.channels import (
    LAV,
    TFUSE,
    ChannelModel,
    fault_offsets,
    gaussian_smooth,
    lowpass_noise,
    markov_misses,
)
from examples.sim.scenarios import LocalizationFault
from examples.sim.simulate import GroundTruth, sumo_to_centre

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


def _truth() -> GroundTruth:
    """Ego driving east at 10 m/s; car 'ahead' 20 m in front, car 'behind' 15 m behind, car
    'far' 100 m ahead (out of both ranges). 61 ticks of 0.1 s."""
    t = np.round(np.arange(61) * 0.1, 1)
    x0 = np.array([0.0, 20.0, -15.0, 100.0])
    x = x0[None, :] + 10.0 * t[:, None]
    n = (len(t), 4)
    return GroundTruth(
        scenario="hand",
        times=t,
        ids=["ego", "ahead", "behind", "far"],
        cls=["car"] * 4,
        length=np.full(4, 4.5),
        width=np.full(4, 1.8),
        min_gap=np.full(n, 2.5),
        x=x,
        y=np.zeros(n),
        yaw=np.zeros(n),
        speed=np.full(n, 10.0),
        lane=np.zeros(n, dtype=int),
        lane_pos=x + 2.25,
        lane_ids=["hw_1"],
        speed_limit=np.full(len(t), 33.3),
        sumo_leader=[None] * len(t),
        sumo_leader_gap=np.full(len(t), np.nan),
        ego_min_gap=np.full(len(t), 2.5),
        ssm_file=Path("unused"),
        ego_index=0,
    )


def test_tfuse_is_blind_behind_and_lav_sees_all_around() -> None:
    gt = _truth()
    lav = ChannelModel(gt, replace(LAV, **QUIET), (), seed=1)
    tfuse = ChannelModel(gt, replace(TFUSE, **QUIET), (), seed=1)
    # lav: 360 deg, 60 m -> ahead (20 m) and behind (15 m); far (100 m) is out of range
    assert sorted(o["x"] for o in lav.objects(0)) == [-15.0, 20.0]
    # tfuse: 200 deg centred forward -> the car directly behind is not seen
    assert [o["x"] for o in tfuse.objects(0)] == [20.0]


def test_prediction_is_constant_velocity_over_30_points_of_0_1_s() -> None:
    gt = _truth()
    for params in (TFUSE, LAV):
        obj = ChannelModel(gt, replace(params, **QUIET), (), seed=1).objects(10)
        ahead = next(o for o in obj if o["x"] > 0)
        pred = np.array(ahead["prediction"])
        assert pred.shape == (30, 3)
        # at t = 1.0 the car is at x = 20 + 10 * 1.0 = 30; points at dt = 0.1 .. 3.0, the same
        # for both channels (ots compares them index by index): x = 30 + 10 * dt
        assert ahead["x"] == 30.0
        np.testing.assert_allclose(pred[:, 0], 0.1 * np.arange(1, 31), atol=1e-9)
        np.testing.assert_allclose(pred[:, 1], 30.0 + 10.0 * pred[:, 0], atol=1e-9)
        np.testing.assert_allclose(pred[:, 2], 0.0, atol=1e-9)


def test_quiet_plan_is_true_future_path_over_the_horizon() -> None:
    gt = _truth()
    for params, points in ((TFUSE, 26), (LAV, 31)):
        plan = ChannelModel(gt, replace(params, **QUIET), (), seed=1).plan(0)
        # tfuse 2.5 s, lav 3.0 s at 0.1 s -> 26 / 31 points; ego at 10 m/s -> x = 10 * dt
        # (the Gaussian smoothing of the ego path keeps a straight line straight)
        assert plan.shape == (points, 3)
        np.testing.assert_allclose(plan[:, 1], 10.0 * plan[:, 0], atol=1e-9)
        np.testing.assert_allclose(plan[:, 2], 0.0, atol=1e-9)


def test_plan_horizon_longer_than_predictions_is_refused() -> None:
    # an object whose prediction ends stays at its last point: a 3.5 s plan against 3.0 s of
    # prediction would meet phantom obstacles, so the model refuses the combination
    with pytest.raises(ValueError, match=r"plan horizon 3\.5 s is longer"):
        ChannelModel(_truth(), replace(LAV, plan_horizon=3.5), (), seed=1)


def test_plans_change_little_from_one_tick_to_the_next() -> None:
    """Plan distortion is a slow process: two plans 0.1 s apart, compared at the same absolute
    times, differ by centimetres (the old white/stretch model moved them by tens of cm)."""
    gt = _truth()
    quiet_loc = {k: 0.0 for k in ("loc_sigma", "loc_drift", "loc_yaw_sigma")}
    model = ChannelModel(gt, replace(LAV, **quiet_loc), (), seed=3)
    a, b = model.plan(20), model.plan(21)
    # b's point n is at the absolute time of a's point n + 1
    gap = np.hypot(*(a[1:, 1:] - b[:-1, 1:]).T)
    assert gap.max() < 0.05
    # while the distortion itself is not zero (0.25 / 0.30 m std at the horizon)
    assert np.hypot(*(a[-1, 1:] - [10.0 * (2.0 + 3.0), 0.0])) > 1e-3


def test_lowpass_noise_has_unit_variance_and_small_steps() -> None:
    x = lowpass_noise(np.random.default_rng(0), 20000, 0.1, 1.0)
    # unit variance by construction (sample std of a correlated series: a few % off)
    assert abs(x.std() - 1.0) < 0.1
    # second-order low-pass: a 0.1 s step is about dt / tau = 0.1 of the std (white: 1.41)
    assert np.diff(x).std() < 0.15


def test_gaussian_smooth_keeps_lines_and_rounds_steps() -> None:
    t = np.arange(100) * 0.1
    line = 3.0 + 2.0 * t
    np.testing.assert_allclose(gaussian_smooth(line, 4.0), line, atol=1e-9)
    # a step of acceleration (0 -> 2 m/s^2 at t = 5 s): raw jerk 2 / 0.1 = 20 m/s^3 in one
    # tick; smoothed with sigma = 0.4 s its peak is about 2 / (0.4 sqrt(2 pi)) = 2.0 m/s^3
    x = np.where(t < 5.0, 0.0, (t - 5.0) ** 2)
    jerk = np.diff(gaussian_smooth(x, 4.0), 3) / 0.1**3
    assert 1.5 < np.abs(jerk[5:-5]).max() < 2.5


def test_missed_detections_come_in_runs_with_the_given_share() -> None:
    miss = markov_misses(np.random.default_rng(0), (20000, 4), 0.03, 3.0)
    assert abs(miss.mean() - 0.03) < 0.005
    starts = (miss[1:] & ~miss[:-1]).sum()
    # mean run length = missed ticks / runs, about 3
    assert 2.5 < miss[1:].sum() / starts < 3.5


def test_fault_offsets_jump_by_the_amplitude_only_inside_the_fault() -> None:
    t = np.round(np.arange(50) * 0.1, 1)
    fault = LocalizationFault("tfuse", 1.0, 2.0, 3.5)
    off = fault_offsets(np.random.default_rng(0), t, (fault,), "tfuse")
    size = np.hypot(off[:, 0], off[:, 1])
    inside = (t >= 1.0) & (t < 2.0)
    assert np.all(size[~inside] == 0.0)
    assert set(np.round(size[inside], 9)) == {0.0, 3.5}
    assert np.all(fault_offsets(np.random.default_rng(0), t, (fault,), "lav") == 0.0)


def test_sumo_front_bumper_and_heading_convert_to_centre_and_yaw() -> None:
    # angle 0 = north: yaw = pi/2; centre = front - 2 m along +y -> (10, 18)
    # angle 90 = east: yaw = 0; centre = (8, 20); angle 180 = south: centre = (10, 22)
    cx, cy, yaw = sumo_to_centre(
        np.array([10.0, 10.0, 10.0]),
        np.array([20.0, 20.0, 20.0]),
        np.array([0.0, 90.0, 180.0]),
        np.array(4.0),
    )
    np.testing.assert_allclose(cx, [10.0, 8.0, 10.0], atol=1e-9)
    np.testing.assert_allclose(cy, [18.0, 20.0, 22.0], atol=1e-9)
    np.testing.assert_allclose(yaw, [np.pi / 2, 0.0, -np.pi / 2], atol=1e-9)


def test_retime_plan_holds_behind_the_own_prediction_of_the_lead() -> None:
    """Queue start: the ego (4.6 m) stands 1 m behind a stopped car (4.5 m) and its true future
    drives off. Against the channel's own prediction (the car stays) the plan stays at its
    first point; once the lead is predicted to move, the plan follows 2 m behind it, never
    backwards; a lead already far enough ahead leaves the plan unchanged."""
    from examples.sim.channels import retime_plan

    dt = np.round(np.arange(31) * 0.1, 1)
    true = np.column_stack([dt, 1.0 * dt**2, np.zeros_like(dt)])  # 2 m/s^2 from rest
    lead_x = 0.5 * 4.6 + 1.0 + 0.5 * 4.5
    stopped = np.array([[lead_x, 0.0, 0.0, 0.0, 0.0, 4.5]])
    held = retime_plan(true, 4.6, stopped, 2.0, 1.75)
    np.testing.assert_allclose(held[:, 1:], 0.0)
    np.testing.assert_array_equal(held[:, 0], dt)
    moving = np.array([[lead_x, 0.0, 2.0, 0.0, 0.0, 4.5]])  # predicted at 2 m/s
    out = retime_plan(true, 4.6, moving, 2.0, 1.75)
    front_gap = (lead_x + 2.0 * dt - 2.25) - (out[:, 1] + 2.3)
    assert np.all(np.diff(out[:, 1]) >= 0.0)
    assert np.all(out[:, 1] <= true[:, 1] + 1e-12)
    assert np.all((front_gap >= 2.0 - 1e-9) | (out[:, 1] == 0.0))
    assert out[-1, 1] == pytest.approx(lead_x + 6.0 - 2.25 - 2.0 - 2.3)
    far = np.array([[40.0, 0.0, 0.0, 0.0, 0.0, 4.5]])
    np.testing.assert_array_equal(retime_plan(true, 4.6, far, 2.0, 1.75), true)
    # a standing lead that turns off (heading 0.5 rad to the right, 5 m/s: out of the 1.75 m
    # corridor after 0.73 s) while the true future drives on at 10 m/s: the plan holds, then
    # speeds up at PLAN_ACCEL (each 0.1 s step at most 2 * 0.1^2 m longer than the one before)
    # instead of jumping onto the true progress, which it never passes
    cruise = np.column_stack([dt, 10.0 * dt, np.zeros_like(dt)])
    turning = np.array([[lead_x, 0.0, 5 * np.cos(0.5), -5 * np.sin(0.5), -0.5, 4.5]])
    out = retime_plan(cruise, 4.6, turning, 2.0, 1.75)
    steps = np.diff(out[:, 1])
    assert steps[0] == 0.0 and np.all(steps >= 0.0)
    assert np.all(np.diff(steps) <= 2.0 * 0.01 + 1e-9)
    assert np.all(out[:, 1] <= cruise[:, 1] + 1e-12) and out[-1, 1] < 0.5 * cruise[-1, 1]
    # a car in the next lane (3.2 m across) or crossing the path is not planned around
    beside = np.array([[lead_x, 3.2, 0.0, 0.0, 0.0, 4.5], [lead_x, -5.0, 0.0, 2.0, 1.57, 4.5]])
    np.testing.assert_array_equal(retime_plan(true, 4.6, beside, 2.0, 1.75), true)
