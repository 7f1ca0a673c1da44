"""Hazard events as OpenSCENARIO 1.2 files: a hazard found in a log becomes a test case.

This module writes; it reads nothing. The front door (`casewatch.scenarios`) reads the judged
stream or bag and hands over, per hazard event, an `EventWindow`: the ego's and every object's
observed poses in one channel over the event plus lead-in and lead-out seconds, as plain
numbers. From those, one `.xosc` per event (built with `scenariogeneration`):

- entities: the ego and every object that came within `radius` metres of the ego during the
  event (none: an ego-only scenario, a valid test of a hazard that needs no other road user),
  each a vehicle of the category its class and size say (`scenario_entities`) or a pedestrian;
- every entity exists only while the channel observed it: an object first seen at the window's
  start is teleported there in Init; one first seen later is removed in Init
  (`DeleteEntityAction`) and added where it was first seen when it was first seen
  (`AddEntityAction`); an object the channel reported a frame without (lost, or for good) is
  removed right after its last observation and added again when seen again. A replay thus
  holds exactly the contacts of the stream, never an object waiting at its first pose. Frames
  the channel has no data for at all (a dropout, a defective line) are bridged for up to
  `BRIDGE_PERIODS` periods: the object moves straight on, as the ego does;
- while present, an entity follows a `FollowTrajectoryAction` along a polyline of its observed
  poses in `position` mode, timed absolutely (`Timing domainAbsoluteRelative="absolute"`,
  scale 1, offset 0): vertex time `t` is simulation time `1 * t + 0`, and 0 is the window's
  start;
- the road network: the OpenDRIVE file given (as a path relative to the .xosc), else none,
  and the file header says so (casewatch does not invent roads).

Numbers are written rounded (positions and sizes to 0.1 mm, angles to 1 µrad, times to 1 µs)
with no negative zero, so a file reads `15.6`, never `15.600000000000001` or `-0.0`.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from casewatch.errors import CasewatchError
from casewatch.evaluator.result import Episode, RunResult
from casewatch.reports.scenario_entities import MASS, entity_kind

if TYPE_CHECKING:
    from scenariogeneration import xosc

#: OpenSCENARIO minor version written (1.2).
OSC_MINOR = 2

#: Channel frames missing altogether (a dropout, a skipped defective line) are bridged for up to
#: this many periods: nobody reported the object gone, so it moves straight on between its
#: poses, as the ego does. A longer silence takes it out of the scene: a replay must not slide
#: an object through a second in which nobody saw where it was.
BRIDGE_PERIODS = 5.0

#: Decimals written: positions and sizes (0.1 mm), angles (1 µrad), times (1 µs).
POSITION_DIGITS = 4
ANGLE_DIGITS = 6
TIME_DIGITS = 6

#: Height [m] of every entity's bounding box: a stream carries footprints only.
HEIGHT = {"pedestrian": 1.8, "bicycle": 1.7, "motorbike": 1.5, "truck": 3.5, "bus": 3.2}
DEFAULT_HEIGHT = 1.5

#: Slack [s] when comparing frame times.
_EPS = 1e-6


class ExportError(CasewatchError, ValueError):
    """Input the export cannot use (names the event, file or channel)."""


@dataclass
class Track:
    """One entity's observations in a window, in time order: times [s] from the window's
    start, world poses, and per observation its class, its footprint's extents (length along,
    width across the heading) and the centre of those extents in the body frame."""

    classes: list[str] = field(default_factory=list)
    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    h: list[float] = field(default_factory=list)
    length: list[float] = field(default_factory=list)
    width: list[float] = field(default_factory=list)
    cx: list[float] = field(default_factory=list)
    cy: list[float] = field(default_factory=list)
    nearest: float = math.inf  # closest approach to the ego during the event [m]

    def add(
        self, t: float, pose: tuple[float, float, float], footprint: np.ndarray, cls: str = ""
    ) -> None:
        """One observation: `pose` (x, y, yaw), `footprint` (V, 2) body-frame vertices."""
        lo, hi = footprint.min(axis=0), footprint.max(axis=0)
        self.classes.append(cls)
        self.t.append(t)
        self.x.append(pose[0])
        self.y.append(pose[1])
        self.h.append(pose[2])
        self.length.append(float(hi[0] - lo[0]))
        self.width.append(float(hi[1] - lo[1]))
        self.cx.append(float(hi[0] + lo[0]) / 2)
        self.cy.append(float(hi[1] + lo[1]) / 2)


@dataclass
class EventWindow:
    """A hazard event's window and what its channel saw in it (filled by the reader)."""

    number: int
    event: Episode
    channel: str
    t0: float
    t1: float
    ego: Track | None = None
    objects: dict[str, Track] = field(default_factory=dict)
    frames: list[float] = field(default_factory=list)  # the channel's frames, from t0 [s]

    @property
    def last_t(self) -> float:
        """The channel's last frame in the window, from t0 [s]."""
        return self.frames[-1] if self.frames else 0.0


