"""Hazard events as OpenSCENARIO test cases: reading what the export needs, then writing it.

The front door of `casewatch export-scenarios` and `casewatch run --scenarios`: it checks the
options, reads the judged stream (JSON Lines, or a ROS 2 bag through its topic mapping, as the
run read it) once, gathers every event window's tracks as plain numbers, and hands each window
to the writer in `casewatch.reports.scenario_export`, which reads nothing itself.

One file per hazard event, always: an event whose channel saw nobody within the radius becomes
an ego-only scenario (said in the catalogue); an event whose file cannot be written is recorded
in the catalogue with the reason, and the other events are still written. Only input that makes
the whole export meaningless (another stream than the one judged, an unknown channel or event,
a missing OpenDRIVE file, a bag whose mapping does not fit) refuses the export.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from casewatch.errors import CasewatchError
from casewatch.evaluator.result import RunResult
from casewatch.monitor.frames import Frame
from casewatch.monitor.source import SourceError, open_source, path_digest, source_kind
from casewatch.reports.render import load_result
from casewatch.reports.scenario_export import (
    EventWindow,
    ExportError,
    Track,
    failed_entry,
    plan_windows,
    write_event,
)
from casewatch.safety_case.findings import CaseError
from casewatch.safety_case.loader import require_case

#: The catalogue written beside the files of one stream.
CATALOGUE = "scenarios.json"

#: The fleet's index, beside one folder per log (`run DIR --scenarios`).
FLEET_INDEX = "index.json"

__all__ = [
    "CATALOGUE",
    "FLEET_INDEX",
    "ExportError",
    "ExportOptions",
    "ExportReport",
    "export_fleet",
    "export_scenarios",
]


@dataclass(frozen=True)
class ExportOptions:
    """What `export-scenarios` and `run --scenario-*` let a user choose."""

    channel: str | None = None
    lead_in: float = 3.0
    lead_out: float = 2.0
    radius: float = 30.0
    opendrive: Path | None = None
    event: int | None = None
    topics: Path | None = None


@dataclass
class ExportReport:
    """What one stream's export wrote: its folder and catalogue entries (one per event)."""

    out: Path
    entries: list[dict] = field(default_factory=list)

    @property
    def written(self) -> list[dict]:
        return [e for e in self.entries if e["file"] is not None]

    @property
    def failed(self) -> list[dict]:
        return [e for e in self.entries if e["file"] is None]


def check_options(options: ExportOptions, flag: str = "--") -> None:
    """Refuse numbers out of range and an OpenDRIVE file that is not there (`ExportError`);
    `flag` is how the options are spelled on the command line (`--scenario-` under `run`)."""
    for name, value in (
        ("lead-in", options.lead_in),
        ("lead-out", options.lead_out),
        ("radius", options.radius),
    ):
        if not (math.isfinite(value) and value >= 0):
            raise ExportError(f"{flag}{name} must be a number >= 0, got {value:g}")
    road = options.opendrive
    if road is not None and not Path(road).is_file():
        raise ExportError(
            f"{road}: no such OpenDRIVE file"
            + (" (it is a folder)" if Path(road).is_dir() else "")
            + f" (looked for {Path(road).resolve()})"
        )


def road_reference(opendrive: Path, out: Path) -> str:
    """The OpenDRIVE path as written into files in folder `out`: relative to that folder (the
    standard resolves a relative `filepath` from the scenario file's folder), so scenarios and
    road can move together; absolute when no relative path exists (another drive)."""
    target = Path(opendrive).resolve()
    try:
        return Path(os.path.relpath(target, Path(out).resolve())).as_posix()
    except ValueError:  # Windows: another drive
        return target.as_posix()


def _frames(result: RunResult, stream: Path, topics: Path | None) -> Iterator[Frame]:
    """The frames of the judged stream as the run read them: JSON Lines with the case's
    channels and period, or a ROS 2 bag through its topic mapping (`topics`, else the case's
    `monitor.topics`)."""
    case_topics = None
    if topics is None and source_kind(stream) == "bag":  # only a bag reads the case's mapping
        try:
            case_topics = require_case(result.case.path).monitor.topics
        except (CaseError, OSError):
            case_topics = None
    try:
        with open_source(
            stream,
            channels=list(result.case.channels),
            period=result.case.period,
            topics=topics,
            case_path=result.case.path,
            case_topics=case_topics,
        ) as source:
            yield from source.reader
    except SourceError as exc:
        raise ExportError(str(exc)) from None


