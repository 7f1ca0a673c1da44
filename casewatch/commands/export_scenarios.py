"""`casewatch export-scenarios RUN_DIR STREAM -o OUT`: hazard events as OpenSCENARIO 1.2 files.

One `.xosc` per hazard event of the run in RUN_DIR (or `--event N`, the N-th): the ego and the
objects that came within `--radius` metres of it during the event (none: an ego-only scenario),
over the event plus `--lead-in` / `--lead-out` seconds clipped to the stream, each present only
while one channel saw it (`--channel`; default: the arbitrated channel at the event's start)
and following the timed polyline of its poses. With `--opendrive FILE` the scenarios reference
that road network (written relative to the .xosc files); without it they say none is attached.
OUT/scenarios.json traces each file back to its event, node, trace and stream. STREAM must be
the stream the run judged (its sha256 is checked). Exit 0 when every event was written, 1 when
an event could not be (named in scenarios.json; the others are written), 2 for input that
cannot be used (an unknown event or channel, another stream, a missing OpenDRIVE file).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from casewatch.errors import EXIT_FINDINGS, EXIT_OK, EXIT_UNUSABLE
from casewatch.evaluator.result import RunResult
from casewatch.monitor.source import source_kind
from casewatch.reports.render import ResultError, load_result
from casewatch.scenarios import (
    CATALOGUE,
    FLEET_INDEX,
    ExportError,
    ExportOptions,
    ExportReport,
    check_options,
    export_fleet,
    export_scenarios,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "export-scenarios",
        help="hazard events as OpenSCENARIO 1.2 files",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("run_dir", metavar="RUN_DIR", help="output folder of `casewatch run`")
    p.add_argument("stream", metavar="STREAM", help="the stream that run judged")
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    add_options(p)


def add_options(p: argparse.ArgumentParser, prefix: str = "") -> None:
    """The export options (shared with `casewatch run --scenarios`)."""
    p.add_argument(
        f"--{prefix}channel",
        default=None,
        help="channel whose view is replayed (default: the arbitrated one)",
    )
    p.add_argument(
        f"--{prefix}lead-in",
        type=float,
        default=3.0,
        metavar="S",
        help="seconds before the event (default %(default)s)",
    )
    p.add_argument(
        f"--{prefix}lead-out",
        type=float,
        default=2.0,
        metavar="S",
        help="seconds after the event (default %(default)s)",
    )
    p.add_argument(
        f"--{prefix}radius",
        type=float,
        default=30.0,
        metavar="M",
        help="objects this close to the ego (centre to centre) during the event are "
        "replayed; with none, the scenario is ego-only (default %(default)s)",
    )
    p.add_argument(
        f"--{prefix}opendrive",
        type=Path,
        default=None,
        metavar="FILE",
        help="OpenDRIVE road network to reference",
    )
    if not prefix:
        p.add_argument(
            "--event",
            type=int,
            default=None,
            metavar="N",
            help="only the N-th hazard event (1-based)",
        )
        p.add_argument(
            "--topics",
            type=Path,
            default=None,
            metavar="FILE",
            help="for a ROS 2 bag: its topic mapping (default: the case's "
            "monitor.topics; docs/bags.md)",
        )


def options_from(args: argparse.Namespace, prefix: str = "") -> ExportOptions:
    """The export options from parsed arguments (`prefix` "scenario_" under `run`)."""
    return ExportOptions(
        channel=getattr(args, f"{prefix}channel"),
        lead_in=getattr(args, f"{prefix}lead_in"),
        lead_out=getattr(args, f"{prefix}lead_out"),
        radius=getattr(args, f"{prefix}radius"),
        opendrive=getattr(args, f"{prefix}opendrive"),
        event=getattr(args, "event", None),
        topics=getattr(args, "topics", None),
    )


def scenario_problem(args: argparse.Namespace, channels: list[str]) -> str | None:
    """Why `run --scenarios` cannot export with these options (checked before judging, so a
    typo never costs a whole run), or None."""
    options = options_from(args, "scenario_")
    if "-" in getattr(args, "streams", []):
        return (
            "--scenarios reads the stream again after judging it, and standard input cannot be "
            "read twice: save the stream to a file, or export later with export-scenarios"
        )
    if options.channel is not None and options.channel not in channels:
        return (
            f"--scenario-channel {options.channel!r} is not one of the case's channels "
            f"({', '.join(channels)})"
        )
    try:
        check_options(options, flag="--scenario-")
    except ExportError as exc:
        return str(exc)
    return None


def print_fleet_index(per_log: list[dict], out: Path, options: ExportOptions) -> dict:
    """`run DIR --scenarios`: export every log, print one line per log and the index's path."""
    index = export_fleet(per_log, out, options)
    for log in index["logs"]:
        if "error" in log:
            print(f"casewatch run: {log['stream']}: no scenarios: {log['error']}", file=sys.stderr)
        elif log["folder"] is not None:
            failed = f", {log['failed']} not exported" if log["failed"] else ""
            folder = out / log["folder"]
            print(f"  {log['stream']}: {log['scenarios']} scenario(s){failed} in {folder}")
    print(
        f"{index['scenarios']} scenario(s) from {len(index['logs'])} logs; "
        f"index {out / FLEET_INDEX}"
    )
    return index


def print_report(report: ExportReport, command: str) -> None:
    """One line per file, one per event that could not be written (on stderr), a total."""
    for e in report.written:
        objects = len(e["entities"]) - 1
        what = (
            f"ego only (nothing within {e['radius']:g} m)"
            if e["ego_only"]
            else f"{objects} objects"
        )
        print(
            f"  {report.out / e['file']}: {e['node']} {e['start']:g}-{e['end']:g} s, channel "
            f"{e['channel']}, {what}"
        )
    for e in report.failed:
        print(
            f"casewatch {command}: hazard event {e['event']} ({e['node']} at {e['start']:g} s) "
            f"not exported: {e['error']}",
            file=sys.stderr,
        )
    failed = f", {len(report.failed)} not exported" if report.failed else ""
    print(f"{len(report.written)} scenario(s){failed}; catalogue {report.out / CATALOGUE}")


def run_export(
    result: RunResult, stream: Path, out: Path, options: ExportOptions, command: str
) -> ExportReport | None:
    """Export and print; None (after one line on stderr) when the export is refused."""
    try:
        report = export_scenarios(result, Path(stream), out, options)
    except (ExportError, OSError) as exc:
        print(f"casewatch {command}: {exc}", file=sys.stderr)
        return None
    print_report(report, command)
    return report


def main(args: argparse.Namespace) -> int:
    try:
        result = load_result(Path(args.run_dir) / "result.json")
    except ResultError as exc:
        print(f"casewatch export-scenarios: {exc}", file=sys.stderr)
        return 2
    if not (Path(args.stream).is_file() or source_kind(args.stream) == "bag"):
        print(f"casewatch export-scenarios: {args.stream}: no such stream or bag", file=sys.stderr)
        return 2
    report = run_export(result, Path(args.stream), args.out, options_from(args), "export-scenarios")
    if report is None:
        return EXIT_UNUSABLE
    return EXIT_FINDINGS if report.failed else EXIT_OK