def clean(value: float, digits: int) -> float:
    """`value` rounded to `digits` decimals, with no negative zero."""
    rounded = round(float(value), digits)
    return 0.0 if rounded == 0 else rounded


def hazard_events(result: RunResult) -> list[Episode]:
    """The run's hazard events in time order; event N is the N-th (1-based)."""
    return [e for e in result.episodes if e.kind == "hazard"]


def _channel_at(result: RunResult, t: float) -> str:
    for interval in result.arbitration:
        if interval.start - 1e-9 <= t <= interval.end + 1e-9 and interval.channel:
            return interval.channel
    return result.case.channels[0]


def plan_windows(
    result: RunResult,
    channel: str | None,
    lead_in: float,
    lead_out: float,
    event: int | None = None,
) -> list[EventWindow]:
    """One window per hazard event (or only event `event`, 1-based): the event plus `lead_in`
    and `lead_out` seconds, clipped to the stream's first and last frame, in `channel` (default:
    the arbitrated channel at the event's start). Raises `ExportError` for an unknown channel or
    event number."""
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
    first = result.stream.t_start if result.stream.t_start is not None else -math.inf
    last = result.stream.t_end if result.stream.t_end is not None else math.inf
    return [
        EventWindow(
            n,
            e,
            channel or _channel_at(result, e.start),
            max(e.start - lead_in, first),
            min(e.end + lead_out, last),
        )
        for n, e in enumerate(events, start=1)
        if event is None or n == event
    ]


def spans(t: np.ndarray, frames: np.ndarray, bridge: float) -> list[tuple[int, int]]:
    """Index ranges `[i, j)` of observations (times `t`) during which the entity stays in the
    scene: a range ends where the channel has a frame without it (a frame in `frames` strictly
    between two observations), or where two observations are more than `bridge` seconds
    apart."""
    if not len(t):
        return []
    a, b = t[:-1], t[1:]
    missed = np.searchsorted(frames, b - _EPS, "left") - np.searchsorted(frames, a + _EPS, "right")
    cuts = (np.nonzero((missed > 0) | (b - a > bridge + _EPS))[0] + 1).tolist()
    bounds = [0, *cuts, len(t)]
    return list(pairwise(bounds))


def file_name(window: EventWindow) -> str:
    """`event-NNN-NODE-START.xosc`."""
    e = window.event
    return f"event-{window.number:03d}-{e.node_id}-{e.start:.1f}s.xosc"


def _median(values: list[float]) -> float:
    return float(statistics.median(values))


def _bounding_box(track: Track, kind: str) -> xosc.BoundingBox:
    height = HEIGHT.get(kind, DEFAULT_HEIGHT)
    return xosc.BoundingBox(
        clean(_median(track.width), POSITION_DIGITS),
        clean(_median(track.length), POSITION_DIGITS),
        height,
        clean(_median(track.cx), POSITION_DIGITS),
        clean(_median(track.cy), POSITION_DIGITS),
        height / 2,
    )


def _entity(name: str, track: Track, kind: str) -> xosc.Vehicle | xosc.Pedestrian:
    """The entity: a vehicle of `kind`'s category, or a pedestrian; its box the median of the
    observed footprint extents (a stream's boxes rarely change size within a track)."""
    box = _bounding_box(track, kind)
    if kind == "pedestrian":
        return xosc.Pedestrian(name, MASS[kind], xosc.PedestrianCategory.pedestrian, box)
    length = clean(_median(track.length), POSITION_DIGITS)
    width = clean(_median(track.width), POSITION_DIGITS)
    track_width = clean(max(width - 0.2, 0.1), POSITION_DIGITS)
    return xosc.Vehicle(
        name,
        getattr(xosc.VehicleCategory, kind),
        box,
        xosc.Axle(0.5, 0.7, track_width, clean(length / 3, POSITION_DIGITS), 0.35),
        xosc.Axle(0.0, 0.7, track_width, 0.0, 0.35),
        70.0,
        10.0,
        10.0,
        mass=MASS[kind],
    )


