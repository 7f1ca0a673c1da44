"""Channel models: what two imperfect driving stacks would report about the same true traffic.

Each channel is seeded on its own (scenario seed and channel seed), so changing one channel's
parameters does not change the other's noise. The errors are those of a tracking stack, not of
raw detections: they are correlated in time, because a fused localisation, an object tracker and
a planner all filter their inputs. White noise of the same size would make consecutive ticks
disagree with each other, which the time-based metrics (ompv, chpps, hcs, ppcs) read as faults.

- Ego motion: SUMO changes a vehicle's acceleration from one step to the next and draws junction
  paths as polylines. The channels see the ego path low-passed (a centred Gaussian kernel of
  `EGO_SMOOTHING` seconds), which is how a real vehicle with actuator lag moves.
- Localisation: truth + a smooth jitter + a slow drift (sums of sinusoids) + injected faults in
  which the ego estimate jumps back and forth by metres for a second or two.
- Perception: a sensing range and a field of view centred forward (below 360 degrees the channel
  is blind behind the ego). Each true vehicle has a per-channel track error: position, heading,
  and velocity (along and across the vehicle's true heading) errors that are smooth random
  processes with correlation time `track_tau`, plus a constant size bias. Missed detections come
  in short runs (`miss_len` ticks), ghosts live a fraction of a second, track ids rarely switch.
  Objects are reported in the channel's own world frame, so its localisation error shifts them.
- Predictions: constant velocity from the tracked velocity vector, `prediction_points` points
  from `prediction_step` to `prediction_points * prediction_step` seconds. The LAV/TFUSE pair use
  the same points (ots compares them index by index) and cover at least their plan horizon (an
  object whose prediction has ended "stays at its last point" in the safety score). The
  real-stack pair does neither, as real stacks do not (`plan_beyond_prediction`).
- Plan: the ego's smoothed true future path over the channel's horizon, shifted by the channel's
  localisation error and distorted by a lateral and a longitudinal offset that grow with the
  square of the look-ahead time and vary slowly in time (second-order low-pass processes).
  Built on the 0.1 s simulation grid, then sampled: every `plan_step` seconds
  (`plan_sampling="time"`), or every `plan_spacing` metres of arc length along the plan with each
  point's dt the time the ego reaches it (`plan_sampling="distance"`, as Autoware resamples its
  trajectories), see `resample_by_distance`.

The per-tick work is vectorised over vehicles and plan/prediction points with numpy; the random
processes are drawn for the whole run when the model is built, so a tick's report does not
depend on which ticks were asked for before (apart from the track-id bookkeeping).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

if TYPE_CHECKING:
    from examples.sim.scenarios import LocalizationFault
    from examples.sim.simulate import GroundTruth


#: Decimals written. Object predictions: centimetres (well below perception noise; they are most
#: of a stream's bytes). Ego pose and plan: 0.1 mm, because the comfort metrics (hcs, ppcs)
#: differentiate positions three times at 0.1 s: a rounding step q adds jerk noise of about
#: 4.5 q / 0.001 s^3, i.e. 1.3 m/s^3 at 1 mm and 0.13 m/s^3 at 0.1 mm.
PREDICTION_DECIMALS = 2
EGO_DECIMALS = 4
OBJECT_DECIMALS = 3

#: Standard deviation (s) of the Gaussian kernel that turns SUMO's ego path into a vehicle's
#: path: SUMO's car-following models step the acceleration (jerk of tens of m/s^3 in one step)
#: and draw junction paths as polylines. At 0.6 s an acceleration step of 7 m/s^2 becomes a
#: jerk of about 7 / (0.6 sqrt(2 pi)) = 4.7 m/s^3. Under a constant acceleration a the smoothed
#: path leads (a > 0) or trails (braking) SUMO's by a sigma^2 / 2: 0.54 m at 3 m/s^2.
EGO_SMOOTHING = 0.6

#: Plan and object speeds below this (m/s) scale the plan distortion and the velocity errors
#: down linearly: a stopped planner plans to stay, a tracker knows a stopped car is stopped.
STANDSTILL_SPEED = 3.0


@dataclass(frozen=True)
class ChannelParams:
    """Parameters of one channel model (units: m, s, rad unless stated)."""

    name: str
    seed: int
    range_m: float
    fov_deg: float  # total field of view centred on the ego's heading; 360 = all around
    pos_sigma: float  # track position error per axis at zero range
    pos_range_growth: float  # relative growth of the position error at the sensing range
    pos_white: float  # white measurement noise on top of the track error, per axis
    yaw_sigma: float  # track heading error
    speed_sigma: float  # track velocity error along the object's heading (m/s)
    lat_speed_sigma: float  # track velocity error across the object's heading (m/s)
    size_sigma: float  # relative bias of length and width, constant per track
    track_tau: float  # correlation time of the track errors
    p_miss: float  # share of ticks in which a visible object is not reported
    miss_len: float  # mean length of a run of missed ticks
    ghost_rate: float  # expected ghost objects appearing per second
    ghost_life: tuple[float, float]  # lifetime range (s)
    p_id_switch: float  # probability per object and tick that its track id changes
    track_timeout: float  # an object unseen for longer gets a new id when seen again
    loc_sigma: float  # localisation jitter per axis (smooth, periods `loc_jitter_period`)
    loc_drift: float  # standard deviation of the slow drift per axis
    loc_drift_period: tuple[float, float]  # periods of the drift components (s)
    loc_yaw_sigma: float
    ego_speed_sigma: float
    plan_horizon: float  # at most prediction_points * prediction_step
    plan_lateral: float  # std of the lateral plan offset at the end of the horizon (m)
    plan_longitudinal: float  # std of the along-path plan offset at the end of the horizon (m)
    plan_tau: float  # time constant of the plan distortion processes (s)
    prediction_points: int = 30
    prediction_step: float = 0.1
    loc_jitter_period: tuple[float, float] = (3.0, 10.0)
    # Added with the real-stack profiles; their defaults are the original LAV/TFUSE model.
    profile: str = ""  # profile name, written to the header meta ("" = the original LAV/TFUSE)
    plan_sampling: Literal["time", "distance"] = "time"
    plan_step: float = 0.1  # s between plan points when sampled by time (a multiple of 0.1 s)
    plan_spacing: float = 1.0  # m of arc length between plan points when sampled by distance
    # "smooth": loc_sigma is the std of a smooth jitter (sinusoids, periods loc_jitter_period);
    # "ar1": loc_sigma is the stationary std per axis of an AR(1) error with lag-1 correlation
    # loc_phi at 0.1 s, and loc_yaw_sigma that of an AR(1) heading error with the same loc_phi
    # (the drift, loc_drift, is added in both models)
    loc_noise: Literal["smooth", "ar1"] = "smooth"
    loc_phi: float = 0.0
    # allow a plan horizon longer than the predictions (real stacks do; objects then "stay at
    # their last point" in the safety score for the remaining plan seconds)
    plan_beyond_prediction: bool = False
    # The plan is re-timed against the channel's own predictions (`retime_plan`): its front
    # bumper stays at least `plan_standstill_gap` metres behind the rear bumper of every
    # in-path vehicle track (predicted centre within `plan_corridor` metres of the path)
    plan_standstill_gap: float = 2.0
    plan_corridor: float = 1.75
    # Added with the stack sampler (`examples.sim.stacks`); defaults keep the models above.
    pos_white_growth: float = 0.0  # relative growth of the white noise at the sensing range
    miss_edge: float = 0.0  # extra miss probability per tick at the sensing range, ~ (r/R)^2
    plan_noise_lon: float = 0.0  # white noise of every published plan point along the path (m)
    plan_noise_lat: float = 0.0  # ... and across it (m)
    pred_noise_lon: float = 0.0  # white noise of every prediction point along the object (m)
    pred_noise_lat: float = 0.0  # ... and across it (m)
    # seconds of the ego's true future a plan follows exactly; beyond, it follows the true
    # progress only as fast as a planner changes speed (`FORESIGHT_ACCEL`) (None: the whole
    # horizon, as the original models). A planner does not know that the car ahead will brake
    # hard in 6 s; a plan of 8 s that did (the true future) carried every later hard braking
    # into the present.
    plan_foresight: float | None = None

    def meta(self) -> dict[str, Any]:
        """Every parameter, for the stream header. The stack sampler's parameters
        (`SAMPLER_FIELDS`) are listed only when set, so the headers of the drives generated
        before them (the bundled data) regenerate byte for byte."""
        out = asdict(self)
        for name, default in SAMPLER_FIELDS.items():
            if out[name] == default:
                del out[name]
        return out

    def coverage(self) -> dict[str, float]:
        """The sensing coverage written to the header's `coverage` key."""
        return {"fov_deg": float(self.fov_deg), "range_m": float(self.range_m)}


