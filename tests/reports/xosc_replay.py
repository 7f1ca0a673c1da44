"""A small, independent player for the scenario files casewatch writes, for the tests.

It reads an `.xosc` with ElementTree (not with the exporter's code) and answers "where is each
entity at simulation time t, if it exists?" the way OpenSCENARIO 1.2 defines it:

- Init: a `TeleportAction` puts an entity in the scene at time 0; a `DeleteEntityAction`
  removes it;
- an event starts when its start trigger holds: `SimulationTimeCondition` (`greaterOrEqual`:
  from `value` on; `greaterThan`: after `value`) or a `StoryboardElementStateCondition` on
  another event's `endTransition` (an instantaneous action's event ends when it starts);
- `AddEntityAction` puts the entity in the scene at its position, `DeleteEntityAction` takes
  it out;
- `FollowTrajectoryAction`: a vertex of time `t_v` is reached at simulation time
  `scale * t_v + offset` (`Timing domainAbsoluteRelative="absolute"`), plus the action's
  start for `relative`; between vertices the pose is interpolated linearly in time (a
  polyline); after the last vertex the entity stays there.

`footprints(t)` gives each present entity's footprint as a shapely polygon (its
`BoundingBox` turned by its heading).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from shapely.geometry import Polygon

#: Intersections smaller than this [m²] are contact, not overlap (positions are written to
#: 0.1 mm).
MIN_OVERLAP = 1e-3


@dataclass
class _Change:
    time: float
    strict: bool  # True: applies after `time` (greaterThan); False: from `time` on
    op: str  # "add", "delete"
    pose: tuple[float, float, float] | None = None


@dataclass
class _Path:
    times: np.ndarray  # simulation times of the vertices
    x: np.ndarray
    y: np.ndarray
    h: np.ndarray


@dataclass
class Entity:
    name: str
    kind: str  # vehicleCategory, or "pedestrian"
    length: float
    width: float
    cx: float
    cy: float
    at_start: tuple[float, float, float] | None = None  # Init teleport
    removed_at_start: bool = False
    changes: list[_Change] = field(default_factory=list)
    paths: list[_Path] = field(default_factory=list)

    def present(self, t: float) -> bool:
        alive = self.at_start is not None and not self.removed_at_start
        for c in sorted(self.changes, key=lambda c: c.time):
            if (t > c.time) if c.strict else (t >= c.time - 1e-9):
                alive = c.op == "add"
        return alive

    def pose(self, t: float) -> tuple[float, float, float]:
        for p in self.paths:
            if p.times[0] - 1e-9 <= t <= p.times[-1] + 1e-9:
                return (
                    float(np.interp(t, p.times, p.x)),
                    float(np.interp(t, p.times, p.y)),
                    float(np.interp(t, p.times, p.h)),
                )
        # not on a path: the latest pose set before t (teleport, add, or a path's end)
        latest = (-math.inf, self.at_start)
        for c in self.changes:
            if c.op == "add" and c.time <= t + 1e-9 and c.time >= latest[0]:
                latest = (c.time, c.pose)
        for p in self.paths:
            if p.times[-1] <= t + 1e-9 and p.times[-1] >= latest[0]:
                latest = (p.times[-1], (float(p.x[-1]), float(p.y[-1]), float(p.h[-1])))
        assert latest[1] is not None, (self.name, t)
        return latest[1]

    def footprint(self, t: float) -> Polygon:
        x, y, h = self.pose(t)
        c, s = math.cos(h), math.sin(h)
        hl, hw = self.length / 2, self.width / 2
        corners = [
            (self.cx + a, self.cy + b) for a, b in ((hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw))
        ]
        return Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in corners])


def _world(position: ET.Element) -> tuple[float, float, float]:
    w = position.find("WorldPosition")
    assert w is not None, "only world positions are written"
    return float(w.get("x")), float(w.get("y")), float(w.get("h", "0"))


class Replay:
    """The entities of one scenario file and how they move."""

    def __init__(self, path: Path):
        root = ET.parse(path).getroot()
        self.root = root
        self.entities: dict[str, Entity] = {}
        for obj in root.iter("ScenarioObject"):
            name = obj.get("name")
            body = obj.find("Vehicle")
            kind = body.get("vehicleCategory") if body is not None else None
            if body is None:
                body = obj.find("Pedestrian")
                kind = "pedestrian"
            dims = body.find("BoundingBox/Dimensions")
            centre = body.find("BoundingBox/Center")
            self.entities[name] = Entity(
                name,
                kind,
                float(dims.get("length")),
                float(dims.get("width")),
                float(centre.get("x")),
                float(centre.get("y")),
            )
        init = root.find("Storyboard/Init/Actions")
        for private in init.iter("Private"):
            for teleport in private.iter("TeleportAction"):
                self.entities[private.get("entityRef")].at_start = _world(teleport.find("Position"))
        for action in init.findall("GlobalAction/EntityAction"):
            if action.find("DeleteEntityAction") is not None:
                self.entities[action.get("entityRef")].removed_at_start = True
        stop = root.find("Storyboard/StopTrigger//SimulationTimeCondition")
        self.end = float(stop.get("value"))
        self._events(root)

    def _events(self, root: ET.Element) -> None:
        events = {e.get("name"): e for e in root.iter("Event")}
        actors = {}
        for group in root.iter("ManeuverGroup"):
            for event in group.iter("Event"):
                actors[event.get("name")] = [r.get("entityRef") for r in group.iter("EntityRef")]
        starts: dict[str, tuple[float, bool]] = {}

        def start(name: str) -> tuple[float, bool]:
            if name not in starts:
                cond = events[name].find("StartTrigger/ConditionGroup/Condition")
                sim = cond.find(".//SimulationTimeCondition")
                if sim is not None:
                    rule = sim.get("rule")
                    assert rule in ("greaterOrEqual", "greaterThan"), rule
                    starts[name] = (float(sim.get("value")), rule == "greaterThan")
                else:
                    ref = cond.find(".//StoryboardElementStateCondition")
                    assert (
                        ref.get("state") == "endTransition"
                        and ref.get("storyboardElementType") == "event"
                    )
                    starts[name] = start(ref.get("storyboardElementRef"))
            return starts[name]

        for name, event in events.items():
            t, strict = start(name)
            for action in event.findall("Action"):
                entity_action = action.find("GlobalAction/EntityAction")
                if entity_action is not None:
                    entity = self.entities[entity_action.get("entityRef")]
                    add = entity_action.find("AddEntityAction")
                    if add is not None:
                        entity.changes.append(
                            _Change(t, strict, "add", _world(add.find("Position")))
                        )
                    else:
                        entity.changes.append(_Change(t, strict, "delete"))
                follow = action.find(".//FollowTrajectoryAction")
                if follow is not None:
                    timing = follow.find("TimeReference/Timing")
                    scale, offset = float(timing.get("scale")), float(timing.get("offset"))
                    base = t if timing.get("domainAbsoluteRelative") == "relative" else 0.0
                    vertices = list(follow.iter("Vertex"))
                    poses = np.array([_world(v.find("Position")) for v in vertices])
                    times = (
                        np.array([float(v.get("time")) for v in vertices]) * scale + offset + base
                    )
                    assert (np.diff(times) > 0).all(), "vertex times must increase"
                    for actor in actors[name]:
                        self.entities[actor].paths.append(_Path(times, *poses.T))

    def footprints(self, t: float) -> dict[str, Polygon]:
        """Every entity present at simulation time `t`, with its footprint."""
        return {n: e.footprint(t) for n, e in self.entities.items() if e.present(t)}


def overlapping(polygons: dict[str, Polygon]) -> set[tuple[str, str]]:
    """Pairs (sorted names) whose footprints overlap by more than MIN_OVERLAP."""
    names = sorted(polygons)
    return {
        (a, b)
        for i, a in enumerate(names)
        for b in names[i + 1 :]
        if polygons[a].intersects(polygons[b])
        and polygons[a].intersection(polygons[b]).area > MIN_OVERLAP
    }


def _world_polygon(footprint: np.ndarray, x: float, y: float, yaw: float) -> Polygon:
    c, s = math.cos(yaw), math.sin(yaw)
    return Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in footprint])


def stream_state(state) -> dict[str, tuple[float, float, Polygon]]:
    """A channel's state at one frame as {entity name: (x, y, footprint)}, named as the
    export names them (`ego`, `obj_<id>`)."""
    e = state.ego
    out = {"ego": (e.x, e.y, _world_polygon(e.footprint, e.x, e.y, e.yaw))}
    o = state.objects
    for k, oid in enumerate(o.ids):
        x, y = float(o.pos[k, 0]), float(o.pos[k, 1])
        out[f"obj_{oid}"] = (x, y, _world_polygon(o.footprints[k], x, y, float(o.yaw[k])))
    return out


@dataclass
class ReplayCheck:
    """What sampling one scenario file against its stream found."""

    samples: int = 0
    stream_contacts: int = 0  # (time, pair) overlaps in the stream among the file's entities
    replay_contacts: int = 0
    new_contacts: list[tuple[float, tuple[str, str]]] = field(default_factory=list)
    presence_errors: list[tuple[float, set[str], set[str]]] = field(default_factory=list)
    max_position_error: float = 0.0


def wait_at_first_pose(replay: Replay) -> Replay:
    """The same file played the way casewatch exported before issue 33: every entity in the
    scene from the start, waiting at its first pose and staying at its last (its adds and
    deletes ignored). For showing what the presence actions prevent."""
    for entity in replay.entities.values():
        adds = [c for c in entity.changes if c.op == "add"]
        if adds and entity.removed_at_start:
            entity.at_start = min(adds, key=lambda c: c.time).pose
        entity.removed_at_start = False
        entity.changes = []
    return replay


def check_replay(
    path: Path, frames: list[tuple[float, dict]], waiting: bool = False
) -> ReplayCheck:
    """Sample the file at every frame time of its channel in the window (`frames`: window
    time, `stream_state(...)`) and halfway between consecutive frames. At a frame time the
    entities present must be exactly those the channel observed, where it observed them; at
    every sample, two footprints may overlap only if the stream's overlapped at that frame
    (halfway: at either neighbouring frame). `waiting`: played as `wait_at_first_pose`."""
    replay = wait_at_first_pose(Replay(path)) if waiting else Replay(path)
    names = set(replay.entities)
    check = ReplayCheck()
    truth = []
    for t, seen in frames:
        kept = {n: v for n, v in seen.items() if n in names}
        pairs = overlapping({n: v[2] for n, v in kept.items()})
        truth.append((t, kept, pairs))
        check.stream_contacts += len(pairs)
    for k, (t, kept, pairs) in enumerate(truth):
        present = replay.footprints(t)
        if set(present) != set(kept):
            check.presence_errors.append((t, set(present), set(kept)))
        for n, (x, y, _) in kept.items():
            if n in present:
                px, py, _ = replay.entities[n].pose(t)
                check.max_position_error = max(check.max_position_error, math.hypot(px - x, py - y))
        samples = [(t, present, pairs)]
        if k + 1 < len(truth):
            mid = (t + truth[k + 1][0]) / 2
            samples.append((mid, replay.footprints(mid), pairs | truth[k + 1][2]))
        for when, polygons, allowed in samples:
            found = overlapping(polygons)
            check.samples += 1
            check.replay_contacts += len(found)
            check.new_contacts += [(when, pair) for pair in sorted(found - allowed)]
    return check
