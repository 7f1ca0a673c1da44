"""Scores of one drive from its traffic-rule events (docs/traffic-rules.md).

**Penalty score** (the simulation safety toolkit's):

    score = c * min(t_o / t, 1) * d - gamma * sum(penalties)
    t_o   = s / v_avg * (1 + alpha) + sum(stop times)

`t` the drive's duration, `s` the distance driven along the route (its progress over the
drive: `t_o` is the reference time for what was driven), `d` the route completion (progress /
length at the end), `v_avg` the reference speed (the time-mean speed limit unless the case sets it),
stop times the time the ego stood (speed below `standstill`) within `stop_zone` metres before
a red light or a stop line. Each rule event adds its penalty, the "while speeding" one when the
ego was above the speed limit at the event's first tick; an at-fault collision's penalty
depends on the other party (at that tick); overlapping no-headlights and no-fog-lights events
count `neither` together instead of both. Decision: the time term is capped at 1 (driving
faster than the reference time earns nothing).

**CARLA Leaderboard**: driving score = 100 * route completion * infraction penalty, the penalty
the product of each infraction's coefficient per event (collisions by party 0.50 / 0.60 /
0.65, red light 0.70, stop sign 0.80; the others 1).

Without a reported route (`world.route`) there is no completion and so no score: missing data
is not a perfect drive; the reason is given instead.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from evaluator.result import Episode, FormulaStats
from monitor.world import PARTIES
from safety_case.contracts import RULES, library
from safety_case.model import ScoringParams

PARTY_NAMES = {v: k for k, v in PARTIES.items()}

#: What the scores read per tick (besides the episodes).
TICK_SIGNALS = ("vehicle_speed", "ego_speed", "speed_limit", "route_progress", "route_length",
                "tl_state", "tl_distance", "stop_distance", "collision_party")  # fmt: skip


def rule_penalty(rule: str, party: str | None, params: ScoringParams) -> tuple[float, float]:
    """(base, while speeding) of an event of `rule` (a collision: with `party`)."""
    data = library(RULES)[rule].data
    if "penalty_by_party" in data:
        key = party or "vehicle"
        return params.penalties.get(f"{rule}.{key}", tuple(data["penalty_by_party"][key]))
    return params.penalties.get(rule, tuple(data["penalty"]))


def carla_coefficient(rule: str, party: str | None, params: ScoringParams) -> float:
    data = library(RULES)[rule].data
    if "carla_by_party" in data:
        key = party or "vehicle"
        return params.carla.get(f"{rule}.{key}", data["carla_by_party"][key])
    return params.carla.get(rule, data["carla"])


def score_run(episodes: list[Episode], formulas: list[FormulaStats], t: np.ndarray,
              ticks: Mapping[str, np.ndarray], period: float,
              params: ScoringParams) -> dict | None:  # fmt: skip
    """Both scores of a run as plain values, or None when the case has no traffic rule."""
    rule_of = {f.id: f.rule for f in formulas if f.rule}
    if not rule_of:
        return None
    events = sorted((e for e in episodes if e.formula_id in rule_of), key=lambda e: e.start)
    n = len(t)
    # the vehicle's own speed; a channel's estimate where the vehicle reports none
    speed = np.where(np.isfinite(ticks["vehicle_speed"]), ticks["vehicle_speed"],
                     ticks["ego_speed"])  # fmt: skip
    limit = ticks["speed_limit"]

    def tick(time: float) -> int:
        return min(int(np.searchsorted(t, time - 1e-9)), n - 1)

    per_rule: dict[str, dict] = {}
    per_infraction: dict[str, dict] = {}
    total = 0.0
    carla = 1.0
    lights: dict[str, list[tuple[float, float]]] = {"no_headlights": [], "no_fog_lights": []}
    for e in events:
        rule = rule_of[e.formula_id]
        k = tick(e.start)
        party = None
        if rule == "collision":
            party = PARTY_NAMES.get(float(ticks["collision_party"][k]), "vehicle")
        speeding = bool(np.isfinite(limit[k]) and np.isfinite(speed[k]) and speed[k] > limit[k])
        base, fast = rule_penalty(rule, party, params)
        penalty = fast if speeding else base
        row = per_rule.setdefault(rule, {"events": 0, "while_speeding": 0, "penalty": 0.0})
        row["events"] += 1
        row["while_speeding"] += int(speeding)
        row["penalty"] += penalty
        total += penalty
        coefficient = carla_coefficient(rule, party, params)
        if coefficient < 1.0:
            name = f"{rule}.{party}" if party else rule
            inf = per_infraction.setdefault(name, {"events": 0, "coefficient": coefficient})
            inf["events"] += 1
            carla *= coefficient
        if rule in lights:
            lights[rule].append((e.start, e.end))
    # neither light at once: `neither` instead of the two penalties
    both = sum(1 for a in lights["no_headlights"] for b in lights["no_fog_lights"]
               if a[0] <= b[1] and b[0] <= a[1])  # fmt: skip
    if both:
        head, fog = (rule_penalty(r, None, params)[0] for r in ("no_headlights", "no_fog_lights"))
        adjust = both * (params.neither - head - fog)
        total += adjust
        per_rule.setdefault("neither_light", {"events": both, "while_speeding": 0,
                                              "penalty": adjust})  # fmt: skip
    duration = n * period
    out: dict = {"penalty": None, "carla": None, "reason": None}
    progress, length = ticks["route_progress"], ticks["route_length"]
    reported = np.isfinite(progress) & np.isfinite(length) & (length > 0)
    limits = limit[np.isfinite(limit)]
    v_avg = params.v_avg if params.v_avg is not None else (
        float(limits.mean()) if limits.size else None)  # fmt: skip
    if not reported.any():
        out["reason"] = "the drive reports no route (world.route): no completion, no score"
    elif v_avg is None or v_avg <= 0:
        out["reason"] = "no reference speed: no speed limit reported and no scoring.v_avg"
    if out["reason"] is not None:
        out["per_rule"] = per_rule
        out["penalty_sum"] = total
        return out
    first, last = (int(k) for k in np.flatnonzero(reported)[[0, -1]])
    route = float(length[last])
    d = float(np.clip(progress[last] / route, 0.0, 1.0))
    s = max(float(progress[last] - progress[first]), 0.0)
    near_red = (ticks["tl_state"] > 2.5) & (ticks["tl_distance"] >= 0) & (
        ticks["tl_distance"] <= params.stop_zone)
    near_stop = (ticks["stop_distance"] >= 0) & (ticks["stop_distance"] <= params.stop_zone)
    standing = np.isfinite(speed) & (speed < params.standstill) & (near_red | near_stop)
    stop_time = float(standing.sum()) * period
    t_o = s / v_avg * (1 + params.alpha) + stop_time
    score = params.c * min(t_o / duration, 1.0) * d - params.gamma * total
    out["penalty"] = {
        "score": round(score, 6), "c": params.c, "t": round(duration, 6), "t_o": round(t_o, 6),
        "d": round(d, 6), "route_length": route, "distance": round(s, 6),
        "v_avg": round(v_avg, 6),
        "stop_time": round(stop_time, 6), "alpha": params.alpha, "gamma": params.gamma,
        "penalty_sum": total, "per_rule": per_rule,
    }  # fmt: skip
    out["carla"] = {"driving_score": round(100.0 * d * carla, 6), "route_completion": round(d, 6),
                    "infraction_penalty": round(carla, 6), "per_infraction": per_infraction}
    return out
