"""A run's verdicts as Foxglove messages: events as log lines, node status per tick, markers.

Everything here comes from the run's own files (result.json and, for the onsets, events.jsonl),
so an annotated recording shows exactly what the reports show:

- `/casewatch/log` (foxglove.Log): each episode's onset (from events.jsonl, at the tick it was
  announced), each closed episode and hazard event (at its last tick), near misses, data gaps
  and ODD changes; the log's `name` is the node.
- `/casewatch/status` (JSON, schema `casewatch.NodeStatus`): every node's status at every tick,
  with its severity as a number for Foxglove's Plot panel. Foxglove publishes no schema for a
  named discrete status, so this one topic is casewatch's own small JSON schema.
- `/casewatch/markers` (foxglove.SceneUpdate): a sphere and a label where the ego was when
  each episode began, shown for the episode's duration, and the driven path.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
from foxglove_schemas_protobuf.TextPrimitive_pb2 import TextPrimitive

from casewatch.annotate import foxglove as fx
from casewatch.annotate.mcap_out import McapOut
from casewatch.evaluator.eventlog import Event, event_record
from casewatch.evaluator.result import STATUS_SEVERITY, NodeStatus, RunResult

LOG_TOPIC = "/casewatch/log"
STATUS_TOPIC = "/casewatch/status"
MARKER_TOPIC = "/casewatch/markers"

STATUS_SCHEMA_NAME = "casewatch.NodeStatus"
STATUS_SCHEMA: dict[str, Any] = {
    "title": STATUS_SCHEMA_NAME,
    "description": "Every node's status at one tick of a casewatch run (docs/results.md).",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "stream time, s"},
        "root": {"type": "string", "description": "the root goal's status"},
        "status": {"type": "object", "additionalProperties": {"type": "string"}},
        "severity": {
            "type": "object",
            "description": "status severity, 8 violated ... 1 satisfied, 0 external",
            "additionalProperties": {"type": "integer"},
        },
    },
    "required": ["t", "root", "status", "severity"],
}

HAZARD_COLOUR = "#c62828"  # the report's --violated
SPI_COLOUR = "#d35400"  # the report's --undermined
TRACK_COLOUR = "#1565c0"


@dataclass(frozen=True)
class Timebase:
    """Stream time (s) to MCAP log time (ns since the epoch): `t0_ns + t * 1e9`. A bag's run
    counts t from its first tick and records that tick's time as `meta.t0_unix_ns`; a JSON
    Lines stream's t is taken as seconds since the epoch (or since its `meta.t0_unix_ns`)."""

    t0_ns: int = 0

    def ns(self, t: float) -> int:
        return self.t0_ns + round(t * 1e9)

    @staticmethod
    def of(result: RunResult) -> Timebase:
        value = result.stream.meta.get("t0_unix_ns", 0)
        return Timebase(int(value) if isinstance(value, int | float) else 0)


def _log(ns: int, level: Log.Level.ValueType, node: str, text: str) -> Log:
    return Log(timestamp=fx.timestamp(ns), level=level, message=text, name=node, file="casewatch")


def log_line(record: dict[str, Any]) -> tuple[float, Log.Level.ValueType, str]:
    """(stream time, foxglove.Log level, text) of one events.jsonl record
    (`evaluator.eventlog.event_record`): onsets and ODD changes at their tick, closed episodes,
    near misses and data gaps at their last tick."""
    kind, node = record["event"], record["node_id"]
    if kind == "episode_open":
        hazard = record["kind"] == "hazard"
        word = "HAZARD" if hazard else "VIOLATED"
        text = f"{word} {node} from {record['start']:.1f} s (open at {record['t']:.1f} s)"
        return record["t"], Log.ERROR if hazard else Log.WARNING, text
    if kind == "odd_change":
        because = f" ({record['because']})" if record.get("because") else ""
        text = f"ODD {node}: {record['state']} from {record['t']:.1f} s{because}"
        return record["t"], Log.INFO if record["state"] == "inside" else Log.WARNING, text
    span = f"{record['start']:.1f}-{record['end']:.1f} s"
    if kind in ("hazard_event", "spi_episode"):
        hazard = kind == "hazard_event"
        worst = float(record["worst_robustness"])
        text = (
            f"{'HAZARD EVENT' if hazard else 'SPI EPISODE'} {node} {span}, worst robustness "
            f"{worst:+.3f} at {record['t_worst']:.1f} s"
        )
        return record["end"], Log.ERROR if hazard else Log.WARNING, text
    if kind == "near_miss":
        text = (
            f"NEAR MISS {node} {span}, robustness down to {record['least_robustness']:.3f} "
            f"(margin {record['warn']:g})"
        )
        return record["end"], Log.INFO, text
    return record["end"], Log.INFO, f"NO DATA {node} {span}, missing {', '.join(record['missing'])}"


def log_message(record: dict[str, Any], time: Timebase) -> tuple[int, Log]:
    """(log time, foxglove.Log) of one events.jsonl record."""
    t, level, text = log_line(record)
    ns = time.ns(t)
    return ns, _log(ns, level, record["node_id"], text)