def collect(frames: Iterable[Frame], windows: list[EventWindow]) -> None:
    """One pass over the frames: every window's ego and object observations in its channel,
    and each object's closest approach to the ego during the event (centre to centre)."""
    for frame in frames:
        for w in windows:
            if not w.t0 - 1e-9 <= frame.t <= w.t1 + 1e-9:
                continue
            state = frame.channels.get(w.channel)
            if state is None:
                continue
            t = frame.t - w.t0
            e = state.ego
            if w.ego is None:
                w.ego = Track()
            w.ego.add(t, (e.x, e.y, e.yaw), e.footprint, "ego")
            w.frames.append(t)
            inside = w.event.start - 1e-9 <= frame.t <= w.event.end + 1e-9
            o = state.objects
            for k, oid in enumerate(o.ids):
                x, y = float(o.pos[k, 0]), float(o.pos[k, 1])
                track = w.objects.get(oid)
                if track is None:
                    track = w.objects[oid] = Track()
                track.add(t, (x, y, float(o.yaw[k])), o.footprints[k], o.cls[k])
                if inside:
                    track.nearest = min(track.nearest, math.hypot(x - e.x, y - e.y))


def export_scenarios(
    result: RunResult, stream: Path, out: Path, options: ExportOptions = ExportOptions()
) -> ExportReport:
    """One `.xosc` per hazard event of `result` (or only `options.event`) into `out`, and the
    catalogue `out/scenarios.json` with one entry per event. Raises `ExportError` when the
    export as a whole cannot be made; a single event that cannot be written is an entry with
    `file: null` and its `error`."""
    check_options(options)
    stream = Path(stream)
    if result.stream.digest and path_digest(stream) != result.stream.digest:
        raise ExportError(
            f"{stream}: not the stream this run judged (sha256 differs from "
            f"result.json's {result.stream.digest[:12]}...)"
        )
    windows = plan_windows(
        result, options.channel, options.lead_in, options.lead_out, options.event
    )
    collect(_frames(result, stream, options.topics), windows)
    out.mkdir(parents=True, exist_ok=True)
    road = road_reference(options.opendrive, out) if options.opendrive else None
    texts = {n.id: n.text for n in result.case.nodes}
    report = ExportReport(out)
    for w in windows:
        text = texts.get(w.event.node_id, "")
        try:
            entry = write_event(w, out, options.radius, result.case.period, road, text)
        except (ExportError, OSError) as exc:
            entry = failed_entry(w, str(exc), text)
        entry["stream"] = str(stream)
        entry["stream_digest"] = result.stream.digest
        report.entries.append(entry)
    catalogue = {"format": "casewatch-scenarios", "version": 2, "scenarios": report.entries}
    (out / CATALOGUE).write_text(json.dumps(catalogue, indent=1), encoding="utf-8")
    return report


def export_fleet(per_log: list[dict], out: Path, options: ExportOptions) -> dict:
    """`run DIR --scenarios`: every judged log's hazard events into `out/<log folder>/`, and
    the fleet's index `out/index.json` (per log: its stream, folder, catalogue and counts, or
    why its export was refused). A log the export refuses does not stop the others."""
    check_options(options)
    out.mkdir(parents=True, exist_ok=True)
    logs = []
    for log in per_log:
        folder = Path(log["out_dir"])
        item: dict = {"stream": log["stream"], "folder": None, "scenarios": 0, "failed": 0}
        logs.append(item)
        if not log.get("ok"):
            item["error"] = "the log was not judged: " + str(log.get("error", ""))
            continue
        try:
            result = load_result(folder / "result.json")
            if not any(e.kind == "hazard" for e in result.episodes):
                continue
            report = export_scenarios(result, Path(log["stream"]), out / folder.name, options)
        except (CasewatchError, OSError) as exc:
            item["error"] = str(exc)
            continue
        item["folder"] = folder.name
        item["catalogue"] = f"{folder.name}/{CATALOGUE}"
        item["scenarios"] = len(report.written)
        item["failed"] = len(report.failed)
    index = {
        "format": "casewatch-scenario-fleet",
        "version": 1,
        "logs": logs,
        "scenarios": sum(item["scenarios"] for item in logs),
        "failed": sum(item["failed"] for item in logs),
        "logs_refused": sum(1 for item in logs if "error" in item),
    }
    (out / FLEET_INDEX).write_text(json.dumps(index, indent=1), encoding="utf-8")
    return index
