"""Hazard events as OpenSCENARIO 1.2 files: a hazard found in a log becomes a test case.

For each hazard event of a run, one `.xosc` reproduces the ego and the objects involved over
the event plus lead-in and lead-out seconds, as one channel saw them (the arbitrated channel
at the event's start, or the one asked for):

- entities: the ego and every object of that channel that came within `radius` metres of the
  ego during the event, as vehicles with the reported dimensions;
- Init: each entity teleported to its first observed pose;
- one maneuver group per entity with a `FollowTrajectoryAction`: a polyline of timed world
  positions (x, y, heading) at every tick it was seen, followed by position with absolute
  timing (0 s = the start of the window); an object first seen later waits at its first pose;
- the road network: the user's OpenDRIVE file when given; otherwise none, and the file header
  says so (casewatch does not invent roads).

`scenariogeneration` builds the XML. A catalogue (`scenarios.json`) traces each file back to its
event, node, trace, channel, window and stream digest.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from scenariogeneration import xosc

from casewatch.errors import CasewatchError
from casewatch.evaluator.inputs import path_digest
from casewatch.evaluator.result import Episode, RunResult
from casewatch.monitor.bags.mapping import MappingError, resolve_mapping
from casewatch.monitor.bags.reader import BagError, is_bag, read_bag
from casewatch.monitor.frames import Frame
from casewatch.monitor.reader import read_stream
from casewatch.safety_case.findings import CaseError
from casewatch.safety_case.loader import require_case

#: OpenSCENARIO minor version written (1.2).
OSC_MINOR = 2


class ExportError(CasewatchError, ValueError):
    """Input the export cannot use (names the event, file or channel)."""


@dataclass
class _Track:
    """An entity's observed poses over the window: times relative to its start."""

    length: float
    width: float
    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    h: list[float] = field(default_factory=list)
    nearest: float = math.inf  # closest approach to the ego during the event [m]


@dataclass
class _Window:
    number: int
    event: Episode
    channel: str
    t0: float
    t1: float
    ego: _Track | None = None
    objects: dict[str, _Track] = field(default_factory=dict)


def _channel_at(result: RunResult, t: float) -> str:
    for interval in result.arbitration:
        if interval.start - 1e-9 <= t <= interval.end + 1e-9 and interval.channel:
            return interval.channel
    return result.case.channels[0]


def hazard_events(result: RunResult) -> list[Episode]:
    """The run's hazard events in time order; event N is the N-th (1-based)."""
    return [e for e in result.episodes if e.kind == "hazard"]


def _frames(result: RunResult, stream: Path, topics: Path | None) -> Iterable[Frame]:
    """The frames of the judged stream: JSON Lines, or a ROS 2 bag read through its topic
    mapping (`topics`, else the case's `monitor.topics`) as the run read it."""
    if not is_bag(stream):
        return read_stream(stream)
    case_topics = None
    if topics is None:
        try:
            case_topics = require_case(result.case.path).monitor.topics
        except (CaseError, OSError):
            case_topics = None
    try:
        mapping = resolve_mapping(topics, result.case.path, case_topics)
        return read_bag(
            stream, mapping, channels=list(result.case.channels), period=result.case.period
        )
    except (MappingError, BagError) as exc:
        raise ExportError(str(exc)) from None


def _collect(frames: Iterable[Frame], windows: list[_Window]) -> None:
    """One pass over the stream: every window's ego and object poses in its channel."""
    for frame in frames:
        for w in windows:
            if not w.t0 - 1e-9 <= frame.t <= w.t1 + 1e-9:
                continue
            state = frame.channels.get(w.channel)
            if state is None:
                continue
            e = state.ego
            half = e.footprint
            length = float(half[:, 0].max() - half[:, 0].min())
            width = float(half[:, 1].max() - half[:, 1].min())
            if w.ego is None:
                w.ego = _Track(length, width)
            _add(w.ego, frame.t - w.t0, e.x, e.y, e.yaw)
            inside = w.event.start - 1e-9 <= frame.t <= w.event.end + 1e-9
            o = state.objects
            for k, oid in enumerate(o.ids):
                x, y = float(o.pos[k, 0]), float(o.pos[k, 1])
                fp = o.footprints[k]
                track = w.objects.get(oid)
                if track is None:
                    track = w.objects[oid] = _Track(
                        float(fp[:, 0].max() - fp[:, 0].min()),
                        float(fp[:, 1].max() - fp[:, 1].min()),
                    )
                _add(track, frame.t - w.t0, x, y, float(o.yaw[k]))
                if inside:
                    track.nearest = min(track.nearest, math.hypot(x - e.x, y - e.y))


def _add(track: _Track, t: float, x: float, y: float, h: float) -> None:
    track.t.append(round(t, 6))
    track.x.append(x)
    track.y.append(y)
    track.h.append(h)


def _vehicle(name: str, track: _Track) -> xosc.Vehicle:
    box = xosc.BoundingBox(track.width, track.length, 1.5, 0.0, 0.0, 0.75)
    axle = xosc.Axle(0.5, 0.7, max(track.width - 0.2, 0.1), track.length / 3, 0.35)
    return xosc.Vehicle(
        name,
        xosc.VehicleCategory.car,
        box,
        axle,
        xosc.Axle(0.0, 0.7, max(track.width - 0.2, 0.1), 0.0, 0.35),
        70.0,
        10.0,
        10.0,
    )


