"""Ground-truth labels: hazard intervals derived from the simulator's truth, never from channels.

Three sources, written as JSON Lines `{"hazard": id, "start": s, "end": s, ...}` with extra
fields saying where each label comes from:

- `source: "geometry"`: ego tailgating (`CSn2`) and ego tailgated (`CSn3`) from true geometry.
  "Following in the same lane" means: on the ego's edge, same SUMO lane id, the other vehicle's
  lane position ahead of (behind) the ego's, the bumper-to-bumper gap measured in the world
  frame from the box centres (projection of the centre offset on the follower's heading minus
  half of both lengths); beyond the ego's edge (the junction's internal lane, the next or the
  previous street), on the ego's lane continuation: a lane the ego drives (drove) through at
  that lane position without changing lanes within an edge, within `CONTINUATION_RANGE` of its
  path, the gap measured along the ego's driven path. The nearest such vehicle. Time gap = gap /
  follower speed. A tick is tailgating when the time gap is below `TIME_GAP_THRESHOLD` (1.0 s)
  and the follower drives faster than `MIN_SPEED` (5 m/s; queues at red lights are not
  tailgating). Consecutive ticks form an interval [first tick, last tick]; intervals closer than
  `MERGE_GAP` (1.0 s) merge; merged intervals shorter than `MIN_DURATION` (1.0 s) are dropped.
- `source: "injected"`: inconsistent localisation (`CSn1`), the localisation faults the
  generator injected, one interval per fault.
- `source: "ssm"` (a separate file): the conflicts of SUMO's SSM device on the ego, restricted to
  the ticks where TTC < 3.0 s or DRAC > 3.0 m/s^2 (SUMO's defaults), merged like above but
  without a minimum duration; PET < 2.0 s gives a point interval. Lead/follow encounters map to
  `CSn2` (ego follows the foe, SUMO encounter type 2) and `CSn3` (foe follows the ego, type 3);
  crossing and merging conflicts are labelled `ssm-conflict`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from examples.sim.scenarios import Scenario
    from examples.sim.simulate import GroundTruth

#: Hazard node ids of the reference safety case (examples/reference-case.yaml).
HAZARD_LOCALIZATION = "CSn1"  # inconsistent ego localisation
HAZARD_TAILGATING = "CSn2"  # ego too close behind a lead vehicle
HAZARD_TAILGATED = "CSn3"  # a follower too close behind the ego
HAZARD_SSM_OTHER = "ssm-conflict"

TIME_GAP_THRESHOLD = 1.0  # s
MIN_SPEED = 5.0  # m/s, follower speed
MIN_DURATION = 1.0  # s
MERGE_GAP = 1.0  # s
SSM_TTC_THRESHOLD = 3.0  # s
SSM_DRAC_THRESHOLD = 3.0  # m/s^2
SSM_PET_THRESHOLD = 2.0  # s


@dataclass
class Following:
    """Per tick: the ego's nearest same-lane leader and follower and their true gaps."""

    lead: np.ndarray  # (T,) vehicle index, -1 when none
    lead_gap: np.ndarray  # (T,) m, NaN when none
    lead_time_gap: np.ndarray  # (T,) s = lead_gap / ego speed, NaN when none
    follower: np.ndarray
    follower_gap: np.ndarray
    follower_time_gap: np.ndarray  # follower_gap / follower speed
    follower_speed: np.ndarray


#: How far (m of the ego's driven path) a leader or follower is looked for on the ego's lane
#: continuation beyond its current edge (across junctions); SUMO's getLeader looks 100 m too.
CONTINUATION_RANGE = 100.0


def _edge(lane_id: str) -> str:
    """The edge of a SUMO lane id (`A2A3_0` -> `A2A3`, internal `:B1_0_0` -> `:B1_0`)."""
    return lane_id.rsplit("_", 1)[0]


