"""One run: open the source, read frames, compute metrics, judge them, assemble the `RunResult`.

This is the composition the CLI and the Python API call, as named stages (`evaluate_stream`
reads as the list of them): check the run can be judged, read the labels, open the source
(`monitor.source`), then per frame the metrics, the ODD conditions, the signal recording and
the STL engine (tick by tick, or the whole log at the end), and last the assembly of the
stream record, timings, ground truth and scores. It streams: frames are read, scored and
dropped one at a time, so memory does not grow with run length beyond the result records
(episodes, gaps, status intervals and the bounded plot series).
"""

from __future__ import annotations

import datetime as dt
import importlib.metadata
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from functools import cache
from pathlib import Path

import numpy as np

from casewatch.errors import CasewatchError
from casewatch.evaluator.core import Evaluator, rtamt_monitor
from casewatch.evaluator.drive_log import DriveLog
from casewatch.evaluator.eventlog import Event, EventLog
from casewatch.evaluator.ground_truth import Label, read_labels, score_events
from casewatch.evaluator.intervals import RunLength
from casewatch.evaluator.offline import LIVE_ENGINE, check_online, is_live_source, resolve_engine
from casewatch.evaluator.options import DEFAULT_MAX_NO_DATA, RunOptions, RunSinks
from casewatch.evaluator.result import (
    ArbitrationInterval,
    CaseInfo,
    Episode,
    GroundTruth,
    RootNoData,
    RunResult,
    StreamDefect,
    StreamInfo,
    Timings,
)
from casewatch.evaluator.scoring import score_run
from casewatch.evaluator.signal_store import Columns, SignalRecorder
from casewatch.evaluator.stl_engines import (
    CheckedMonitor,
    EngineMismatch,
    Mismatch,
    PrecomputedMonitor,
    evaluate_whole_log,
    input_names,
)
from casewatch.evaluator.whole_log import NotReplayable, judge_whole_log
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.frames import Coverage, Frame, Header
from casewatch.monitor.reader import StreamError
from casewatch.monitor.source import Source, SourceError, open_source
from casewatch.monitor.world import condition_values
from casewatch.safety_case.model import Case, NodeType
from casewatch.spec.model import CompiledFormula, CompiledSpec

__all__ = [
    "DEFAULT_MAX_NO_DATA",
    "InputError",
    "RunOptions",
    "RunSinks",
    "evaluate_stream",
]

#: How many defects result.json lists in full (the count is always exact).
MAX_LISTED_DEFECTS = 1000


class InputError(CasewatchError):
    """Input the run cannot use (unreadable stream, period mismatch, strict-mode defect)."""


@dataclass
class _Clock:
    read: float = 0.0
    metrics: float = 0.0
    judge: float = 0.0
    started: float = field(default_factory=time.perf_counter)


def case_info(case: Case, spec: CompiledSpec) -> CaseInfo:
    return CaseInfo.from_case(case, spec.root_id, {f.node_id: f.id for f in spec.formulas})


def evaluate_stream(
    case: Case,
    spec: CompiledSpec,
    source: str | Path,
    options: RunOptions | None = None,
    sinks: RunSinks | None = None,
    *,
    payload: bytes | None = None,
) -> RunResult:
    """Judge one stream (a path, or `-` for standard input) against a compiled case.

    `options` shape the result; `sinks` say where the event log, the signals and live events
    go; `payload` is a JSON Lines log's bytes when they were shipped instead of read from
    `source`. Raises `InputError` for input that cannot be judged; labels are read before the
    stream so a bad labels file fails fast.
    """
    options = options or RunOptions()
    sinks = sinks or RunSinks()
    if options.check_online and is_live_source(source):
        raise InputError("--check-online judges a log twice; standard input can be read once")
    # a sink that follows the ticks as they are judged (casewatch.live) needs the live path
    result = _evaluate(case, spec, source, options, sinks, payload, sinks.on_tick is not None)
    if options.check_online:  # issue 36: the whole-log path must give the live path's result
        online = _evaluate(case, spec, source, options, RunSinks(), payload, True)
        check_online(source, result, online)
    return result


