"""What a Dask task runs (`run_task`), and logs shipped to workers that do not share the file
system (`casewatch run --ship-logs MIB`).

A task judged in place leaves `TASK_FILE` in the log's folder (this fleet's id and the log's
summary): when the worker holding a finished task's value dies before the client took it, the
scheduler runs the task again, and it returns that summary instead of judging the log again.

A small log's bytes (and its labels') travel with its Dask task; the worker judges copies in a
private temporary folder and sends the log's output files back with the task's value; the
client writes them into the log's folder as the task finishes. The result names the client's
paths (`batch.as_recorded`), so a shipped log's result.json is the one a shared file system
would have given, and `--resume` reuses it the same way.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

from pydantic import ValidationError

from casewatch.batch import Job, run_job
from casewatch.evaluator.summary import LogSummary


@dataclass(frozen=True)
class TaskResult:
    """What a Dask task returns: the log's summary, and its output files (path relative to
    the log's folder, bytes) when it was judged away from that folder."""

    summary: LogSummary
    files: tuple[tuple[str, bytes], ...] = ()


def ship(job: Job, limit_bytes: int) -> Job:
    """The job with its log's and labels' bytes attached when the log is a file of at most
    `limit_bytes` (a bag folder is never shipped: its workers must see it)."""
    stream = Path(job.stream)
    if limit_bytes <= 0 or not stream.is_file() or stream.stat().st_size > limit_bytes:
        return job
    shipped = [(job.stream, stream.read_bytes())]
    labels = job.options.labels_path
    if labels is not None and labels.is_file():
        shipped.append((str(labels), labels.read_bytes()))
    return replace(job, shipped=tuple(shipped))


#: The file a task judged in place leaves in its log's folder (see the module docstring).
TASK_FILE = ".casewatch-task.json"


def run_task(job: Job, fleet: str = "") -> TaskResult:
    """A Dask task: judge the log where it is, or, shipped, from copies, returning the files.
    `fleet` names this run of the fleet: a log whose folder says this fleet already judged it
    is not judged again."""
    if not job.shipped:
        marker = Path(job.out_dir) / TASK_FILE
        done = _already_done(marker, fleet)
        if done is not None:
            return TaskResult(done)
        summary = run_job(job)
        if fleet:
            marker.parent.mkdir(parents=True, exist_ok=True)
            record = {"fleet": fleet, "summary": summary.model_dump()}
            marker.write_text(json.dumps(record), encoding="utf-8")
        return TaskResult(summary)
    folder = Path(tempfile.mkdtemp(prefix="casewatch-ship-"))
    try:
        (folder / "log").mkdir()
        (folder / "labels").mkdir()
        stream_path, data = job.shipped[0]
        local_stream = folder / "log" / Path(stream_path).name
        local_stream.write_bytes(data)
        options = job.options
        if len(job.shipped) > 1:
            labels_path, labels = job.shipped[1]
            local_labels = folder / "labels" / Path(labels_path).name
            local_labels.write_bytes(labels)
            options = options.with_labels(local_labels)
        out = folder / "out"
        local = replace(
            job, stream=str(local_stream), out_dir=str(out), options=options, shipped=()
        )
        summary = run_job(local, recorded=job)
        files = tuple(
            (str(p.relative_to(out)), p.read_bytes()) for p in sorted(out.rglob("*")) if p.is_file()
        )
        return TaskResult(summary, files)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def written_summary(job: Job, fleet: str) -> LogSummary | None:
    """The summary a task of this fleet left in the log's folder once it had written the log's
    results (None when it had not): how a client that lost its scheduler keeps the logs its
    workers finished."""
    return None if job.shipped else _already_done(Path(job.out_dir) / TASK_FILE, fleet)


def _already_done(marker: Path, fleet: str) -> LogSummary | None:
    if not fleet:
        return None
    try:
        record = json.loads(marker.read_text(encoding="utf-8"))
        if record.get("fleet") != fleet:
            return None
        return LogSummary.model_validate(record["summary"])
    except (OSError, ValueError, KeyError, TypeError, AttributeError, ValidationError):
        return None


def receive(job: Job, result: TaskResult) -> LogSummary:
    """Write a shipped log's files into its folder (result.json last, atomically, so a folder
    with a result.json is always complete) and return its summary."""
    out = Path(job.out_dir)
    last = None
    for name, data in result.files:
        target = out / name
        if name == "result.json":
            last = (target, data)
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    if last is not None:
        target, data = last
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_name("result.json.partial")
        partial.write_bytes(data)
        partial.replace(target)
    return result.summary