def _continuation(gt: GroundTruth) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Leaders and followers of the ego on its lane continuation across edges and junctions.

    A vehicle on another edge than the ego's (the next street, the junction's internal lane,
    the previous street) is on the ego's lane continuation when the ego drives (later) or drove
    (earlier) through its position on its lane: a stretch of the ego's own lane sequence with
    the ego on that lane at that lane position, reached without a lane change within an edge
    and within `CONTINUATION_RANGE` metres of the ego's path. Its gap is the distance along the
    ego's driven path (the ego's front-bumper odometer): leader rear bumper minus ego front
    bumper, or ego rear bumper minus follower front bumper. Returns (lead, lead_gap, follower,
    follower_gap), index -1 and NaN where there is none.
    """
    e = gt.ego_index
    n_t = len(gt.times)
    lead = np.full(n_t, -1)
    foll = np.full(n_t, -1)
    lead_gap = np.full(n_t, np.nan)
    foll_gap = np.full(n_t, np.nan)
    ego_lane = gt.lane[:, e]
    if n_t < 2 or (ego_lane < 0).any():
        return lead, lead_gap, foll, foll_gap
    edges = [_edge(name) for name in gt.lane_ids]
    half = 0.5 * gt.length[e]
    fx = gt.x[:, e] + half * np.cos(gt.yaw[:, e])
    fy = gt.y[:, e] + half * np.sin(gt.yaw[:, e])
    odo = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(fx), np.diff(fy)))])
    # the ego's lane sequence as runs [first, last] tick on one lane
    cut = np.flatnonzero(np.diff(ego_lane) != 0) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [n_t]]) - 1
    run_lane = ego_lane[starts]
    run_of = np.repeat(np.arange(len(starts)), ends - starts + 1)
    # a lane change within an edge breaks the continuation between two runs
    broken = np.array([edges[a] == edges[b] for a, b in pairwise(run_lane.tolist())], dtype=bool)
    others = np.ones(len(gt.ids), dtype=bool)
    others[e] = False
    for k in range(n_t):
        r0 = run_of[k]
        here = edges[ego_lane[k]]
        near = np.flatnonzero(
            others
            & (gt.lane[k] >= 0)
            & (np.hypot(gt.x[k] - gt.x[k, e], gt.y[k] - gt.y[k, e]) <= CONTINUATION_RANGE + 20.0)
        )
        for j in near.tolist():
            lane_j = gt.lane[k, j]
            if edges[lane_j] == here:
                continue
            pos = gt.lane_pos[k, j]
            for step, runs in ((1, range(r0 + 1, len(starts))), (-1, range(r0 - 1, -1, -1))):
                for r in runs:
                    if broken[min(r, r0) : max(r, r0)].any():
                        break
                    gone = odo[starts[r]] - odo[k] if step > 0 else odo[k] - odo[ends[r]]
                    if gone > CONTINUATION_RANGE:
                        break
                    if run_lane[r] != lane_j:
                        continue
                    a, b = starts[r], ends[r]
                    lp = gt.lane_pos[a : b + 1, e]
                    # the ego's samples on a short (junction) lane may start after its first
                    # metre or end before its last: reach out by the step into (out of) it
                    before = odo[a] - odo[a - 1] if a > 0 else 0.0
                    after = odo[b + 1] - odo[b] if b + 1 < n_t else 0.0
                    if (
                        np.any(np.diff(lp) < 0)
                        or not lp[0] - before - 1e-6 <= pos <= lp[-1] + after + 1e-6
                    ):
                        break
                    if pos < lp[0]:
                        at = odo[a] - (lp[0] - pos)
                    elif pos > lp[-1]:
                        at = odo[b] + (pos - lp[-1])
                    else:
                        at = float(np.interp(pos, lp, odo[a : b + 1]))
                    if step > 0:
                        g = at - gt.length[j] - odo[k]
                        if g <= CONTINUATION_RANGE and (lead[k] < 0 or g < lead_gap[k]):
                            lead[k], lead_gap[k] = j, g
                    else:
                        g = odo[k] - gt.length[e] - at
                        if g <= CONTINUATION_RANGE and (foll[k] < 0 or g < foll_gap[k]):
                            foll[k], foll_gap[k] = j, g
                    break
    return lead, lead_gap, foll, foll_gap


def following(gt: GroundTruth) -> Following:
    """Nearest leader and follower of the ego in its lane at every tick, gaps from geometry.

    On the ego's edge: the same SUMO lane id, lane position ahead of (behind) the ego's, the
    bumper gap from the box centres. Beyond it (the next or previous street, a junction's
    internal lane): the ego's lane continuation, with the gap along the ego's driven path
    (`_continuation`). The nearer of the two is the leader (follower).
    """
    e = gt.ego_index
    n_t = len(gt.times)
    rows = np.arange(n_t)
    others = np.ones(len(gt.ids), dtype=bool)
    others[e] = False
    same = (gt.lane == gt.lane[:, [e]]) & (gt.lane >= 0) & others[None, :]
    ego_pos = gt.lane_pos[:, [e]]
    with np.errstate(invalid="ignore"):
        ahead = same & (gt.lane_pos > ego_pos)
        behind = same & (gt.lane_pos < ego_pos)
    lead = np.where(ahead, gt.lane_pos, np.inf).argmin(axis=1)
    lead = np.where(ahead.any(axis=1), lead, -1)
    foll = np.where(behind, gt.lane_pos, -np.inf).argmax(axis=1)
    foll = np.where(behind.any(axis=1), foll, -1)

    def gap(front: np.ndarray, back: np.ndarray) -> np.ndarray:
        """Bumper gap between the vehicle `back` and the vehicle `front` ahead of it."""
        ok = (front >= 0) & (back >= 0)
        f, b = np.where(ok, front, 0), np.where(ok, back, 0)
        hx, hy = np.cos(gt.yaw[rows, b]), np.sin(gt.yaw[rows, b])
        proj = (gt.x[rows, f] - gt.x[rows, b]) * hx + (gt.y[rows, f] - gt.y[rows, b]) * hy
        g = proj - 0.5 * (gt.length[f] + gt.length[b])
        return np.where(ok, g, np.nan)

    ego_idx = np.full(n_t, e)
    lead_gap = gap(lead, ego_idx)
    foll_gap = gap(ego_idx, foll)
    c_lead, c_lead_gap, c_foll, c_foll_gap = _continuation(gt)
    with np.errstate(invalid="ignore"):
        use = (c_lead >= 0) & ((lead < 0) | (c_lead_gap < lead_gap))
        lead, lead_gap = np.where(use, c_lead, lead), np.where(use, c_lead_gap, lead_gap)
        use = (c_foll >= 0) & ((foll < 0) | (c_foll_gap < foll_gap))
        foll, foll_gap = np.where(use, c_foll, foll), np.where(use, c_foll_gap, foll_gap)
    ego_speed = gt.speed[:, e]
    foll_speed = np.where(foll >= 0, gt.speed[rows, np.maximum(foll, 0)], np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        lead_tg = np.where(ego_speed > 0, lead_gap / ego_speed, np.inf)
        foll_tg = np.where(foll_speed > 0, foll_gap / foll_speed, np.inf)
    lead_tg = np.where(lead >= 0, lead_tg, np.nan)
    foll_tg = np.where(foll >= 0, foll_tg, np.nan)
    return Following(lead, lead_gap, lead_tg, foll, foll_gap, foll_tg, foll_speed)


def intervals(
    times: np.ndarray,
    mask: np.ndarray,
    merge_gap: float = MERGE_GAP,
    min_duration: float = MIN_DURATION,
) -> list[tuple[float, float]]:
    """[first, last] times of runs of True in `mask`; runs closer than `merge_gap` merge, merged
    runs shorter than `min_duration` are dropped."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return []
    edges = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    runs: list[list[float]] = []
    for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
        if runs and times[s] - runs[-1][1] < merge_gap:
            runs[-1][1] = float(times[e])
        else:
            runs.append([float(times[s]), float(times[e])])
    return [(a, b) for a, b in runs if b - a >= min_duration - 1e-9]


