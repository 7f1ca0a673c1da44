"""One run: read frames, compute metrics, judge them, and assemble the `RunResult`.

This is the composition the CLI and the Python API call. It streams: frames are read, scored
and dropped one at a time, so memory does not grow with run length beyond the result records
(episodes, gaps, status intervals and the bounded plot series).
"""

from __future__ import annotations

import datetime as dt
import io
import math
import time
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from casewatch import __version__
from casewatch.errors import CasewatchError
from casewatch.evaluator.core import Evaluator, rtamt_monitor
from casewatch.evaluator.drive_log import DriveLog
from casewatch.evaluator.eventlog import Event, EventLog
from casewatch.evaluator.ground_truth import read_labels, score_events
from casewatch.evaluator.inputs import open_hashed, path_digest
from casewatch.evaluator.intervals import RunLength
from casewatch.evaluator.result import (
    ArbitrationInterval,
    CaseInfo,
    Episode,
    RootNoData,
    RunResult,
    StreamDefect,
    StreamInfo,
    Timings,
)
from casewatch.evaluator.scoring import score_run
from casewatch.evaluator.signal_store import Columns, SignalRecorder
from casewatch.evaluator.stl_engines import (
    ENGINES,
    CheckedMonitor,
    EngineMismatch,
    Mismatch,
    PrecomputedMonitor,
    evaluate_whole_log,
    input_names,
)
from casewatch.monitor.bags.mapping import MappingError, resolve_mapping
from casewatch.monitor.bags.reader import BagError, BagReader, is_bag, read_bag
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.frames import Coverage, Header
from casewatch.monitor.reader import StreamError, read_stream
from casewatch.monitor.world import condition_values
from casewatch.safety_case.model import Case, NodeType
from casewatch.spec.model import CompiledFormula, CompiledSpec

#: How many defects result.json lists in full (the count is always exact).
MAX_LISTED_DEFECTS = 1000

#: Default of `--max-no-data`: the bundled drives' root goal is `no-data` on 2-3 % of ticks
#: (warm-up), a drive with a channel missing throughout on all of them.
DEFAULT_MAX_NO_DATA = 0.5


class InputError(CasewatchError):
    """Input the run cannot use (unreadable stream, period mismatch, strict-mode defect)."""


@dataclass
class RunOptions:
    strict: bool = False
    labels: Path | None = None
    events_path: Path | None = None  # events.jsonl, appended and flushed as events close
    on_event: Callable[[Event], None] | None = None
    progress: Callable[[int, float], None] | None = None  # (frames, stream time) every ~1 s
    series_points: int = 1000
    # the largest share of ticks the root goal may be `no-data` before the run is unusable input
    max_no_data: float = DEFAULT_MAX_NO_DATA
    # where to save every per-tick signal value (`signals.npz`, evaluator.signal_store); None: not
    signals_path: Path | None = None
    fail_on: str = "any"  # which episodes fail the run (evaluator.policy), recorded in the result
    # the topic mapping for a ROS 2 bag (`--topics`); None: the case's `monitor.topics`
    topics: Path | None = None
    stl_engine: str = "rtamt"  # rtamt, numpy or both (evaluator.stl_engines)
    # after each frame judged tick by tick: (frame, every node's status, evaluator, reader);
    # how live views (casewatch.live) follow a run without reaching into this loop
    on_tick: Callable[[Any, Mapping[str, str], Evaluator, Any], None] | None = None


@dataclass
class _Clock:
    read: float = 0.0
    metrics: float = 0.0
    judge: float = 0.0
    started: float = field(default_factory=time.perf_counter)


def case_info(case: Case, spec: CompiledSpec) -> CaseInfo:
    return CaseInfo.from_case(case, spec.root_id, {f.node_id: f.id for f in spec.formulas})


