"""The penalty score and the CARLA score of a drive, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest

from evaluator.result import Episode, FormulaStats
from evaluator.scoring import score_run
from safety_case.model import ScoringParams


def formula(fid: str, rule: str | None) -> FormulaStats:
    return FormulaStats(id=fid, node_id=fid, node_text=rule or "", kind="hazard", source="x",
                        rtamt="x", rule=rule)  # fmt: skip


def event(fid: str, start: float, end: float | None = None) -> Episode:
    return Episode(formula_id=fid, node_id=fid, kind="hazard", start=start, end=end or start,
                   ticks=1, worst_robustness=-1.0, t_worst=start, trace=[])  # fmt: skip


FORMULAS = [formula("R", "red_light"), formula("C", "collision"), formula("S", "stop_sign"),
            formula("H", "no_headlights"), formula("F", "no_fog_lights")]  # fmt: skip


def ticks(n: int = 100) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """10 s at 0.1 s: limit 10 m/s; the ego stands 5 m before a red light for the first
    second, then drives 9 m/s (12 m/s at t = 3.0 s); route 100 m, 80 m driven at the end; a
    pedestrian at fault from t = 5.0 s."""
    t = np.round(np.arange(n) * 0.1, 6)
    speed = np.where(t < 1.0, 0.0, 9.0)
    speed[30] = 12.0
    tl_state = np.where(t < 1.0, 3.0, 0.0)
    return t, {
        "vehicle_speed": speed, "ego_speed": np.full(n, np.nan), "speed_limit": np.full(n, 10.0),
        "route_progress": np.linspace(0.0, 80.0, n), "route_length": np.full(n, 100.0),
        "tl_state": tl_state, "tl_distance": np.where(t < 1.0, 5.0, 1000.0),
        "stop_distance": np.full(n, 1000.0), "collision_party": np.where(t >= 5.0, 1.0, 0.0),
    }  # fmt: skip


def test_penalty_and_carla_scores_hand_computed():
    t, cols = ticks()
    events = [event("R", 3.0), event("C", 5.0, 5.2), event("S", 7.0)]
    out = score_run(events, FORMULAS, t, cols, 0.1, ScoringParams())
    p = out["penalty"]
    # 80 m driven: t_o = 80 / 10 * 1.2 + 1.0 s standing at the red light = 10.6 s > t = 10 s:
    # capped at 1
    assert (p["t"], p["t_o"], p["stop_time"], p["d"], p["v_avg"], p["distance"]) == (
        10.0, 10.6, 1.0, 0.8, 10.0, 80.0)
    # red light while speeding 100, pedestrian collision 600, stop sign 40: 740
    assert p["penalty_sum"] == 740.0
    assert p["per_rule"]["red_light"] == {"events": 1, "while_speeding": 1, "penalty": 100.0}
    assert p["score"] == pytest.approx(100 * 1.0 * 0.8 - 0.7 * 740)
    c = out["carla"]
    # 0.7 (red light) * 0.5 (pedestrian) * 0.8 (stop sign) = 0.28; 100 * 0.8 * 0.28 = 22.4
    assert c["infraction_penalty"] == pytest.approx(0.28)
    assert c["driving_score"] == pytest.approx(22.4)
    assert c["per_infraction"]["collision.pedestrian"] == {"events": 1, "coefficient": 0.5}


def test_overrides_and_neither_light():
    t, cols = ticks()
    params = ScoringParams(gamma=1.0, c=10.0, alpha=0.0, penalties={"red_light": (5.0, 7.0)},
                           carla={"red_light": 0.5})  # fmt: skip
    events = [event("R", 3.0), event("H", 6.0, 8.0), event("F", 7.0, 9.0)]
    out = score_run(events, FORMULAS, t, cols, 0.1, params)
    p = out["penalty"]
    # red light while speeding: 7; no headlights 30 + no fog lights 10 at once -> neither 50
    assert p["penalty_sum"] == 7.0 + 50.0
    assert p["per_rule"]["neither_light"]["penalty"] == 10.0
    # t_o = 80 / 10 + 1.0 = 9 s over 10 s: 10 * 0.9 * 0.8 - 57
    assert p["score"] == pytest.approx(7.2 - 57.0)
    assert out["carla"]["driving_score"] == pytest.approx(100 * 0.8 * 0.5)


def test_no_route_is_no_score_not_a_perfect_one():
    t, cols = ticks()
    cols["route_progress"][:] = np.nan
    out = score_run([event("R", 3.0)], FORMULAS, t, cols, 0.1, ScoringParams())
    assert out["penalty"] is None and out["carla"] is None
    assert "no route" in out["reason"] and out["penalty_sum"] == 100.0
    assert score_run([], [formula("X", None)], t, cols, 0.1, ScoringParams()) is None