#: Parameters added with the stack sampler (`examples.sim.stacks`) and their defaults (the
#: dataclass's), which keep the original models.
SAMPLER_FIELDS: dict[str, Any] = {
    f.name: f.default
    for f in fields(ChannelParams)
    if f.name
    in (
        "pos_white_growth",
        "miss_edge",
        "plan_noise_lon",
        "plan_noise_lat",
        "pred_noise_lon",
        "pred_noise_lat",
        "plan_foresight",
    )
}


#: The all-round channel (the study's LAV stack: 360-degree LiDAR perception).
LAV = ChannelParams(
    name="lav",
    seed=101,
    range_m=60.0,
    fov_deg=360.0,
    pos_sigma=0.08,
    pos_range_growth=0.5,
    pos_white=0.02,
    yaw_sigma=0.01,
    speed_sigma=0.08,
    lat_speed_sigma=0.03,
    size_sigma=0.04,
    track_tau=1.0,
    p_miss=0.02,
    miss_len=3.0,
    ghost_rate=0.03,
    ghost_life=(0.3, 1.0),
    p_id_switch=0.001,
    track_timeout=1.0,
    loc_sigma=0.02,
    loc_drift=0.06,
    loc_drift_period=(20.0, 60.0),
    loc_yaw_sigma=0.004,
    ego_speed_sigma=0.05,
    plan_horizon=3.0,
    plan_lateral=0.25,
    plan_longitudinal=0.30,
    plan_tau=5.0,
)

#: The forward-looking channel (the study's TransFuser stack: camera-based, blind behind, a
#: shorter plan).
TFUSE = ChannelParams(
    name="tfuse",
    seed=202,
    range_m=50.0,
    fov_deg=200.0,
    pos_sigma=0.08,
    pos_range_growth=0.5,
    pos_white=0.03,
    yaw_sigma=0.015,
    speed_sigma=0.10,
    lat_speed_sigma=0.05,
    size_sigma=0.07,
    track_tau=0.8,
    p_miss=0.03,
    miss_len=3.0,
    ghost_rate=0.05,
    ghost_life=(0.2, 0.8),
    p_id_switch=0.002,
    track_timeout=0.5,
    loc_sigma=0.03,
    loc_drift=0.08,
    loc_drift_period=(15.0, 45.0),
    loc_yaw_sigma=0.006,
    ego_speed_sigma=0.08,
    plan_horizon=2.5,
    plan_lateral=0.20,
    plan_longitudinal=0.30,
    plan_tau=4.0,
    loc_jitter_period=(3.0, 8.0),
)


#: Real-stack profile with 360-degree LiDAR perception (reported as channel `lav`): long range,
#: a plan resampled every metre along the path over 5 s (Autoware-like), predictions of 4 s at
#: 0.5 s, an unsmoothed AR(1) localisation error of 6 cm per axis (lag-1 correlation 0.7 at
#: 0.1 s, i.e. a correlation time of -0.1 / ln 0.7 = 0.28 s: scan matching at 10 Hz fused with
#: odometry) and no slow drift.
LIDAR_STACK = ChannelParams(
    name="lav",
    seed=303,
    range_m=80.0,
    fov_deg=360.0,
    pos_sigma=0.06,
    pos_range_growth=0.8,
    pos_white=0.02,
    yaw_sigma=0.01,
    speed_sigma=0.10,
    lat_speed_sigma=0.04,
    size_sigma=0.04,
    track_tau=0.8,
    p_miss=0.02,
    miss_len=3.0,
    ghost_rate=0.03,
    ghost_life=(0.3, 1.0),
    p_id_switch=0.001,
    track_timeout=1.0,
    loc_sigma=0.06,
    loc_drift=0.0,
    loc_drift_period=(20.0, 60.0),
    loc_yaw_sigma=0.003,
    ego_speed_sigma=0.05,
    plan_horizon=5.0,
    plan_lateral=0.30,
    plan_longitudinal=0.50,
    plan_tau=5.0,
    prediction_points=8,
    prediction_step=0.5,
    profile="LIDAR_STACK",
    plan_sampling="distance",
    plan_spacing=1.0,
    loc_noise="ar1",
    loc_phi=0.7,
    plan_beyond_prediction=True,
)

