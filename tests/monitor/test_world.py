"""World inputs: a frame's `world` as the signals the traffic rules read."""

from __future__ import annotations

import pytest

from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.parse import FrameDefect, parse_frame
from casewatch.monitor.world import (
    LEADERBOARD_INPUTS,
    NONE_AHEAD,
    WORLD_SIGNALS,
    condition_values,
    parse_world,
)
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import WORLD_METRICS


def test_a_full_world_as_signals():
    values = parse_world(
        {
            "speed": 14.2,
            "speed_limit": 13.9,
            "traffic_light": {"state": "red", "distance": 12.5},
            "stop_sign": {"distance": -0.4},
            "marking": "double_solid",
            "indicator": "left",
            "lights": {"low_beam": True, "fog": False},
            "collisions": [
                {"id": "p1", "with": "pedestrian", "ego_at_fault": True},
                {"id": "v7", "with": "vehicle", "ego_at_fault": False},
            ],
            "route": {"progress": 120.0, "length": 800.0},
        }
    )
    assert values == {
        "vehicle_speed": 14.2,
        "speed_limit": 13.9,
        "tl_state": 3.0,
        "tl_distance": 12.5,
        "stop_distance": -0.4,
        "marking": 3.0,
        "indicator": 1.0,
        "low_beam": 1.0,
        "fog_lights": 0.0,
        "collision_at_fault": 1.0,
        "collision_victim": 1.0,
        "collision_party": 1.0,
        "route_progress": 120.0,
        "route_length": 800.0,
        # the Leaderboard's inputs: the victim contact's party; the rest not reported
        "collision_victim_party": 2.0,
        "route_outside_lanes": None,
        "route_deviated": None,
        "blocked": None,
        "route_timeout": None,
        "scenario_timeout": None,
        "yield_failed": None,
        "traffic_speed": None,
        "crossing_side": None,
    }


def test_the_leaderboard_inputs_and_the_crossing_side():
    values = parse_world(
        {
            "marking": "broken",
            "crossing": "right",
            "indicator": "left",
            "route": {"progress": 10.0, "length": 100.0, "outside_lanes": True, "deviated": False},
            "blocked": False,
            "timeouts": {"route": False, "scenario": True},
            "emergency_vehicle": {"failed_to_yield": True},
            "traffic_speed": 8.5,
        }
    )
    picked = {k: values[k] for k in (*LEADERBOARD_INPUTS, "crossing_side", "indicator")}
    assert picked == {
        "route_outside_lanes": 1.0,
        "route_deviated": 0.0,
        "blocked": 0.0,
        "route_timeout": 0.0,
        "scenario_timeout": 1.0,
        "yield_failed": 1.0,
        "traffic_speed": 8.5,
        "collision_victim_party": 0.0,
        "crossing_side": 2.0,
        "indicator": 1.0,
    }
    # nothing crossed: the side is 0 (none), not a data gap
    assert parse_world({})["crossing_side"] == 0.0


def test_none_ahead_is_not_missing_but_unreported_is():
    values = parse_world({})
    # no light, stop sign, marking or contact: their "none" values
    assert (values["tl_state"], values["tl_distance"], values["stop_distance"]) == (
        0.0,
        NONE_AHEAD,
        NONE_AHEAD,
    )
    assert (values["marking"], values["collision_at_fault"], values["collision_party"]) == (
        0.0,
        0.0,
        0.0,
    )
    # no speed limit, indicator, lights or route reported: no value
    assert [
        values[k]
        for k in (
            "vehicle_speed",
            "speed_limit",
            "indicator",
            "low_beam",
            "fog_lights",
            "route_progress",
        )
    ] == [None] * 6


@pytest.mark.parametrize(
    ("world", "words"),
    [
        (
            {"traffic_light": {"state": "amber", "distance": 3}},
            "world.traffic_light.state: expected one of off, green, yellow, red",
        ),
        ({"marking": "dashed"}, "world.marking: expected one of broken, solid, double_solid"),
        ({"collisions": [{"with": "tree", "ego_at_fault": True}]}, "world.collisions[0].with"),
        ({"collisions": [{"with": "vehicle", "ego_at_fault": "yes"}]}, "true or false"),
        ({"speed_limit": -3}, "world.speed_limit: expected a number >= 0"),
        ({"sped_limit": 3}, "world.sped_limit: unknown key"),
        ({"crossing": "left"}, "world.crossing: a side without a marking being crossed"),
        ({"marking": "broken", "crossing": "up"}, "world.crossing: expected one of left, right"),
        (
            {"route": {"progress": 1, "length": 9, "offroad": True}},
            "world.route.offroad: unknown key",
        ),
        ({"timeouts": {"route": 1}}, "world.timeouts.route: expected true or false"),
        ({"emergency_vehicle": {"yielded": True}}, "world.emergency_vehicle: expected"),
        ({"traffic_speed": -1}, "world.traffic_speed: expected a number >= 0"),
        ([], "world: expected an object"),
    ],
)
def test_bad_world_inputs_are_frame_defects(world, words):
    with pytest.raises(FrameDefect, match=words.replace("[", r"\[").replace("]", r"\]")):
        parse_frame({"t": 0.0, "channels": {}, "world": world})


def test_the_catalogue_knows_every_world_signal():
    assert set(WORLD_SIGNALS) | set(condition_values({})) == set(WORLD_METRICS)


def test_the_engine_passes_world_signals_and_scalar_signals_fill_what_world_does_not():
    eng = MetricEngine(MetricParams(), ["a", "b"])
    frame = parse_frame(
        {
            "t": 0.0,
            "channels": {},
            "world": {"marking": "solid"},
            "signals": {"speed_limit": 8.3, "marking": 0.0},
        }
    )
    out = eng.step(frame)
    assert out["marking"] == 2.0  # the world's
    assert out["speed_limit"] == 8.3  # not in the world: the scalar signal's
    assert condition_values({"environment.light": "night"}) == {"night": 1.0, "fog": None}