def _pose(track: Track, i: int, heading: float) -> xosc.WorldPosition:
    return xosc.WorldPosition(
        clean(track.x[i], POSITION_DIGITS),
        clean(track.y[i], POSITION_DIGITS),
        0.0,
        clean(heading, ANGLE_DIGITS),
    )


def _at_or_after(name: str, t: float) -> xosc.ValueTrigger:
    return xosc.ValueTrigger(
        name,
        0.0,
        xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition(clean(t, TIME_DIGITS), xosc.Rule.greaterOrEqual),
    )


def _after(name: str, t: float, kind: str = "start") -> xosc.ValueTrigger:
    return xosc.ValueTrigger(
        name,
        0.0,
        xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition(clean(t, TIME_DIGITS), xosc.Rule.greaterThan),
        kind,
    )


def _once_ended(name: str, event: str) -> xosc.ValueTrigger:
    return xosc.ValueTrigger(
        name,
        0.0,
        xosc.ConditionEdge.none,
        xosc.StoryboardElementStateCondition(
            xosc.StoryboardElementType.event, event, xosc.StoryboardElementState.endTransition
        ),
    )


def _event(name: str, action) -> xosc.Event:
    event = xosc.Event(name, xosc.Priority.parallel)
    event.add_action(f"{name}_action", action)
    return event


def _follow(name: str, track: Track, i: int, j: int, headings: np.ndarray):
    """The polyline of observations `i..j-1`, timed absolutely: vertex time = simulation
    time (scale 1, offset 0)."""
    times = [clean(track.t[k], TIME_DIGITS) for k in range(i, j)]
    positions = [_pose(track, k, float(headings[k - i])) for k in range(i, j)]
    trajectory = xosc.Trajectory(name, False)
    trajectory.add_shape(xosc.Polyline(times, positions))
    return xosc.FollowTrajectoryAction(
        trajectory, xosc.FollowingMode.position, xosc.ReferenceContext.absolute, 1.0, 0.0
    )


def _stage(
    name: str,
    track: Track,
    frames: np.ndarray,
    bridge: float,
    init: xosc.Init,
    maneuver: xosc.Maneuver,
) -> int:
    """Init actions and events that make entity `name` exist exactly while observed; returns
    the number of spans it is present in."""
    t = np.asarray(track.t)
    last_t = float(frames[-1])
    parts = spans(t, frames, bridge)
    for k, (i, j) in enumerate(parts, start=1):
        # unwrapped: a player interpolating headings linearly never turns the long way round
        headings = np.unwrap(np.asarray(track.h[i:j]))
        start = f"{name}_add_{k}"
        if t[i] <= _EPS:
            init.add_init_action(name, xosc.TeleportAction(_pose(track, i, headings[0])))
        else:
            if k == 1:  # not in the scene until first seen
                init.add_global_action(xosc.DeleteEntityAction(name))
            add = _event(start, xosc.AddEntityAction(name, _pose(track, i, headings[0])))
            add.add_trigger(_at_or_after(f"{start}_at", t[i]))
            maneuver.add_event(add)
        if j - i >= 2:
            follow = _event(
                f"{name}_follow_{k}", _follow(f"{name}_path_{k}", track, i, j, headings)
            )
            follow.add_trigger(
                _at_or_after(f"{name}_follow_{k}_at", 0.0)
                if t[i] <= _EPS
                else _once_ended(f"{name}_follow_{k}_after_add", start)
            )
            maneuver.add_event(follow)
        if t[j - 1] < last_t - _EPS:  # seen for the last time before the window ends
            delete = _event(f"{name}_delete_{k}", xosc.DeleteEntityAction(name))
            delete.add_trigger(_after(f"{name}_delete_{k}_after", t[j - 1]))
            maneuver.add_event(delete)
    return len(parts)