def _follow(name: str, track: _Track) -> xosc.FollowTrajectoryAction:
    positions = [
        xosc.WorldPosition(x, y, 0.0, h) for x, y, h in zip(track.x, track.y, track.h, strict=True)
    ]
    trajectory = xosc.Trajectory(f"{name}_path", False)
    trajectory.add_shape(xosc.Polyline(list(track.t), positions))
    return xosc.FollowTrajectoryAction(
        trajectory, xosc.FollowingMode.position, xosc.ReferenceContext.absolute, 1.0, 0.0
    )


def _scenario(
    w: _Window, entities: dict[str, _Track], opendrive: Path | None, node_text: str
) -> xosc.Scenario:
    catalog = xosc.Catalog()
    road = xosc.RoadNetwork(roadfile=str(opendrive)) if opendrive else xosc.RoadNetwork()
    objects = xosc.Entities()
    init = xosc.Init()
    start = xosc.ValueTrigger(
        "start",
        0.0,
        xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition(0.0, xosc.Rule.greaterThan),
    )
    act = xosc.Act("replay", start)
    for name, track in entities.items():
        objects.add_scenario_object(name, _vehicle(name, track))
        init.add_init_action(
            name, xosc.TeleportAction(xosc.WorldPosition(track.x[0], track.y[0], 0.0, track.h[0]))
        )
        event = xosc.Event(f"{name}_follow", xosc.Priority.override)
        event.add_action(f"{name}_trajectory", _follow(name, track))
        event.add_trigger(
            xosc.ValueTrigger(
                f"{name}_start",
                0.0,
                xosc.ConditionEdge.none,
                xosc.SimulationTimeCondition(0.0, xosc.Rule.greaterThan),
            )
        )
        maneuver = xosc.Maneuver(f"{name}_maneuver")
        maneuver.add_event(event)
        group = xosc.ManeuverGroup(f"{name}_group")
        group.add_actor(name)
        group.add_maneuver(maneuver)
        act.add_maneuver_group(group)
    stop = xosc.ValueTrigger(
        "end",
        0.0,
        xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition(w.t1 - w.t0, xosc.Rule.greaterThan),
        "stop",
    )
    board = xosc.StoryBoard(init, stop)
    board.add_act(act)
    e = w.event
    road_note = "" if opendrive else "; no road network attached (casewatch does not invent roads)"
    description = (
        f"casewatch hazard event {w.number}: {e.node_id} ({node_text}) from "
        f"{e.start:g} s to {e.end:g} s, replayed from channel {w.channel} over "
        f"{w.t0:g}-{w.t1:g} s{road_note}"
    )
    return xosc.Scenario(
        description,
        "casewatch",
        xosc.ParameterDeclarations(),
        objects,
        board,
        road,
        catalog,
        osc_minor_version=OSC_MINOR,
    )


def export_scenarios(
    result: RunResult,
    stream: Path,
    out: Path,
    channel: str | None = None,
    lead_in: float = 3.0,
    lead_out: float = 2.0,
    radius: float = 30.0,
    opendrive: Path | None = None,
    event: int | None = None,
    topics: Path | None = None,
) -> list[dict]:
    """Write one `.xosc` per hazard event (or only event `event`, 1-based) into `out` and the
    catalogue `scenarios.json`'s entries, which it returns."""
    if result.stream.digest and path_digest(stream) != result.stream.digest:
        raise ExportError(
            f"{stream}: not the stream this run judged (sha256 differs from "
            f"result.json's {result.stream.digest[:12]}...)"
        )
    if channel is not None and channel not in result.case.channels:
        raise ExportError(
            f"channel {channel!r} is not one of the run's channels "
            f"({', '.join(result.case.channels)})"
        )
    events = hazard_events(result)
    if event is not None and not 1 <= event <= len(events):
        raise ExportError(
            f"no hazard event {event}: the run has {len(events)} (1 to {len(events)})"
            if events
            else "the run has no hazard event"
        )
    chosen = [(n, e) for n, e in enumerate(events, start=1) if event is None or n == event]
    windows = [
        _Window(
            n,
            e,
            channel or _channel_at(result, e.start),
            max(e.start - lead_in, result.stream.t_start or 0.0),
            e.end + lead_out,
        )
        for n, e in chosen
    ]
    _collect(_frames(result, stream, topics), windows)
    texts = {n.id: n.text for n in result.case.nodes}
    out.mkdir(parents=True, exist_ok=True)
    entries = []
    for w in windows:
        if w.ego is None:
            raise ExportError(
                f"hazard event {w.number} ({w.event.node_id} at "
                f"{w.event.start:g} s): channel {w.channel} has no frame in "
                "its window"
            )
        involved = {
            f"obj_{oid}": track
            for oid, track in sorted(w.objects.items())
            if track.nearest <= radius
        }
        if not involved:
            raise ExportError(
                f"hazard event {w.number} ({w.event.node_id} at "
                f"{w.event.start:g} s): channel {w.channel} saw no object within "
                f"{radius:g} m of the ego during the event"
            )
        entities = {"ego": w.ego, **involved}
        name = f"event-{w.number:03d}-{w.event.node_id}-{w.event.start:.1f}s.xosc"
        _scenario(w, entities, opendrive, texts.get(w.event.node_id, "")).write_xml(str(out / name))
        entries.append(
            {
                "file": name,
                "event": w.number,
                "formula": w.event.formula_id,
                "node": w.event.node_id,
                "node_text": texts.get(w.event.node_id, ""),
                "start": w.event.start,
                "end": w.event.end,
                "window": [w.t0, w.t1],
                "channel": w.channel,
                "entities": sorted(entities),
                "stream": str(stream),
                "stream_digest": result.stream.digest,
                "road_network": str(opendrive) if opendrive else None,
                "trace": [[step.id for step in path] for path in w.event.trace],
            }
        )
    return entries
