"""SPI-relevant faults, injected into one channel's reports, with a label for each.

The channel models of `examples.sim.channels` produce a channel's frame from the truth; the
faults here change that frame afterwards, so the drive with and the drive without the faults
share every random draw (the detection rule of `evaluator.faults` compares the two). Each
family is what a real stack does when one of its modules fails:

| family | what the faulty channel reports | duration |
| --- | --- | --- |
| `object_drop` | a real vehicle inside both coverages is missing (a track lost) | 2-5 s |
| `phantom` | a car 15 m ahead that is not there, driving along (a false track) | 2 s |
| `plan_lateral` | its plan 1-2 m to one side, shifted whole or diverging within 1-2 s | 2 s |
| `prediction_reversed` | every moving object predicted to drive backwards (a sign error) | 2 s |
| `localisation_drift` | its ego pose, and all it places by it, drifting 0.5-1 m/s | 2-4 s |
| `frozen_channel` | the same frame over and over (a hung process republishing) | 2-3 s |

Faults are placed where they can be seen and judged alone: an object drop needs a vehicle that
stays well inside both channels' coverage (4 m inside the range and the field of view) for the
whole fault; a phantom needs 8 m clear of real vehicles; a frozen channel needs the ego moving
(> 5 m/s); reversed predictions need a moving object (> 3 m/s) both channels see. Fault windows
keep `SPACING` seconds from each other and from every labelled hazard.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from examples.sim.simulate import GroundTruth
from examples.sim.stacks import min_coverage

#: Families in the order they are placed.
FAMILIES = (
    "object_drop",
    "phantom",
    "plan_lateral",
    "prediction_reversed",
    "localisation_drift",
    "frozen_channel",
)
#: Seconds kept clear before a fault's start and after its end (of other faults, of labels).
SPACING = 5.0
#: Seconds inside the coverage edges a dropped vehicle must stay (range, and perpendicular
#: distance from the field-of-view edge rays), well beyond casewatch's 2 m coverage margin.
INSIDE = 4.0


@dataclass
class InjectedFault:
    """One fault: family, channel, tick range [first, last] and what it needs to apply."""

    fault: str
    channel: str
    first: int
    last: int
    info: dict[str, Any] = field(default_factory=dict)

    def label(self, times: np.ndarray) -> dict[str, Any]:
        """Its line of the fault-labels file (`evaluator.faults`)."""
        out = {
            "fault": self.fault,
            "start": round(float(times[self.first]), 3),
            "end": round(float(times[self.last]), 3),
            "channel": self.channel,
            "source": "injected",
        }
        out.update({k: v for k, v in self.info.items() if not k.startswith("_")})
        return out


def _inside_both(gt: GroundTruth, half_fov: float, range_m: float) -> np.ndarray:
    """(T, V) True where vehicle v is well inside the common coverage seen from the true ego."""
    e = gt.ego_index
    dx = gt.x - gt.x[:, e : e + 1]
    dy = gt.y - gt.y[:, e : e + 1]
    dist = np.hypot(dx, dy)
    bearing = np.abs((np.arctan2(dy, dx) - gt.yaw[:, e : e + 1] + np.pi) % (2 * np.pi) - np.pi)
    if half_fov >= math.pi - 1e-9:
        edge = np.full_like(dist, np.inf)
    else:
        # perpendicular distance from the nearer edge ray (negative outside the wedge)
        edge = dist * np.sin(half_fov - bearing)
        edge = np.where(bearing <= half_fov, edge, -1.0)
    ok = (dist <= range_m - INSIDE) & (edge >= INSIDE) & (dist > 3.0)
    ok[:, e] = False
    return ok & np.isfinite(gt.x)


def _free(busy: np.ndarray, first: int, last: int, pad: int) -> bool:
    lo, hi = max(0, first - pad), min(len(busy), last + pad + 1)
    return not busy[lo:hi].any()


def plan_faults(
    gt: GroundTruth,
    n_ticks: int,
    channels: tuple[Any, Any],
    rng: np.random.Generator,
    labels: list[dict[str, Any]],
    per_family: int = 1,
) -> list[InjectedFault]:
    """Place up to `per_family` faults of every family in the first `n_ticks` ticks (a family
    with no place that fits is left out, never forced)."""
    times = gt.times[:n_ticks]
    step = float(times[1] - times[0])
    pad = round(SPACING / step)
    busy = np.zeros(n_ticks, dtype=bool)
    busy[: round(8.0 / step)] = True  # warm-up: every history metric is filling
    for lab in labels:
        busy[(times >= lab["start"] - 1e-9) & (times <= lab["end"] + 1e-9)] = True
    half_fov, range_m = min_coverage(*channels)
    inside = _inside_both(gt, half_fov, range_m)[:n_ticks]
    e = gt.ego_index
    speed = gt.speed[:n_ticks, e]
    names = [c.name for c in channels]
    out: list[InjectedFault] = []
    for family in FAMILIES:
        for _ in range(per_family):
            fault = _place(family, gt, times, busy, pad, inside, speed, rng, names)
            if fault is None:
                break
            busy[fault.first : fault.last + 1] = True
            out.append(fault)
    return sorted(out, key=lambda f: f.first)


def _place(
    family: str,
    gt: GroundTruth,
    times: np.ndarray,
    busy: np.ndarray,
    pad: int,
    inside: np.ndarray,
    speed: np.ndarray,
    rng: np.random.Generator,
    names: list[str],
) -> InjectedFault | None:
    step = float(times[1] - times[0])
    duration = {
        "object_drop": rng.uniform(2.0, 5.0),
        "localisation_drift": rng.uniform(2.0, 4.0),
        "frozen_channel": rng.uniform(2.0, 3.0),
    }.get(family, 2.0)
    n = round(duration / step)
    channel = str(rng.choice(names))
    e = gt.ego_index
    starts = rng.permutation(np.arange(0, len(times) - n))
    for first in starts.tolist():
        last = first + n - 1
        if not _free(busy, first, last, pad):
            continue
        span = slice(first, last + 1)
        info: dict[str, Any] = {}
        if family == "object_drop":
            whole = inside[span].all(axis=0)
            if not whole.any():
                continue
            vehicle = int(rng.choice(np.flatnonzero(whole)))
            info = {"vehicle": gt.ids[vehicle], "_vehicle": vehicle}
        elif family == "phantom":
            ahead = _phantom_positions(gt, first, last)
            gap = np.hypot(gt.x[span] - ahead[:, 0:1], gt.y[span] - ahead[:, 1:2])
            gap[:, e] = np.inf
            if np.nanmin(gap) < 8.0 or speed[span].min() < 3.0:
                continue
        elif family == "plan_lateral":
            if speed[span].min() < 3.0:
                continue
            info = {
                "offset_m": round(float(rng.uniform(1.0, 2.0)), 2),
                "side": str(rng.choice(["left", "right"])),
                "ramp_s": round(float(rng.choice([0.0, rng.uniform(1.0, 2.0)])), 2),
            }
        elif family == "prediction_reversed":
            moving = inside[span] & (gt.speed[span] > 3.0)
            if not moving.any(axis=1).all():
                continue
        elif family == "localisation_drift":
            if speed[span].min() < 1.0:
                continue
            info = {
                "rate_m_s": round(float(rng.uniform(0.5, 1.0)), 2),
                "heading_deg": round(float(rng.uniform(0.0, 360.0)), 1),
            }
        elif family == "frozen_channel" and speed[span].min() < 5.0:
            continue
        return InjectedFault(family, channel, first, last, info)
    return None


def _phantom_positions(gt: GroundTruth, first: int, last: int) -> np.ndarray:
    """(n, 2) a point 15 m ahead of the true ego at every tick of [first, last]."""
    e = gt.ego_index
    k = np.arange(first, last + 1)
    yaw = gt.yaw[k, e]
    return np.column_stack([gt.x[k, e] + 15.0 * np.cos(yaw), gt.y[k, e] + 15.0 * np.sin(yaw)])


class Injector:
    """Applies the planned faults to one channel's frames, tick by tick (`apply`)."""

    def __init__(self, faults: list[InjectedFault]):
        self.faults = faults
        self._frozen: dict[str, dict[str, Any]] = {}

    def apply(
        self, tick: int, channel: str, report: dict[str, Any], reported: np.ndarray
    ) -> dict[str, Any]:
        """The channel's report at `tick` with the faults active there; `reported` holds the
        true vehicle index of each reported object (-1 for ghosts). Returns `report` itself
        when no fault is active, else a changed copy."""
        active = [f for f in self.faults if f.channel == channel and f.first <= tick <= f.last]
        if not active:
            return report
        out = copy.deepcopy(report)
        for fault in active:
            k = tick - fault.first
            if fault.fault == "frozen_channel":
                frozen = self._frozen.setdefault(f"{channel}:{fault.first}", copy.deepcopy(out))
                out = copy.deepcopy(frozen)
            elif fault.fault == "object_drop":
                vehicle = fault.info["_vehicle"]
                keep = [
                    o
                    for o, v in zip(out["objects"], reported.tolist(), strict=True)
                    if v != vehicle
                ]
                out["objects"] = keep
            elif fault.fault == "phantom":
                out["objects"].append(_phantom(out["ego"], fault))
            elif fault.fault == "plan_lateral":
                _shift_plan(out, fault)
            elif fault.fault == "prediction_reversed":
                for obj in out["objects"]:
                    if math.hypot(obj["vx"], obj["vy"]) > 1.0:
                        obj["prediction"] = [
                            [dt, round(2 * obj["x"] - x, 2), round(2 * obj["y"] - y, 2)]
                            for dt, x, y in obj["prediction"]
                        ]
            elif fault.fault == "localisation_drift":
                _drift(out, fault, (k + 1) * 0.1)
        return out


