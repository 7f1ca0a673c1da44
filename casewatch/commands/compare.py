"""`casewatch compare RUNS... -o OUT`: many runs side by side, grouped by agent and scenario.

RUNS are output folders of `casewatch run` (each with result.json) or fleet folders (each
with summary.json). Runs are grouped by keys of their stream's meta (`--by`, default
`agent,scenario`); a run without a key is grouped under "(none)". Per group: runs, hours, the
penalty score and CARLA driving score (mean, min, max), and events and penalties per traffic
rule; a table of the penalty score by the first two keys; a violation map of every hazard
episode over the driven tracks, and over the road network with `--net` (SUMO) or `--xodr`
(OpenDRIVE), with a check that every marker lies on its track and on a lane. Writes
OUT/compare.json, OUT/compare.md and OUT/compare.html. Exit 0, or 2 for input that cannot be
used.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from casewatch.commands.common import UsageError, run_folders
from casewatch.evaluator.compare import compare_runs, unknown_keys
from casewatch.reports.compare import check_lines, render_compare_html, render_compare_md, stat_text
from casewatch.reports.render import ResultError, load_result
from casewatch.reports.roadmap import NetworkError, check_markers, read_opendrive, read_sumo_net


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "compare",
        help="compare many runs grouped by agent and scenario, with a violation map",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("runs", metavar="RUN", nargs="+", help="run or fleet folders")
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--by",
        default="agent,scenario",
        help="comma-separated stream meta keys to group by (default agent,scenario)",
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--net",
        type=Path,
        metavar="FILE.net.xml",
        help="SUMO network drawn under the map, and the off-road check",
    )
    where.add_argument(
        "--xodr",
        type=Path,
        metavar="FILE.xodr",
        help="OpenDRIVE map drawn under the map, and the off-road check",
    )


def _unique_names(folders: list[Path]) -> list[str]:
    """Folder names, qualified by their parent where two runs share one (two fleets)."""
    names = [f.name for f in folders]
    return [f"{f.parent.name}/{f.name}" if names.count(f.name) > 1 else f.name for f in folders]


def read_run(folder: Path) -> dict:
    """A run's `result.json`, validated as a `RunResult` (the one schema of results; keys added
    since, such as `track`, `scores`, `episodes[].x/y`, default when absent), as plain data."""
    path = Path(folder) / "result.json"
    if not path.is_file():
        raise UsageError(f"{folder}: no result.json (not the output folder of casewatch run)")
    return load_result(path).model_dump()


def main(args: argparse.Namespace) -> int:
    by = [k.strip() for k in args.by.split(",") if k.strip()]
    try:
        if not by:
            raise UsageError("--by needs at least one stream meta key, e.g. agent,scenario")
        folders: list[Path] = []
        for given in args.runs:
            found = run_folders(Path(given))
            if not found:
                raise UsageError(f"{given}: a fleet folder without any judged log")
            folders += [found[name] for name in sorted(found)]
        folders = list(dict.fromkeys(folders))  # the same run given twice counts once
        runs = [
            (name, folder, read_run(folder))
            for name, folder in zip(_unique_names(folders), folders, strict=True)
        ]
        missing = unknown_keys(runs, by)
        if missing:
            raise UsageError(
                f"--by {', '.join(missing)}: no run's stream meta has "
                f"{'this key' if len(missing) == 1 else 'these keys'}"
            )
        network = None
        if args.net is not None:
            network = read_sumo_net(args.net)
        elif args.xodr is not None:
            network = read_opendrive(args.xodr)
    except (UsageError, ResultError, NetworkError) as exc:
        print(f"casewatch compare: {exc}", file=sys.stderr)
        return 2
    report = compare_runs(runs, by)
    if network is not None:
        report["checks"]["network"] = check_markers(report["markers"], network)
    tracks = {name: data.get("track") or [] for name, _, data in runs}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "compare.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (args.out / "compare.md").write_text(render_compare_md(report), encoding="utf-8")
    (args.out / "compare.html").write_text(
        render_compare_html(report, tracks, network), encoding="utf-8"
    )
    _print_table(report)
    print(f"{args.out / 'compare.md'}, {args.out / 'compare.html'}, {args.out / 'compare.json'}")
    return 0


def _print_table(report: dict) -> None:
    for key, names in report["without_key"].items():
        if names:
            print(
                f"note: {len(names)} run(s) without '{key}' in the stream meta, grouped under "
                "(none)"
            )
    rows = [("group", "runs", "hours", "penalty score", "driving score", "events")]
    rows += [
        (
            g["label"],
            str(g["runs"]),
            f"{g['hours']:.3f}",
            stat_text(g["penalty_score"]),
            stat_text(g["driving_score"]),
            str(g["hazard_events"]),
        )
        for g in report["groups"]
    ]
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print(
            "  ".join(
                c.ljust(w) if i == 0 else c.rjust(w)
                for i, (c, w) in enumerate(zip(r, widths, strict=True))
            )
        )
    for line in check_lines(report):
        print(line)
