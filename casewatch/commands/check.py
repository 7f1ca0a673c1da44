"""`casewatch check CASE.yaml`: report every problem in a safety case, one line per finding.

Exit codes: 0 no errors (warnings allowed), 1 errors, 2 usage or a file that cannot be read.
A case that loads but binds no evidence (a pure gsn2x argument, or a `monitor` with no `spi`,
`contract` or `hazard`) gets one more line saying that nothing is monitored.
`collect_findings` is the single place that decides which checks run, so further checks (the
formula checks of `spec/`) are added there and reach both output formats at once.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from casewatch import api
from casewatch.safety_case.findings import Finding
from casewatch.safety_case.model import Case
from casewatch.safety_case.structure import unmonitored_reason
from casewatch.spec.compiler import Mode

#: Findings with this code mean the file itself could not be read (exit 2, not 1).
UNREADABLE_CODES = frozenset({"CW001"})


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "check",
        help="check a safety case and report every problem with its line",
        description="Load a safety case, run every check and print one line per finding: "
        "PATH:LINE:COL: CODE severity: message. Exit 0 without errors, 1 with errors, 2 when "
        "the file cannot be read.",
    )
    parser.add_argument("case", metavar="CASE.yaml", help="the safety case to check")
    parser.add_argument(
        "--format",
        choices=("text", "json"),
        default="text",
        help="text (default): one line per finding; json: a JSON list of findings",
    )
    parser.add_argument(
        "--mode",
        choices=("online", "offline"),
        default="online",
        help="online (default): formulas must be causal (no future operators), as for live "
        "monitoring; offline: bounded future operators are accepted",
    )


def collect_findings(path: str | Path, mode: Mode = "online") -> tuple[Case | None, list[Finding]]:
    """Load the case and run every check (structure, then formulas); sorted by position.

    The case is None when loading failed (syntax or schema errors); otherwise it is returned
    even when structural checks found errors, so the formula checks still look at it.
    """
    return api.check(path, mode=mode)


def main(args: argparse.Namespace) -> int:
    path = str(args.case)
    case, findings = collect_findings(path, getattr(args, "mode", "online"))
    errors = sum(f.severity == "error" for f in findings)
    warnings = len(findings) - errors
    if getattr(args, "format", "text") == "json":
        print(json.dumps([f.to_dict() for f in findings], indent=2))
    else:
        for item in findings:
            print(item.format())
        nodes = f", {len(case.nodes)} nodes" if case is not None else ""
        print(
            f"{path}: {errors} error{'s' * (errors != 1)}, "
            f"{warnings} warning{'s' * (warnings != 1)}{nodes}",
            file=sys.stderr,
        )
        reason = unmonitored_reason(case) if case is not None else None
        if reason is not None:  # loaded, but a run would judge nothing: never "all clear"
            print(f"{path}: {reason}", file=sys.stderr)
    if any(f.code in UNREADABLE_CODES for f in findings):
        return 2
    return 1 if errors else 0