def log_messages(
    result: RunResult, records: Iterable[dict[str, Any]], time: Timebase
) -> Iterator[tuple[int, Log]]:
    """(log time, foxglove.Log) for every onset and ODD change in `records` (events.jsonl)
    and every closed episode, near miss and data gap of `result`."""
    for r in records:
        if r.get("event") in ("episode_open", "odd_change"):
            yield log_message(r, time)
    closed: list[Event] = [*result.episodes, *result.near_misses, *result.data_gaps]
    for event in closed:
        yield log_message(event_record(event), time)


def tick_statuses(statuses: list[NodeStatus]) -> tuple[np.ndarray, dict[str, list[str]]]:
    """The run's ticks and every node's status at each, from the status timelines (each
    interval's ticks evenly spaced from its start to its end)."""
    columns: dict[str, list[str]] = {}
    times: np.ndarray | None = None
    for node in statuses:
        t_parts, s_parts = [], []
        for run in node.timeline:
            t_parts.append(np.linspace(run.start, run.end, run.ticks))
            s_parts.extend([str(run.status)] * run.ticks)
        t = np.round(np.concatenate(t_parts), 6) if t_parts else np.zeros(0)
        if times is None:
            times = t
        elif len(t) != len(times):
            raise ValueError(f"node {node.node_id} has {len(t)} ticks, the others {len(times)}")
        columns[node.node_id] = s_parts
    return (np.zeros(0) if times is None else times), columns


def status_messages(result: RunResult, time: Timebase) -> Iterator[tuple[int, dict[str, Any]]]:
    """(log time, JSON value) for every tick: each node's status and its severity."""
    times, columns = tick_statuses(result.status)
    root = result.case.root_id
    names = list(columns)
    for k, t in enumerate(times.tolist()):
        yield time.ns(t), status_value(t, {n: columns[n][k] for n in names}, root)


def status_value(t: float, status: Mapping[str, str], root: str) -> dict[str, Any]:
    """One `/casewatch/status` message: every node's status at `t` and its severity."""
    return {
        "t": t,
        "root": status.get(root, "no-data"),
        "status": dict(status),
        "severity": {n: STATUS_SEVERITY.get(s, 0) for n, s in status.items()},
    }


def marker_messages(result: RunResult, time: Timebase) -> Iterator[tuple[int, SceneUpdate]]:
    """(log time, SceneUpdate): the driven path once, then one marker per placed episode,
    from its first tick for its duration."""
    period = result.case.period
    if result.track:
        first = result.track[0][0]
        line = LinePrimitive(
            type=LinePrimitive.LINE_STRIP,
            pose=fx.pose(0.0, 0.0),
            thickness=2.0,
            scale_invariant=True,
            points=fx.points([(p[1], p[2]) for p in result.track]),
            color=fx.color(TRACK_COLOUR, 0.8),
        )
        entity = SceneEntity(
            timestamp=fx.timestamp(time.ns(first)),
            frame_id=fx.WORLD_FRAME,
            id="casewatch-track",
            lines=[line],
        )
        yield time.ns(first), SceneUpdate(entities=[entity])
    for i, e in enumerate(result.episodes):
        if e.x is None or e.y is None:
            continue
        ns = time.ns(e.start)
        hue = HAZARD_COLOUR if e.kind == "hazard" else SPI_COLOUR
        label = (
            f"{e.node_id} {'hazard' if e.kind == 'hazard' else 'SPI'} {e.start:.1f}-{e.end:.1f} s"
        )
        entity = SceneEntity(
            timestamp=fx.timestamp(ns),
            frame_id=fx.WORLD_FRAME,
            id=f"episode-{i}",
            lifetime=fx.duration(e.end - e.start + period),
            spheres=[
                SpherePrimitive(
                    pose=fx.pose(e.x, e.y, 1.0), size=fx.size(3, 3, 3), color=fx.color(hue, 0.6)
                )
            ],
            texts=[
                TextPrimitive(
                    pose=fx.pose(e.x, e.y, 4.0),
                    billboard=True,
                    font_size=14.0,
                    scale_invariant=True,
                    color=fx.color(hue),
                    text=label,
                )
            ],
            metadata=fx.metadata(
                node_id=e.node_id,
                kind=e.kind,
                start=e.start,
                end=e.end,
                worst_robustness=e.worst_robustness,
            ),
        )
        yield ns, SceneUpdate(entities=[entity])


def write_verdicts(out: McapOut, result: RunResult, records: list[dict[str, Any]]) -> None:
    """Every casewatch topic of `result` into `out`."""
    time = Timebase.of(result)
    out.protobuf_topic(LOG_TOPIC, Log)
    out.json_topic(STATUS_TOPIC, STATUS_SCHEMA_NAME, STATUS_SCHEMA)
    out.protobuf_topic(MARKER_TOPIC, SceneUpdate)
    for ns, message in sorted(log_messages(result, records, time), key=lambda m: m[0]):
        out.message(LOG_TOPIC, ns, message)
    for ns, value in status_messages(result, time):
        out.json(STATUS_TOPIC, ns, value)
    for ns, update in marker_messages(result, time):
        out.message(MARKER_TOPIC, ns, update)
