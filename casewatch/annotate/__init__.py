"""`casewatch annotate`: a run's verdicts written into the recording it judged, as MCAP.

Front-door composition (it reads recordings and streams, then hands plain values to the
writers): the recording's own messages are copied (`recording`), a JSON Lines drive is drawn
as Foxglove scene entities (`scene`), and the verdicts of result.json and events.jsonl become
Foxglove log lines, a per-tick status topic and episode markers (`verdicts`). The file opens in
Foxglove, which reads MCAP with its published schemas (docs/live.md).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from casewatch.annotate.mcap_out import McapOut
from casewatch.annotate.recording import RecordingError, copy_recording, recording_profile
from casewatch.annotate.scene import SCENE_TOPIC, scene_messages
from casewatch.annotate.verdicts import (
    LOG_TOPIC,
    MARKER_TOPIC,
    STATUS_TOPIC,
    Timebase,
    write_verdicts,
)
from casewatch.errors import CasewatchError
from casewatch.evaluator.result import RunResult
from casewatch.monitor.source import open_source, path_digest, source_kind
from casewatch.reports.render import load_result

__all__ = ["AnnotateError", "Annotated", "RecordingError", "annotate"]

CASEWATCH_TOPICS = frozenset({LOG_TOPIC, STATUS_TOPIC, MARKER_TOPIC})
SCENE_PREFIX = SCENE_TOPIC.split("{")[0]  # /casewatch/scene/


class AnnotateError(CasewatchError):
    """A run folder or recording annotate cannot use (missing result, another recording)."""


@dataclass
class Annotated:
    """What was written: the file, messages per topic, and how many came from the recording."""

    path: Path
    counts: dict[str, int] = field(default_factory=dict)
    copied: int = 0
    damage: str | None = None  # a recording copied only up to where it is damaged
    topics: tuple[str, ...] = ()  # casewatch's own topics in the file


def read_events(path: Path) -> list[dict[str, Any]]:
    """events.jsonl's records (an absent file: none; a bad line: `AnnotateError`)."""
    if not path.is_file():
        return []
    records = []
    with open(path, encoding="utf-8") as fh:
        for number, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError as exc:
                raise AnnotateError(f"{path}:{number}: not a JSON line ({exc.msg})") from None
            if not isinstance(record, dict):
                raise AnnotateError(f"{path}:{number}: expected an event object")
            records.append(record)
    return records


def _check_recording(result: RunResult, recording: Path, run_dir: Path) -> None:
    if not recording.exists():
        raise AnnotateError(f"{recording}: no such recording")
    digest = path_digest(recording)
    if digest != result.stream.digest:
        raise AnnotateError(
            f"{recording} is not the stream {run_dir} judged (sha256 {digest[:12]}..., the run "
            f"judged {result.stream.path} with {(result.stream.digest or 'none')[:12]}...)"
        )


def _write_scene(result: RunResult, recording: Path, out: McapOut) -> None:
    channels = list(result.case.channels)
    for channel in channels:
        out.protobuf_topic(SCENE_TOPIC.format(channel=channel), SceneUpdate)
    t0 = Timebase.of(result).t0_ns
    with open_source(recording, channels=channels, period=result.case.period) as source:
        messages = scene_messages(iter(source.reader), channels, result.case.period, t0)
        for topic, ns, update in messages:
            out.message(topic, ns, update)


def annotate(run_dir: Path, recording: Path, out_path: Path) -> Annotated:
    """Write `out_path`: the recording's messages (or a JSON Lines drive's scene) plus the
    verdicts of the run in `run_dir` (its result.json and events.jsonl)."""
    result = load_result(run_dir / "result.json")
    _check_recording(result, recording, run_dir)
    if out_path.resolve() == recording.resolve() or (
        recording.is_dir() and recording.resolve() in out_path.resolve().parents
    ):
        raise AnnotateError(f"{out_path}: the output would overwrite the recording")
    records = read_events(run_dir / "events.jsonl")
    bag = source_kind(recording) == "bag"
    profile = recording_profile(recording) if bag else ""
    tmp = out_path.with_name(out_path.name + ".part")
    out = McapOut(tmp, profile=profile)
    copied = 0
    damage = None
    done = False
    try:
        out.metadata(
            "casewatch",
            {
                "case": result.case.path,
                "module": result.case.module,
                "root": result.case.root_id,
                "verdict": result.verdict,
                "stream": result.stream.path,
                "stream_sha256": result.stream.digest or "",
                "casewatch_version": result.casewatch_version,
            },
        )
        if bag:
            copied, damage = copy_recording(recording, out)
        else:
            _write_scene(result, recording, out)
        write_verdicts(out, result, records)
        done = True
    finally:
        out.close()
        if not done:
            tmp.unlink(missing_ok=True)  # no half file left behind
    tmp.replace(out_path)  # a run killed midway leaves no half file under the final name
    ours = tuple(t for t in out.counts if t in CASEWATCH_TOPICS or t.startswith(SCENE_PREFIX))
    return Annotated(
        path=out_path, counts=dict(out.counts), copied=copied, damage=damage, topics=ours
    )
