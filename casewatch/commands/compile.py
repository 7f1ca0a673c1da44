"""`casewatch compile CASE.yaml -o DIR`: compile a safety case's SPIs and hazards to STL files.

Writes `DIR/specs.stl`, `DIR/trace.json` and `DIR/signals.json` (see `spec/artifacts.py`).
Exit codes: 0 written (warnings allowed), 2 when the case has errors or cannot be read; nothing
is written then, so a stale spec is never mistaken for a fresh one.
"""

from __future__ import annotations

import argparse
import sys

from casewatch.safety_case.checks import check_file, sort_findings
from casewatch.safety_case.findings import has_errors
from casewatch.spec.artifacts import write_artifacts
from casewatch.spec.compiler import compile_case


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "compile",
        help="compile the SPIs and hazard rules of a safety case into rtamt STL files",
        description="Check a safety case, compile every SPI threshold and hazard rule into an "
        "STL formula rtamt evaluates correctly, and write DIR/specs.stl, DIR/trace.json and "
        "DIR/signals.json. Exit 0 on success, 2 when the case has errors.",
    )
    parser.add_argument("case", metavar="CASE.yaml", help="the safety case to compile")
    parser.add_argument("-o", "--output", metavar="DIR", required=True, help="output folder")
    parser.add_argument(
        "--mode",
        choices=("online", "offline"),
        default="online",
        help="online (default): formulas must be causal (past-time only); offline: bounded "
        "future operators are allowed",
    )


def main(args: argparse.Namespace) -> int:
    path = str(args.case)
    case, findings = check_file(path)
    spec = None
    if case is not None and not has_errors(findings):
        spec, formula_findings = compile_case(case, args.mode)
        findings = findings + formula_findings
    for item in sort_findings(findings):
        print(item.format())
    if case is None or spec is None or has_errors(findings):
        errors = sum(f.severity == "error" for f in findings)
        print(f"{path}: {errors} error{'s' * (errors != 1)}; nothing written", file=sys.stderr)
        return 2
    written = write_artifacts(spec, args.output, case.monitor.signals)
    print(
        f"{path}: {len(spec.formulas)} formulas compiled ({args.mode}) -> "
        + ", ".join(str(p) for p in written),
        file=sys.stderr,
    )
    return 0
