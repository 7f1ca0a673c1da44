"""`casewatch export-scenarios RUN_DIR STREAM -o OUT`: hazard events as OpenSCENARIO 1.2 files.

One `.xosc` per hazard event of the run in RUN_DIR (or `--event N`, the N-th): the ego and the
objects that came within `--radius` metres of it during the event, over the event plus
`--lead-in` / `--lead-out` seconds, each following the timed polyline of its poses as one
channel saw them (`--channel`; default: the arbitrated channel at the event's start). With
`--opendrive FILE` the scenarios reference that road network; without it they say none is
attached. OUT/scenarios.json traces each file back to its event, node, trace and stream.
STREAM must be the stream the run judged (its sha256 is checked). Exit 0, or 2 for input that
cannot be used (an unknown event, another stream, an event whose channel saw nobody near the
ego).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from casewatch.monitor.bags.reader import is_bag
from casewatch.reports.render import ResultError, load_result
from casewatch.reports.scenario_export import ExportError, export_scenarios


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
        help="objects this close to the ego during the event are involved",
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


def run_export(
    result,
    stream: Path,
    out: Path,
    channel,
    lead_in: float,
    lead_out: float,
    radius: float,
    opendrive,
    event=None,
    topics: Path | None = None,
) -> int:
    """Export and write the catalogue; prints one line per file. Exit code."""
    for name, value in (("lead-in", lead_in), ("lead-out", lead_out), ("radius", radius)):
        if not (math.isfinite(value) and value >= 0):
            print(f"casewatch export-scenarios: --{name} must be a number >= 0", file=sys.stderr)
            return 2
    if opendrive is not None and not Path(opendrive).is_file():
        print(f"casewatch export-scenarios: {opendrive}: no such OpenDRIVE file", file=sys.stderr)
        return 2
    try:
        entries = export_scenarios(
            result, Path(stream), out, channel, lead_in, lead_out, radius, opendrive, event, topics
        )
    except (ExportError, OSError) as exc:
        print(f"casewatch export-scenarios: {exc}", file=sys.stderr)
        return 2
    (out / "scenarios.json").write_text(
        json.dumps({"format": "casewatch-scenarios", "version": 1, "scenarios": entries}, indent=1),
        encoding="utf-8",
    )
    for e in entries:
        print(
            f"  {out / e['file']}: {e['node']} {e['start']:g}-{e['end']:g} s, channel "
            f"{e['channel']}, {len(e['entities']) - 1} objects"
        )
    print(f"{len(entries)} scenario(s); catalogue {out / 'scenarios.json'}")
    return 0


def main(args: argparse.Namespace) -> int:
    try:
        result = load_result(Path(args.run_dir) / "result.json")
    except ResultError as exc:
        print(f"casewatch export-scenarios: {exc}", file=sys.stderr)
        return 2
    if not (Path(args.stream).is_file() or is_bag(args.stream)):
        print(f"casewatch export-scenarios: {args.stream}: no such stream or bag", file=sys.stderr)
        return 2
    return run_export(
        result,
        Path(args.stream),
        args.out,
        args.channel,
        args.lead_in,
        args.lead_out,
        args.radius,
        args.opendrive,
        args.event,
        args.topics,
    )