def evaluate_stream(
    case: Case, spec: CompiledSpec, source: str | Path, options: RunOptions | None = None
) -> RunResult:
    """Judge one stream (a path, or `-` for standard input) against a compiled case.

    Raises `InputError` for input that cannot be judged; labels are read before the stream so
    a bad labels file fails fast.
    """
    options = options or RunOptions()
    if not case.monitor.channels:
        raise InputError(
            f"{case.path} has no `monitor` block: it is a pure argument (checked, "
            "nothing to judge); add monitor: {channels: [...], period: 0.1s} and "
            "bind evidence with spi: to monitor it"
        )
    whole_log = options.stl_engine != "rtamt"
    if options.stl_engine not in ENGINES:
        raise InputError(f"unknown STL engine {options.stl_engine!r} (one of {', '.join(ENGINES)})")
    if whole_log and str(source) == "-":
        raise InputError(
            f"--stl-engine {options.stl_engine} judges whole logs; a live stream on "
            "standard input needs --stl-engine rtamt"
        )
    labels = None
    if options.labels is not None:
        labels = read_labels(options.labels)
    bag = is_bag(source)
    if bag:
        reader, name, digest = _open_bag(case, source, options)
        binary = hashing = None
    else:
        try:
            binary, hashing, name = open_hashed(source)
        except OSError as exc:
            raise InputError(f"{source}: cannot read stream: {exc.strerror or exc}") from None
    log = EventLog(options.events_path) if options.events_path else None
    where = DriveLog()  # the ego's position and what the scores read, per tick

    def emit(event: Event) -> None:
        if isinstance(event, Episode):
            where.place([event])  # its position, in events.jsonl as in result.json
        if log is not None:
            log.write(event)
        if options.on_event is not None:
            options.on_event(event)

    evaluator = Evaluator(case, spec, on_event=emit, series_points=options.series_points)
    columns = Columns(input_names(spec)) if whole_log else None
    conditions: dict = {}  # the stream's conditions (docs/odd.md), one mapping per change
    as_signals = condition_values(conditions)  # their `night` and `fog` signals
    tick_conditions: list[dict] = []  # per tick, for the whole-log replay
    engine = MetricEngine(case.monitor.metrics, list(case.monitor.channels))
    recorder = None
    if options.signals_path is not None:
        inputs = {name for f in spec.formulas for g in f.monitored() for name in g.signals}
        names = [*engine.signal_names, *sorted(inputs - set(engine.signal_names))]
        recorder = SignalRecorder(names, case.monitor.period, case.monitor.metrics.max_gap)
    if not bag:
        text = io.TextIOWrapper(binary, encoding="utf-8", errors="strict")
        reader = read_stream(
            text,
            strict=options.strict,
            channels=list(case.monitor.channels),
            period=case.monitor.period,
        )
    arbitration = RunLength()
    clock = _Clock()
    complete = True
    t_first: float | None = None
    t_last: float | None = None
    next_progress = time.perf_counter() + 1.0
    period_checked = False
    try:
        try:
            for frame in _timed(reader, clock):
                t1 = time.perf_counter()
                if not period_checked:
                    period_checked = True
                    _check_period(reader, case, name)
                    engine.coverage = channel_coverage(case, reader.header)
                    if reader.header is not None:
                        conditions = dict(reader.header.conditions)
                    as_signals = condition_values(conditions)
                if frame.odd:
                    conditions = {**conditions, **frame.odd}
                    as_signals = condition_values(conditions)  # only when they change
                values = engine.step(frame)
                values.update(as_signals)
                where.add(frame, engine.last_arbitration, values)  # before any episode closes
                if recorder is not None:
                    recorder.add(frame.t, values)
                t2 = time.perf_counter()
                if columns is not None:
                    columns.add(frame.t, values)  # judged once the whole log is read
                    tick_conditions.append(conditions)
                else:
                    statuses = evaluator.step(frame.t, values, conditions)
                    if options.on_tick is not None:
                        options.on_tick(frame, statuses, evaluator, reader)
                t3 = time.perf_counter()
                arbitration.add(frame.t, engine.last_arbitration)
                clock.metrics += t2 - t1
                clock.judge += t3 - t2
                if t_first is None:
                    t_first = frame.t
                t_last = frame.t
                if options.progress is not None and t3 >= next_progress:
                    options.progress(reader.frames_read, frame.t)
                    next_progress = t3 + 1.0
        except StreamError as exc:
            evaluator.finish()  # episodes closed so far still reach events.jsonl
            raise InputError(f"{exc} (--strict stops at the first defect)") from None
        except UnicodeDecodeError as exc:
            raise InputError(f"{name}: stream is not UTF-8 text ({exc.reason})") from None
        except KeyboardInterrupt:
            complete = False
        finally:
            if binary is not None:
                binary.close()
                hashing.close()
        if columns is not None:
            evaluator = _judge_whole_log(case, spec, columns, tick_conditions, options, emit, clock)
        evaluator.finish()
    finally:
        if log is not None:
            log.close()
        if recorder is not None:
            recorder.save(options.signals_path)
    total = time.perf_counter() - clock.started
    stream = StreamInfo(
        path=str(source),
        digest=digest if bag else hashing.sha256.hexdigest(),
        meta=dict(reader.header.meta) if reader.header is not None else {},
        frames_read=reader.frames_read,
        t_start=t_first,
        t_end=t_last,
        duration=0.0 if t_first is None else round(t_last - t_first + case.monitor.period, 6),
        defects=[
            StreamDefect(line=d.line, kind=d.kind, message=d.message)
            for d in reader.defects[:MAX_LISTED_DEFECTS]
        ],
        defect_count=len(reader.defects),
        dropouts=dict(reader.dropouts),
        topics=reader.topic_report() if bag else {},
    )
    statuses = evaluator.node_statuses()
    root = next(s for s in statuses if s.node_id == spec.root_id)
    root_ticks = sum(root.ticks.values())
    no_data_ticks = root.ticks.get("no-data", 0)
    share = no_data_ticks / root_ticks if root_ticks else 1.0
    ground_truth = None
    if labels is not None:
        hazards = {
            n.id: n.text
            for n in case.nodes.values()
            if n.type is NodeType.COUNTER_SOLUTION and n.hazard is not None
        }
        ground_truth = score_events(
            evaluator.episodes, labels[0], hazards, str(options.labels), labels[1]
        )
    return RunResult(
        casewatch_version=__version__,
        created=dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        case=case_info(case, spec),
        stream=stream,
        verdict=root.worst if root.timeline else "no-data",
        formulas=evaluator.formula_stats(),
        episodes=evaluator.episodes,
        near_misses=evaluator.near_misses,
        data_gaps=evaluator.data_gaps,
        status=statuses,
        series=evaluator.series(),
        arbitration=[
            ArbitrationInterval(
                channel=r.value, start=round(r.start, 6), end=round(r.end, 6), ticks=r.ticks
            )
            for r in arbitration.runs
        ],
        ground_truth=ground_truth,
        timings=Timings(
            total_s=round(total, 6),
            read_s=round(clock.read, 6),
            metrics_s=round(clock.metrics, 6),
            stl_s=round(evaluator.stl_seconds, 6),
            episodes_status_s=round(clock.judge - evaluator.stl_seconds, 6),
            frames_per_s=round(reader.frames_read / total, 1) if total > 0 else 0.0,
            peak_rss_mib=peak_rss_mib(),
        ),
        complete=complete,
        fail_on=options.fail_on,
        root_no_data=RootNoData(
            ticks=root_ticks,
            no_data_ticks=no_data_ticks,
            share=round(share, 6),
            limit=options.max_no_data,
            exceeded=share > options.max_no_data,
        ),
        conditions=evaluator.condition_stats(),
        odd=evaluator.odd_summaries(),
        track=where.track(),
        scores=score_run(
            evaluator.episodes,
            evaluator.formula_stats(),
            where.times(),
            where.columns(),
            case.monitor.period,
            case.monitor.scoring,
        ),
    )


