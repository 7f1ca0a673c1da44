"""Driving stacks drawn from the ranges real stacks span, not one hand-made pair.

The named profiles of `examples.sim.channels` (LAV/TFUSE, LIDAR_STACK/CAMERA_STACK) are single
points; SPIs tuned on them fit those points. `sample_stack` draws a channel model from the
ranges independent stacks are reported to span (issue 28 of the tracker, "What independent
stacks look like"):

| property | range |
| --- | --- |
| per-track position bias | drifts slowly (correlation time 2-8 s), 0.05-0.25 m per axis |
| white position noise | 0.02-0.10 m per axis, growing 1-3x towards the sensing range |
| misses | 1-5 % per object and frame, more near the edge of range |
| ghosts | 0.02-0.1 a second, each living 0.2-1 s |
| track id switches | every 1-2 minutes per track |
| heading / size / velocity noise | 0.01-0.05 rad, 3-10 %, 0.05-0.3 m/s per track |
| plan and prediction sampling | every 0.1-0.5 s (plans also every 1-2 m of path) |
| plan / prediction point noise | 0.1-0.2 m along, 0.02-0.05 m across |
| plan horizon / prediction horizon | 3-8 s / 2-5 s, different per channel |
| field of view / range | 90-360 degrees / 50-120 m |
| localisation | AR(1) error 0.03-0.15 m (lag-1 correlation 0.5-0.9), drift 0-0.1 m |
| planner foresight | the plan follows the true future for 1.5-3 s, then the route at that speed |

A profile's `level` places every noise parameter in its range: 0 the low end, 1 the high end,
with a jitter of +-0.15 so two stacks of one level still differ; `None` draws each parameter
uniformly over its whole range ("mixed"). Sampling, horizons, field of view and range are drawn
over their whole ranges in every profile: they are design choices, not noise levels. Channel
dropouts (one to three a drive) are not a channel parameter; `examples.sim.spi_sweep` removes
the channel from the frames.
"""

from __future__ import annotations

import math

import numpy as np

from examples.sim.channels import ChannelParams

#: Sweep profiles: name -> noise level (None: every parameter uniform over its range).
PROFILE_LEVELS: dict[str, float | None] = {"low": 0.15, "mid": 0.5, "high": 0.85, "mixed": None}

#: Fields of view (degrees) a stack may have, and the probability of each.
_FOVS = (90.0, 120.0, 180.0, 240.0, 360.0)


def _between(rng: np.random.Generator, lo: float, hi: float, level: float | None) -> float:
    """A value in [lo, hi]: at `level` (+-0.15 jitter, clipped), or uniform when None."""
    u = rng.random() if level is None else min(1.0, max(0.0, level + rng.uniform(-0.15, 0.15)))
    return lo + u * (hi - lo)


def sample_stack(
    rng: np.random.Generator,
    name: str,
    seed: int,
    level: float | None,
    profile: str = "",
) -> ChannelParams:
    """One channel model (reported as channel `name`) drawn from the table above."""
    lv = level
    fov = float(rng.choice(_FOVS))
    range_m = float(rng.uniform(50.0, 120.0))
    prediction_step = float(rng.choice((0.1, 0.2, 0.5)))
    prediction_points = max(4, round(rng.uniform(2.0, 5.0) / prediction_step))
    sampling = "distance" if rng.random() < 0.3 else "time"
    plan_step = float(rng.choice((0.1, 0.2, 0.5)))
    # a horizon the time step divides (3-8 s)
    plan_horizon = plan_step * round(rng.uniform(3.0, 8.0) / plan_step)
    switch_period = rng.uniform(60.0, 120.0)  # s between id switches of one track
    ghost_lo = _between(rng, 0.2, 0.6, lv)
    return ChannelParams(
        name=name,
        seed=seed,
        range_m=range_m,
        fov_deg=fov,
        pos_sigma=_between(rng, 0.05, 0.25, lv),
        pos_range_growth=_between(rng, 0.3, 1.5, lv),
        pos_white=_between(rng, 0.02, 0.10, lv),
        pos_white_growth=_between(rng, 0.0, 2.0, lv),
        yaw_sigma=_between(rng, 0.01, 0.05, lv),
        speed_sigma=_between(rng, 0.05, 0.3, lv),
        lat_speed_sigma=_between(rng, 0.02, 0.12, lv),
        size_sigma=_between(rng, 0.03, 0.10, lv),
        track_tau=_between(rng, 2.0, 8.0, None),
        p_miss=_between(rng, 0.01, 0.05, lv),
        miss_len=_between(rng, 1.5, 4.0, lv),
        miss_edge=_between(rng, 0.02, 0.10, lv),
        ghost_rate=_between(rng, 0.02, 0.10, lv),
        ghost_life=(ghost_lo, max(ghost_lo, 1.0)),
        p_id_switch=0.1 / switch_period,
        track_timeout=_between(rng, 0.5, 1.0, None),
        loc_sigma=_between(rng, 0.03, 0.15, lv),
        loc_drift=_between(rng, 0.0, 0.10, lv),
        loc_drift_period=(20.0, 60.0),
        loc_yaw_sigma=_between(rng, 0.002, 0.008, lv),
        ego_speed_sigma=_between(rng, 0.03, 0.10, lv),
        plan_horizon=round(plan_horizon, 6),
        plan_lateral=_between(rng, 0.1, 0.3, lv),
        plan_longitudinal=_between(rng, 0.2, 0.5, lv),
        plan_tau=_between(rng, 3.0, 6.0, None),
        prediction_points=int(prediction_points),
        prediction_step=prediction_step,
        profile=profile,
        plan_sampling=sampling,
        plan_step=plan_step,
        plan_spacing=float(rng.choice((1.0, 2.0))),
        loc_noise="ar1",
        loc_phi=_between(rng, 0.5, 0.9, None),
        plan_beyond_prediction=True,
        plan_noise_lon=_between(rng, 0.1, 0.2, lv),
        plan_noise_lat=_between(rng, 0.02, 0.05, lv),
        pred_noise_lon=_between(rng, 0.1, 0.2, lv),
        pred_noise_lat=_between(rng, 0.02, 0.05, lv),
        plan_foresight=_between(rng, 1.5, 3.0, None),
    )


def sample_pair(seed: int, profile: str) -> tuple[ChannelParams, ChannelParams]:
    """Two independent stacks (channels `lav` and `tfuse`) of sweep profile `profile` for
    generator seed `seed`; the same arguments always give the same pair."""
    if profile not in PROFILE_LEVELS:
        raise ValueError(f"unknown stack profile {profile!r}; known: {', '.join(PROFILE_LEVELS)}")
    level = PROFILE_LEVELS[profile]
    rng = np.random.default_rng([seed, sorted(PROFILE_LEVELS).index(profile), 28])
    a = sample_stack(rng, "lav", 1000 + seed, level, f"sampled-{profile}")
    b = sample_stack(rng, "tfuse", 2000 + seed, level, f"sampled-{profile}")
    return a, b


def min_coverage(a: ChannelParams, b: ChannelParams) -> tuple[float, float]:
    """(half field of view in radians, range in m) that both channels cover (for fault
    placement: inside both coverages)."""
    return math.radians(min(a.fov_deg, b.fov_deg)) / 2.0, min(a.range_m, b.range_m)
