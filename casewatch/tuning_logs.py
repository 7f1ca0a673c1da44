"""The logs `casewatch tune` and `calibrate` read: saved signals, and each log's labels.

Fault labels (`NAME.fault-labels.jsonl`, `evaluator.faults`) are found beside each log's labels
or stream, like its labels, when labels are asked for (`--labels auto`, or a file for a single
log); `calibrate` reports the faults each SPI reveals and keeps their stretches out of nominal
driving.

A LOG argument is a run folder of `casewatch run --save-signals` (it holds `signals.npz` and
`result.json`), a fleet folder (its `summary.json` lists the run folders), or streams (a file,
a folder of streams, a glob): those are judged once with `--save-signals` into `OUT/runs`, so
the metrics are computed once and every candidate threshold reads the saved values.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from casewatch import batch
from casewatch.errors import CasewatchError
from casewatch.evaluator.faults import (
    FaultLabel,
    FaultLabelsError,
    fault_labels_path,
    read_fault_labels,
)
from casewatch.evaluator.ground_truth import Label, LabelsError, read_labels
from casewatch.evaluator.options import RunOptions
from casewatch.evaluator.signal_store import FILE_NAME, SavedSignals, SignalsError, load_signals


class LogsError(CasewatchError, ValueError):
    """Logs tuning cannot use (names the log and what is missing)."""


@dataclass(frozen=True)
class TuningLog:
    name: str
    folder: Path
    signals: SavedSignals
    labels: list[Label] | None
    labels_path: str | None
    faults: list[FaultLabel] | None = None  # injected faults, when a fault-labels file is found
    faults_path: str | None = None


def _read_json(path: Path) -> dict:
    """A run's `result.json`; LogsError when it is not one."""
    try:
        value = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise LogsError(f"{path}: cannot read it as casewatch output ({exc})") from None
    if not isinstance(value, dict):
        raise LogsError(f"{path}: not casewatch output (expected a JSON object)")
    return value


def _run_folders(arguments: list[str], case_path: str, out: Path, jobs: int) -> list[Path]:
    folders: list[Path] = []
    streams: list[Path] = []
    for arg in arguments:
        path = Path(arg)
        if path.is_dir() and (path / FILE_NAME).is_file():
            folders.append(path)
        elif path.is_dir() and (path / "summary.json").is_file():
            try:
                summary = batch.read_summary(path)
            except batch.FleetError as exc:
                raise LogsError(str(exc)) from None
            for log in summary["per_log"]:
                if not log.get("ok", True):
                    raise LogsError(
                        f"{path}: log {log.get('stream')} failed in that run "
                        f"({log.get('error')}); run it again"
                    )
                folders.append(Path(log["out_dir"]))
        elif path.is_dir() and (path / "result.json").is_file():
            raise LogsError(
                f"{path}: this run kept no signals; run the log again with "
                "--save-signals (or pass the stream itself)"
            )
        else:
            try:
                streams.extend(batch.find_streams(arg))
            except batch.NoStreams as exc:
                raise LogsError(str(exc)) from None
    missing = [s for s in streams if not s.is_file()]
    if missing:
        raise LogsError(f"{missing[0]}: no such stream, run folder or fleet folder")
    if streams:
        runs = out / "runs"
        summary = batch.run_many(
            case_path,
            "",
            streams,
            runs,
            RunOptions(labels="auto"),
            batch.Outputs(save_signals=True),
            batch.local_runner(jobs),
        )
        for log in cast(list, summary["per_log"]):
            if not log["ok"]:
                raise LogsError(f"{log['stream']}: could not be judged: {log['error']}")
            folders.append(Path(log["out_dir"]))
    return folders


def _labels_of(folder: Path, labels: str | None, single: bool) -> tuple[list[Label], str] | None:
    path, _ = _label_places(folder, labels, single)
    if not path:
        return None
    if not Path(path).is_file():
        raise LogsError(
            f"{folder}: its labels {path} are not there (a path relative to where "
            "the log was judged?); pass --labels FILE for a single log"
        )
    try:
        found, _ = read_labels(path)
    except LabelsError as exc:
        raise LogsError(str(exc)) from None
    return found, str(path)


def _label_places(folder: Path, labels: str | None, single: bool) -> tuple[str | None, list[Path]]:
    """The log's labels file (None: none) and the paths beside which its fault labels may lie
    (the labels file, then the stream)."""
    if labels not in (None, "auto"):
        if not single:
            raise LogsError(
                "with several logs use --labels auto (each log's labels: the file "
                "its run was judged with, or NAME.labels.jsonl beside its stream)"
            )
        return labels, [Path(labels)]
    result = _read_json(folder / "result.json")
    truth = result.get("ground_truth") or {}
    path = truth.get("labels_path") if isinstance(truth, dict) else None
    stream_info = result.get("stream")
    stream = stream_info.get("path") if isinstance(stream_info, dict) else None
    if not path and labels == "auto" and isinstance(stream, str):
        sibling = batch.sibling_labels(Path(stream))
        path = str(sibling) if sibling else None
    places = [Path(p) for p in (path, stream) if isinstance(p, str) and p]
    return (path if isinstance(path, str) and path else None), places


def _faults_of(
    folder: Path, labels: str | None, single: bool
) -> tuple[list[FaultLabel], str] | None:
    """The log's injected faults, from `NAME.fault-labels.jsonl` beside its labels or stream."""
    _, places = _label_places(folder, labels, single)
    for place in places:
        candidate = fault_labels_path(place)
        if candidate.is_file():
            try:
                return read_fault_labels(candidate), str(candidate)
            except FaultLabelsError as exc:
                raise LogsError(str(exc)) from None
    return None


def load_logs(
    arguments: list[str],
    case_path: str,
    out: Path,
    jobs: int = 1,
    labels: str | None = None,
    need_labels: bool = False,
) -> list[TuningLog]:
    """Every log of `arguments` with its saved signals and (with `labels`) its labels."""
    folders = _run_folders(arguments, case_path, out, jobs)
    if not folders:
        raise LogsError("no logs given")
    logs = []
    for folder in folders:
        try:
            signals = load_signals(folder)
        except SignalsError as exc:
            raise LogsError(str(exc)) from None
        single = len(folders) == 1
        got = _labels_of(folder, labels, single) if labels else None
        if need_labels and got is None:
            raise LogsError(
                f"{folder}: the log has no labels (NAME.labels.jsonl beside its "
                "stream, or a run judged with --labels); tune scores thresholds "
                "against labels"
            )
        faults = _faults_of(folder, labels, single) if labels else None
        logs.append(
            TuningLog(
                folder.name,
                folder,
                signals,
                got[0] if got else None,
                got[1] if got else None,
                faults[0] if faults else None,
                faults[1] if faults else None,
            )
        )
    return logs
