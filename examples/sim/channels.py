"""Channel models: what two imperfect driving stacks would report about the same true traffic.

Each channel is seeded on its own (scenario seed and channel seed), so changing one channel's
parameters does not change the other's noise. Per channel:

- localisation: white noise, a slow smooth drift (a sum of a few low-frequency sinusoids), and
  injected faults in which the ego estimate jumps back and forth by metres for a second or two;
- perception: a sensing range and a field of view centred forward (a channel with a field of view
  below 360 degrees is blind behind the ego), position noise growing with range, heading, speed
  and size noise, missed detections, short-lived ghost objects, and track-id switches; objects are
  reported in the channel's own world frame, so its localisation error shifts them too;
- predictions: constant velocity and heading, `prediction_points` points every
  `prediction_step` seconds;
- the ego plan: the ego's true future path over the channel's horizon, shifted by the channel's
  localisation error and distorted smoothly (a lateral offset growing with the square of the
  look-ahead time and a speed bias that stretches the path).

The per-tick work is vectorised over vehicles and plan/prediction points with numpy; the only
Python loop is over frames (and over the few visible objects for the id bookkeeping).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

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


@dataclass(frozen=True)
class ChannelParams:
    """Parameters of one channel model (units: m, s, rad unless stated)."""

    name: str
    seed: int
    range_m: float
    fov_deg: float  # total field of view centred on the ego's heading; 360 = all around
    pos_sigma: float  # object position noise at zero range; doubles at the sensing range
    yaw_sigma: float
    speed_sigma: float
    size_sigma: float  # relative (fraction of length and width)
    p_miss: float  # probability that a visible object is not reported in a tick
    ghost_rate: float  # expected ghost objects appearing per second
    ghost_life: tuple[float, float]  # lifetime range (s)
    p_id_switch: float  # probability per object and tick that its track id changes
    track_timeout: float  # an object unseen for longer gets a new id when seen again
    loc_sigma: float  # localisation jitter per axis (smooth, periods `loc_jitter_period`)
    loc_drift: float  # standard deviation of the slow drift per axis
    loc_drift_period: tuple[float, float]  # periods of the drift components (s)
    loc_yaw_sigma: float
    ego_speed_sigma: float
    plan_horizon: float
    plan_lateral: float  # std of the lateral plan offset at the end of the horizon
    plan_speed_bias: float  # std of the relative stretch of the planned path
    plan_period: tuple[float, float]  # periods of the plan distortion processes (s)
    prediction_points: int = 30
    prediction_step: float = 0.1
    loc_jitter_period: tuple[float, float] = (1.5, 6.0)


#: The all-round channel (the study's LAV stack: 360-degree perception, 5 s plan). Its 30
#: prediction points are 0.2 s apart so they cover its plan: an object whose prediction ends
#: "stays at its last point" for the safety score, which would put phantom obstacles in a
#: longer plan.
LAV = ChannelParams(
    name="lav", seed=101, range_m=60.0, fov_deg=360.0, pos_sigma=0.20, yaw_sigma=0.03,
    speed_sigma=0.3, size_sigma=0.05, p_miss=0.04, ghost_rate=0.08, ghost_life=(0.3, 1.0),
    p_id_switch=0.002, track_timeout=1.0, loc_sigma=0.05, loc_drift=0.15,
    loc_drift_period=(20.0, 60.0), loc_yaw_sigma=0.005, ego_speed_sigma=0.1,
    plan_horizon=5.0, plan_lateral=0.3, plan_speed_bias=0.03, plan_period=(4.0, 15.0),
    prediction_step=0.2,
)

#: The forward-looking channel (the study's TransFuser stack: blind behind, 3 s plan).
TFUSE = ChannelParams(
    name="tfuse", seed=202, range_m=50.0, fov_deg=200.0, pos_sigma=0.30, yaw_sigma=0.05,
    speed_sigma=0.5, size_sigma=0.08, p_miss=0.07, ghost_rate=0.15, ghost_life=(0.2, 0.8),
    p_id_switch=0.005, track_timeout=0.5, loc_sigma=0.08, loc_drift=0.20,
    loc_drift_period=(15.0, 45.0), loc_yaw_sigma=0.008, ego_speed_sigma=0.15,
    plan_horizon=3.0, plan_lateral=0.2, plan_speed_bias=0.04, plan_period=(3.0, 10.0),
)


def smooth_process(
    rng: np.random.Generator, times: np.ndarray, std: float, period: tuple[float, float],
    components: int = 4,
) -> np.ndarray:
    """A smooth zero-mean signal with standard deviation about `std`: a sum of sinusoids with
    random periods in `period` and random phases (each has variance a^2 / 2)."""
    periods = rng.uniform(period[0], period[1], components)
    phases = rng.uniform(0.0, 2.0 * np.pi, components)
    amp = std * np.sqrt(2.0 / components)
    return amp * np.sin(2.0 * np.pi * times[:, None] / periods[None, :] + phases).sum(axis=1)


def fault_offsets(
    rng: np.random.Generator, times: np.ndarray, faults: tuple[LocalizationFault, ...],
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
class Localization:
    """A channel's ego estimate for every tick (world frame)."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    offset: np.ndarray  # (T, 2) estimate minus truth, including faults