def _evaluate(
    case: Case,
    spec: CompiledSpec,
    source: str | Path,
    options: RunOptions,
    sinks: RunSinks,
    payload: bytes | None,
    live: bool,
) -> RunResult:
    """The stages, judged by the engine `options.stl_engine` resolves to for this source (the
    result records the options as given: `--resume` compares them)."""
    engine = LIVE_ENGINE if live else resolve_engine(options.stl_engine, source)
    judging = replace(options, stl_engine=engine)
    check_judgeable(case, source, judging)
    labels = read_run_labels(options)
    opened = open_run_source(case, source, options, payload)
    run = Judging(case, spec, judging, sinks)
    complete = run.read(opened)
    return assemble_result(case, spec, options, opened, run, labels, complete)


def check_judgeable(case: Case, source: str | Path, options: RunOptions) -> None:
    """Stage 0: the case has something to monitor, and the engine can judge this source."""
    if not case.monitor.channels:
        raise InputError(
            f"{case.path} has no `monitor` block: it is a pure argument (checked, "
            "nothing to judge); add monitor: {channels: [...], period: 0.1s} and "
            "bind evidence with spi: to monitor it"
        )
    if options.stl_engine != "rtamt" and is_live_source(source):
        raise InputError(
            f"--stl-engine {options.stl_engine} judges whole logs; a live stream on "
            "standard input needs --stl-engine rtamt"
        )


def read_run_labels(options: RunOptions) -> tuple[list[Label], str] | None:
    """Stage 1: the ground-truth labels and their sha256 (`LabelsError` for a bad file)."""
    path = options.labels_path
    return None if path is None else read_labels(path)


def open_run_source(
    case: Case, source: str | Path, options: RunOptions, payload: bytes | None = None
) -> Source:
    """Stage 2: the stream or bag, opened with the case's channels and period."""
    try:
        return open_source(
            source,
            channels=list(case.monitor.channels),
            period=case.monitor.period,
            strict=options.strict,
            topics=options.topics_path,
            case_path=case.path,
            case_topics=case.monitor.topics,
            payload=payload,
        )
    except SourceError as exc:
        raise InputError(str(exc)) from None


class _Events:
    """Where a closed event goes: its position from the drive log, events.jsonl, the caller."""

    def __init__(self, sinks: RunSinks, where: DriveLog) -> None:
        self.sinks = sinks
        self.where = where
        self.log = EventLog(sinks.events_path) if sinks.events_path else None

    def emit(self, event: Event) -> None:
        if isinstance(event, Episode):
            self.where.place([event])  # its position, in events.jsonl as in result.json
        if self.log is not None:
            self.log.write(event)
        if self.sinks.on_event is not None:
            self.sinks.on_event(event)

    def close(self) -> None:
        if self.log is not None:
            self.log.close()


class OddTracker:
    """The stream's reported conditions (docs/odd.md): the header's, updated by each frame's
    `odd` changes, and their `night` and `fog` signals (recomputed only when they change)."""

    def __init__(self) -> None:
        self.conditions: dict = {}
        self.signals = condition_values(self.conditions)

    def start(self, header: Header | None) -> None:
        if header is not None:
            self.conditions = dict(header.conditions)
        self.signals = condition_values(self.conditions)

    def update(self, frame: Frame) -> None:
        if frame.odd:
            self.conditions = {**self.conditions, **frame.odd}
            self.signals = condition_values(self.conditions)


