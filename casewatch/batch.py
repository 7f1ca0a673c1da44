"""Many logs at once: find them, judge each in a worker process or Dask task, write summary.json.

Composition only: each worker does what `casewatch run` does for one stream (prepare, evaluate,
write, render); `evaluator.summary` does the adding up. Every log ends as an entry of
summary.json, judged or failed with its reason, whatever happens to a worker or the scheduler
(docs/fleet.md); the paths a worker gets are absolute, so a worker in another working directory
reads the same files.
"""

from __future__ import annotations

import glob
import json
import multiprocessing
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field, replace
from pathlib import Path

from pydantic import ValidationError

from casewatch.crash import write_crash_log
from casewatch.errors import CasewatchError
from casewatch.evaluator.ground_truth import LabelsError
from casewatch.evaluator.options import AUTO_LABELS, RunOptions, RunSinks
from casewatch.evaluator.result import RunResult, result_digest
from casewatch.evaluator.session import InputError, evaluate_stream
from casewatch.evaluator.signal_store import FILE_NAME as SIGNALS_FILE
from casewatch.evaluator.stl_engines import EngineMismatch
from casewatch.evaluator.summary import FleetSummary, LogSummary, summarise, summarise_result
from casewatch.monitor.source import BAG_SUFFIXES, file_digest, path_digest, source_kind
from casewatch.monitor.warmup import warm_up
from casewatch.safety_case.findings import CaseError
from casewatch.safety_case.model import Case
from casewatch.spec.model import CompiledSpec

STREAM_SUFFIXES = (".jsonl", ".jsonl.gz", ".ndjson", ".ndjson.gz")
LABEL_SUFFIXES = (".labels.jsonl", "-labels.jsonl")


class NoStreams(CasewatchError, ValueError):
    """The pattern or folder matched no stream file."""


def is_stream_file(path: Path) -> bool:
    """A JSON Lines stream or a ROS 2 bag (an .mcap or .db3 file, or a bag folder); a storage
    file inside a bag folder belongs to that bag, not a log of its own."""
    name = path.name
    if source_kind(path) == "bag":
        return path.is_dir() or not (path.parent / "metadata.yaml").is_file()
    return name.endswith(STREAM_SUFFIXES) and not name.endswith(LABEL_SUFFIXES)


def find_streams(pattern: str) -> list[Path]:
    """A folder (its stream files, sorted), a glob, or a single file."""
    path = Path(pattern)
    if path.is_dir():
        if source_kind(path) == "bag":
            return [path]
        found = sorted(p for p in path.iterdir() if is_stream_file(p))
        if not found:
            raise NoStreams(
                f"{pattern}: no stream files in this folder (looked for "
                f"{', '.join(STREAM_SUFFIXES + BAG_SUFFIXES)} and bag folders; labels files "
                "are not streams)"
            )
        return found
    if any(ch in pattern for ch in "*?["):
        found = sorted(Path(p) for p in glob.glob(pattern) if is_stream_file(Path(p)))
        if not found:
            raise NoStreams(f"{pattern}: the pattern matches no stream file")
        return found
    return [path]