#: Real-stack profile with forward camera perception (reported as channel `tfuse`): 120-degree
#: field of view (blind behind and to the sides), 70 m, depth error growing strongly with range,
#: a plan every 0.5 s over 3 s, predictions of 2.5 s at 0.1 s, an unsmoothed AR(1) localisation
#: error of 12 cm per axis (lag-1 correlation 0.6 at 0.1 s, correlation time 0.20 s: visual
#: odometry and GNSS) and no slow drift.
CAMERA_STACK = ChannelParams(
    name="tfuse",
    seed=404,
    range_m=70.0,
    fov_deg=120.0,
    pos_sigma=0.08,
    pos_range_growth=1.5,
    pos_white=0.04,
    yaw_sigma=0.02,
    speed_sigma=0.15,
    lat_speed_sigma=0.06,
    size_sigma=0.08,
    track_tau=0.6,
    p_miss=0.03,
    miss_len=3.0,
    ghost_rate=0.05,
    ghost_life=(0.2, 0.8),
    p_id_switch=0.002,
    track_timeout=0.5,
    loc_sigma=0.12,
    loc_drift=0.0,
    loc_drift_period=(15.0, 45.0),
    loc_yaw_sigma=0.005,
    ego_speed_sigma=0.08,
    plan_horizon=3.0,
    plan_lateral=0.20,
    plan_longitudinal=0.30,
    plan_tau=4.0,
    prediction_points=25,
    prediction_step=0.1,
    profile="CAMERA_STACK",
    plan_sampling="time",
    plan_step=0.5,
    loc_noise="ar1",
    loc_phi=0.6,
    plan_beyond_prediction=True,
)

#: Every named profile, by profile name.
PROFILES: dict[str, ChannelParams] = {
    "LAV": LAV,
    "TFUSE": TFUSE,
    "LIDAR_STACK": LIDAR_STACK,
    "CAMERA_STACK": CAMERA_STACK,
}


def ar1_noise(
    rng: np.random.Generator,
    n: int,
    sigma: float,
    phi: float,
    shape: tuple[int, ...] = (),
) -> np.ndarray:
    """(n, *shape) zero-mean AR(1) noise x_k = phi x_(k-1) + sqrt(1 - phi^2) sigma w_k with
    white w, started in its stationary state (x_0 ~ N(0, sigma^2)): standard deviation `sigma`
    and lag-1 correlation `phi` at every tick."""
    white = rng.standard_normal((n, *shape))
    out = np.empty((n, *shape))
    if n == 0:
        return out
    gain = math.sqrt(1.0 - phi * phi)
    out[0] = white[0]
    for k in range(1, n):
        out[k] = phi * out[k - 1] + gain * white[k]
    return sigma * out


def smooth_process(
    rng: np.random.Generator,
    times: np.ndarray,
    std: float,
    period: tuple[float, float],
    components: int = 4,
) -> np.ndarray:
    """A smooth zero-mean signal with standard deviation about `std`: a sum of sinusoids with
    random periods in `period` and random phases (each has variance a^2 / 2)."""
    periods = rng.uniform(period[0], period[1], components)
    phases = rng.uniform(0.0, 2.0 * np.pi, components)
    amp = std * np.sqrt(2.0 / components)
    return amp * np.sin(2.0 * np.pi * times[:, None] / periods[None, :] + phases).sum(axis=1)


def lowpass_noise(
    rng: np.random.Generator,
    n: int,
    dt: float,
    tau: float,
    shape: tuple[int, ...] = (),
) -> np.ndarray:
    """(n, *shape) unit-variance zero-mean noise, low-passed by two first-order stages of time
    constant `tau` in series (a critically damped second-order filter: smooth, no overshoot).

    With phi = exp(-dt / tau) the output is b_k = sum_m (m + 1) phi^m w_{k-m} for white w, of
    variance sum_m (m + 1)^2 phi^(2m) = (1 + phi^2) / (1 - phi^2)^3; dividing by its square root
    gives unit variance. A warm-up of 6 tau starts the series in its stationary state.
    """
    phi = math.exp(-dt / tau)
    warm = math.ceil(6.0 * tau / dt)
    white = rng.standard_normal((warm + n, *shape))
    a = np.zeros(shape)
    b = np.zeros(shape)
    out = np.empty((n, *shape))
    for k in range(warm + n):
        a = phi * a + white[k]
        b = phi * b + a
        if k >= warm:
            out[k - warm] = b
    return out / math.sqrt((1.0 + phi**2) / (1.0 - phi**2) ** 3)


def gaussian_smooth(values: np.ndarray, sigma_ticks: float) -> np.ndarray:
    """Centred Gaussian low-pass of `values` along axis 0 (truncated at 4 sigma).

    The ends are padded by point reflection (2 v_0 - v_k), which keeps a straight line
    straight, so the smoothed path neither bends nor slows down at the start or end of the run.
    """
    if sigma_ticks <= 0:
        return values.copy()
    h = max(1, math.ceil(4.0 * sigma_ticks))
    h = min(h, len(values) - 1)
    if h < 1:
        return values.copy()
    k = np.arange(-h, h + 1)
    kernel = np.exp(-0.5 * (k / sigma_ticks) ** 2)
    kernel /= kernel.sum()
    head = 2.0 * values[0] - values[1 : h + 1][::-1]
    tail = 2.0 * values[-1] - values[-h - 1 : -1][::-1]
    padded = np.concatenate([head, values, tail])
    return np.convolve(padded, kernel, mode="valid")


def fault_offsets(
    rng: np.random.Generator,
    times: np.ndarray,
    faults: tuple[LocalizationFault, ...],
    channel: str,
) -> np.ndarray:
    """(T, 2) localisation offsets of the injected faults of `channel`.

    Inside a fault the estimate alternates between the true position and a jump of `amplitude`
    metres in a random direction, each state held 1 to 3 ticks. The alternation is what makes
    the moving variance of ELS rise: with a 3.5 m jump, els = 1/(1+d) swings between about 0.8
    and 0.22, and a 5-tick window holding both values has a sample variance of about 0.06-0.09,
    above the reference threshold 0.05.
    """
    out = np.zeros((len(times), 2))
    for fault in faults:
        if fault.channel != channel:
            continue
        ticks = np.flatnonzero((times >= fault.start - 1e-9) & (times < fault.end - 1e-9))
        if len(ticks) == 0:
            continue
        dwell = rng.integers(1, 4, size=len(ticks))
        state = np.repeat(np.arange(len(ticks)) % 2 == 0, dwell)[: len(ticks)]
        angle = rng.uniform(0.0, 2.0 * np.pi)
        direction = np.array([np.cos(angle), np.sin(angle)])
        out[ticks] += state[:, None] * fault.amplitude * direction[None, :]
    return out