def signal_recorder(
    case: Case, spec: CompiledSpec, engine: MetricEngine, sinks: RunSinks
) -> SignalRecorder | None:
    """Records every per-tick signal value for `signals.npz` when the run keeps them: the
    metric engine's signals, then the formulas' other inputs in name order."""
    if sinks.signals_path is None:
        return None
    inputs = {name for f in spec.formulas for g in f.monitored() for name in g.signals}
    names = [*engine.signal_names, *sorted(inputs - set(engine.signal_names))]
    return SignalRecorder(names, case.monitor.period, case.monitor.metrics.max_gap)


class TickJudge:
    """The rtamt engine: every tick judged as it arrives (a live stream's only engine)."""

    def __init__(self, evaluator: Evaluator) -> None:
        self.evaluator = evaluator

    def step(self, t: float, values: dict, conditions: dict) -> dict[str, str]:
        return self.evaluator.step(t, values, conditions)  # every node's status at t

    def judged(self, clock: _Clock) -> Evaluator:
        return self.evaluator


class WholeLogJudge:
    """The numpy (or `both`) engine: the ticks kept as columns, every formula judged over the
    whole log once it is read; with numpy, episodes, gaps and statuses are then formed from
    the whole arrays (`whole_log.judge_whole_log`), with `both` the ticks are replayed through
    an evaluator with rtamt running too, which must agree on every value (`EngineMismatch`)."""

    def __init__(self, case: Case, spec: CompiledSpec, options: RunOptions, emit) -> None:
        self.case, self.spec, self.options, self.emit = case, spec, options, emit
        self.columns = Columns(input_names(spec))
        #: the conditions where they change: (first tick, mapping); the same mapping object
        #: stands for the ticks up to the next change (`OddTracker` replaces it on a change)
        self.conditions: list[tuple[int, dict]] = []
        self._latest: dict | None = None

    def step(self, t: float, values: dict, conditions: dict) -> None:
        if conditions is not self._latest:
            self.conditions.append((self.columns.n, conditions))
            self._latest = conditions
        self.columns.add(t, values)

    def judged(self, clock: _Clock) -> Evaluator:
        case, spec, options, columns = self.case, self.spec, self.options, self.columns
        started = time.perf_counter()
        whole = evaluate_whole_log(spec, columns, case.monitor.metrics.max_gap)
        vector_s = time.perf_counter() - started
        found: list[Mismatch] = []
        counter = [0]

        def factory(f: CompiledFormula, period: float) -> PrecomputedMonitor | CheckedMonitor:
            if options.stl_engine == "numpy":
                return PrecomputedMonitor(whole.values[f.id])
            return CheckedMonitor(rtamt_monitor(f, period), f, whole, found, counter)

        replay = time.perf_counter()
        evaluator: Evaluator | None = None
        if options.stl_engine == "numpy":
            evaluator = self._evaluator(_no_monitor)
            try:
                judge_whole_log(evaluator, columns, self.conditions, whole.values)
            except NotReplayable:
                evaluator = None
        if evaluator is None:
            evaluator = self._evaluator(factory)
            replay_ticks(evaluator, columns, self.conditions)
        clock.judge += time.perf_counter() - replay + vector_s
        evaluator.stl_seconds += vector_s
        if counter[0]:
            raise EngineMismatch(found, counter[0])
        return evaluator

    def _evaluator(self, factory) -> Evaluator:
        return Evaluator(
            self.case,
            self.spec,
            on_event=self.emit,
            monitor_factory=factory,
            series_points=self.options.series_points,
        )


def replay_ticks(evaluator: Evaluator, columns: Columns, changes: list[tuple[int, dict]]) -> None:
    """Every tick of `columns` through `evaluator.step`, under the conditions of its stretch."""
    t = columns.t.tolist()
    bounds = [*(i for i, _ in changes[1:]), len(t)] if changes else []
    for (start, conditions), stop in zip(changes, bounds, strict=True):
        for i in range(start, stop):
            evaluator.step(t[i], columns.row(i), conditions)


def _no_monitor(formula: CompiledFormula, period: float) -> PrecomputedMonitor:
    return PrecomputedMonitor(_NO_VALUES)


