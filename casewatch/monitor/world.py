"""World inputs: what a simulator (or the vehicle) says about the ego's situation at a tick, as
signals the traffic rules read (docs/streams.md "World inputs", docs/traffic-rules.md).

A frame's `world` describes the ego's own speed (the vehicle's, not a channel's estimate), speed
limits, signals, stop signs, the lane marking being crossed, the indicator and lights, contacts
and route progress. Inside a reported `world`, an absent traffic light, stop sign, marking or
contact list means *there is none* (the signals read their "none" values: nothing to run is not
missing data), while an absent speed, speed limit, indicator, lights or route means *not
reported* (no value: a rule reading it has a data gap).
A frame without `world` reports nothing.

Besides the world signals that rules read, a `world` can carry what the CARLA Leaderboard 2.0
scores and no rule reads (`LEADERBOARD_INPUTS`: driving outside the route's lanes, route
deviation, blocked, timeouts, an emergency vehicle not yielded to, the surrounding traffic's
speed). They are all *not reported* when absent: the Leaderboard score then names the
infraction "not scored", never "none". The side a marking is crossed to (`world.crossing`,
the world signal `crossing_side` that `broken_wrong_indicator` reads) is *not reported* when
a marking is crossed without it, and 0 when no marking is crossed."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from casewatch.errors import CasewatchError

#: Distance [m] a traffic light or stop line reads when there is none ahead (the rules compare
#: distances, so "none" must be a number far away, like the situation signals' GAP_CAP).
NONE_AHEAD = 1000.0

LIGHT_STATES = {"off": 0.0, "green": 1.0, "yellow": 2.0, "red": 3.0}
MARKINGS = {"broken": 1.0, "solid": 2.0, "double_solid": 3.0}
INDICATOR = {"off": 0.0, "left": 1.0, "right": 2.0}
PARTIES = {"pedestrian": 1.0, "vehicle": 2.0, "two_wheeler": 3.0, "object": 4.0}

#: The world signals, name -> meaning (the catalogue `safety_case.signals` lists them too).
WORLD_SIGNALS: dict[str, str] = {
    "vehicle_speed": "the ego's speed from the vehicle (its speedometer, a simulator) [m/s]",
    "speed_limit": "speed limit of the ego's lane [m/s]",
    "tl_state": "state of the next traffic light: 0 none or off, 1 green, 2 yellow, 3 red",
    "tl_distance": f"distance to its stop line [m] (negative once past; {NONE_AHEAD:g}: none)",
    "stop_distance": f"distance to the next stop line of a stop sign [m] ({NONE_AHEAD:g}: none)",
    "marking": "lane marking the ego crosses: 0 none, 1 broken, 2 solid, 3 double solid",
    "indicator": "indicator: 0 off, 1 left, 2 right",
    "low_beam": "low beam on: 1, off: 0",
    "fog_lights": "fog lights on: 1, off: 0",
    "collision_at_fault": "contacts this tick where the ego is at fault",
    "collision_victim": "contacts this tick where the other party is at fault",
    "collision_party": "party of the first at-fault contact: 0 none, 1 pedestrian, 2 vehicle, "
    "3 two-wheeler, 4 object",
    "route_progress": "distance driven along the route [m]",
    "route_length": "length of the route [m]",
    "crossing_side": "side the ego crosses a marking to: 0 none, 1 left, 2 right (the "
    "indicator's codes)",
}


#: What the Leaderboard score reads besides the world signals (evaluator/scoring.py): values
#: per tick, no value when the stream does not report them.
LEADERBOARD_INPUTS: dict[str, str] = {
    "route_outside_lanes": "1 while the ego drives outside the lanes of its route, else 0",
    "route_deviated": "1 once the ego has left its route (the Leaderboard ends the route), else 0",
    "blocked": "1 while the simulator reports the ego blocked (it ends the route), else 0",
    "route_timeout": "1 once the route's time is up (it ends the route), else 0",
    "scenario_timeout": "1 while a scenario of the route has timed out, else 0",
    "yield_failed": "1 while the ego fails to yield to an emergency vehicle behind it, else 0",
    "traffic_speed": "mean speed of the surrounding traffic [m/s]",
    "collision_victim_party": "party of the first contact with the other at fault: 0 none, "
    "1 pedestrian, 2 vehicle, 3 two-wheeler, 4 object",
}

#: The world signal of the side the ego crosses a marking to (`broken_wrong_indicator` reads
#: it): 0 not crossing, 1 left, 2 right (the indicator's codes).
CROSSING_SIDE = "crossing_side"
SIDES = {"left": 1.0, "right": 2.0}


class WorldError(CasewatchError, ValueError):
    """A `world` entry that cannot be read; the message names the key."""


@dataclass(frozen=True, slots=True)
class Contact:
    other: str
    party: str
    ego_at_fault: bool


def _num(v: Any, where: str, allow_negative: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise WorldError(f"{where}: expected a finite number, got {v!r:.40}")
    if not allow_negative and v < 0:
        raise WorldError(f"{where}: expected a number >= 0, got {v!r}")
    return float(v)


def _choice(v: Any, choices: dict[str, float], where: str) -> float:
    if v not in choices:
        raise WorldError(f"{where}: expected one of {', '.join(choices)}, got {v!r:.40}")
    return choices[v]


def _bool(v: Any, where: str) -> float:
    if not isinstance(v, bool):
        raise WorldError(f"{where}: expected true or false, got {v!r:.40}")
    return 1.0 if v else 0.0


def _map(v: Any, where: str, known: tuple[str, ...] | None = None) -> dict:
    """`v` as an object; with `known`, none of its keys outside it."""
    if not isinstance(v, dict):
        raise WorldError(f"{where}: expected an object, got {v!r:.40}")
    unknown = sorted(set(v) - set(known)) if known is not None else []
    if unknown and known is not None:
        raise WorldError(f"{where}.{unknown[0]}: unknown key (known: {', '.join(known)})")
    return v


KEYS = (
    "speed",
    "speed_limit",
    "traffic_light",
    "stop_sign",
    "marking",
    "crossing",
    "indicator",
    "lights",
    "collisions",
    "route",
    "blocked",
    "timeouts",
    "emergency_vehicle",
    "traffic_speed",
)
ROUTE_KEYS = ("progress", "length", "outside_lanes", "deviated")
TIMEOUT_KEYS = ("route", "scenario")


def parse_world(raw: Any) -> dict[str, float | None]:
    """A frame's `world` as world-signal values (see the module docstring); `WorldError` for
    anything malformed."""
    w = _map(raw, "world", KEYS)
    out: dict[str, float | None] = dict.fromkeys((*WORLD_SIGNALS, *LEADERBOARD_INPUTS))
    if w.get("speed") is not None:
        out["vehicle_speed"] = _num(w["speed"], "world.speed", allow_negative=False)
    if w.get("speed_limit") is not None:
        out["speed_limit"] = _num(w["speed_limit"], "world.speed_limit", allow_negative=False)
    light = w.get("traffic_light")
    out["tl_state"], out["tl_distance"] = 0.0, NONE_AHEAD
    if light is not None:
        light = _map(light, "world.traffic_light")
        out["tl_state"] = _choice(light.get("state"), LIGHT_STATES, "world.traffic_light.state")
        out["tl_distance"] = _num(light.get("distance"), "world.traffic_light.distance")
    stop = w.get("stop_sign")
    out["stop_distance"] = NONE_AHEAD
    if stop is not None:
        out["stop_distance"] = _num(
            _map(stop, "world.stop_sign").get("distance"), "world.stop_sign.distance"
        )
    marking = w.get("marking")
    out["marking"] = 0.0 if marking is None else _choice(marking, MARKINGS, "world.marking")
    if w.get("crossing") is not None:
        if marking is None:
            raise WorldError(
                "world.crossing: a side without a marking being crossed (world.marking)"
            )
        out[CROSSING_SIDE] = _choice(w["crossing"], SIDES, "world.crossing")
    elif marking is None:
        out[CROSSING_SIDE] = 0.0  # nothing crossed: no side to report
    if w.get("indicator") is not None:
        out["indicator"] = _choice(w["indicator"], INDICATOR, "world.indicator")
    if w.get("lights") is not None:
        lights = _map(w["lights"], "world.lights")
        if lights.get("low_beam") is not None:
            out["low_beam"] = _bool(lights["low_beam"], "world.lights.low_beam")
        if lights.get("fog") is not None:
            out["fog_lights"] = _bool(lights["fog"], "world.lights.fog")
    contacts = w.get("collisions") or []
    if not isinstance(contacts, list):
        raise WorldError(f"world.collisions: expected a list, got {contacts!r:.40}")
    at_fault = victim = 0
    party = victim_party = 0.0
    for k, c in enumerate(contacts):
        where = f"world.collisions[{k}]"
        c = _map(c, where)
        kind = _choice(c.get("with"), PARTIES, f"{where}.with")
        if _bool(c.get("ego_at_fault"), f"{where}.ego_at_fault"):
            at_fault += 1
            party = party or kind
        else:
            victim += 1
            victim_party = victim_party or kind
    out["collision_at_fault"], out["collision_victim"] = float(at_fault), float(victim)
    out["collision_party"], out["collision_victim_party"] = party, victim_party
    if w.get("route") is not None:
        route = _map(w["route"], "world.route", ROUTE_KEYS)
        out["route_progress"] = _num(route.get("progress"), "world.route.progress")
        out["route_length"] = _num(route.get("length"), "world.route.length", allow_negative=False)
        for key, name in (("outside_lanes", "route_outside_lanes"), ("deviated", "route_deviated")):
            if route.get(key) is not None:
                out[name] = _bool(route[key], f"world.route.{key}")
    if w.get("blocked") is not None:
        out["blocked"] = _bool(w["blocked"], "world.blocked")
    if w.get("timeouts") is not None:
        timeouts = _map(w["timeouts"], "world.timeouts", TIMEOUT_KEYS)
        for key in TIMEOUT_KEYS:
            if timeouts.get(key) is not None:
                out[f"{key}_timeout"] = _bool(timeouts[key], f"world.timeouts.{key}")
    if w.get("emergency_vehicle") is not None:
        ev = _map(w["emergency_vehicle"], "world.emergency_vehicle")
        if set(ev) - {"failed_to_yield"}:
            raise WorldError(
                'world.emergency_vehicle: expected {"failed_to_yield": true|false}, '
                f"got keys {', '.join(sorted(ev))}"
            )
        out["yield_failed"] = _bool(
            ev.get("failed_to_yield"), "world.emergency_vehicle.failed_to_yield"
        )
    if w.get("traffic_speed") is not None:
        out["traffic_speed"] = _num(w["traffic_speed"], "world.traffic_speed", allow_negative=False)
    return out


#: Condition signals: what the conditions (meta.odd, frame odd) say, as numbers rules read.
CONDITION_SIGNALS: dict[str, str] = {
    "night": "1 when the conditions say environment.light is night, else 0",
    "fog": "1 when the conditions say environment.weather is fog, else 0",
}


def condition_values(conditions: dict) -> dict[str, float | None]:
    """`night` and `fog` from the reported conditions (no value when not reported)."""
    light = conditions.get("environment.light")
    weather = conditions.get("environment.weather")
    return {
        "night": None if light is None else float(light == "night"),
        "fog": None if weather is None else float(weather == "fog"),
    }
