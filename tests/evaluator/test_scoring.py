"""The penalty score (eqs. 6.1, 6.3 of the CARLA safety-monitor thesis) and the CARLA
Leaderboard 2.0 score of a drive, each value computed by hand from the formula."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from casewatch.evaluator.result import Episode, FormulaStats
from casewatch.evaluator.scoring import score_run
from casewatch.safety_case.model import ScoringParams


def formula(fid: str, rule: str | None) -> FormulaStats:
    return FormulaStats(
        id=fid, node_id=fid, node_text=rule or "", kind="hazard", source="x", rtamt="x", rule=rule
    )


def event(fid: str, start: float, end: float | None = None) -> Episode:
    return Episode(
        formula_id=fid,
        node_id=fid,
        kind="hazard",
        start=start,
        end=end or start,
        ticks=1,
        worst_robustness=-1.0,
        t_worst=start,
        trace=[],
    )


FORMULAS = [
    formula("R", "red_light"),
    formula("C", "collision"),
    formula("S", "stop_sign"),
    formula("H", "no_headlights"),
    formula("F", "no_fog_lights"),
]


def ticks(n: int = 100) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """10 s at 0.1 s: limit 10 m/s; the ego stands 5 m before a red light for the first
    second, crosses its stop line at t = 1.0 s, then drives 9 m/s (12 m/s at t = 3.0 s); route
    100 m, 80 m driven at the end; a pedestrian contact, the ego at fault, from t = 5.0 s."""
    t = np.round(np.arange(n) * 0.1, 6)
    speed = np.where(t < 1.0, 0.0, 9.0)
    speed[30] = 12.0
    tl_distance = np.where(t < 1.0, 5.0, np.where(t < 1.5, -1.0, 1000.0))
    contact = np.where((t >= 5.0) & (t < 5.3), 1.0, 0.0)
    return t, {
        "vehicle_speed": speed,
        "ego_speed": np.full(n, np.nan),
        "speed_limit": np.full(n, 10.0),
        "route_progress": np.linspace(0.0, 80.0, n),
        "route_length": np.full(n, 100.0),
        "tl_state": np.where(t < 1.0, 3.0, 0.0),
        "tl_distance": tl_distance,
        "stop_distance": np.full(n, 1000.0),
        "collision_party": contact,
        "collision_at_fault": contact,
        "collision_victim": np.zeros(n),
        "collision_victim_party": np.zeros(n),
    }


def test_eq_6_1_as_written():
    t, cols = ticks()
    events = [event("R", 3.0), event("C", 5.0, 5.2), event("S", 7.0)]
    out = score_run(events, FORMULAS, t, cols, 0.1, ScoringParams())
    p = out["penalty"]
    # s = the route length 100 m (not the 80 m driven); v_avg 10 m/s; one stop line passed,
    # 12 s: t_o = 100 / 10 * (1 + 0.2) + 12 = 24 s; t = 10 s; c = 80 / 100 = 0.8
    assert (p["s"], p["v_avg"], p["stops"], p["t_o"], p["t"], p["c"], p["d"]) == (
        100.0,
        10.0,
        [12.0],
        24.0,
        10.0,
        0.8,
        100.0,
    )
    # red light while speeding 100, pedestrian 600, stop sign 40 (table A.3): 740
    assert p["penalty_sum"] == 740.0
    assert p["per_rule"]["red_light"] == {"events": 1, "while_speeding": 1, "penalty": 100.0}
    # uncapped: t_o / t = 2.4. score = 0.8 * 2.4 * 100 - 0.7 * 740 = 192 - 518 = -326
    assert p["timeliness"] == 2.4
    assert p["score"] == pytest.approx(-326.0)
    assert p["made_of"].startswith(
        "-326 = c 0.8 x t_o 24 s / t 10 s x d 100 - gamma 0.7 x "
        "penalties 740; t_o = s 100 m / v_avg 10 m/s x (1 + alpha "
        "0.2) + 1 stops 12 s"
    )


def test_the_capped_time_term_is_an_explicit_variant():
    t, cols = ticks()
    out = score_run([], FORMULAS, t, cols, 0.1, ScoringParams(timeliness_cap=True))
    # min(24 / 10, 1) = 1: 0.8 * 1 * 100 - 0 = 80
    assert out["penalty"]["score"] == pytest.approx(80.0)
    assert "(capped at 1)" in out["penalty"]["made_of"]


def test_v_avg_is_the_speed_limit_averaged_over_the_route_not_over_time():
    # 40 m in 8 s under 10 m/s (ticks 0-80), then 40 m in 1.9 s under 20 m/s. Over the route:
    # (40 * 10 + 40 * 20) / 80 = 15 m/s (over time: (81 * 10 + 19 * 20) / 100 = 11.9)
    t, cols = ticks()
    cols["route_progress"] = np.concatenate([np.linspace(0, 40, 81), np.linspace(40, 80, 20)[1:]])
    cols["speed_limit"] = np.where(np.arange(100) <= 80, 10.0, 20.0)
    cols["route_length"] = np.full(100, 80.0)
    out = score_run([], FORMULAS, t, cols, 0.1, ScoringParams(alpha=0.0, stops=[]))
    p = out["penalty"]
    assert p["v_avg"] == pytest.approx(15.0) and p["v_avg_from"] == "route"
    # t_o = 80 / 15 = 5.333 s; c = 1; score = 1 * 5.333 / 10 * 100 = 53.33
    assert p["score"] == pytest.approx(80 / 15 / 10 * 100)


def test_stops_route_length_and_overrides_are_parameters():
    t, cols = ticks()
    params = ScoringParams(
        gamma=1.0,
        d=10.0,
        alpha=0.0,
        route_length=200.0,
        stops=[12.0, 30.0],
        penalties={"red_light": (5.0, 7.0)},
        carla={"red_light": 0.5},
    )
    events = [event("R", 3.0), event("H", 6.0, 8.0), event("F", 7.0, 9.0)]
    out = score_run(events, FORMULAS, t, cols, 0.1, params)
    p = out["penalty"]
    # red light while speeding: 7; no headlights 30 + no fog lights 10 at once -> neither 50
    assert p["penalty_sum"] == 7.0 + 50.0
    assert p["per_rule"]["neither_light"]["penalty"] == 10.0
    # s = 200 m: c = 80 / 200 = 0.4; t_o = 200 / 10 + 12 + 30 = 62 s; 0.4 * 6.2 * 10 - 57
    assert (p["c"], p["t_o"]) == (0.4, 62.0)
    assert p["score"] == pytest.approx(0.4 * 6.2 * 10 - 57.0)
    assert out["carla"]["per_infraction"]["red_light"] == {"events": 1, "coefficient": 0.5}


@pytest.mark.parametrize(
    ("key", "value"),
    [("gamma", 0.0), ("gamma", 1.5), ("alpha", 1.5), ("d", 1001.0), ("stop_allowance", -1.0)],
)
def test_the_parameters_are_bounded_as_the_thesis_bounds_them(key, value):
    with pytest.raises(ValidationError, match=key):
        ScoringParams(**{key: value})


def test_leaderboard_collisions_red_light_stop_sign():
    t, cols = ticks()
    events = [event("R", 3.0), event("C", 5.0, 5.2), event("S", 7.0)]
    c = score_run(events, FORMULAS, t, cols, 0.1, ScoringParams())["carla"]
    # 0.7 (red light) * 0.5 (pedestrian) * 0.8 (stop sign) = 0.28; 100 * 0.8 * 0.28 = 22.4
    assert c["infraction_penalty"] == pytest.approx(0.28)
    assert c["driving_score"] == pytest.approx(22.4)
    assert c["per_infraction"]["collisions_pedestrian"] == {"events": 1, "coefficient": 0.5}
    # the stream carries none of the other inputs: not scored, never "none"
    assert set(c["not_scored"]) == {
        "route_dev",
        "vehicle_blocked",
        "route_timeout",
        "scenario_timeouts",
        "yield_emergency_vehicle_infractions",
        "outside_route_lanes",
        "min_speed_infractions",
    }
    assert "not scored: route_dev" in c["made_of"]


def test_leaderboard_counts_the_victims_collisions():
    # hit from behind by a vehicle at fault, route half done: 100 * 0.5 * 0.6 = 30 (casewatch's
    # penalty score does not blame the victim; the Leaderboard counts every collision)
    t, cols = ticks()
    cols["collision_at_fault"][:] = 0.0
    cols["collision_party"][:] = 0.0
    cols["collision_victim"] = np.where((t >= 2.0) & (t < 2.4), 1.0, 0.0)
    cols["collision_victim_party"] = cols["collision_victim"] * 2.0
    cols["route_progress"] = np.linspace(0.0, 50.0, 100)
    out = score_run([], FORMULAS, t, cols, 0.1, ScoringParams())
    assert out["carla"]["driving_score"] == pytest.approx(30.0)
    assert out["carla"]["per_infraction"] == {
        "collisions_vehicle": {"events": 1, "coefficient": 0.6}
    }
    assert out["penalty"]["penalty_sum"] == 0.0


def test_leaderboard_flagged_and_percentage_infractions():
    t, cols = ticks()
    n = len(t)
    cols["collision_party"][:] = cols["collision_at_fault"][:] = 0.0
    cols["scenario_timeout"] = np.where((t >= 4.0) & (t < 4.5), 1.0, 0.0)
    cols["yield_failed"] = np.zeros(n)
    cols["route_outside_lanes"] = np.where((t >= 6.0) & (t < 8.0), 1.0, 0.0)
    cols["traffic_speed"] = np.full(n, 12.0)
    for name in ("route_deviated", "blocked", "route_timeout"):
        cols[name] = np.zeros(n)
    c = score_run([], FORMULAS, t, cols, 0.1, ScoringParams())["carla"]
    # scenario timeout 0.7; outside lanes 2 s at 9 m/s = 18 m of 100 m: 1 - 0.18 = 0.82;
    # minimum speed: checkpoints at 25, 50, 75 m (the route's last 20 m not driven); ego mean
    # speed per stretch against 12 m/s traffic:
    #   0-25 m: ticks 0..31 (progress 25.05 at tick 31): speeds 0 x 10, then 9 x 22 but 12 at
    #   tick 30 -> (9 * 22 + 3) / 32 = 6.28125 -> 52.34 % -> 1 - 0.3 * 0.4766 = 0.85702
    #   25-50 m: ticks 32..61 (50.1 at 61), 9 m/s -> 75 % -> 1 - 0.3 * 0.25 = 0.925
    #   50-75 m: ticks 62..92 (75.15 at 92), 9 m/s -> 0.925
    assert c["per_infraction"]["scenario_timeouts"] == {"events": 1, "coefficient": 0.7}
    assert c["per_infraction"]["outside_route_lanes"]["percentage"] == pytest.approx(18.0)
    assert c["per_infraction"]["min_speed_infractions"]["percentage"] == [52.34, 75.0, 75.0]
    expected = 0.7 * 0.82 * (1 - 0.3 * (1 - 0.5234)) * 0.925 * 0.925
    assert c["infraction_penalty"] == pytest.approx(expected, abs=1e-6)
    assert c["driving_score"] == pytest.approx(100 * 0.8 * expected, abs=1e-4)
    assert c["not_scored"] == {}


def test_leaderboard_min_speed_and_yield_match_a_published_result():
    # a public Leaderboard 2.0 result: min speed 79.63 % and one failure to yield to an
    # emergency vehicle give an infraction penalty of 0.657223:
    # (1 - 0.3 * (1 - 0.7963)) * 0.7 = 0.93889 * 0.7 = 0.657223
    n = 41
    t = np.round(np.arange(n) * 0.1, 6)
    cols = {
        "vehicle_speed": np.full(n, 7.963),
        "speed_limit": np.full(n, 10.0),
        "route_progress": np.linspace(0.0, 100.0, n),
        "route_length": np.full(n, 100.0),
        "traffic_speed": np.full(n, 10.0),
        "yield_failed": np.where(t >= 3.0, 1.0, 0.0),
        "collision_at_fault": np.zeros(n),
        "collision_victim": np.zeros(n),
    }
    c = score_run([], FORMULAS, t, cols, 0.1, ScoringParams(min_speed_checkpoints=1))["carla"]
    assert c["infraction_penalty"] == pytest.approx(0.657223, abs=1e-6)


def test_a_route_deviation_ends_the_route():
    t, cols = ticks()
    cols["route_deviated"] = np.where(t >= 4.0, 1.0, 0.0)
    cols["blocked"] = np.zeros(len(t))
    events = [event("R", 3.0), event("C", 5.0, 5.2), event("S", 7.0)]
    c = score_run(events, FORMULAS, t, cols, 0.1, ScoringParams())["carla"]
    # ended at tick 40: completion = progress at tick 39 = 80 * 39 / 99; the red light (3.0 s)
    # counts, the collision and the stop sign after the end do not
    assert c["ended_by"] == "route_dev"
    assert c["route_completion"] == pytest.approx(80 * 39 / 99 / 100, abs=1e-6)
    assert c["infraction_penalty"] == pytest.approx(0.7)
    assert "route_timeout" in c["not_scored"] and "vehicle_blocked" not in c["not_scored"]


def test_no_route_is_no_score_not_a_perfect_one():
    t, cols = ticks()
    cols["route_progress"][:] = np.nan
    out = score_run([event("R", 3.0)], FORMULAS, t, cols, 0.1, ScoringParams())
    assert out["penalty"] is None and out["carla"] is None
    assert "no route" in out["reason"] and out["penalty_sum"] == 100.0
    assert score_run([], [formula("X", None)], t, cols, 0.1, ScoringParams()) is None