def _judge_whole_log(
    case: Case,
    spec: CompiledSpec,
    columns: Columns,
    conditions: list[dict],
    options: RunOptions,
    emit: Callable[[Event], None],
    clock: _Clock,
) -> Evaluator:
    """Every formula over the whole log at once (numpy), then the ticks replayed through the
    evaluator with those values; with `both`, rtamt runs too and must agree on every value."""
    started = time.perf_counter()
    whole = evaluate_whole_log(spec, columns, case.monitor.metrics.max_gap)
    vector_s = time.perf_counter() - started
    found: list[Mismatch] = []
    counter = [0]

    def factory(f: CompiledFormula, period: float) -> PrecomputedMonitor | CheckedMonitor:
        if options.stl_engine == "numpy":
            return PrecomputedMonitor(whole.values[f.id])
        return CheckedMonitor(rtamt_monitor(f, period), f, whole, found, counter)

    evaluator = Evaluator(
        case, spec, on_event=emit, monitor_factory=factory, series_points=options.series_points
    )
    t = columns.t.tolist()
    replay = time.perf_counter()
    for i, ti in enumerate(t):
        evaluator.step(ti, columns.row(i), conditions[i])
    clock.judge += time.perf_counter() - replay + vector_s
    evaluator.stl_seconds += vector_s
    if counter[0]:
        raise EngineMismatch(found, counter[0])
    return evaluator