def localize(
    gt: GroundTruth, params: ChannelParams, faults: tuple[LocalizationFault, ...], seed: int
) -> Localization:
    """The channel's ego pose over the whole run: truth + white noise + drift + faults."""
    rng = np.random.default_rng([seed, params.seed, 1])
    t = gt.times
    e = gt.ego_index
    drift = np.stack([smooth_process(rng, t, params.loc_drift, params.loc_drift_period)
                      for _ in range(2)], axis=1)
    # a fused localisation is smooth at 10 Hz: its error is correlated from tick to tick, not
    # white (white noise of a few cm would read as tens of m/s^3 of jerk in hcs)
    noise = np.stack([smooth_process(rng, t, params.loc_sigma, params.loc_jitter_period, 6)
                      for _ in range(2)], axis=1)
    offset = drift + noise + fault_offsets(rng, t, faults, params.name)
    yaw = gt.yaw[:, e] + smooth_process(rng, t, params.loc_yaw_sigma, params.loc_jitter_period, 6)
    yaw += smooth_process(rng, t, params.loc_yaw_sigma, params.loc_drift_period)
    return Localization(gt.x[:, e] + offset[:, 0], gt.y[:, e] + offset[:, 1], yaw, offset)


def true_plan_points(gt: GroundTruth, tick: int, horizon: float, step: float) -> np.ndarray:
    """(N, 3) [dt, x, y] of the ego's true centre over the next `horizon` seconds (truncated at
    the end of the simulated run)."""
    e = gt.ego_index
    k = round(step / (gt.times[1] - gt.times[0]))
    n = round(horizon / step) + 1
    idx = tick + k * np.arange(n)
    idx = idx[idx < len(gt.times)]
    dt = gt.times[idx] - gt.times[tick]
    return np.column_stack([dt, gt.x[idx, e], gt.y[idx, e]])