def stream_stem(path: Path) -> str:
    name = path.name
    for suffix in sorted(STREAM_SUFFIXES + BAG_SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return path.stem


def sibling_labels(path: Path) -> Path | None:
    """NAME.labels.jsonl beside the stream NAME.jsonl(.gz), as an absolute path (result.json
    records it, and `casewatch tune` reads it again from wherever it runs)."""
    candidate = path.with_name(stream_stem(path) + ".labels.jsonl")
    return candidate.resolve() if candidate.is_file() else None


def labels_for(stream: str, labels: str | None) -> str | None:
    """The labels file for `stream`: `--labels` as given, or with `auto` the sibling
    NAME.labels.jsonl when it exists (never for standard input)."""
    if labels != AUTO_LABELS:
        return labels
    found = None if stream == "-" else sibling_labels(Path(stream))
    return str(found) if found else None


@dataclass(frozen=True)
class Outputs:
    """What each log's folder gets besides result.json and events.jsonl (never changes a
    result, so not a run option)."""

    formats: tuple[str, ...] = ()  # reports to render (html, md, junit)
    save_signals: bool = False  # keep signals.npz (for casewatch tune and calibrate)


@dataclass(frozen=True)
class Job:
    """One log of a fleet, as a worker gets it: plain values only (it is pickled), every path
    absolute."""

    case_path: str
    stream: str
    out_dir: str
    options: RunOptions  # this log's: `--labels auto` already resolved to its file
    outputs: Outputs = field(default_factory=Outputs)
    # (path, bytes) of the log and its labels, sent along to a worker that does not share the
    # file system (`--ship-logs`); the results then come back with the task (casewatch.shipping)
    shipped: tuple[tuple[str, bytes], ...] = ()


def run_job(job: Job, recorded: Job | None = None) -> LogSummary:
    """Judge one log; never raises (the summary says what went wrong; an internal error leaves
    its traceback in the log's folder and marks the summary `crashed`). `recorded` is the job
    as the client sent it when `job` reads shipped copies: the result and summary name its
    paths, not the copies'."""
    from casewatch import api

    recorded = recorded or job
    started = time.perf_counter()
    out = Path(job.out_dir)

    def failed(error: str, **flags: bool) -> LogSummary:
        return LogSummary(
            stream=recorded.stream,
            out_dir=recorded.out_dir,
            ok=False,
            error=error.replace(job.stream, recorded.stream),
            seconds=round(time.perf_counter() - started, 3),
            **flags,
        )

    try:
        case, spec = _PREPARED.get(job.case_path) or api.prepare(job.case_path)
        sinks = RunSinks(
            events_path=out / "events.jsonl",
            signals_path=out / SIGNALS_FILE if job.outputs.save_signals else None,
        )
        result = evaluate_stream(case, spec, job.stream, job.options, sinks)
        if recorded is not job:
            result = as_recorded(result, recorded)
        api.write_result(result, out)
        if job.outputs.formats:
            api.render(out, job.outputs.formats)
    except (InputError, LabelsError, CaseError, OSError) as exc:
        return failed(str(exc))
    except EngineMismatch as exc:  # a bug in one of the STL engines, never a verdict: exit 4
        return failed(str(exc), engines_disagree=True)
    except Exception as exc:  # a bug: keep the other logs going, exit 3 at the end
        log = write_crash_log(exc, ["run", job.case_path, job.stream, "-o", job.out_dir], out)
        return failed(
            f"internal error ({type(exc).__name__}: {exc}); please attach {log} to a bug report",
            crashed=True,
        )
    return summarise_result(result, recorded.out_dir, time.perf_counter() - started)


def as_recorded(result: RunResult, recorded: Job) -> RunResult:
    """A result judged from shipped copies, naming the client's stream and labels paths."""
    stream = result.stream.model_copy(update={"path": recorded.stream})
    update: dict[str, object] = {"stream": stream, "options": recorded.options.recorded()}
    if result.ground_truth is not None and recorded.options.labels is not None:
        update["ground_truth"] = result.ground_truth.model_copy(
            update={"labels_path": recorded.options.labels}
        )
    return result.model_copy(update=update)


class FleetError(CasewatchError, ValueError):
    """A `summary.json` that is not a casewatch fleet summary (names the file)."""


def read_summary(folder: Path) -> dict:
    """A fleet folder's `summary.json`, checked to hold a `per_log` list of logs with their
    `out_dir` (what `diff`, `tune`, `calibrate` and `report` read of a fleet)."""
    path = Path(folder) / "summary.json"
    try:
        summary = json.loads(
            path.read_text(encoding="utf-8"),
            parse_int=lambda d: int(d) if len(d) < 300 else float(d),
        )
        if not isinstance(summary, dict) or not isinstance(summary.get("per_log"), list):
            raise ValueError("no per_log list")
        if not all(isinstance(log, dict) and "out_dir" in log for log in summary["per_log"]):
            raise ValueError("a log without out_dir")
        FleetSummary.model_validate(summary)  # types of what is there; the file as written
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise FleetError(
            f"{path}: not a casewatch fleet summary ({where}: {first['msg']})"
        ) from None
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise FleetError(f"{path}: not a casewatch fleet summary ({exc})") from None
    return summary


def reusable(job: Job, case_digest: str) -> LogSummary | None:
    """The summary of a log already judged completely with this case, these run options and
    from this stream (its result.json's case digest, recorded options and stream sha256 match,
    its labels file is the one scored, and its own content digest still matches its content:
    an edited or damaged result is judged again), else None (`--resume`)."""
    from casewatch.reports.render import ResultError, load_result

    try:
        result = load_result(Path(job.out_dir) / "result.json")
    except ResultError:
        return None
    if result.content_digest is None or result.content_digest != result_digest(result):
        return None
    if not result.complete or result.case.digest != case_digest:
        return None
    if result.options != job.options.recorded():
        return None
    try:
        if result.stream.digest != path_digest(job.stream):
            return None
        labels = job.options.labels_path
        if labels is not None and (
            result.ground_truth is None or result.ground_truth.labels_digest != file_digest(labels)
        ):
            return None
    except OSError:
        return None
    return summarise_result(result, job.out_dir, 0.0)


#: Runs the jobs it is given, telling `finished(i, summary)` of the i-th as each ends; returns
#: None, or why the engine was lost before every job finished (the Dask scheduler died).
Runner = Callable[[list[Job], Callable[[int, LogSummary], None]], "str | None"]


#: The cases of the local runner's jobs, loaded, checked and compiled once for all its logs
#: (about 0.14 s a time for the reference case) by `_prepared_once`, before its workers fork.
#: Only the local runner fills it, for the time of one run: a Dask worker lives on between
#: runs, so it prepares the case for every job, as before.
Prepared = dict[str, tuple[Case, CompiledSpec]]
_PREPARED: Prepared = {}


@contextmanager
def _prepared_once(work: list[Job], prepared: Prepared) -> Iterator[None]:
    """`_PREPARED` filled with each case of `work` (from `prepared` when there, else prepared
    here, when it prepares without error: one that does not is left to `run_job`, which
    reports it per log), and emptied after."""
    from casewatch import api

    try:
        for path in {job.case_path for job in work}:
            with suppress(CaseError, OSError):
                _PREPARED[path] = prepared.get(path) or api.prepare(path)
        yield
    finally:
        _PREPARED.clear()


def local_runner(jobs: int = 1, prepared: Prepared | None = None) -> Runner:
    """Jobs in this process (`jobs` 1) or in `jobs` forked worker processes. `prepared`:
    cases the caller has already loaded and compiled, by absolute path (what `Job` holds)."""

    def run(work: list[Job], finished: Callable[[int, LogSummary], None]) -> str | None:
        with _prepared_once(work, prepared or {}):
            if jobs <= 1:
                for k, job in enumerate(work):
                    finished(k, run_job(job))
                return None
            # Compile once here: forked workers inherit the kernels; spawned ones (where fork
            # is unavailable) load them from the disk cache this fills instead of each
            # compiling.
            warm_up()
            methods = multiprocessing.get_all_start_methods()
            context = multiprocessing.get_context("fork" if "fork" in methods else None)
            with ProcessPoolExecutor(max_workers=jobs, mp_context=context) as pool:
                for k, summary in enumerate(pool.map(run_job, work)):
                    finished(k, summary)
        return None

    return run


def plan_jobs(
    case_path: str, streams: Sequence[Path], out_dir: Path, options: RunOptions, outputs: Outputs
) -> list[Job]:
    """One job per stream, each in its own folder under `out_dir` (named after the stream,
    `-2`, `-3`, ... when two streams share a name), with `--labels auto` resolved and every
    path absolute (a worker may run in another working directory, or on another machine)."""
    absolute = Path(case_path).absolute()
    options = replace(
        options,
        topics=None if options.topics is None else str(Path(options.topics).absolute()),
        labels=options.labels
        if options.labels in (None, AUTO_LABELS)
        else str(Path(options.labels).absolute()),
    )
    used: set[str] = set()
    work: list[Job] = []
    for stream in streams:
        stem = stream_stem(stream)
        name, n = stem, 2
        while name in used:
            name, n = f"{stem}-{n}", n + 1
        used.add(name)
        path = Path(stream).absolute()
        labels = labels_for(str(path), options.labels)
        work.append(
            Job(
                str(absolute),
                str(path),
                str(out_dir.absolute() / name),
                options.with_labels(labels),
                outputs,
            )
        )
    return work


class FleetLost(CasewatchError):
    """The Dask scheduler was lost mid-fleet: the unfinished logs are failed entries of the
    summary.json written before this is raised (exit 2: run again with --resume)."""


def run_many(
    case_path: str,
    case_digest: str,
    streams: Sequence[Path],
    out_dir: Path,
    options: RunOptions,
    outputs: Outputs = Outputs(),
    runner: Runner | None = None,
    *,
    on_done: Callable[[LogSummary], None] | None = None,
    on_resumed: Callable[[LogSummary], None] | None = None,
    resume: bool = False,
) -> dict[str, object]:
    """Judge every stream with `options` (by `runner`: `local_runner`, or
    `dask_engine.dask_runner`) and write `out_dir/summary.json`; `on_done` hears of each log
    judged as it finishes, `on_resumed` of each reused one. With `resume`, a log whose complete
    `result.json` was judged with this case (digest), these options, from this very stream
    (sha256) is not judged again. Raises `FleetLost` (after writing summary.json, every
    unfinished log a failed entry) when the runner's cluster is lost."""
    work = plan_jobs(case_path, streams, out_dir, options, outputs)
    done: dict[int, LogSummary] = {}
    if resume:
        for k, job in enumerate(work):
            reused = reusable(job, case_digest)
            if reused is not None:
                done[k] = reused
                if on_resumed:
                    on_resumed(reused)
    todo = [k for k in range(len(work)) if k not in done]

    def finished(i: int, summary: LogSummary) -> None:
        done[todo[i]] = summary
        if on_done:
            on_done(summary)

    lost = (runner or local_runner())([work[k] for k in todo], finished)
    unfinished = [k for k in todo if k not in done]
    for k in unfinished:
        done[k] = LogSummary(
            stream=work[k].stream, out_dir=work[k].out_dir, ok=False, error=f"not judged: {lost}"
        )
    summary = summarise([done[k] for k in range(len(work))], case_path, case_digest)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=1), encoding="utf-8")
    if lost is not None:
        raise FleetLost(
            f"{lost}; {len(unfinished)} log(s) not judged, listed as failed in "
            f"{out_dir / 'summary.json'}: run the same command with --resume once it is back"
        )
    return summary