def _open_bag(case: Case, source: str | Path, options: RunOptions) -> tuple[BagReader, str, str]:
    """A bag's reader, display name and digest (sha256 of its files), or `InputError`."""
    try:
        mapping = resolve_mapping(options.topics, case.path, case.monitor.topics)
        reader = read_bag(
            source,
            mapping,
            channels=list(case.monitor.channels),
            period=case.monitor.period,
            strict=options.strict,
        )
        return reader, str(source), path_digest(source)
    except (MappingError, BagError) as exc:
        raise InputError(str(exc)) from None
    except OSError as exc:
        raise InputError(f"{source}: cannot read the bag: {exc.strerror or exc}") from None


def _timed(reader, clock: _Clock) -> Iterator:
    """The reader's frames, with the time spent reading and parsing added to `clock.read`."""
    frames = iter(reader)
    while True:
        started = time.perf_counter()
        try:
            frame = next(frames)
        except StopIteration:
            return
        clock.read += time.perf_counter() - started
        yield frame


def peak_rss_mib(pid: int | str = "self") -> float | None:
    """Peak resident memory of a process since its exec (Linux `VmHWM`), in MiB.

    Not `getrusage`: on Linux its maximum also counts the parent's memory at fork time, which
    would charge the caller's memory to the run.
    """
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return round(int(line.split()[1]) / 1024, 1)
    except OSError:
        return None
    return None


def channel_coverage(case: Case, header: Header | None) -> dict[str, Coverage]:
    """What each channel can see: the case's `monitor.coverage` where it declares a channel,
    else the stream header's `coverage`, else all-round (spi-reference "Channel coverage").
    The case wins because it is the reviewed statement of the system under judgement."""
    out = dict(header.coverage) if header is not None else {}
    for channel, declared in case.monitor.coverage.items():
        out[channel] = Coverage(
            declared.fov_deg, math.inf if declared.range_m is None else declared.range_m
        )
    return {c: out.get(c, Coverage()) for c in case.monitor.channels}


def _check_period(reader, case: Case, name: str) -> None:
    header = reader.header
    if header is not None and abs(header.period - case.monitor.period) > 1e-9:
        raise InputError(
            f"{name}:1: the stream's period is {header.period:g} s but the case's "
            f"monitor.period is {case.monitor.period:g} s; STL windows would be wrong "
            "(resample the stream or set monitor.period to match)"
        )