def _scenario(
    w: EventWindow,
    entities: dict[str, tuple[Track, str]],
    bridge: float,
    road: str | None,
    node_text: str,
) -> tuple[xosc.Scenario, dict[str, int]]:
    objects = xosc.Entities()
    init = xosc.Init()
    act = xosc.Act("replay", _at_or_after("replay_start", 0.0))
    presence: dict[str, int] = {}
    frames = np.asarray(w.frames)
    groups = 0
    for name, (track, kind) in entities.items():
        objects.add_scenario_object(name, _entity(name, track, kind))
        maneuver = xosc.Maneuver(f"{name}_maneuver")
        # the ego is the system under test: it stays in the scene through channel dropouts
        reach = math.inf if name == "ego" else bridge
        presence[name] = _stage(name, track, frames, reach, init, maneuver)
        if maneuver.events:
            group = xosc.ManeuverGroup(f"{name}_group")
            group.add_actor(name)
            group.add_maneuver(maneuver)
            act.add_maneuver_group(group)
            groups += 1
    board = xosc.StoryBoard(init, _after("end", w.t1 - w.t0, "stop"))
    if groups:  # a one-frame window moves nobody: Init alone (an act needs a group)
        board.add_act(act)
    e = w.event
    road_note = "" if road else "; no road network attached (casewatch does not invent roads)"
    description = (
        f"casewatch hazard event {w.number}: {e.node_id} ({node_text}) from "
        f"{e.start:g} s to {e.end:g} s, replayed from channel {w.channel} over "
        f"{w.t0:g}-{w.t1:g} s{road_note}"
    )
    scenario = xosc.Scenario(
        description,
        "casewatch",
        xosc.ParameterDeclarations(),
        objects,
        board,
        xosc.RoadNetwork(roadfile=road) if road else xosc.RoadNetwork(),
        xosc.Catalog(),
        osc_minor_version=OSC_MINOR,
    )
    return scenario, presence


def _load_xosc() -> None:
    """Import scenariogeneration's `xosc` as this module's global, at the first file written:
    it takes about 0.6 s to import, and `casewatch run` (which imports this module for its
    `--scenarios` option) must not pay that on every run that exports nothing."""
    global xosc
    from scenariogeneration import xosc


def write_event(
    w: EventWindow,
    out: Path,
    radius: float,
    period: float,
    road: str | None = None,
    node_text: str = "",
) -> dict:
    """Write event window `w` as `out/<file_name(w)>`; returns its catalogue entry (without
    the stream fields, which the reader adds). `road` is the OpenDRIVE path as written into
    the file. Raises `ExportError` when the channel has no frame in the window."""
    if w.ego is None:
        raise ExportError(
            f"hazard event {w.number} ({w.event.node_id} at {w.event.start:g} s): channel "
            f"{w.channel} has no frame in its window {w.t0:g}-{w.t1:g} s"
        )
    _load_xosc()
    involved: dict[str, tuple[Track, str]] = {}
    for oid, track in sorted(w.objects.items()):
        if track.nearest <= radius:
            kind = entity_kind(
                statistics.mode(track.classes), _median(track.length), _median(track.width)
            ).kind
            involved[f"obj_{oid}"] = (track, kind)
    nearest = min((track.nearest for track in w.objects.values()), default=math.inf)
    entities = {"ego": (w.ego, "car"), **involved}
    scenario, presence = _scenario(w, entities, BRIDGE_PERIODS * period, road, node_text)
    name = file_name(w)
    scenario.write_xml(str(out / name))
    return {
        "file": name,
        **_event_fields(w, node_text),
        "window": [clean(w.t0, TIME_DIGITS), clean(w.t1, TIME_DIGITS)],
        "channel": w.channel,
        "entities": list(entities),
        "ego_only": not involved,
        "radius": radius,
        "nearest_object_m": None if math.isinf(nearest) else round(nearest, 3),
        "objects": {
            n: {
                "category": kind,
                "class": statistics.mode(track.classes),
                "first_seen": clean(track.t[0], TIME_DIGITS),
                "last_seen": clean(track.t[-1], TIME_DIGITS),
                "spans": presence[n],
            }
            for n, (track, kind) in involved.items()
        },
        "road_network": road,
        "trace": [[step.id for step in path] for path in w.event.trace],
    }


def failed_entry(w: EventWindow, error: str, node_text: str = "") -> dict:
    """The catalogue entry of an event whose file could not be written: no file, the reason."""
    return {
        "file": None,
        **_event_fields(w, node_text),
        "window": [clean(w.t0, TIME_DIGITS), clean(w.t1, TIME_DIGITS)],
        "channel": w.channel,
        "error": error,
        "trace": [[step.id for step in path] for path in w.event.trace],
    }


def _event_fields(w: EventWindow, node_text: str) -> dict:
    e = w.event
    return {
        "event": w.number,
        "formula": e.formula_id,
        "node": e.node_id,
        "node_text": node_text,
        "start": e.start,
        "end": e.end,
    }