def tailgating_mask(fol: Following, ego_speed: np.ndarray) -> np.ndarray:
    """Ticks where the ego follows its same-lane leader closer than the threshold."""
    with np.errstate(invalid="ignore"):
        return (fol.lead >= 0) & (ego_speed > MIN_SPEED) & (fol.lead_time_gap < TIME_GAP_THRESHOLD)


def tailgated_mask(fol: Following) -> np.ndarray:
    """Ticks where the ego's same-lane follower is closer than the threshold."""
    with np.errstate(invalid="ignore"):
        return (
            (fol.follower >= 0)
            & (fol.follower_speed > MIN_SPEED)
            & (fol.follower_time_gap < TIME_GAP_THRESHOLD)
        )


def _who(gt: GroundTruth, idx: np.ndarray, times: np.ndarray, a: float, b: float) -> list[str]:
    sel = (times >= a - 1e-9) & (times <= b + 1e-9) & (idx >= 0)
    return sorted({gt.ids[i] for i in idx[sel].tolist()})


def geometry_labels(gt: GroundTruth, duration: float) -> list[dict[str, Any]]:
    """Tailgating (CSn2) and tailgated (CSn3) intervals from true geometry, within [0, duration]."""
    fol = following(gt)
    keep = gt.times <= duration + 1e-9
    t = gt.times[keep]
    ego_speed = gt.speed[keep, gt.ego_index]
    sub = Following(*(getattr(fol, f)[keep] for f in Following.__dataclass_fields__))
    out: list[dict[str, Any]] = []
    for hazard, mask, idx, tg in (
        (HAZARD_TAILGATING, tailgating_mask(sub, ego_speed), sub.lead, sub.lead_time_gap),
        (HAZARD_TAILGATED, tailgated_mask(sub), sub.follower, sub.follower_time_gap),
    ):
        for a, b in intervals(t, mask):
            sel = (t >= a) & (t <= b) & mask
            out.append(
                {
                    "hazard": hazard,
                    "start": round(a, 3),
                    "end": round(b, 3),
                    "source": "geometry",
                    "vehicles": _who(gt, np.where(mask, idx, -1), t, a, b),
                    "min_time_gap": round(float(np.nanmin(tg[sel])), 3),
                }
            )
    return out