_NO_VALUES = np.zeros(0)


class Judging:
    """Stages 3-6 over the frames of one source: metrics, ODD tracking, signal recording and
    the STL engine, with the drive log and the arbitration record the result is assembled
    from. `read` consumes the source; `evaluator` is the judged one afterwards."""

    def __init__(
        self, case: Case, spec: CompiledSpec, options: RunOptions, sinks: RunSinks
    ) -> None:
        self.case, self.spec, self.options, self.sinks = case, spec, options, sinks
        self.where = DriveLog()  # the ego's position and what the scores read, per tick
        self.events = _Events(sinks, self.where)
        # the whole-log path judges with the evaluator WholeLogJudge builds: this one only
        # closes what a stream defect interrupts, so it gets no rtamt monitors to build
        self.evaluator = Evaluator(
            case,
            spec,
            on_event=self.events.emit,
            series_points=options.series_points,
            **({} if options.stl_engine == LIVE_ENGINE else {"monitor_factory": _no_monitor}),
        )
        self.judge: TickJudge | WholeLogJudge = (
            TickJudge(self.evaluator)
            if options.stl_engine == "rtamt"
            else WholeLogJudge(case, spec, options, self.events.emit)
        )
        self.odd = OddTracker()
        self.engine = MetricEngine(case.monitor.metrics, list(case.monitor.channels))
        self.recorder = signal_recorder(case, spec, self.engine, sinks)
        self.arbitration = RunLength()
        self.clock = _Clock()
        self.t_first: float | None = None
        self.t_last: float | None = None

    def read(self, source: Source) -> bool:
        """Judge every frame of `source`; False when interrupted (Ctrl-C) before its end."""
        complete = True
        try:
            try:
                complete = self._frames(source)
            finally:
                source.close()
            self.evaluator = self.judge.judged(self.clock)
            self.evaluator.finish()
        finally:
            self.events.close()
            if self.recorder is not None and self.sinks.signals_path is not None:
                self.recorder.save(self.sinks.signals_path)
        return complete

    def _frames(self, source: Source) -> bool:
        reader = source.reader
        next_progress = time.perf_counter() + 1.0
        started = False
        try:
            for frame in _timed(reader, self.clock):
                t1 = time.perf_counter()
                if not started:
                    started = True
                    _check_period(reader, self.case, source.name)
                    self.engine.coverage = channel_coverage(self.case, reader.header)
                    self.odd.start(reader.header)
                self.odd.update(frame)
                values = self.engine.step(frame)
                values.update(self.odd.signals)
                # before any episode closes: an episode's position is read from here
                self.where.add(frame, self.engine.last_arbitration, values)
                if self.recorder is not None:
                    self.recorder.add(frame.t, values)
                t2 = time.perf_counter()
                statuses = self.judge.step(frame.t, values, self.odd.conditions)
                if statuses is not None and self.sinks.on_tick is not None:  # casewatch.live
                    self.sinks.on_tick(frame, statuses, self.evaluator, reader)
                t3 = time.perf_counter()
                self.arbitration.add(frame.t, self.engine.last_arbitration)
                self.clock.metrics += t2 - t1
                self.clock.judge += t3 - t2
                if self.t_first is None:
                    self.t_first = frame.t
                self.t_last = frame.t
                if self.sinks.progress is not None and t3 >= next_progress:
                    self.sinks.progress(reader.frames_read, frame.t)
                    next_progress = t3 + 1.0
        except StreamError as exc:
            self.evaluator.finish()  # episodes closed so far still reach events.jsonl
            raise InputError(f"{exc} (--strict stops at the first defect)") from None
        except UnicodeDecodeError as exc:
            raise InputError(f"{source.name}: stream is not UTF-8 text ({exc.reason})") from None
        except KeyboardInterrupt:
            return False
        return True


