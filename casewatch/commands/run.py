"""`casewatch run CASE STREAM... -o OUTDIR`: judge streams and write results and reports.

One stream (a file, or `-` for standard input, judged live as frames arrive) writes
`OUTDIR/events.jsonl`, `OUTDIR/result.json` and the reports. Several streams (a folder, a glob
or several paths) write one such folder per log under OUTDIR plus `OUTDIR/summary.json`, in
`--jobs` parallel processes.

Exit codes: 0 nothing violated, 1 any SPI episode or hazard event, 2 input that cannot be used
(including a run whose root goal was `no-data` on more than `--max-no-data` of its ticks; this
wins over 1), 3 an internal error (see `casewatch/crash.py`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import cast

from casewatch import api, batch
from casewatch.commands.common import prepare_case
from casewatch.commands.export_scenarios import add_options as add_scenario_options
from casewatch.commands.export_scenarios import (
    options_from,
    print_fleet_index,
    run_export,
    scenario_problem,
)
from casewatch.crash import ENGINES_DISAGREE, INTERNAL_ERROR
from casewatch.dask_engine import EngineError, dask_runner
from casewatch.evaluator.eventlog import Event
from casewatch.evaluator.ground_truth import LabelsError
from casewatch.evaluator.options import (
    DEFAULT_MAX_NO_DATA,
    STL_ENGINES,
    OptionsError,
    RunOptions,
    RunSinks,
)
from casewatch.evaluator.policy import FAIL_ON, damaged, gated
from casewatch.evaluator.result import DataGap, Episode, EpisodeOpen, NearMiss, OddChange, RunResult
from casewatch.evaluator.session import InputError, evaluate_stream
from casewatch.evaluator.signal_store import FILE_NAME as SIGNALS_FILE
from casewatch.evaluator.stl_engines import EngineMismatch
from casewatch.evaluator.summary import LogSummary
from casewatch.live import flags as live_flags
from casewatch.monitor.source import source_kind
from casewatch.monitor.warmup import warm_up
from casewatch.progress import FleetProgress, StreamProgress
from casewatch.reports.render import FORMATS, parse_formats
from casewatch.safety_case.model import Case
from casewatch.spec.model import CompiledSpec
from casewatch.stream_hints import RefusalHints, channel_hint, refusal_lines


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "run",
        help="judge one or more streams against a safety case",
        description="Judge streams against a safety case; write results and reports.",
    )
    p.add_argument("case", help="the safety case (YAML)")
    p.add_argument(
        "streams",
        nargs="+",
        metavar="STREAM",
        help="a JSON Lines stream (.jsonl or .jsonl.gz), a ROS 2 bag (.mcap, .db3 "
        "or a bag folder), '-' for standard input, a folder of streams and "
        "bags, or a glob such as 'logs/*.jsonl.gz'",
    )
    p.add_argument(
        "--stl-engine",
        choices=STL_ENGINES,
        default="auto",
        help="auto (default): a log on disk is judged whole (numpy over every formula), "
        "standard input tick by tick as it arrives (rtamt); rtamt or numpy force one, both "
        "runs the two and compares every value (a disagreement exits 4 naming the "
        "formula and tick); the result is the same either way",
    )
    p.add_argument(
        "--live",
        action="store_true",
        help="judge a log tick by tick as a live stream would be (rtamt), not whole",
    )
    p.add_argument(
        "--check-online",
        action="store_true",
        help="judge each log whole and tick by tick, and exit 4 naming every field of "
        "result.json where the two differ (takes twice as long; a self-test)",
    )
    p.add_argument(
        "--topics",
        type=Path,
        metavar="FILE",
        help="for ROS 2 bags: the topic mapping (YAML; default: the case's "
        "monitor.topics; docs/bags.md)",
    )
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--labels",
        help="ground-truth labels (JSON Lines); 'auto' uses "
        "NAME.labels.jsonl next to each stream when present",
    )
    p.add_argument(
        "--strict",
        action="store_true",
        help="stop at the first stream defect instead of skipping the frame",
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="parallel processes (or local Dask workers) for several logs",
    )
    p.add_argument(
        "--engine",
        choices=("processes", "dask"),
        default="processes",
        help="several logs as local processes (default) or as Dask tasks "
        "(docs/fleet.md; needs pip install 'casewatch[fleet]')",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="tcp://HOST:PORT",
        help="with --engine dask: an existing Dask scheduler instead of a local "
        "cluster of --jobs workers",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="skip logs whose complete result.json was judged with this case, the same "
        "run options (labels, --fail-on, --max-no-data, --stl-engine, --topics, --strict) "
        "and from the same stream (sha256), and whose own content digest verifies",
    )
    p.add_argument(
        "--ship-logs",
        type=_mib,
        default=0.0,
        metavar="MIB",
        help="with --engine dask: send logs of at most MIB MiB (and their labels) to the "
        "workers with their tasks and take their results back, for workers that do not share "
        "the file system (the case must still be at the same path on every worker)",
    )
    p.add_argument(
        "--format",
        default=",".join(FORMATS),
        help="reports to write: any of html,md,junit, or 'none' (default: all)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress or event lines")
    p.add_argument(
        "--fail-on",
        choices=FAIL_ON,
        default="any",
        help="which episodes make the run exit 1 and fail in JUnit: any (default), "
        "hazard (hazard events only), spi, never",
    )
    p.add_argument(
        "--scenarios",
        action="store_true",
        help="also export every hazard event as OpenSCENARIO into OUT/scenarios (several "
        "logs: OUT/scenarios/<log>/ and OUT/scenarios/index.json; options as for "
        "export-scenarios, prefixed scenario-)",
    )
    add_scenario_options(p, prefix="scenario-")
    live_flags.add_options(p)  # --serve, --serve-public, --serve-linger, --annotate
    p.add_argument(
        "--save-signals",
        action="store_true",
        help="keep every per-tick signal value in OUT/signals.npz (for casewatch "
        "tune and calibrate)",
    )
    p.add_argument(
        "--max-no-data",
        type=_share,
        default=DEFAULT_MAX_NO_DATA,
        metavar="SHARE",
        help="largest share (0-1) of ticks the root goal may read no-data; above it "
        "the stream is unusable input, exit code 2, not a pass "
        f"(default: {DEFAULT_MAX_NO_DATA:g})",
    )


def _share(text: str) -> float:
    """A share between 0 and 1 for `--max-no-data` (argparse turns ValueError into exit 2)."""
    value = float(text)
    if not 0.0 <= value <= 1.0:  # NaN fails this too
        raise argparse.ArgumentTypeError(f"expected a share between 0 and 1, got {text!r}")
    return value


def _mib(text: str) -> float:
    """A size in MiB for `--ship-logs` (0: ship nothing)."""
    value = float(text)
    if not 0.0 <= value <= 4096.0:  # NaN fails this too; a task is no place for a large log
        raise argparse.ArgumentTypeError(f"expected MiB from 0 to 4096, got {text!r}")
    return value


def _formats(text: str) -> tuple[str, ...]:
    """The reports to write; 'none' writes only events.jsonl and result.json."""
    if text.strip().lower() == "none":
        return ()
    return tuple(parse_formats(text))


def event_line(event: Event) -> str:
    """One line per event: an onset (node, start, trace), a closed episode (node, span, worst
    robustness, trace) or a data gap."""
    if isinstance(event, EpisodeOpen):
        label = "HAZARD  " if event.kind == "hazard" else "VIOLATED"
        trace = " | ".join(" -> ".join(step.id for step in path) for path in event.trace)
        return (
            f"{label} {event.node_id}  from {event.start:.1f} s (open at {event.t:.1f} s)"
            f"  trace {trace}"
        )
    if isinstance(event, NearMiss):
        return (
            f"NEAR     {event.node_id}  {event.start:.1f}-{event.end:.1f} s  robustness down "
            f"to {event.least_robustness:.3f} at {event.t_least:.1f} s (margin "
            f"{event.warn:g}; not a violation)"
        )
    if isinstance(event, OddChange):
        what = {
            "outside": "OUTSIDE the ODD",
            "unknown": "conditions NOT REPORTED",
            "inside": "inside the ODD again",
        }[event.state]
        because = f" ({event.because})" if event.because else ""
        return f"ODD      {event.node_id}  {what} from {event.t:.1f} s{because}"
    if isinstance(event, DataGap):
        return (
            f"NO DATA  {event.node_id}  {event.start:.1f}-{event.end:.1f} s  "
            f"({event.ticks} ticks; missing {', '.join(event.missing)})"
        )
    label = "ENDED   "
    trace = " | ".join(" -> ".join(step.id for step in path) for path in event.trace)
    return (
        f"{label} {event.node_id}  {event.start:.1f}-{event.end:.1f} s  "
        f"worst {event.worst_robustness:+.3f} at {event.t_worst:.1f} s  trace {trace}"
    )


def run_options(args: argparse.Namespace) -> RunOptions:
    """The run options of this command line, built once and handed unchanged to the single
    run, to every `--jobs` worker and to every Dask task (`--labels auto` is resolved per
    stream)."""
    return RunOptions(
        labels=args.labels,
        strict=args.strict,
        max_no_data=args.max_no_data,
        fail_on=args.fail_on,
        topics=str(args.topics) if args.topics else None,
        stl_engine=_stl_engine(args),
        check_online=args.check_online,
    )


def _stl_engine(args: argparse.Namespace) -> str:
    """`--stl-engine`, or rtamt with `--live` (which forces the live path)."""
    if not args.live:
        return args.stl_engine
    if args.stl_engine not in ("auto", "rtamt"):
        raise OptionsError(f"--live judges tick by tick: not with --stl-engine {args.stl_engine}")
    return "rtamt"


def main(args: argparse.Namespace) -> int:
    try:
        formats = _formats(args.format)
        options = run_options(args)
    except (ValueError, OptionsError) as exc:
        print(f"casewatch run: {exc}", file=sys.stderr)
        return 2
    if args.jobs < 1:
        print("casewatch run: --jobs must be at least 1", file=sys.stderr)
        return 2
    prepared = prepare_case("run", args.case)
    if prepared is None:
        return 2
    case, spec = prepared
    if args.scenarios and (problem := scenario_problem(args, case.monitor.channels)):
        print(f"casewatch run: {problem}", file=sys.stderr)  # refused before judging anything
        return 2
    first = args.streams[0]
    single = len(args.streams) == 1 and (
        source_kind(first) in ("stdin", "bag")
        or not (Path(first).is_dir() or any(c in first for c in "*?["))
    )
    if problem := live_flags.refusal(args, single):
        print(f"casewatch run: {problem}", file=sys.stderr)
        return 2
    if single:
        return _run_single(args, case, spec, formats, options)
    return _run_many(args, (case, spec), formats, options)


def _run_single(args, case, spec, formats: tuple[str, ...], options: RunOptions) -> int:
    stream = args.streams[0]
    live = stream == "-"
    options = options.with_labels(batch.labels_for(stream, options.labels))

    def on_event(event: Event) -> None:
        if (
            live
            and not args.quiet
            and isinstance(event, Episode | EpisodeOpen | NearMiss | OddChange)
        ):
            print(event_line(event), flush=True)

    bar = StreamProgress(enabled=not (live or args.quiet))  # silent unless on a terminal
    view = live_flags.start_view(args, case, spec, stream)  # --serve: the live page, or None
    sinks = RunSinks(
        events_path=args.out / "events.jsonl",
        signals_path=args.out / SIGNALS_FILE if args.save_signals else None,
        on_event=live_flags.chain(view, on_event),
        progress=None if live else bar.update,
        on_tick=live_flags.tick_hook(view),
    )
    warm_up()  # compiled kernels ready before the first frame (matters for a live stream)
    try:
        with bar:
            result = evaluate_stream(case, spec, stream, options, sinks)
    except (InputError, LabelsError) as exc:
        live_flags.finish(view, None, args, str(exc))
        print(f"casewatch run: {exc}", file=sys.stderr)
        return 2
    except EngineMismatch as exc:
        print(f"casewatch run: {stream}: {exc}", file=sys.stderr)
        return ENGINES_DISAGREE
    path = api.write_result(result, args.out)
    written = api.render(args.out, formats) if formats else {}
    if not args.quiet:
        _print_summary(result, path, written)
    live_flags.finish(view, result, args)  # the final verdict stays on the page
    if live_flags.annotate_after(args, stream):
        return 2
    if args.scenarios and not live and any(e.kind == "hazard" for e in result.episodes):
        # an event that cannot be exported is named and recorded; the exit code stays the run's
        scenarios = options_from(args, "scenario_")
        if run_export(result, Path(stream), args.out / "scenarios", scenarios, "run") is None:
            return 2
    if result.stream.frames_read == 0:
        print(
            f"casewatch run: {stream}: no frames could be read "
            f"({result.stream.defect_count} defects); nothing was judged",
            file=sys.stderr,
        )
        for line in refusal_lines(result):  # the cause, not only result.json's count
            print(f"  {line}", file=sys.stderr)
        return 2
    no_data = result.root_no_data
    if no_data is not None and no_data.exceeded:
        print(
            f"casewatch run: {stream}: the root goal {result.case.root_id} had no data on "
            f"{no_data.share:.1%} of {no_data.ticks} ticks (limit {no_data.limit:.0%}, "
            "--max-no-data); the stream cannot vouch for the case: unusable input, not a "
            "pass",
            file=sys.stderr,
        )
        for line in channel_hint(result):
            print(f"  {line}", file=sys.stderr)
        return 2
    if damaged(result.stream.defect_count):  # a finding under every --fail-on policy
        print(
            f"casewatch run: {stream}: the log is damaged ({result.stream.defect_count} stream "
            "defect(s), listed in result.json); the frames they lost were not judged: a "
            "finding, not a pass",
            file=sys.stderr,
        )
        return 1
    return 1 if any(gated(e.kind, args.fail_on) for e in result.episodes) else 0


def _print_summary(result: RunResult, path: Path, written: dict[str, Path]) -> None:
    s = result.stream
    spi = sum(1 for e in result.episodes if e.kind == "spi")
    hazards = len(result.episodes) - spi
    gaps = sum(f.ticks_no_data for f in result.formulas)
    print(
        f"{result.case.module}: {s.frames_read} frames, {s.duration:.1f} s, "
        f"{s.defect_count} defects; root goal {result.case.root_id}: {result.verdict.upper()}"
    )
    print(f"  {spi} SPI episodes, {hazards} hazard events, {gaps} formula-ticks without data")
    if result.root_no_data is not None and result.root_no_data.ticks:
        n = result.root_no_data
        print(
            f"  root goal without data on {n.no_data_ticks} of {n.ticks} ticks ({n.share:.1%}; "
            f"limit {n.limit:.0%})"
        )
    if result.ground_truth is not None:
        o = result.ground_truth.overall
        p = "n/a" if o.precision is None else f"{o.precision:.1%}"
        r = "n/a" if o.recall is None else f"{o.recall:.1%}"
        print(
            f"  ground truth: {o.true_positives} TP, {o.false_positives} FP, "
            f"{o.false_negatives} FN; precision {p}, recall {r}"
        )
    print(f"  result: {path}")
    for fmt, report in written.items():
        print(f"  {fmt}: {report}")


def _run_many(
    args, prepared: tuple[Case, CompiledSpec], formats: tuple[str, ...], options: RunOptions
) -> int:
    case = prepared[0]
    streams: list[Path] = []
    try:
        for pattern in args.streams:
            if pattern == "-":
                raise batch.NoStreams("'-' (standard input) cannot be combined with other streams")
            streams.extend(batch.find_streams(pattern))
    except batch.NoStreams as exc:
        print(f"casewatch run: {exc}", file=sys.stderr)
        return 2
    if args.labels not in (None, "auto"):
        print(
            "casewatch run: with several streams use --labels auto "
            "(NAME.labels.jsonl next to each stream)",
            file=sys.stderr,
        )
        return 2

    bar = FleetProgress(len(streams), enabled=not args.quiet)  # a bar only on a terminal
    hints = RefusalHints()

    def on_done(log: LogSummary) -> None:
        if args.quiet:
            return
        if log.ok:
            short = " (too little data: --max-no-data)" if log.too_little_data else ""
            bar.log(
                f"  {log.stream}: {log.frames} frames, {log.verdict}{short} ({log.seconds:.1f} s)"
            )
            if log.frames == 0:  # why, from its result.json; a cause shared by logs once
                for line in hints.new(Path(log.out_dir)):
                    bar.log(f"    {line}")
        else:
            bar.log(f"  {log.stream}: FAILED: {log.error}")
        bar.advance((log.duration_s or 0.0) / 3600.0)

    def on_resumed(log: LogSummary) -> None:
        bar.resumed()  # neither judged work nor part of the time left
        if not args.quiet:
            bar.log(f"  {log.stream}: already judged ({log.verdict}; --resume)")

    if (args.scheduler or args.ship_logs) and args.engine != "dask":
        print("casewatch run: --scheduler and --ship-logs go with --engine dask", file=sys.stderr)
        return 2
    runner = (
        dask_runner(args.jobs, args.scheduler, args.ship_logs)
        if args.engine == "dask"
        else batch.local_runner(args.jobs, {str(Path(args.case).absolute()): prepared})
    )
    try:
        with bar:
            summary = batch.run_many(
                args.case,
                case.digest,
                streams,
                args.out,
                options,
                batch.Outputs(formats, args.save_signals),
                runner,
                on_done=on_done,
                on_resumed=on_resumed,
                resume=args.resume,
            )
    except (EngineError, batch.FleetLost) as exc:
        print(f"casewatch run: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(
            f"{summary['logs']} logs, {summary['hours']:.3f} h judged, "
            f"{summary['logs_failed']} failed, {summary['logs_without_data']} with too little "
            f"data; summary: {args.out / 'summary.json'}"
        )
    per_log = cast(list[dict], summary["per_log"])
    if args.scenarios:  # one folder per log and an index; the exit code stays the run's
        scenarios = options_from(args, "scenario_")
        print_fleet_index(per_log, args.out / "scenarios", scenarios)
    for log in per_log:  # even with --quiet: exit 3 and 4 never pass unexplained
        if args.quiet and (log.get("crashed") or log.get("engines_disagree")):
            print(f"casewatch run: {log['stream']}: {log['error']}", file=sys.stderr)
    if summary["logs_crashed"]:
        return INTERNAL_ERROR
    if summary.get("logs_engines_disagree"):
        return ENGINES_DISAGREE
    if summary["logs_failed"] or summary["logs_without_data"]:
        return 2
    episodes = sum(
        int(f["episodes"])
        for f in cast(list[dict], summary["formulas"])
        if gated(f["kind"], args.fail_on)
    )
    return 1 if episodes or summary.get("logs_damaged") else 0