def fault_labels(sc: Scenario, times: np.ndarray) -> list[dict[str, Any]]:
    """One CSn1 interval per injected localisation fault: [first, last] tick inside the fault."""
    out = []
    for f in sc.faults:
        inside = times[(times >= f.start - 1e-9) & (times < f.end - 1e-9)]
        if len(inside) == 0:
            continue
        out.append(
            {
                "hazard": HAZARD_LOCALIZATION,
                "start": round(float(inside[0]), 3),
                "end": round(float(inside[-1]), 3),
                "source": "injected",
                "channel": f.channel,
                "amplitude": f.amplitude,
            }
        )
    return out


@dataclass
class SsmConflict:
    """One `<conflict>` of SUMO's SSM output, with its time lines (trajectories=true)."""

    foe: str
    begin: float
    end: float
    times: np.ndarray
    types: np.ndarray
    ttc: np.ndarray  # NaN where SUMO wrote NA
    drac: np.ndarray
    pet: tuple[float, float] | None  # (time, value)


@dataclass
class SsmLog:
    conflicts: list[SsmConflict] = field(default_factory=list)
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sgap: np.ndarray = field(default_factory=lambda: np.zeros(0))  # bumper gap to the leader
    tgap: np.ndarray = field(default_factory=lambda: np.zeros(0))  # sgap / ego speed


def _floats(text: str | None) -> np.ndarray:
    if not text:
        return np.zeros(0)
    return np.array([np.nan if v in ("NA", "") else float(v) for v in text.split()])


def read_ssm(path: Path) -> SsmLog:
    """Parse an SSM device output file (see SUMO's "SSM Device" documentation)."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ValueError(f"{path}: cannot read SUMO SSM output: {exc}") from exc
    log = SsmLog()
    for c in root.iter("conflict"):

        def span(tag: str, conflict: ET.Element = c) -> np.ndarray:
            el = conflict.find(tag)
            return _floats(el.get("values") if el is not None else None)

        times = span("timeSpan")
        pet_el = c.find("PET")
        pet = None
        if pet_el is not None and pet_el.get("value") not in (None, "NA"):
            pet = (float(pet_el.get("time", "nan")), float(pet_el.get("value", "nan")))
        ttc, drac = span("TTCSpan"), span("DRACSpan")
        log.conflicts.append(
            SsmConflict(
                foe=c.get("foe", ""),
                begin=float(c.get("begin", "nan")),
                end=float(c.get("end", "nan")),
                times=times,
                types=span("typeSpan"),
                ttc=ttc if len(ttc) else np.full(len(times), np.nan),
                drac=drac if len(drac) else np.full(len(times), np.nan),
                pet=pet,
            )
        )
    g = root.find("globalMeasures")
    if g is not None:
        for tag, attr in (("timeSpan", "times"), ("SGAPSpan", "sgap"), ("TGAPSpan", "tgap")):
            el = g.find(tag)
            if el is not None:
                setattr(log, attr, _floats(el.get("values")))
    return log


def ssm_labels(log: SsmLog, duration: float) -> list[dict[str, Any]]:
    """Critical stretches of the SSM conflicts as labels (see the module docstring)."""
    out: list[dict[str, Any]] = []
    for c in log.conflicts:
        with np.errstate(invalid="ignore"):
            crit = (c.ttc < SSM_TTC_THRESHOLD) | (c.drac > SSM_DRAC_THRESHOLD)
        crit &= c.times <= duration + 1e-9
        for a, b in intervals(c.times, crit, min_duration=0.0):
            sel = (c.times >= a) & (c.times <= b) & crit
            kinds = c.types[sel].astype(int)
            kind = int(np.bincount(kinds).argmax()) if len(kinds) else -1
            hazard = {2: HAZARD_TAILGATING, 3: HAZARD_TAILGATED}.get(kind, HAZARD_SSM_OTHER)
            label: dict[str, Any] = {
                "hazard": hazard,
                "start": round(a, 3),
                "end": round(b, 3),
                "source": "ssm",
                "foe": c.foe,
                "encounter_type": kind,
            }
            if np.isfinite(c.ttc[sel]).any():
                label["min_ttc"] = round(float(np.nanmin(c.ttc[sel])), 3)
            if np.isfinite(c.drac[sel]).any():
                label["max_drac"] = round(float(np.nanmax(c.drac[sel])), 3)
            out.append(label)
        if c.pet is not None and c.pet[1] < SSM_PET_THRESHOLD and c.pet[0] <= duration:
            out.append(
                {
                    "hazard": HAZARD_SSM_OTHER,
                    "start": round(c.pet[0], 3),
                    "end": round(c.pet[0], 3),
                    "source": "ssm",
                    "foe": c.foe,
                    "pet": c.pet[1],
                }
            )
    out.sort(key=lambda d: (d["start"], d["hazard"]))
    return out
