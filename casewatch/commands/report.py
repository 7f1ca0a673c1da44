"""`casewatch report OUTDIR`: re-render the reports of a run from its result.json alone."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from casewatch.evaluator.policy import FAIL_ON
from casewatch.reports.render import (
    FORMATS,
    ResultError,
    load_result,
    parse_formats,
    render_reports,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "report",
        help="re-render the reports of a run from OUTDIR/result.json",
        description="Re-render HTML, Markdown and JUnit reports from OUTDIR/result.json, "
        "without re-running the evaluator; for a fleet folder (summary.json), write its "
        "overview page OUTDIR/fleet.html.",
    )
    parser.add_argument("outdir", metavar="OUTDIR", help="output folder of `casewatch run`")
    parser.add_argument(
        "--format",
        default=",".join(FORMATS),
        help=f"comma-separated formats to write (default and valid: {','.join(FORMATS)})",
    )
    parser.add_argument(
        "--fail-on",
        choices=FAIL_ON,
        default=None,
        help="which episodes JUnit counts as failures (default: the run's own "
        "--fail-on, recorded in result.json)",
    )


def main(args: argparse.Namespace) -> int:
    """Exit 0 when every report was written, 2 when the input or options are unusable."""
    try:
        formats = parse_formats(args.format)
    except ValueError as exc:
        print(f"casewatch report: {exc}", file=sys.stderr)
        return 2
    outdir = Path(args.outdir)
    if (outdir / "summary.json").is_file() and not (outdir / "result.json").is_file():
        return _fleet(outdir)
    if not outdir.is_dir():
        print(
            f"casewatch report: {outdir}: no such folder (expected the output folder of "
            "`casewatch run`)",
            file=sys.stderr,
        )
        return 2
    try:
        result = load_result(outdir / "result.json")
    except ResultError as exc:
        print(f"casewatch report: {exc}", file=sys.stderr)
        return 2
    if args.fail_on is not None:
        result.fail_on = args.fail_on
    try:
        written = render_reports(result, outdir, formats)
    except OSError as exc:
        print(f"casewatch report: cannot write reports into {outdir}: {exc}", file=sys.stderr)
        return 2
    for name, path in written.items():
        print(f"{name}: {path}")
    return 0


def _fleet(folder: Path) -> int:
    """A fleet folder: its overview page `fleet.html` (the logs' own reports stay as they are)."""
    from casewatch.batch import FleetError, read_summary
    from casewatch.reports.fleet import render_fleet

    try:
        summary = read_summary(folder)
        try:
            html = render_fleet(summary, folder)
        except (KeyError, TypeError, ValueError) as exc:  # a log entry missing its fields
            raise FleetError(
                f"{folder}/summary.json: not a casewatch fleet summary "
                f"({type(exc).__name__}: {exc})"
            ) from None
    except FleetError as exc:
        print(f"casewatch report: {exc}", file=sys.stderr)
        return 2
    target = folder / "fleet.html"
    target.write_text(html, encoding="utf-8")
    print(f"fleet: {target}")
    return 0