@dataclass
class EgoMotion:
    """The ego's physical path: SUMO's path low-passed (see `EGO_SMOOTHING`)."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray


def ego_motion(gt: GroundTruth, sigma: float = EGO_SMOOTHING) -> EgoMotion:
    """Smooth the ego's SUMO path with a centred Gaussian kernel of `sigma` seconds."""
    e = gt.ego_index
    ticks = sigma / (gt.times[1] - gt.times[0]) if len(gt.times) > 1 else 0.0
    x = gaussian_smooth(gt.x[:, e], ticks)
    y = gaussian_smooth(gt.y[:, e], ticks)
    yaw = gaussian_smooth(np.unwrap(gt.yaw[:, e]), ticks)
    yaw = (yaw + np.pi) % (2.0 * np.pi) - np.pi
    return EgoMotion(x, y, yaw, gaussian_smooth(gt.speed[:, e], ticks))


@dataclass
class Localization:
    """A channel's ego estimate for every tick (world frame)."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    offset: np.ndarray  # (T, 2) estimate minus the ego's physical path, including faults


def localize(
    gt: GroundTruth,
    params: ChannelParams,
    faults: tuple[LocalizationFault, ...],
    seed: int,
    motion: EgoMotion | None = None,
) -> Localization:
    """The channel's ego pose over the whole run: path + jitter + drift + faults. The jitter is
    smooth (`loc_noise="smooth"`) or an unsmoothed AR(1) error (`"ar1"`)."""
    rng = np.random.default_rng([seed, params.seed, 1])
    m = motion if motion is not None else ego_motion(gt)
    t = gt.times
    if params.loc_noise == "ar1":
        noise = ar1_noise(rng, len(t), params.loc_sigma, params.loc_phi, (2,))
        drift = np.stack(
            [smooth_process(rng, t, params.loc_drift, params.loc_drift_period) for _ in range(2)],
            axis=1,
        )
        offset = noise + drift + fault_offsets(rng, t, faults, params.name)
        yaw = m.yaw + ar1_noise(rng, len(t), params.loc_yaw_sigma, params.loc_phi)
        return Localization(m.x + offset[:, 0], m.y + offset[:, 1], yaw, offset)
    drift = np.stack(
        [smooth_process(rng, t, params.loc_drift, params.loc_drift_period) for _ in range(2)],
        axis=1,
    )
    # a fused localisation is smooth at 10 Hz: its error is correlated from tick to tick, not
    # white (white noise of a few cm would read as tens of m/s^3 of jerk in hcs)
    noise = np.stack(
        [smooth_process(rng, t, params.loc_sigma, params.loc_jitter_period, 6) for _ in range(2)],
        axis=1,
    )
    offset = drift + noise + fault_offsets(rng, t, faults, params.name)
    yaw = m.yaw + smooth_process(rng, t, params.loc_yaw_sigma, params.loc_jitter_period, 6)
    yaw += smooth_process(rng, t, params.loc_yaw_sigma, params.loc_drift_period)
    return Localization(m.x + offset[:, 0], m.y + offset[:, 1], yaw, offset)


def true_plan_points(
    gt: GroundTruth,
    tick: int,
    horizon: float,
    step: float,
    motion: EgoMotion | None = None,
) -> np.ndarray:
    """(N, 3) [dt, x, y] of the ego's physical centre path over the next `horizon` seconds
    (truncated at the end of the simulated run)."""
    m = motion if motion is not None else ego_motion(gt)
    k = round(step / (gt.times[1] - gt.times[0]))
    n = round(horizon / step) + 1
    idx = tick + k * np.arange(n)
    idx = idx[idx < len(gt.times)]
    dt = gt.times[idx] - gt.times[tick]
    return np.column_stack([dt, m.x[idx], m.y[idx]])


#: Largest acceleration and deceleration [m/s^2] of a plan beyond its foresight
#: (`limit_foresight`): a planner's comfortable acceleration, and the braking it plans for what
#: it knows ahead (a red light, a turn; SUMO's normal deceleration). The emergency braking of a
#: surprise is not in its plan until it happens.
FORESIGHT_ACCEL = 3.0
FORESIGHT_DECEL = 3.0


def limit_foresight(
    gt: GroundTruth,
    tick: int,
    pts: np.ndarray,
    motion: EgoMotion,
    foresight: float,
) -> tuple[np.ndarray, np.ndarray]:
    """`pts` ([dt, x, y] on the 0.1 s grid, the ego's true future) and the headings along it,
    the progress beyond `foresight` seconds following the true progress with its speed
    changing by at most FORESIGHT_ACCEL / FORESIGHT_DECEL, along the route the ego will take
    (its true path further on, straight on past its end)."""
    ahead = true_plan_points(gt, tick, 4.0 * float(pts[-1, 0]) + 10.0, 0.1, motion)
    ahead_yaw = np.unwrap(motion.yaw[tick + np.arange(len(ahead))])
    seg = np.hypot(np.diff(ahead[:, 1]), np.diff(ahead[:, 2]))
    s_ahead = np.concatenate([[0.0], np.cumsum(seg)])
    dt = pts[:, 0]
    s = s_ahead[: len(pts)]
    f = int(np.searchsorted(dt, foresight + 1e-9)) - 1
    speed = (s[f] - s[f - 1]) / (dt[f] - dt[f - 1]) if f > 0 else 0.0
    s_new = s.copy()
    for k in range(max(f, 0) + 1, len(s)):
        h = dt[k] - dt[k - 1]
        wanted = (s[k] - s_new[k - 1]) / h
        speed = max(0.0, min(max(wanted, speed - FORESIGHT_DECEL * h), speed + FORESIGHT_ACCEL * h))
        s_new[k] = s_new[k - 1] + speed * h
    x = np.interp(s_new, s_ahead, ahead[:, 1])
    y = np.interp(s_new, s_ahead, ahead[:, 2])
    yaw = np.interp(s_new, s_ahead, ahead_yaw)
    beyond = s_new > s_ahead[-1]
    if beyond.any():
        extra = s_new[beyond] - s_ahead[-1]
        x[beyond] += extra * np.cos(ahead_yaw[-1])
        y[beyond] += extra * np.sin(ahead_yaw[-1])
    return np.column_stack([dt, x, y]), (yaw + np.pi) % (2.0 * np.pi) - np.pi


def resample_by_distance(pts: np.ndarray, spacing: float) -> np.ndarray:
    """Resample a (N, 3) [dt, x, y] plan every `spacing` metres of arc length from its first
    point; each new point's dt is the time at which the plan reaches it (linear between the
    input points), so dt is non-uniform when the speed varies. The points run up to the arc
    length the plan covers, so the last one lies within `spacing` of the plan's end.

    Standstill decision: when the plan covers less than one `spacing`, the result is its first
    and last point, [0, x0, y0] and [H, xH, yH]: "stay (or creep) for the whole horizon". A plan
    always has at least two points, and its last dt is then the horizon.
    """
    seg = np.hypot(np.diff(pts[:, 1]), np.diff(pts[:, 2]))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    n = math.floor(s[-1] / spacing + 1e-9) + 1
    if n < 2 or len(pts) < 2:
        return pts[[0, -1]].copy()
    target = spacing * np.arange(n)
    j = np.clip(np.searchsorted(s, target, side="left"), 1, len(s) - 1)
    s0, s1 = s[j - 1], s[j]
    length = s1 - s0
    w = np.where(length > 0.0, (target - s0) / np.where(length > 0.0, length, 1.0), 0.0)
    return pts[j - 1] + w[:, None] * (pts[j] - pts[j - 1])


#: A vehicle track is planned around only while its heading is within this angle of the
#: plan's direction where it lies (decision: vehicles crossing the path or oncoming are not
#: planned around; a real planner yields to them at junctions by rules the channel model does
#: not have, and the ego's true future already does what SUMO decided).
PLAN_ALIGN = math.radians(45.0)
#: Length (m) of the straight extensions before the plan's start and after its end along which
#: tracks are projected (a lead beyond the plan's end still lies on its path).
_PLAN_EXTENSION = 1000.0
#: Vertex spacing (m) of the path the tracks are projected on.
_PLAN_VERTEX_SPACING = 0.1
#: Largest acceleration [m/s^2] of a re-timed plan's progress. When a lead's limit lets go
#: (the lead leaves the corridor, e.g. it turns off while its constant-velocity prediction goes
#: straight on), the clipped progress would jump back to the true future's: a plan standing
#: for two seconds, then covering 8 m in 0.3 s, which no planner publishes. Progress regains
#: speed at this rate instead (a planner's comfortable acceleration).
PLAN_ACCEL = 2.0


def accel_limited(progress: np.ndarray, dt: np.ndarray, speed: float) -> np.ndarray:
    """`progress` (arc positions at times `dt`, non-decreasing) lowered where it would gain
    speed faster than PLAN_ACCEL, starting from `speed` [m/s] before the first step. Only
    lowers (an upper limit stays respected) and stays non-decreasing."""
    out = progress.copy()
    v = speed
    for k in range(1, len(out)):
        h = dt[k] - dt[k - 1]
        if h <= 0.0:
            continue
        out[k] = min(out[k], out[k - 1] + (v + PLAN_ACCEL * h) * h)
        v = (out[k] - out[k - 1]) / h
    return out


def _project(
    vx: np.ndarray,
    vy: np.ndarray,
    sv: np.ndarray,
    qx: np.ndarray,
    qy: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Project points (qx, qy) onto the polyline (vx, vy) with arc length sv at its vertices:
    distance to it, arc length of the foot point, heading of the nearest segment."""
    ax, ay = vx[:-1], vy[:-1]
    ux, uy = np.diff(vx), np.diff(vy)
    l2 = ux * ux + uy * uy
    rx, ry = qx[..., None] - ax, qy[..., None] - ay
    t = np.clip((rx * ux + ry * uy) / l2, 0.0, 1.0)
    d = np.hypot(rx - t * ux, ry - t * uy)
    j = d.argmin(axis=-1)[..., None]
    dist = np.take_along_axis(d, j, axis=-1)[..., 0]
    arc = sv[j[..., 0]] + np.take_along_axis(t, j, axis=-1)[..., 0] * np.sqrt(l2)[j[..., 0]]
    return dist, arc, np.arctan2(uy, ux)[j[..., 0]]