def stream_info(case: Case, source: Source, run: Judging) -> StreamInfo:
    """What the result records of the source: path, digest, header meta, frames, defects."""
    reader = source.reader
    t_first, t_last = run.t_first, run.t_last
    return StreamInfo(
        path=source.path,
        digest=source.digest(),
        meta=dict(reader.header.meta) if reader.header is not None else {},
        frames_read=reader.frames_read,
        t_start=t_first,
        t_end=t_last,
        duration=0.0
        if t_first is None or t_last is None
        else round(t_last - t_first + case.monitor.period, 6),
        defects=[
            StreamDefect(line=d.line, kind=d.kind, message=d.message)
            for d in reader.defects[:MAX_LISTED_DEFECTS]
        ],
        defect_count=len(reader.defects),
        dropouts=dict(reader.dropouts),
        topics=source.topic_report(),
    )


def ground_truth(
    case: Case,
    evaluator: Evaluator,
    options: RunOptions,
    labels: tuple[list[Label], str] | None,
) -> GroundTruth | None:
    """The hazard events scored against the labels (None without labels)."""
    if labels is None:
        return None
    hazards = {
        n.id: n.text
        for n in case.nodes.values()
        if n.type is NodeType.COUNTER_SOLUTION and n.hazard is not None
    }
    return score_events(evaluator.episodes, labels[0], hazards, str(options.labels_path), labels[1])


def timings(run: Judging, frames: int) -> Timings:
    """Where the run's time went (the STL share from the evaluator's own clock)."""
    clock, evaluator = run.clock, run.evaluator
    total = time.perf_counter() - clock.started
    return Timings(
        total_s=round(total, 6),
        read_s=round(clock.read, 6),
        metrics_s=round(clock.metrics, 6),
        stl_s=round(evaluator.stl_seconds, 6),
        episodes_status_s=round(clock.judge - evaluator.stl_seconds, 6),
        frames_per_s=round(frames / total, 1) if total > 0 else 0.0,
        peak_rss_mib=peak_rss_mib(),
    )


@cache
def casewatch_version() -> str:
    """The installed distribution's version (read here, not from the `casewatch` package: the
    evaluator sits below the front door and never imports it)."""
    try:
        return importlib.metadata.version("casewatch")
    except importlib.metadata.PackageNotFoundError:  # a source tree that was never installed
        return "unknown"


def assemble_result(
    case: Case,
    spec: CompiledSpec,
    options: RunOptions,
    source: Source,
    run: Judging,
    labels: tuple[list[Label], str] | None,
    complete: bool,
) -> RunResult:
    """Stage 7: the `RunResult` from the judged evaluator, the drive log and the source."""
    evaluator = run.evaluator
    stream = stream_info(case, source, run)
    statuses = evaluator.node_statuses()
    root = next(s for s in statuses if s.node_id == spec.root_id)
    root_ticks = sum(root.ticks.values())
    no_data_ticks = root.ticks.get("no-data", 0)
    share = no_data_ticks / root_ticks if root_ticks else 1.0
    truth = ground_truth(case, evaluator, options, labels)
    return RunResult(
        casewatch_version=casewatch_version(),
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
            for r in run.arbitration.runs
        ],
        ground_truth=truth,
        timings=timings(run, stream.frames_read),
        complete=complete,
        fail_on=options.fail_on,
        options=options.recorded(),
        root_no_data=RootNoData(
            ticks=root_ticks,
            no_data_ticks=no_data_ticks,
            share=round(share, 6),
            limit=options.max_no_data,
            exceeded=share > options.max_no_data,
        ),
        conditions=evaluator.condition_stats(),
        odd=evaluator.odd_summaries(),
        track=run.where.track(),
        scores=score_run(
            evaluator.episodes,
            evaluator.formula_stats(),
            run.where.times(),
            run.where.columns(),
            case.monitor.period,
            case.monitor.scoring,
        ),
    )


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
