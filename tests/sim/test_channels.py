"""Channel models (examples/sim/channels.py) on a hand-built ground truth, no SUMO needed."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from examples.sim.channels import LAV, TFUSE, ChannelModel, fault_offsets
from examples.sim.scenarios import LocalizationFault
from examples.sim.simulate import GroundTruth, sumo_to_centre

QUIET = {"pos_sigma": 0.0, "yaw_sigma": 0.0, "speed_sigma": 0.0, "size_sigma": 0.0,
         "p_miss": 0.0, "ghost_rate": 0.0, "p_id_switch": 0.0, "loc_sigma": 0.0,
         "loc_drift": 0.0, "loc_yaw_sigma": 0.0, "ego_speed_sigma": 0.0,
         "plan_lateral": 0.0, "plan_speed_bias": 0.0}


def _truth() -> GroundTruth:
    """Ego driving east at 10 m/s; car 'ahead' 20 m in front, car 'behind' 15 m behind, car
    'far' 100 m ahead (out of both ranges). 61 ticks of 0.1 s."""
    t = np.round(np.arange(61) * 0.1, 1)
    x0 = np.array([0.0, 20.0, -15.0, 100.0])
    x = x0[None, :] + 10.0 * t[:, None]
    n = (len(t), 4)
    return GroundTruth(
        scenario="hand", times=t, ids=["ego", "ahead", "behind", "far"], cls=["car"] * 4,
        length=np.full(4, 4.5), width=np.full(4, 1.8), min_gap=np.full(n, 2.5), x=x,
        y=np.zeros(n), yaw=np.zeros(n), speed=np.full(n, 10.0), lane=np.zeros(n, dtype=int),
        lane_pos=x + 2.25, lane_ids=["hw_1"], speed_limit=np.full(len(t), 33.3),
        sumo_leader=[None] * len(t), sumo_leader_gap=np.full(len(t), np.nan),
        ego_min_gap=np.full(len(t), 2.5), ssm_file=Path("unused"), ego_index=0,
    )


def test_tfuse_is_blind_behind_and_lav_sees_all_around() -> None:
    gt = _truth()
    lav = ChannelModel(gt, replace(LAV, **QUIET), (), seed=1)
    tfuse = ChannelModel(gt, replace(TFUSE, **QUIET), (), seed=1)
    # lav: 360 deg, 60 m -> ahead (20 m) and behind (15 m); far (100 m) is out of range
    assert sorted(o["x"] for o in lav.objects(0)) == [-15.0, 20.0]
    # tfuse: 200 deg centred forward -> the car directly behind is not seen
    assert [o["x"] for o in tfuse.objects(0)] == [20.0]


def test_prediction_is_constant_velocity_over_30_points() -> None:
    gt = _truth()
    for params, last_dt in ((TFUSE, 2.9), (LAV, 5.8)):
        obj = ChannelModel(gt, replace(params, **QUIET), (), seed=1).objects(10)
        ahead = next(o for o in obj if o["x"] > 0)
        pred = np.array(ahead["prediction"])
        assert pred.shape == (30, 3)
        # at t = 1.0 the car is at x = 20 + 10 * 1.0 = 30; tfuse: 29 steps of 0.1 s -> 2.9 s,
        # x = 30 + 29 = 59; lav: 29 steps of 0.2 s -> 5.8 s, x = 30 + 58 = 88
        assert ahead["x"] == 30.0
        np.testing.assert_allclose(pred[-1], [last_dt, 30.0 + 10.0 * last_dt, 0.0])


def test_quiet_plan_is_true_future_path_over_the_horizon() -> None:
    gt = _truth()
    plan = ChannelModel(gt, replace(TFUSE, **QUIET), (), seed=1).plan(0)
    # 3.0 s horizon at 0.1 s -> 31 points; ego at 10 m/s -> x = 10 * dt
    assert plan.shape == (31, 3)
    np.testing.assert_allclose(plan[:, 1], 10.0 * plan[:, 0], atol=1e-9)


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
    cx, cy, yaw = sumo_to_centre(np.array([10.0, 10.0, 10.0]), np.array([20.0, 20.0, 20.0]),
                                 np.array([0.0, 90.0, 180.0]), np.array(4.0))
    np.testing.assert_allclose(cx, [10.0, 8.0, 10.0], atol=1e-9)
    np.testing.assert_allclose(cy, [18.0, 20.0, 22.0], atol=1e-9)
    np.testing.assert_allclose(yaw, [np.pi / 2, 0.0, -np.pi / 2], atol=1e-9)