def retime_plan(
    pts: np.ndarray,
    ego_length: float,
    tracks: np.ndarray,
    gap: float,
    corridor: float,
    yaw: tuple[float, float] | None = None,
) -> np.ndarray:
    """Limit a plan's progress along its own path so that it never runs into the channel's own
    constant-velocity prediction of an in-path vehicle.

    `pts` is the (N, 3) [dt, x, y] plan on its time grid, `tracks` the channel's vehicle tracks
    as (M, 6) [x, y, vx, vy, yaw, length] in the same frame. A track's predicted centre at dt is
    (x + vx dt, y + vy dt), for every plan dt (beyond the published prediction horizon too: the
    planner's own constant-velocity model). It is in the path at dt when that centre lies within
    `corridor` metres of the path (extended straight beyond its ends) and its heading within
    `PLAN_ALIGN` of the path's there. It is a lead when, at the first dt it is in the path, its
    centre is ahead of the plan's (a track the plan is already past, a follower, or one the
    ego's true future overtakes before it enters the path, is not). While a lead is in the path,
    the plan's arc position p(dt) (its centre, 0 at the first point) is at most
    s_lead(dt) - length / 2 - gap - ego_length / 2: its front bumper stays `gap` behind the
    lead's rear bumper. p is the plan's own arc position clipped by those limits, made
    non-increasing backwards (a limit at dt holds for every earlier dt, so progress is monotone
    and never has to go back) and at least 0: a plan that starts closer than `gap` stays at its
    first point until the limit lets it move, and then speeds up at most at PLAN_ACCEL
    (`accel_limited`), never jumping to the true future's progress. The path is unchanged;
    points whose arc position is not limited are returned exactly as given. `yaw` (the path's
    heading at its first and last point) orients the straight extensions; without it, the
    chords over the path's first and last metre do.
    """
    if len(pts) < 2 or len(tracks) == 0:
        return pts
    seg = np.hypot(np.diff(pts[:, 1]), np.diff(pts[:, 2]))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] < 1e-6:
        return pts  # standing still: nothing to re-time
    # the path to project on: vertices at least _PLAN_VERTEX_SPACING apart (and the last one),
    # so the direction of a millimetre segment near a stop does not turn the corridor
    keep = [0]
    for i in range(1, len(s)):
        if s[i] - s[keep[-1]] >= _PLAN_VERTEX_SPACING:
            keep.append(i)
    if keep[-1] != len(s) - 1:
        if len(keep) > 1:
            keep[-1] = len(s) - 1
        else:
            keep.append(len(s) - 1)
    vx, vy, sv = pts[keep, 1], pts[keep, 2], s[keep]
    if yaw is not None:
        h0, h1 = yaw
    else:
        i0 = min(int(np.searchsorted(sv, 1.0)), len(sv) - 1)
        i1 = max(int(np.searchsorted(sv, sv[-1] - 1.0, side="right")) - 1, 0)
        h0 = math.atan2(vy[i0] - vy[0], vx[i0] - vx[0])
        h1 = math.atan2(vy[-1] - vy[i1], vx[-1] - vx[i1])
    ext = _PLAN_EXTENSION
    vx = np.concatenate([[vx[0] - ext * math.cos(h0)], vx, [vx[-1] + ext * math.cos(h1)]])
    vy = np.concatenate([[vy[0] - ext * math.sin(h0)], vy, [vy[-1] + ext * math.sin(h1)]])
    sv = np.concatenate([[-ext], sv, [sv[-1] + ext]])
    dt = pts[:, 0]
    qx = tracks[:, 0, None] + tracks[:, 2, None] * dt[None, :]
    qy = tracks[:, 1, None] + tracks[:, 3, None] * dt[None, :]
    dist, arc, head = _project(vx, vy, sv, qx, qy)
    turn = (tracks[:, 4, None] - head + np.pi) % (2.0 * np.pi) - np.pi
    inside = (dist <= corridor) & (np.abs(turn) <= PLAN_ALIGN)
    first = inside.argmax(axis=1)
    lead = inside.any(axis=1) & (arc[np.arange(len(tracks)), first] > s[first])
    if not lead.any():
        return pts
    # margin[i, k, j]: how far the ego's front bumper at path point j would stay behind the
    # rear bumper of lead i predicted at dt_k, less the gap, measured along the lead's heading
    # (not along the path's arc length, which a plan creeping sideways or folding back by
    # centimetres near a stop would lengthen); the limit at dt_k is the first path position
    # where it turns negative
    li = np.flatnonzero(lead)
    ux, uy = np.cos(tracks[li, 4]), np.sin(tracks[li, 4])
    along = (qx[li, :, None] - pts[None, None, :, 1]) * ux[:, None, None] + (
        qy[li, :, None] - pts[None, None, :, 2]
    ) * uy[:, None, None]
    margin = along - 0.5 * (tracks[li, 5, None, None] + ego_length) - gap
    neg = margin < 0.0
    j = neg.argmax(axis=2)
    jm = np.maximum(j - 1, 0)
    m0 = np.take_along_axis(margin, jm[..., None], axis=2)[..., 0]
    m1 = np.take_along_axis(margin, j[..., None], axis=2)[..., 0]
    frac = np.where(j > 0, m0 / np.where(m0 > m1, m0 - m1, 1.0), 0.0)
    cross = np.where(j > 0, s[jm] + frac * (s[j] - s[jm]), 0.0)
    active = neg.any(axis=2) & inside[li]
    limit = np.where(active, cross, np.inf).min(axis=0)
    if np.all(limit >= s):
        return pts
    prog = np.minimum.accumulate(np.minimum(s, limit)[::-1])[::-1]
    prog = np.maximum(prog, 0.0)
    first_step = dt[1] - dt[0]
    prog = accel_limited(prog, dt, s[1] / first_step if first_step > 0 else 0.0)
    out = pts.copy()
    cut = prog < s
    out[cut, 1] = np.interp(prog[cut], s, pts[:, 1])
    out[cut, 2] = np.interp(prog[cut], s, pts[:, 2])
    return out