class ChannelModel:
    """Turns ground truth into one channel's per-frame report, tick by tick (stateful tracks)."""

    def __init__(
        self, gt: GroundTruth, params: ChannelParams, faults: tuple[LocalizationFault, ...],
        seed: int,
    ) -> None:
        self.gt = gt
        self.p = params
        self.loc = localize(gt, params, faults, seed)
        self.rng = np.random.default_rng([seed, params.seed, 2])
        plan_rng = np.random.default_rng([seed, params.seed, 3])
        self.plan_lat = smooth_process(plan_rng, gt.times, params.plan_lateral, params.plan_period)
        self.plan_stretch = smooth_process(
            plan_rng, gt.times, params.plan_speed_bias, params.plan_period
        )
        self.track: dict[int, str] = {}
        self.last_seen: dict[int, float] = {}
        self.next_id = 1
        self.ghosts: list[dict[str, Any]] = []
        ego = gt.ego_index
        self.others = np.ones(len(gt.ids), dtype=bool)
        self.others[ego] = False

    def _new_id(self) -> str:
        tid = str(self.next_id)
        self.next_id += 1
        return tid

    def ego(self, tick: int) -> dict[str, float]:
        gt, e, p = self.gt, self.gt.ego_index, self.p
        speed = gt.speed[tick, e] + self.rng.normal(0.0, p.ego_speed_sigma)
        yaw = self.loc.yaw[tick]
        return {
            "x": self.loc.x[tick], "y": self.loc.y[tick], "yaw": yaw,
            "vx": speed * np.cos(yaw), "vy": speed * np.sin(yaw),
            "length": gt.length[e], "width": gt.width[e],
        }

    def plan(self, tick: int) -> np.ndarray:
        """(N, 3) plan: true future path, stretched, bent sideways, shifted by localisation."""
        gt, e = self.gt, self.gt.ego_index
        pts = true_plan_points(gt, tick, self.p.plan_horizon, 0.1)
        start = pts[0, 1:]
        rel = pts[:, 1:] - start
        yaw = gt.yaw[tick, e]
        normal = np.array([-np.sin(yaw), np.cos(yaw)])
        frac = pts[:, 0] / self.p.plan_horizon
        bent = (start + rel * (1.0 + self.plan_stretch[tick])
                + (self.plan_lat[tick] * frac**2)[:, None] * normal[None, :])
        pts[:, 1:] = bent + self.loc.offset[tick]
        return pts

    def objects(self, tick: int) -> list[dict[str, Any]]:
        gt, p, rng = self.gt, self.p, self.rng
        e = gt.ego_index
        t = gt.times[tick]
        ex, ey, eyaw = gt.x[tick, e], gt.y[tick, e], gt.yaw[tick, e]
        dx, dy = gt.x[tick] - ex, gt.y[tick] - ey
        dist = np.hypot(dx, dy)
        bearing = (np.arctan2(dy, dx) - eyaw + np.pi) % (2.0 * np.pi) - np.pi
        with np.errstate(invalid="ignore"):
            visible = (self.others & (dist <= p.range_m)
                       & (np.abs(bearing) <= np.radians(p.fov_deg) / 2.0 + 1e-9))
        visible &= rng.random(len(visible)) >= p.p_miss
        idx = np.flatnonzero(visible)
        n = len(idx)
        sigma = p.pos_sigma * (1.0 + dist[idx] / p.range_m)
        off = self.loc.offset[tick]
        x = gt.x[tick, idx] + off[0] + rng.normal(0.0, 1.0, n) * sigma
        y = gt.y[tick, idx] + off[1] + rng.normal(0.0, 1.0, n) * sigma
        yaw = gt.yaw[tick, idx] + rng.normal(0.0, p.yaw_sigma, n)
        speed = np.maximum(gt.speed[tick, idx] + rng.normal(0.0, p.speed_sigma, n), 0.0)
        length = gt.length[idx] * (1.0 + rng.normal(0.0, p.size_sigma, n))
        width = gt.width[idx] * (1.0 + rng.normal(0.0, p.size_sigma, n))
        switch = rng.random(n) < p.p_id_switch
        ids = []
        for j, sw in zip(idx.tolist(), switch.tolist(), strict=True):
            lost = t - self.last_seen.get(j, -np.inf) > p.track_timeout
            if j not in self.track or lost or sw:
                self.track[j] = self._new_id()
            self.last_seen[j] = t
            ids.append(self.track[j])
        cls = [gt.cls[j] for j in idx.tolist()]

        # ghosts: appear at a random spot in the field of view and ride along with the ego
        if rng.random() < p.ghost_rate * 0.1:
            life = rng.uniform(*p.ghost_life)
            half = np.radians(p.fov_deg) / 2.0
            self.ghosts.append({
                "id": self._new_id(), "until": t + life,
                "r": rng.uniform(5.0, p.range_m * 0.8), "b": rng.uniform(-half, half),
            })
        self.ghosts = [g for g in self.ghosts if g["until"] >= t]
        if self.ghosts:
            r = np.array([g["r"] for g in self.ghosts])
            b = np.array([g["b"] for g in self.ghosts]) + eyaw
            m = len(self.ghosts)
            x = np.concatenate([x, ex + off[0] + r * np.cos(b) + rng.normal(0, 0.3, m)])
            y = np.concatenate([y, ey + off[1] + r * np.sin(b) + rng.normal(0, 0.3, m)])
            yaw = np.concatenate([yaw, eyaw + rng.normal(0.0, 0.3, m)])
            speed = np.concatenate([speed, np.full(m, gt.speed[tick, e])])
            length = np.concatenate([length, rng.uniform(0.8, 4.5, m)])
            width = np.concatenate([width, rng.uniform(0.6, 2.0, m)])
            ids += [g["id"] for g in self.ghosts]
            cls += ["unknown"] * m

        vx, vy = speed * np.cos(yaw), speed * np.sin(yaw)
        dts = p.prediction_step * np.arange(p.prediction_points)
        px = x[:, None] + vx[:, None] * dts[None, :]
        py = y[:, None] + vy[:, None] * dts[None, :]
        pred = np.stack([np.broadcast_to(dts, px.shape), px, py], axis=2)
        state = np.round(np.column_stack([x, y, yaw, vx, vy, length, width]),
                         OBJECT_DECIMALS).tolist()
        pred_l = np.round(pred, PREDICTION_DECIMALS).tolist()
        return [
            {"id": ids[i], "cls": cls[i], "x": s[0], "y": s[1], "yaw": s[2], "vx": s[3],
             "vy": s[4], "length": s[5], "width": s[6], "prediction": pred_l[i]}
            for i, s in enumerate(state)
        ]

    def frame(self, tick: int) -> dict[str, Any]:
        """The channel's entry of a casewatch frame at `tick` (floats rounded to 3 decimals)."""
        ego = {k: round(float(v), EGO_DECIMALS) for k, v in self.ego(tick).items()}
        return {"ego": ego, "plan": np.round(self.plan(tick), EGO_DECIMALS).tolist(),
                "objects": self.objects(tick)}
