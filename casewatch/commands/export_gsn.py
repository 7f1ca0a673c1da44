"""`casewatch export-gsn CASE [RUN_DIR] -o OUT`: the argument as gsn2x YAML, with live status.

Writes `OUT/<module>.gsn.yaml` (every module of the case in one file); with a run folder (its
`result.json`), each node also gets the class of its worst status over the run and
`OUT/casewatch-status.css` styles them: `gsn2x OUT/<module>.gsn.yaml -s casewatch-status.css`.
Exit codes: 0 written, 2 a case with errors, an unreadable run, or a run of another case.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from casewatch.reports.gsn_export import gsn_document, write_gsn
from casewatch.reports.render import ResultError, load_result
from casewatch.safety_case.checks import check_file
from casewatch.safety_case.findings import has_errors
from casewatch.safety_case.gsn2x_schema import gsn2x_problems


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "export-gsn",
        help="write the argument as gsn2x YAML, with a run's node statuses as CSS classes",
        description="Write the case as gsn2x YAML (OUT/<module>.gsn.yaml); with RUN_DIR, "
        "each node's worst status over that run as a CSS class and "
        "OUT/casewatch-status.css. casewatch reads the file back as the same case.",
    )
    p.add_argument("case", help="the safety case (YAML)")
    p.add_argument("run", nargs="?", type=Path, help="a run folder (with result.json)")
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")


def main(args: argparse.Namespace) -> int:
    case, findings = check_file(args.case)
    if case is None or has_errors(findings):
        for f in findings:
            if f.severity == "error":
                print(f.format(), file=sys.stderr)
        print(f"casewatch export-gsn: {args.case} has errors; fix them first", file=sys.stderr)
        return 2
    statuses = None
    if args.run is not None:
        try:
            result = load_result(args.run / "result.json" if args.run.is_dir() else args.run)
        except (OSError, ValueError, ResultError) as exc:
            print(f"casewatch export-gsn: {args.run}: cannot read the run: {exc}", file=sys.stderr)
            return 2
        if result.case.digest != case.digest:
            print(
                f"casewatch export-gsn: {args.run} was judged with another version of the "
                f"case (digest {result.case.digest[:12]}, this file {case.digest[:12]}); its "
                "statuses would be pinned on the wrong nodes",
                file=sys.stderr,
            )
            return 2
        statuses = {s.node_id: s.worst for s in result.status}
    for path in write_gsn(case, args.out, statuses):
        print(f"written: {path}")
    # what gsn2x would still refuse, e.g. an `extends` of a module this file does not hold
    for problem in gsn2x_problems(gsn_document(case, statuses)):
        print(f"casewatch export-gsn: warning: gsn2x would refuse it: {problem}", file=sys.stderr)
    return 0