def markov_misses(
    rng: np.random.Generator,
    shape: tuple[int, int],
    share: float,
    mean_len: float,
) -> np.ndarray:
    """(T, V) booleans: runs of missed ticks with mean length `mean_len` covering about
    `share` of the ticks (a two-state Markov chain started in its stationary state)."""
    out = np.zeros(shape, dtype=bool)
    if share <= 0.0:
        return out
    p_end = 1.0 / max(mean_len, 1.0)
    p_start = min(1.0, share * p_end / (1.0 - share))
    u = rng.random(shape)
    state = rng.random(shape[1]) < share
    for k in range(shape[0]):
        state = np.where(state, u[k] >= p_end, u[k] < p_start)
        out[k] = state
    return out


class ChannelModel:
    """Turns ground truth into one channel's per-frame report (stateful only in its track ids)."""

    def __init__(
        self,
        gt: GroundTruth,
        params: ChannelParams,
        faults: tuple[LocalizationFault, ...],
        seed: int,
    ) -> None:
        p = params
        horizon = p.prediction_points * p.prediction_step
        if p.plan_horizon > horizon + 1e-9 and not p.plan_beyond_prediction:
            raise ValueError(
                f"channel {p.name}: plan horizon {p.plan_horizon} s is longer than its "
                f"predictions ({horizon:g} s); objects would stop at the end of their "
                "prediction and stand in the plan's way"
            )
        sim_step = float(gt.times[1] - gt.times[0]) if len(gt.times) > 1 else 0.1
        self.plan_every = round(p.plan_step / sim_step)
        if p.plan_sampling == "time" and (
            self.plan_every < 1
            or abs(self.plan_every * sim_step - p.plan_step) > 1e-9
            or abs(p.plan_horizon / p.plan_step - round(p.plan_horizon / p.plan_step)) > 1e-9
        ):
            raise ValueError(
                f"channel {p.name}: plan_step {p.plan_step} s must be a multiple of the "
                f"simulation step {sim_step:g} s and divide the plan horizon {p.plan_horizon} s"
            )
        if p.plan_sampling == "distance" and not p.plan_spacing > 0.0:
            raise ValueError(f"channel {p.name}: plan_spacing must be positive")
        if p.loc_noise == "ar1" and not 0.0 <= p.loc_phi < 1.0:
            raise ValueError(f"channel {p.name}: loc_phi must lie in [0, 1)")
        self.gt = gt
        self.p = p
        self.motion = ego_motion(gt)
        self.loc = localize(gt, p, faults, seed, self.motion)
        n_t, n_v = gt.x.shape
        dt = float(gt.times[1] - gt.times[0]) if n_t > 1 else 0.1
        self.rng = np.random.default_rng([seed, params.seed, 2])
        plan_rng = np.random.default_rng([seed, params.seed, 3])
        track_rng = np.random.default_rng([seed, params.seed, 4])
        self.plan_lat = p.plan_lateral * lowpass_noise(plan_rng, n_t, dt, p.plan_tau)
        self.plan_lon = p.plan_longitudinal * lowpass_noise(plan_rng, n_t, dt, p.plan_tau)
        # per-(tick, vehicle) track errors, unit variance; scaled when reported
        self.err_pos = lowpass_noise(track_rng, n_t, dt, p.track_tau, (n_v, 2))
        self.err_vel = lowpass_noise(track_rng, n_t, dt, p.track_tau, (n_v, 2))
        self.err_yaw = lowpass_noise(track_rng, n_t, dt, p.track_tau, (n_v,))
        self.size_bias = 1.0 + p.size_sigma * track_rng.standard_normal((n_v, 2))
        self.missed = markov_misses(track_rng, (n_t, n_v), p.p_miss, p.miss_len)
        edge_rng = np.random.default_rng([seed, params.seed, 5])
        self.edge_draw = edge_rng.random((n_t, n_v)) if p.miss_edge > 0.0 else None
        self.plan_noise_rng = np.random.default_rng([seed, params.seed, 6])
        self.reported = np.zeros(0, dtype=int)
        self.switch = track_rng.random((n_t, n_v)) < p.p_id_switch
        self.track: dict[int, str] = {}
        self.last_seen: dict[int, float] = {}
        self.next_id = 1
        self.ghosts: list[dict[str, Any]] = []
        self.others = np.ones(n_v, dtype=bool)
        self.others[gt.ego_index] = False
        self.pred_dt = p.prediction_step * np.arange(1, p.prediction_points + 1)
        self.tracks = np.zeros((0, 6))

    def _new_id(self) -> str:
        tid = str(self.next_id)
        self.next_id += 1
        return tid

    def ego(self, tick: int) -> dict[str, float]:
        gt, e, p = self.gt, self.gt.ego_index, self.p
        speed = self.motion.speed[tick] + self.rng.normal(0.0, p.ego_speed_sigma)
        yaw = self.loc.yaw[tick]
        return {
            "x": self.loc.x[tick],
            "y": self.loc.y[tick],
            "yaw": yaw,
            "vx": speed * np.cos(yaw),
            "vy": speed * np.sin(yaw),
            "length": gt.length[e],
            "width": gt.width[e],
        }

    def plan(self, tick: int, tracks: np.ndarray | None = None) -> np.ndarray:
        """(N, 3) plan: the physical future path, offset along and across itself by amounts that
        grow with (dt / H)^2, shifted by the localisation error; built on the 0.1 s grid,
        re-timed against the channel's own predictions of `tracks` (its vehicle tracks at this
        tick, [x, y, vx, vy, yaw, length]; `retime_plan`), then sampled by time (every
        `plan_step` s) or by distance (every `plan_spacing` m)."""
        m = self.motion
        pts = true_plan_points(self.gt, tick, self.p.plan_horizon, 0.1, m)
        idx = tick + np.arange(len(pts))
        yaw = m.yaw[idx]
        if self.p.plan_foresight is not None and pts[-1, 0] > self.p.plan_foresight + 1e-9:
            pts, yaw = limit_foresight(self.gt, tick, pts, m, self.p.plan_foresight)
        frac = (pts[:, 0] / self.p.plan_horizon) ** 2
        scale = min(1.0, max(0.0, float(m.speed[tick])) / STANDSTILL_SPEED)
        lon = scale * self.plan_lon[tick] * frac
        # never backwards: where the true path stops, a shrinking along-path offset would fold
        # the plan back on itself; the plan holds its position instead
        s_true = np.concatenate(
            [[0.0], np.cumsum(np.hypot(np.diff(pts[:, 1]), np.diff(pts[:, 2])))]
        )
        lon = np.maximum.accumulate(s_true + lon) - s_true
        lat = scale * self.plan_lat[tick] * frac
        pts[:, 1] += lon * np.cos(yaw) - lat * np.sin(yaw) + self.loc.offset[tick, 0]
        pts[:, 2] += lon * np.sin(yaw) + lat * np.cos(yaw) + self.loc.offset[tick, 1]
        if tracks is not None:
            pts = retime_plan(
                pts,
                float(self.gt.length[self.gt.ego_index]),
                tracks,
                self.p.plan_standstill_gap,
                self.p.plan_corridor,
                yaw=(float(yaw[0]), float(yaw[-1])),
            )
        if self.p.plan_sampling == "distance":
            out = resample_by_distance(pts, self.p.plan_spacing)
        elif self.plan_every > 1:
            out = pts[:: self.plan_every]
        else:
            out = pts
        return self._plan_noise(out)

    def _plan_noise(self, pts: np.ndarray) -> np.ndarray:
        """A planner's own point noise (`plan_noise_lon`/`_lat`), along and across the path;
        drawn from its own generator so the other noise does not change with it."""
        p = self.p
        if (p.plan_noise_lon <= 0.0 and p.plan_noise_lat <= 0.0) or len(pts) < 2:
            return pts
        d = np.gradient(pts[:, 1:3], axis=0)
        norm = np.hypot(d[:, 0], d[:, 1])
        ok = norm > 1e-6
        ux = np.where(ok, d[:, 0] / np.where(ok, norm, 1.0), 1.0)
        uy = np.where(ok, d[:, 1] / np.where(ok, norm, 1.0), 0.0)
        lon = self.plan_noise_rng.normal(0.0, 1.0, len(pts)) * p.plan_noise_lon
        lat = self.plan_noise_rng.normal(0.0, 1.0, len(pts)) * p.plan_noise_lat
        out = pts.copy()
        out[:, 1] += lon * ux - lat * uy
        out[:, 2] += lon * uy + lat * ux
        return out

    def objects(self, tick: int) -> list[dict[str, Any]]:
        gt, p, rng, m = self.gt, self.p, self.rng, self.motion
        t = gt.times[tick]
        ex, ey, eyaw = gt.x[tick, gt.ego_index], gt.y[tick, gt.ego_index], m.yaw[tick]
        dx, dy = gt.x[tick] - ex, gt.y[tick] - ey
        dist = np.hypot(dx, dy)
        bearing = (np.arctan2(dy, dx) - eyaw + np.pi) % (2.0 * np.pi) - np.pi
        with np.errstate(invalid="ignore"):
            visible = (
                self.others
                & (dist <= p.range_m)
                & (np.abs(bearing) <= np.radians(p.fov_deg) / 2.0 + 1e-9)
            )
        visible &= ~self.missed[tick]
        if p.miss_edge > 0.0:
            # misses grow towards the edge of the sensing range (weak returns, small images)
            visible &= self.edge_draw[tick] >= p.miss_edge * (dist / p.range_m) ** 2
        idx = np.flatnonzero(visible)
        n = len(idx)
        sigma = p.pos_sigma * (1.0 + p.pos_range_growth * dist[idx] / p.range_m)
        off = self.loc.offset[tick]
        white = p.pos_white * (1.0 + p.pos_white_growth * dist[idx] / p.range_m)
        err = (
            self.err_pos[tick, idx] * sigma[:, None] + rng.normal(0.0, 1.0, (n, 2)) * white[:, None]
        )
        x = gt.x[tick, idx] + off[0] + err[:, 0]
        y = gt.y[tick, idx] + off[1] + err[:, 1]
        true_yaw = gt.yaw[tick, idx]
        yaw = true_yaw + p.yaw_sigma * self.err_yaw[tick, idx]
        speed = gt.speed[tick, idx]
        moving = np.clip(speed / STANDSTILL_SPEED, 0.0, 1.0)
        v_lon = speed + moving * p.speed_sigma * self.err_vel[tick, idx, 0]
        v_lat = moving * p.lat_speed_sigma * self.err_vel[tick, idx, 1]
        c, s = np.cos(true_yaw), np.sin(true_yaw)
        vx, vy = v_lon * c - v_lat * s, v_lon * s + v_lat * c
        length = gt.length[idx] * self.size_bias[idx, 0]
        width = gt.width[idx] * self.size_bias[idx, 1]
        ids = []
        for j, sw in zip(idx.tolist(), self.switch[tick, idx].tolist(), strict=True):
            lost = t - self.last_seen.get(j, -np.inf) > p.track_timeout
            if j not in self.track or lost or sw:
                self.track[j] = self._new_id()
            self.last_seen[j] = t
            ids.append(self.track[j])
        cls = [gt.cls[j] for j in idx.tolist()]
        # the channel's vehicle tracks, for its planner (ghosts are not planned around)
        self.tracks = np.column_stack([x, y, vx, vy, yaw, length])
        #: the true vehicle index of every reported object (-1: a ghost), for fault injection
        self.reported = idx.copy()

        # ghosts: a false track at a random spot in the field of view that rides along with the
        # ego (same velocity) for a fraction of a second
        if rng.random() < p.ghost_rate * 0.1:
            half = np.radians(p.fov_deg) / 2.0
            self.ghosts.append(
                {
                    "id": self._new_id(),
                    "until": t + rng.uniform(*p.ghost_life),
                    "r": rng.uniform(5.0, p.range_m * 0.8),
                    "b": rng.uniform(-half, half),
                    "dyaw": rng.normal(0.0, 0.1),
                    "length": rng.uniform(0.8, 4.5),
                    "width": rng.uniform(0.6, 2.0),
                }
            )
        self.ghosts = [g for g in self.ghosts if g["until"] >= t]
        if self.ghosts:
            g_r = np.array([g["r"] for g in self.ghosts])
            g_b = np.array([g["b"] for g in self.ghosts]) + eyaw
            g_yaw = eyaw + np.array([g["dyaw"] for g in self.ghosts])
            ev = max(0.0, float(m.speed[tick]))
            x = np.concatenate([x, ex + off[0] + g_r * np.cos(g_b)])
            y = np.concatenate([y, ey + off[1] + g_r * np.sin(g_b)])
            yaw = np.concatenate([yaw, g_yaw])
            vx = np.concatenate([vx, np.full(len(g_r), ev * np.cos(eyaw))])
            vy = np.concatenate([vy, np.full(len(g_r), ev * np.sin(eyaw))])
            length = np.concatenate([length, [g["length"] for g in self.ghosts]])
            width = np.concatenate([width, [g["width"] for g in self.ghosts]])
            ids += [g["id"] for g in self.ghosts]
            cls += ["unknown"] * len(g_r)
            self.reported = np.concatenate([self.reported, np.full(len(g_r), -1)])

        dts = self.pred_dt
        px = x[:, None] + vx[:, None] * dts[None, :]
        py = y[:, None] + vy[:, None] * dts[None, :]
        if p.pred_noise_lon > 0.0 or p.pred_noise_lat > 0.0:
            # a prediction module's own sampling noise, point by point along and across the
            # object's heading
            shape = px.shape
            lon_n = rng.normal(0.0, 1.0, shape) * p.pred_noise_lon
            lat_n = rng.normal(0.0, 1.0, shape) * p.pred_noise_lat
            cy, sy = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
            px = px + lon_n * cy - lat_n * sy
            py = py + lon_n * sy + lat_n * cy
        pred = np.stack([np.broadcast_to(dts, px.shape), px, py], axis=2)
        state = np.round(
            np.column_stack([x, y, yaw, vx, vy, length, width]), OBJECT_DECIMALS
        ).tolist()
        pred_l = np.round(pred, PREDICTION_DECIMALS).tolist()
        return [
            {
                "id": ids[i],
                "cls": cls[i],
                "x": s[0],
                "y": s[1],
                "yaw": s[2],
                "vx": s[3],
                "vy": s[4],
                "length": s[5],
                "width": s[6],
                "prediction": pred_l[i],
            }
            for i, s in enumerate(state)
        ]

    def frame(self, tick: int) -> dict[str, Any]:
        """The channel's entry of a casewatch frame at `tick` (floats rounded, see *_DECIMALS)."""
        ego = {k: round(float(v), EGO_DECIMALS) for k, v in self.ego(tick).items()}
        # objects first: the plan is re-timed against this tick's own tracks (the plan draws
        # no random numbers, so the order does not change the noise)
        objects = self.objects(tick)
        plan = np.round(self.plan(tick, self.tracks), EGO_DECIMALS).tolist()
        return {"ego": ego, "plan": plan, "objects": objects}
