"""Scores of one drive from its traffic-rule events and world inputs (docs/traffic-rules.md).

**Penalty score**: eqs. 6.1 and 6.3 of the CARLA safety-monitor thesis, as written and named:

    score = c * t_o / t * d - gamma * sum_x f(m_x)                          (6.1)
    t_o   = s / v_avg * (1 + alpha) + sum_i t_avg_ni                        (6.3)

`c` the proportion of the route completed (route progress / route length at the end), `t` the
time the drive took, `d` the scenario's difficulty (0-1000, `monitor.scoring.d`), `gamma` the
discount factor (0, 1], `f(m_x)` the sum of the penalty points of rule x (table A.3), `s` the
length of the route, `v_avg` the average speed limit over the route (the limits weighted by the
route distance driven under each), `alpha` the traffic intensity [0, 1], `t_avg_ni` the time
allowed at stop i (`stop_allowance`, 12 s, at each traffic-light or stop-sign stop line the
drive passes, or the case's list `stops`). The time term is not capped: the thesis gives a
driver quicker than `t_o` more than `d` (`timeliness_cap` is casewatch's capped variant). Each
rule event adds its penalty, the "while speeding" one when the ego was above the speed limit at
the event's first tick; an at-fault collision's penalty depends on the other party (at that
tick); overlapping no-headlights and no-fog-lights events count `neither` together.

**CARLA Leaderboard 2.0**: driving score = 100 * route completion * infraction penalty, the
penalty the product over infractions of the Leaderboard's coefficients: collisions (every
contact, the ego at fault or not) with a pedestrian 0.50, a vehicle 0.60, anything else 0.65;
red light 0.70; stop sign 0.80; scenario timeout 0.70; failing to yield to an emergency vehicle
0.70; driving outside the route's lanes `1 - p/100` (p the share of the route driven outside);
minimum speed `1 - 0.3 * (1 - p/100)` per route stretch where the ego's mean speed is p % of
the surrounding traffic's (p < 100). Route deviation, being blocked and the route timeout end
the route: the completion is the progress at that tick, and nothing after it counts. An
infraction whose input the stream never reported is "not scored" (listed, never counted as
none).

Without a reported route (`world.route`) there is no completion and so no score: missing data
is not a perfect drive; the reason is given instead.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from casewatch.evaluator.result import Episode, FormulaStats
from casewatch.monitor.world import PARTIES
from casewatch.safety_case.contracts import RULES, library
from casewatch.safety_case.model import ScoringParams

PARTY_NAMES = {v: k for k, v in PARTIES.items()}

#: What the scores read per tick (besides the episodes).
TICK_SIGNALS = (
    "vehicle_speed",
    "ego_speed",
    "speed_limit",
    "route_progress",
    "route_length",
    "tl_state",
    "tl_distance",
    "stop_distance",
    "collision_party",
    "collision_at_fault",
    "collision_victim",
    "collision_victim_party",
    "route_outside_lanes",
    "route_deviated",
    "blocked",
    "route_timeout",
    "scenario_timeout",
    "yield_failed",
    "traffic_speed",
)

#: Leaderboard 2.0 infraction -> coefficient per event (its statistics manager's table).
LEADERBOARD = {
    "collisions_pedestrian": 0.5,
    "collisions_vehicle": 0.6,
    "collisions_layout": 0.65,
    "red_light": 0.7,
    "stop_infraction": 0.8,
    "scenario_timeouts": 0.7,
    "yield_emergency_vehicle_infractions": 0.7,
}
#: per-percentage infractions: (coefficient, how the percentage p reduces the penalty)
OUTSIDE_LANES, MIN_SPEED = "outside_route_lanes", "min_speed_infractions"
MIN_SPEED_COEFFICIENT = 0.7
#: the infractions that end the route, and the input each reads
ROUTE_ENDS = {
    "route_dev": "route_deviated",
    "vehicle_blocked": "blocked",
    "route_timeout": "route_timeout",
}
#: the Leaderboard's collision kinds by the other party (casewatch's party -> its name)
#: the world key (docs/streams.md) each Leaderboard input comes from
WORLD_KEY = {
    "route_deviated": "world.route.deviated",
    "blocked": "world.blocked",
    "route_timeout": "world.timeouts.route",
    "scenario_timeout": "world.timeouts.scenario",
    "yield_failed": "world.emergency_vehicle.failed_to_yield",
}
COLLISION_KIND = {
    "pedestrian": "collisions_pedestrian",
    "vehicle": "collisions_vehicle",
    "two_wheeler": "collisions_vehicle",
    "object": "collisions_layout",
}


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


def _runs(mask: np.ndarray) -> list[int]:
    """The first tick of every run of consecutive True ticks."""
    m = np.asarray(mask, dtype=bool)
    return [int(k) for k in np.flatnonzero(m & ~np.concatenate(([False], m[:-1])))]


def _reported(column: np.ndarray, upto: int) -> bool:
    return bool(np.isfinite(column[:upto]).any())


def _crossings(distance: np.ndarray) -> int:
    """Stop lines passed: the distance to one goes from ahead (> 0) to at or past it (<= 0)."""
    d = np.asarray(distance, dtype=float)
    before, after = d[:-1], d[1:]
    return int(np.sum(np.isfinite(before) & np.isfinite(after) & (before > 0) & (after <= 0)))


def _g(x: float) -> str:
    return f"{x:.4g}"


def score_run(
    episodes: list[Episode],
    formulas: list[FormulaStats],
    t: np.ndarray,
    ticks: Mapping[str, np.ndarray],
    period: float,
    params: ScoringParams,
) -> dict | None:
    """Both scores of a run as plain values, or None when the case has no traffic rule."""
    rule_of = {f.id: f.rule for f in formulas if f.rule}
    if not rule_of:
        return None
    events = sorted((e for e in episodes if e.formula_id in rule_of), key=lambda e: e.start)
    n = len(t)
    nan = np.full(n, np.nan)
    ticks = {name: np.asarray(ticks.get(name, nan), dtype=float) for name in TICK_SIGNALS}
    # the vehicle's own speed; a channel's estimate where the vehicle reports none
    speed = np.where(
        np.isfinite(ticks["vehicle_speed"]), ticks["vehicle_speed"], ticks["ego_speed"]
    )
    limit = ticks["speed_limit"]

    def tick(time: float) -> int:
        return min(int(np.searchsorted(t, time - 1e-9)), n - 1)

    per_rule: dict[str, dict] = {}
    total = 0.0
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
        if rule in lights:
            lights[rule].append((e.start, e.end))
    # neither light at once: `neither` instead of the two penalties (table A.3)
    both = sum(
        1
        for a in lights["no_headlights"]
        for b in lights["no_fog_lights"]
        if a[0] <= b[1] and b[0] <= a[1]
    )
    if both:
        head, fog = (rule_penalty(r, None, params)[0] for r in ("no_headlights", "no_fog_lights"))
        adjust = both * (params.neither - head - fog)
        total += adjust
        per_rule.setdefault(
            "neither_light", {"events": both, "while_speeding": 0, "penalty": adjust}
        )
    out: dict = {"penalty": None, "carla": None, "reason": None}
    progress, length = ticks["route_progress"], ticks["route_length"]
    if params.route_length is not None:
        length = np.where(np.isfinite(progress), params.route_length, np.nan)
    reported = np.isfinite(progress) & np.isfinite(length) & (length > 0)
    if not reported.any():
        out["reason"] = "the drive reports no route (world.route): no completion, no score"
        out["per_rule"] = per_rule
        out["penalty_sum"] = total
        return out
    out["penalty"] = _penalty_score(
        t, ticks, period, params, per_rule, total, progress, length, reported
    )
    if out["penalty"] is None:
        out["reason"] = (
            "no reference speed: no speed limit reported along the route and no scoring.v_avg"
        )
        out["per_rule"] = per_rule
        out["penalty_sum"] = total
    out["carla"] = _leaderboard(
        events, rule_of, t, ticks, speed, period, params, progress, length, reported
    )
    return out


def _penalty_score(
    t: np.ndarray,
    ticks: dict[str, np.ndarray],
    period: float,
    params: ScoringParams,
    per_rule: dict,
    total: float,
    progress: np.ndarray,
    length: np.ndarray,
    reported: np.ndarray,
) -> dict | None:
    """Eqs. 6.1 and 6.3 (see the module docstring); None without a reference speed."""
    n = len(t)
    last = int(np.flatnonzero(reported)[-1])
    s = float(length[last])
    c = float(np.clip(progress[last] / s, 0.0, 1.0))
    # v_avg over the route: each tick's limit weighted by the route distance it covers
    limit = ticks["speed_limit"]
    step = np.diff(progress, prepend=np.nan)
    weight = np.where(np.isfinite(step) & (step > 0) & np.isfinite(limit), step, 0.0)
    if params.v_avg is not None:
        v_avg, v_from = params.v_avg, "scoring.v_avg"
    elif weight.sum() > 0:
        v_avg, v_from = float((limit * weight)[weight > 0].sum() / weight.sum()), "route"
    elif np.isfinite(limit).any():  # the ego never advanced: the limits it stood under
        v_avg, v_from = float(np.nanmean(limit)), "time"
    else:
        return None
    if v_avg <= 0:
        return None
    if params.stops is not None:
        stops = [float(x) for x in params.stops]
        stops_from = "scoring.stops"
    else:
        passed = _crossings(ticks["tl_distance"]) + _crossings(ticks["stop_distance"])
        stops = [params.stop_allowance] * passed
        stops_from = "stop lines passed"
    duration = n * period
    t_o = s / v_avg * (1 + params.alpha) + sum(stops)
    timeliness = t_o / duration
    if params.timeliness_cap:
        timeliness = min(timeliness, 1.0)
    score = c * timeliness * params.d - params.gamma * total
    made_of = (
        f"{_g(score)} = c {_g(c)} x t_o {_g(t_o)} s / t {_g(duration)} s"
        f"{' (capped at 1)' if params.timeliness_cap else ''} x d {_g(params.d)}"
        f" - gamma {_g(params.gamma)} x penalties {_g(total)}; t_o = s {_g(s)} m / v_avg "
        f"{_g(v_avg)} m/s x (1 + alpha {_g(params.alpha)}) + {len(stops)} stops "
        f"{_g(sum(stops))} s"
    )
    return {
        "score": round(score, 6),
        "c": round(c, 6),
        "t": round(duration, 6),
        "t_o": round(t_o, 6),
        "d": params.d,
        "s": s,
        "v_avg": round(v_avg, 6),
        "v_avg_from": v_from,
        "alpha": params.alpha,
        "gamma": params.gamma,
        "stops": stops,
        "stops_from": stops_from,
        "timeliness": round(timeliness, 6),
        "timeliness_cap": params.timeliness_cap,
        "penalty_sum": total,
        "per_rule": per_rule,
        "made_of": made_of,
    }


def _leaderboard(
    events: list[Episode],
    rule_of: dict[str, str],
    t: np.ndarray,
    ticks: dict[str, np.ndarray],
    speed: np.ndarray,
    period: float,
    params: ScoringParams,
    progress: np.ndarray,
    length: np.ndarray,
    reported: np.ndarray,
) -> dict:
    """The Leaderboard 2.0 driving score (see the module docstring)."""
    n = len(t)
    # the route ends at the first tick of route deviation, blocked or route timeout
    end, ended_by = n, None
    not_scored: dict[str, str] = {}
    for name, signal in ROUTE_ENDS.items():
        column = ticks[signal]
        if not _reported(column, n):
            not_scored[name] = f"the stream reports no {WORLD_KEY[signal]}"
            continue
        hits = np.flatnonzero(column > 0.5)
        if hits.size and int(hits[0]) < end:
            end, ended_by = int(hits[0]), name
    last = (
        int(np.flatnonzero(reported[: max(end, 1)])[-1])
        if reported[: max(end, 1)].any()
        else int(np.flatnonzero(reported)[0])
    )
    route = float(length[last])
    completion = float(np.clip(progress[last] / route, 0.0, 1.0))
    cutoff = float(t[end]) - 1e-9 if end < n else np.inf  # events from the route's end on: none
    counted: dict[str, dict] = {}
    factor = 1.0

    def count(name: str, coefficient: float) -> None:
        nonlocal factor
        row = counted.setdefault(name, {"events": 0, "coefficient": coefficient})
        row["events"] += 1
        factor *= coefficient

    # collisions: every contact, whoever is at fault; one per run of contact ticks
    at_fault, victim = ticks["collision_at_fault"], ticks["collision_victim"]
    if _reported(at_fault, end):
        contact = (np.nan_to_num(at_fault) + np.nan_to_num(victim)) > 0
        for k in _runs(contact[:end]):
            code = (
                ticks["collision_party"][k]
                if at_fault[k] > 0
                else ticks["collision_victim_party"][k]
            )
            party = PARTY_NAMES.get(float(code), "vehicle")
            coefficient = params.carla.get(f"collision.{party}", LEADERBOARD[COLLISION_KIND[party]])
            count(COLLISION_KIND[party], coefficient)
    else:
        for name in ("collisions_pedestrian", "collisions_vehicle", "collisions_layout"):
            not_scored[name] = "the stream reports no world.collisions"
    # red light and stop sign: the case's rule events
    for rule, name in (("red_light", "red_light"), ("stop_sign", "stop_infraction")):
        if rule not in rule_of.values():
            not_scored[name] = f"the case has no {rule} rule"
            continue
        for e in events:
            if rule_of[e.formula_id] == rule and e.start < cutoff:
                count(name, carla_coefficient(rule, None, params))
    # events the stream flags
    for signal, name in (
        ("scenario_timeout", "scenario_timeouts"),
        ("yield_failed", "yield_emergency_vehicle_infractions"),
    ):
        column = ticks[signal]
        if not _reported(column, end):
            not_scored[name] = f"the stream reports no {WORLD_KEY[signal]}"
            continue
        for _ in _runs(column[:end] > 0.5):
            count(name, LEADERBOARD[name])
    # outside the route's lanes: the share of the route driven outside them
    outside = ticks["route_outside_lanes"]
    if not _reported(outside, end):
        not_scored[OUTSIDE_LANES] = "the stream reports no world.route.outside_lanes"
    else:
        moved = np.where(np.isfinite(speed[:end]), speed[:end], 0.0) * period
        share = float(moved[outside[:end] > 0.5].sum() / route)
        if share > 0:
            p = min(share, 1.0) * 100
            counted[OUTSIDE_LANES] = {
                "events": 1,
                "coefficient": round(1 - p / 100, 6),
                "percentage": round(p, 4),
            }
            factor *= 1 - p / 100
    # minimum speed: per stretch of the route, the ego's mean speed against the traffic's
    traffic = ticks["traffic_speed"]
    if not _reported(traffic, end):
        not_scored[MIN_SPEED] = "the stream reports no world.traffic_speed"
    else:
        marks = (
            route * np.arange(1, params.min_speed_checkpoints + 1) / params.min_speed_checkpoints
        )
        where = np.where(np.isfinite(progress), progress, -np.inf)
        start = 0
        for k, mark in enumerate(marks):
            passed = np.flatnonzero(where[:end] >= mark - 1e-9)
            final = k == len(marks) - 1 and completion > 0.95
            stop = int(passed[0]) + 1 if passed.size else (end if final else None)
            if stop is None:
                break
            sel = slice(start, stop)
            ok = np.isfinite(traffic[sel]) & np.isfinite(speed[sel])
            start = stop
            if not ok.any() or traffic[sel][ok].mean() <= 0:
                continue
            p = round(float(speed[sel][ok].mean() / traffic[sel][ok].mean() * 100), 2)
            if p < 100:
                c = 1 - (1 - MIN_SPEED_COEFFICIENT) * (1 - p / 100)
                row = counted.setdefault(
                    MIN_SPEED, {"events": 0, "coefficient": 1.0, "percentage": []}
                )
                row["events"] += 1
                row["coefficient"] = round(row["coefficient"] * c, 6)
                row["percentage"].append(p)
                factor *= c
    for name in ROUTE_ENDS:
        if name == ended_by:
            counted[name] = {"events": 1, "coefficient": 1.0, "ends_route": True}
    score = 100.0 * completion * factor
    parts = " * ".join(
        f"{name} {_g(r['coefficient'])}"
        + (f"^{r['events']}" if r["events"] > 1 and "percentage" not in r else "")
        for name, r in counted.items()
        if r["coefficient"] != 1.0
    )
    made_of = (
        f"{_g(score)} = 100 x route completion {_g(completion)} x infraction penalty "
        f"{_g(factor)}{' (' + parts + ')' if parts else ''}"
        f"{'; route ended by ' + ended_by if ended_by else ''}"
        f"{'; not scored: ' + ', '.join(not_scored) if not_scored else ''}"
    )
    return {
        "driving_score": round(score, 6),
        "route_completion": round(completion, 6),
        "infraction_penalty": round(factor, 6),
        "per_infraction": counted,
        "ended_by": ended_by,
        "not_scored": not_scored,
        "made_of": made_of,
    }