def _phantom(ego: dict[str, Any], fault: InjectedFault) -> dict[str, Any]:
    """A car 15 m ahead of the channel's ego estimate, moving with it, predicted 3 s."""
    c, s = math.cos(ego["yaw"]), math.sin(ego["yaw"])
    x, y = ego["x"] + 15.0 * c, ego["y"] + 15.0 * s
    vx, vy = ego["vx"], ego["vy"]
    pred = [
        [round(0.1 * i, 3), round(x + vx * 0.1 * i, 2), round(y + vy * 0.1 * i, 2)]
        for i in range(1, 31)
    ]
    return {
        "id": f"phantom-{fault.first}",
        "cls": "car",
        "x": round(x, 3),
        "y": round(y, 3),
        "yaw": round(ego["yaw"], 3),
        "vx": round(vx, 3),
        "vy": round(vy, 3),
        "length": 4.5,
        "width": 1.8,
        "prediction": pred,
    }


def _shift_plan(report: dict[str, Any], fault: InjectedFault) -> None:
    """The plan moved `offset_m` to one side of the ego heading, reached at `ramp_s` seconds
    of plan time (0: the whole plan shifted)."""
    yaw = report["ego"]["yaw"]
    sign = 1.0 if fault.info["side"] == "left" else -1.0
    nx, ny = -math.sin(yaw) * sign, math.cos(yaw) * sign
    ramp = fault.info["ramp_s"]
    size = fault.info["offset_m"]
    plan = []
    for dt, x, y in report["plan"]:
        d = size if ramp <= 0 else size * min(1.0, dt / ramp)
        plan.append([dt, round(x + d * nx, 4), round(y + d * ny, 4)])
    report["plan"] = plan


def _drift(report: dict[str, Any], fault: InjectedFault, elapsed: float) -> None:
    """Everything the channel places by its ego pose moved `rate * elapsed` metres."""
    d = fault.info["rate_m_s"] * elapsed
    h = math.radians(fault.info["heading_deg"])
    ox, oy = d * math.cos(h), d * math.sin(h)
    report["ego"]["x"] = round(report["ego"]["x"] + ox, 4)
    report["ego"]["y"] = round(report["ego"]["y"] + oy, 4)
    report["plan"] = [[dt, round(x + ox, 4), round(y + oy, 4)] for dt, x, y in report["plan"]]
    for obj in report["objects"]:
        obj["x"] = round(obj["x"] + ox, 3)
        obj["y"] = round(obj["y"] + oy, 3)
        obj["prediction"] = [
            [dt, round(x + ox, 2), round(y + oy, 2)] for dt, x, y in obj["prediction"]
        ]
