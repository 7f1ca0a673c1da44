"""The catalogue of signal names a safety case may use in its formulas.

The built-in metrics are defined normatively in `docs/spi-reference.md`. This module only knows
their names and shapes (cross-channel pair, per channel, ordered pair for the safety score), so
that `spec/` can resolve names and `monitor/` can emit exactly the same set.

Naming convention:
- unsuffixed `els`: the worst value over pairs (or channels);
- per unordered pair `els__lav__tfuse`, channels in the order declared in `monitor.channels`;
- per channel `ppcs__lav`;
- safety score per ordered pair `ss__lav__tfuse` (plan of lav against the world model of tfuse,
  including `ss__lav__lav`) and per channel `ss__lav` (the worst world model for lav's plan).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations, product
from typing import Literal

SignalShape = Literal["pair", "channel", "ordered_pair", "global", "declared"]

#: Cross-channel similarity metrics, one value per unordered channel pair.
PAIR_METRICS: dict[str, str] = {
    "els": "Ego Location Similarity",
    "els_var": "moving variance of ELS",
    "eos": "Ego Orientation Similarity",
    "ocs": "Object Count Similarity",
    "ols": "Object Location Similarity",
    "oos": "Object Orientation Similarity",
    "oas": "Object Area Similarity",
    "ots": "Object Trajectory Similarity",
    "ets": "Ego Trajectory Similarity",
    "crpps": "Cross-Channel Planned Path Similarity",
    "ego_dist": "distance between the channels' ego positions [m]",
    "ego_yaw_diff": "difference between the channels' ego headings [rad]",
    "lone_age": "longest time [s] an object both channels can see was reported by one only",
    "plan_lat": "largest sideways offset [m] between the plans' first seconds, ego offset removed",
}

#: Per-channel metrics, one value per channel.
CHANNEL_METRICS: dict[str, str] = {
    "chpps": "Channel Planned Path Similarity",
    "ompv": "Object Motion Prediction Validation",
    "hcs": "History Comfort Score",
    "ppcs": "Planned Path Comfort Score",
}

#: Situation signals, one value per channel (spi-reference "Situation signals"). Their
#: unsuffixed form is the worst over the channels whose coverage includes the region (ahead for
#: lead_*, behind for follow_*), so a forward-only channel never makes follow_* a data gap.
SITUATION_METRICS: dict[str, str] = {
    "lead_gap": "bumper-to-bumper gap to the in-path leader [m]",
    "lead_thw": "time headway to the leader: gap / ego speed [s]",
    "lead_ttc": "time to collision with the leader [s]",
    "lead_speed": "speed of the leader along the ego's path [m/s] (0 when there is none)",
    "follow_gap": "bumper-to-bumper gap to the in-lane follower [m]",
    "follow_thw": "time headway of the follower: gap / follower speed [s]",
    "follow_ttc": "time to collision of the follower [s]",
    "follow_speed": "speed of the follower towards the ego [m/s]",
    "ego_speed": "ego speed [m/s]",
    "ego_accel": "ego longitudinal acceleration [m/s^2]",
}

#: Signals with only an unsuffixed form.
GLOBAL_METRICS: dict[str, str] = {
    "crpps_mean": "Cross-Channel Planned Path Similarity from the mean Frechet distance",
}

#: World inputs (a frame's `world`, monitor/world.py) and condition signals (meta.odd): one
#: value per tick, no channel. Kept in step with monitor.world by a test.
WORLD_METRICS: dict[str, str] = {
    "vehicle_speed": "the ego's speed from the vehicle (speedometer, simulator) [m/s]",
    "speed_limit": "speed limit of the ego's lane [m/s]",
    "tl_state": "next traffic light: 0 none or off, 1 green, 2 yellow, 3 red",
    "tl_distance": "distance to the traffic light's stop line [m] (1000: none ahead)",
    "stop_distance": "distance to the next stop sign's stop line [m] (1000: none ahead)",
    "marking": "lane marking being crossed: 0 none, 1 broken, 2 solid, 3 double solid",
    "indicator": "indicator: 0 off, 1 left, 2 right",
    "low_beam": "low beam: 1 on, 0 off",
    "fog_lights": "fog lights: 1 on, 0 off",
    "collision_at_fault": "contacts this tick with the ego at fault",
    "collision_victim": "contacts this tick with the other party at fault",
    "collision_party": "first at-fault contact: 0 none, 1 pedestrian, 2 vehicle, 3 two-wheeler, "
    "4 object",
    "route_progress": "distance driven along the route [m]",
    "route_length": "length of the route [m]",
    "crossing_side": "side the ego crosses a marking to: 0 none, 1 left, 2 right",
    "night": "1 when the conditions say environment.light is night",
    "fog": "1 when the conditions say environment.weather is fog",
}

SAFETY_SCORE = "ss"
SAFETY_SCORE_NAME = "Safety score (time to collision and post-encroachment time)"

#: For these the unsuffixed signal is the maximum over pairs; for every other metric the minimum.
WORST_IS_MAX: frozenset[str] = frozenset(
    {"els_var", "ego_dist", "ego_yaw_diff", "ego_speed", "follow_speed", "lone_age", "plan_lat"}
)

SEP = "__"


@dataclass(frozen=True)
class SignalInfo:
    """What a resolvable signal name means."""

    name: str
    metric: str  # the catalogue entry it derives from, or the declared name itself
    shape: SignalShape
    channels: tuple[str, ...]  # the channels it depends on (empty for declared signals)
    description: str


def pair_name(metric: str, a: str, b: str) -> str:
    return f"{metric}{SEP}{a}{SEP}{b}"


def channel_name(metric: str, channel: str) -> str:
    return f"{metric}{SEP}{channel}"


def builtin_signals(channels: list[str] | tuple[str, ...]) -> dict[str, SignalInfo]:
    """Every built-in signal name for this channel set, in a stable order."""
    chans = tuple(channels)
    out: dict[str, SignalInfo] = {}
    for metric, desc in PAIR_METRICS.items():
        out[metric] = SignalInfo(metric, metric, "pair", chans, f"{desc}, worst pair")
        for a, b in combinations(chans, 2):
            name = pair_name(metric, a, b)
            out[name] = SignalInfo(name, metric, "pair", (a, b), f"{desc}, {a} vs {b}")
    for metric, desc in GLOBAL_METRICS.items():
        out[metric] = SignalInfo(metric, metric, "global", chans, desc)
    for metric, desc in WORLD_METRICS.items():
        out[metric] = SignalInfo(metric, metric, "global", (), f"{desc} (world input)")
    for metric, desc in CHANNEL_METRICS.items():
        out[metric] = SignalInfo(metric, metric, "channel", chans, f"{desc}, worst channel")
        for c in chans:
            name = channel_name(metric, c)
            out[name] = SignalInfo(name, metric, "channel", (c,), f"{desc}, channel {c}")
    for metric, desc in SITUATION_METRICS.items():
        out[metric] = SignalInfo(metric, metric, "channel", chans, f"{desc}, worst channel")
        for c in chans:
            name = channel_name(metric, c)
            out[name] = SignalInfo(name, metric, "channel", (c,), f"{desc}, channel {c}")
    ss = SAFETY_SCORE
    out[ss] = SignalInfo(ss, ss, "ordered_pair", chans, f"{SAFETY_SCORE_NAME}, worst pair")
    for c in chans:
        name = channel_name(ss, c)
        out[name] = SignalInfo(
            name, ss, "channel", chans, f"{SAFETY_SCORE_NAME}, plan of {c}, worst world model"
        )
    for a, b in product(chans, chans):
        name = pair_name(ss, a, b)
        out[name] = SignalInfo(
            name, ss, "ordered_pair", (a, b), f"{SAFETY_SCORE_NAME}, plan of {a} vs objects of {b}"
        )
    return out


def available_signals(
    channels: list[str] | tuple[str, ...], declared: dict[str, str] | None = None
) -> dict[str, SignalInfo]:
    """Built-in signals plus the scalar signals the case declares under `monitor.signals`."""
    out = builtin_signals(channels)
    for name, desc in (declared or {}).items():
        out[name] = SignalInfo(name, name, "declared", (), desc or "declared stream signal")
    return out
